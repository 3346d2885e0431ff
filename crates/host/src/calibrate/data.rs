//! The records as a fit sees them: prepared, weighted, thinned for a search, with a robust
//! window loss; the model run over them and the costs.

use crate::error::HostError;
use crate::record::Record;
use crate::residual::weighted_norm;
use crate::simulate::{column, Quantity, COLUMNS};
use geared_servo::{ActuatorParams, Outputs, Plant, PlantState};
use nalgebra::DVector;
use std::sync::atomic::{AtomicU64, Ordering};

/// One record prepared for fitting.
#[derive(Clone, Debug)]
pub struct Data {
    /// Commanded voltages, one per row, V.
    pub volts: Vec<f64>,
    /// Measured output, one per row.
    pub y: Vec<f64>,
    /// Output column name.
    pub output: String,
    /// Sample period, s.
    pub sample_period_s: f64,
    /// Steps of the first voltage held before the record when it does not start at rest.
    pub preroll: usize,
    /// Weight of each row in the fit, 0 to 1: 1 everywhere unless spans are weighted out
    /// ([`Data::with_weights`]), e.g. where the model cannot be followed sample by sample
    /// (`crate::predictability`).
    pub weight: Vec<f64>,
    /// ‖√w (y − ȳ_w)‖₂ (ȳ_w the weighted mean), the NRMSE denominator.
    pub norm: f64,
    /// Robust window loss for the search ([`Robust`]); `None`: plain least squares.
    pub robust: Option<Robust>,
    /// The record's other measured outputs, fitted beside the first ([`Channel`]).
    pub extra: Vec<Channel>,
    /// The first output is an angle taken as its steps from one sample to the next:
    /// `y[k] = θ[k] − θ[k−1]` of the column `output`, `y[0]` = 0, and the model's alike
    /// ([`Data::from_record`] for a record whose first output is an angle). An angle is the
    /// integral of a speed: after a span no model can follow (gear rattle), or from an
    /// encoder whose zero is not the model's, the unit's position is off by an amount that
    /// stays; its steps are not, and they are compared row by row like a speed.
    pub steps: bool,
}

/// A further measured output of a record, fitted beside the first (`Data::y`) on the same
/// rows and weights, each in units of its own floor.
///
/// One run of the model gives every output of a row, so a further output costs no
/// simulation. Its residual enters the fit scaled by `scale` = σ₁ / floor (σ₁ the first
/// output's noise level, [`crate::noise::sigma`]): a row of it at its floor weighs what a
/// row of the first output at its noise does, and the first output's NRMSE² stays the
/// unit of the cost. The floor is what even the right model cannot get below
/// ([`Channel::floor_of`]): the output's noise and resolution and, for the load angle,
/// where in the gap the load sits — a load angle is known to the model only to within the
/// backlash wherever the gears have parted (held-out gravity_torque/69 of the foreign
/// suite: the emulator at the truth follows the reference's angle to 8e-4 of its spread,
/// on a gap of 0.05° over a swing of −17° to +39°), so a weight of 1/noise² alone would let
/// that disagreement outweigh the tachometer.
#[derive(Clone, Debug, PartialEq)]
pub struct Channel {
    /// Output column name ([`crate::record::OUTPUT_COLUMNS`]).
    pub output: String,
    /// Measured output, one per row, in the column's unit.
    pub y: Vec<f64>,
    /// Its noise level from the record, with its resolution (a quantised output's step
    /// q adds q/√12), in the column's unit.
    pub noise: f64,
    /// Its floor, in the column's unit ([`Channel::floor_of`]).
    pub floor: f64,
    /// σ₁ / floor: brings a residual of this output into the first output's unit at its
    /// noise level.
    pub scale: f64,
}

impl Channel {
    /// The floor of an output of noise (and resolution) `noise` for a model with total
    /// backlash `backlash_deg` at the load: √(noise² + b²/12) for the load angle (in
    /// degrees: where in a gap of b the load sits is uniform at worst), `noise` for every
    /// other output.
    pub fn floor_of(output: &str, noise: f64, backlash_deg: f64) -> f64 {
        // The angle columns are in degrees (`crate::simulate::COLUMNS`).
        let angle = column(output).is_some_and(|c| c.quantity == Quantity::Angle);
        let gap = if angle && backlash_deg.is_finite() {
            backlash_deg.abs()
        } else {
            0.0
        };
        (noise * noise + gap * gap / 12.0).sqrt()
    }
}

/// The step of a quantised output (an encoder's count): the smallest change between
/// consecutive samples, when at least 90 % of the changes are whole multiples of it (to
/// 1 %); 0 for an output that is not quantised.
pub fn resolution(y: &[f64]) -> f64 {
    let steps: Vec<f64> = y
        .windows(2)
        .map(|w| match w {
            [a, b] => (b - a).abs(),
            _ => 0.0,
        })
        .filter(|d| *d > 0.0 && d.is_finite())
        .collect();
    let q = steps.iter().copied().fold(f64::INFINITY, f64::min);
    if steps.len() < 10 || !q.is_finite() {
        return 0.0;
    }
    let whole = steps
        .iter()
        .filter(|d| {
            let m = *d / q;
            (m - m.round()).abs() < 0.01
        })
        .count();
    if whole as f64 >= 0.9 * steps.len() as f64 {
        q
    } else {
        0.0
    }
}

/// The steps of `theta` from one sample to the next, 0 at the first ([`Data::steps`]).
pub fn steps_of(theta: &[f64]) -> Vec<f64> {
    std::iter::once(0.0)
        .chain(theta.windows(2).map(|w| match w {
            [a, b] => b - a,
            _ => 0.0,
        }))
        .take(theta.len())
        .collect()
}

/// A robust loss over short windows of a record, for the *search* of a calibration (never
/// for the figures it reports).
///
/// Near a lightly damped resonance a gear train with backlash has coexisting periodic
/// responses (a jump, as in a softening spring), and where it rattles its motion is chaotic
/// (MODEL.md): a parameter change of a percent can move a burst onto the other branch, and
/// the least-squares cost then jumps by an order of magnitude — it is a patchwork of basins,
/// not a bowl. Per window of `window` rows the residual energy E is compared with what the
/// noise alone gives there, N = σ² Σw, and u = E/N enters as c ln(1 + u/c): like u while the
/// window is within a few noise levels (u ≈ 1 for noise, a moderate model error of a few
/// noise levels keeps almost its whole weight), but a window on the wrong branch (u in the
/// hundreds) counts as some tens of noisy windows, not as a thousand. The search then sees how
/// many windows a parameter set follows, which changes smoothly, instead of how far the ones
/// it misses are off.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Robust {
    /// Noise standard deviation of the record, in its output's unit.
    pub sigma: f64,
    /// Rows per window.
    pub window: usize,
    /// Scale c of the compression, in noise energies.
    pub scale: f64,
}

impl Robust {
    /// Window length, s: about a period of the lowest gear-mode frequency of interest and
    /// the predictability windows' length.
    pub const WINDOW_S: f64 = 0.025;
    /// c: a window with 3 noise energies keeps 87 % of its weight, one with 1000 counts as 18.
    pub const SCALE: f64 = 3.0;

    /// The share of its energy a window of noise alone keeps (u ≈ 1): c ln(1 + 1/c).
    pub fn noise_share() -> f64 {
        Robust::SCALE * (1.0 / Robust::SCALE).ln_1p()
    }

    /// The loss for a record sampled every `h` s whose noise is `sigma`.
    pub fn new(sigma: f64, h: f64) -> Robust {
        Robust {
            sigma,
            window: ((Robust::WINDOW_S / h).round() as usize).max(8),
            scale: Robust::SCALE,
        }
    }
}

/// A start from rest: the command leaves a zero run at least this long, s.
pub const REST_S: f64 = 0.05;

/// A record with at least twice this many rows is thinned for a global search
/// ([`Data::thinned`]): 10 s at 2 kHz, more than the 8.8 s stepped sine of the paper's bench
/// procedure (22 bursts), which the search sees whole; a 20 s stepped sine (50 bursts) is
/// searched on every other burst.
pub const SEARCH_ROWS: usize = 20_000;

/// Output columns the fit can use, in order of preference: every measured output
/// ([`crate::record::OUTPUT_COLUMNS`]).
pub const FIT_OUTPUTS: [&str; 5] = crate::record::OUTPUT_COLUMNS;

/// Whether a record starts in motion (in the steady state of its first voltage) rather
/// than at rest: its first output sample `y[0]` is far from zero (more than 5 % of the
/// largest) and, for a speed-like output under a first voltage that is not zero, of the
/// sign and at least half the size of what the record shows elsewhere at that voltage (the
/// median output over the rows whose voltage is within 10 % of it). A sensor offset puts
/// the first sample of a record that starts at rest far from zero too; only the second
/// test tells the two apart (foreign case tach_offset/10: a 0.18 V tachometer offset at
/// rest under 7.85 V, 0.21 V against a threshold of 0.20 V, where the record shows a
/// median of 2.3 V at that voltage; the real square-wave record: −6.2 V under −15.6 V,
/// median −5.8 V). Without rows to compare with, the first test alone decides.
pub fn starts_in_motion(volts: &[f64], y: &[f64], output: &str) -> bool {
    let peak = y.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let (Some(&y0), Some(&v0)) = (y.first(), volts.first()) else {
        return false;
    };
    if y0.is_nan() || y0.abs() <= 0.05 * peak {
        return false;
    }
    let speed_like = column(output).is_some_and(|c| c.quantity == Quantity::Speed);
    if !speed_like || v0 == 0.0 || !v0.is_finite() {
        return true;
    }
    let mut near: Vec<f64> = volts
        .iter()
        .zip(y)
        .skip(1)
        .filter(|(v, _)| (**v - v0).abs() <= 0.1 * v0.abs())
        .map(|(_, y)| *y)
        .collect();
    if near.len() < 3 {
        return true;
    }
    near.sort_by(f64::total_cmp);
    let median = near.get(near.len() / 2).copied().unwrap_or(y0);
    median * y0 > 0.0 && y0.abs() >= 0.5 * median.abs()
}

impl Data {
    /// Prepares `rec`: the first output of [`FIT_OUTPUTS`] it has is fitted, and every
    /// other one it has beside it, each in units of its own floor ([`Channel`]; the floor of
    /// a load angle here without the gap: [`Data::with_backlash`] adds it). An output that
    /// is constant, or a record whose first output shows no noise (no unit to weigh the
    /// others in), leaves the others out. When the record did not start at rest
    /// ([`starts_in_motion`]), the first voltage is held for 2 s before it (a steady
    /// state).
    pub fn from_record(rec: &Record, name: &str) -> Result<Data, HostError> {
        let (output, raw) = FIT_OUTPUTS
            .iter()
            .find_map(|c| rec.output(c).map(|y| (c.to_string(), y.to_vec())))
            .ok_or_else(|| HostError::input(format!("{name}: no output column to fit")))?;
        let steps = column(&output).is_some_and(|c| c.quantity == Quantity::Angle);
        let y = if steps { steps_of(&raw) } else { raw };
        // An angle's steps say whether the record starts in motion as a speed does, from
        // its first step.
        let in_motion = if steps {
            let mut probe = y.clone();
            if let (Some(first), Some(&next)) = (probe.first_mut(), y.get(1)) {
                *first = next;
            }
            starts_in_motion(&rec.motor_voltage_v, &probe, "load_speed_rad_s")
        } else {
            starts_in_motion(&rec.motor_voltage_v, &y, &output)
        };
        let preroll = if in_motion {
            (2.0 / rec.sample_period_s).round() as usize
        } else {
            0
        };
        let weight = vec![1.0; y.len()];
        let (_, norm) = weighted_norm(&y, &weight);
        if norm <= 0.0 || !norm.is_finite() {
            return Err(HostError::input(format!(
                "{name}: column `{output}` is constant: nothing to fit"
            )));
        }
        let mut extra = Vec::new();
        // The angle whose steps are the first output is fitted as it is too, over each
        // predictable span with its offset free ([`channel_residual`]): its slow motion,
        // which its steps show only under the noise of every row.
        for c in FIT_OUTPUTS.iter().filter(|c| steps || **c != output) {
            let Some(yc) = rec.output(c) else { continue };
            let (_, nc) = weighted_norm(yc, &weight);
            if nc <= 0.0 || !nc.is_finite() {
                continue;
            }
            let q = resolution(yc);
            let noise = crate::noise::sigma(yc).hypot(q / 12f64.sqrt());
            extra.push(Channel {
                output: c.to_string(),
                y: yc.to_vec(),
                noise,
                floor: noise,
                scale: 0.0,
            });
        }
        let d = Data {
            volts: rec.motor_voltage_v.clone(),
            y,
            output,
            sample_period_s: rec.sample_period_s,
            preroll,
            weight,
            norm,
            robust: None,
            extra,
            steps,
        };
        Ok(d.with_backlash(0.0))
    }

    /// The same record with each further output's floor and scale ([`Channel`]) for a model
    /// of total backlash `backlash_deg` at the load (the load angle's floor holds where in
    /// the gap the load sits). A further output whose floor is zero or not finite, or every
    /// one when the first output shows no noise, is left out.
    pub fn with_backlash(&self, backlash_deg: f64) -> Data {
        let sigma = self.sigma();
        let extra = if sigma > 0.0 && sigma.is_finite() {
            self.extra
                .iter()
                .filter_map(|c| {
                    let floor = Channel::floor_of(&c.output, c.noise, backlash_deg);
                    (floor > 0.0 && floor.is_finite()).then(|| Channel {
                        floor,
                        scale: sigma / floor,
                        ..c.clone()
                    })
                })
                .collect()
        } else {
            Vec::new()
        };
        Data {
            extra,
            ..self.clone()
        }
    }

    /// The record as the predictability ensembles judge it
    /// ([`crate::predictability::assess`]): itself, but when its first output is the
    /// armature current, the motor speed instead (and no further outputs). The ensembles
    /// compare their spread with the output's own RMS, and the current's is mostly V/R,
    /// which the command fixes whatever the gears do; its unpredictable part is k_b·ω/R,
    /// the motor speed's (foreign suite, clean/1 stripped to its current: the rattling
    /// bursts, 13–135 Hz, spread by under 5 % of the current, kept 66 % of the stepped sine,
    /// and the true parameters sat at 1.7 times the noise floor on those rows).
    pub fn motion(&self) -> std::borrow::Cow<'_, Data> {
        if self.output == "current_a" && !self.steps {
            std::borrow::Cow::Owned(Data {
                output: "motor_speed_rad_s".to_string(),
                extra: Vec::new(),
                ..self.clone()
            })
        } else {
            std::borrow::Cow::Borrowed(self)
        }
    }

    /// The names of the outputs fitted, the first first (an angle's steps as
    /// "`column` steps", [`Data::steps`]).
    pub fn columns(&self) -> Vec<String> {
        std::iter::once(self.first_name())
            .chain(self.extra.iter().map(|c| c.output.clone()))
            .collect()
    }

    /// The output columns the record has, as they are named in it (an angle fitted as its
    /// steps once: it is also among the further outputs).
    pub fn measured(&self) -> Vec<&str> {
        let mut out = vec![self.output.as_str()];
        for c in &self.extra {
            if !out.contains(&c.output.as_str()) {
                out.push(c.output.as_str());
            }
        }
        out
    }

    /// The first output's name: its column's, with " steps" after it when it is an angle
    /// taken as its steps ([`Data::steps`]).
    pub fn first_name(&self) -> String {
        if self.steps {
            format!("{} steps", self.output)
        } else {
            self.output.clone()
        }
    }

    /// The noise level of the first output as it is fitted, in its unit
    /// ([`crate::noise::sigma`]). An angle's steps (`e[k] − e[k−1]` of its noise e) carry
    /// √2 times the angle's noise, and their third differences are the angle's fourth,
    /// which the estimator is not calibrated on: the angle is rebuilt from the steps and
    /// its noise taken, with its resolution (an encoder's count q adds q/√12, [`resolution`]),
    /// times √2.
    pub fn sigma(&self) -> f64 {
        if !self.steps {
            return crate::noise::sigma(&self.y);
        }
        let theta: Vec<f64> = self
            .y
            .iter()
            .scan(0.0, |a, d| {
                *a += d;
                Some(*a)
            })
            .collect();
        let q = resolution(&theta);
        std::f64::consts::SQRT_2 * crate::noise::sigma(&theta).hypot(q / 12f64.sqrt())
    }

    /// The same record with the robust window loss `r` for the search (`None`: plain).
    pub fn with_robust(&self, r: Option<Robust>) -> Data {
        Data {
            robust: r.filter(|r| r.sigma > 0.0 && r.sigma.is_finite()),
            ..self.clone()
        }
    }

    /// The same record weighted by the rows both `a` and `b` keep: each row's smaller
    /// weight (two models' predictable rows of this record, to compare them like with like).
    pub fn with_rows_both_keep(&self, a: &Data, b: &Data) -> Data {
        let w: Vec<f64> = a
            .weight
            .iter()
            .zip(&b.weight)
            .map(|(p, q)| p.min(*q))
            .collect();
        self.with_weights(&w)
    }

    /// The same record with row weights `w` (clamped to 0..=1; missing rows weigh 1) and the
    /// NRMSE denominator taken over them. Unchanged when every weight would be zero or the
    /// weighted output is constant: there would be nothing left to fit.
    pub fn with_weights(&self, w: &[f64]) -> Data {
        let weight: Vec<f64> = (0..self.y.len())
            .map(|k| w.get(k).copied().unwrap_or(1.0))
            .map(|x| if x.is_nan() { 0.0 } else { x.clamp(0.0, 1.0) })
            .collect();
        let (_, norm) = weighted_norm(&self.y, &weight);
        if norm <= 0.0 || !norm.is_finite() {
            return self.clone();
        }
        Data {
            weight,
            norm,
            ..self.clone()
        }
    }

    /// Share of the rows with weight below ½ (weighted out).
    pub fn excluded_share(&self) -> f64 {
        let n = self.weight.len().max(1) as f64;
        self.weight.iter().filter(|w| **w < 0.5).count() as f64 / n
    }

    /// Sum of the weights (the effective number of rows).
    pub fn weight_sum(&self) -> f64 {
        self.weight.iter().sum()
    }

    /// Largest |commanded voltage|, V.
    pub fn max_abs_v(&self) -> f64 {
        self.volts.iter().fold(0.0f64, |m, v| m.max(v.abs()))
    }

    /// Rows where the command leaves a zero run (below 1 % of its largest magnitude) of at
    /// least [`REST_S`] (a start from rest), with the row where the next such run begins (or
    /// the record's end): the bursts of a stepped sine.
    pub fn restarts(&self) -> Vec<(usize, usize)> {
        let peak = self.max_abs_v();
        let zero = 0.01 * peak;
        let min_run = ((REST_S / self.sample_period_s).round() as usize).max(1);
        // Zero runs as (first row, one past the last).
        let mut runs: Vec<(usize, usize)> = Vec::new();
        let mut lo: Option<usize> = None;
        for (k, v) in self.volts.iter().enumerate() {
            match (v.abs() < zero, lo) {
                (true, None) => lo = Some(k),
                (false, Some(a)) => {
                    if k - a >= min_run {
                        runs.push((a, k));
                    }
                    lo = None;
                }
                _ => {}
            }
        }
        runs.iter()
            .enumerate()
            .map(|(i, &(_, start))| {
                let end = runs.get(i + 1).map(|r| r.0).unwrap_or(self.volts.len());
                (start, end)
            })
            .filter(|&(start, end)| start < end)
            .collect()
    }

    /// The record thinned for a global search to every k-th burst, k = ⌊rows / `max_rows`⌋,
    /// when that is 2 or more (and it has starts from rest, [`Data::restarts`]); itself
    /// otherwise. The search then sees between `max_rows` and twice as many rows.
    ///
    /// A long stepped sine (20 s of 2 kHz: 50 bursts) tells a global search no more about
    /// where the basin lies than half its bursts do, and the search's cost is one simulation
    /// of every row per trial point. The record is cut where each burst begins into pieces
    /// (a burst with the rest after it; the first piece also holds what precedes the second
    /// burst), and every k-th piece is kept from the first on: the kept bursts still span the
    /// whole frequency range. The pieces are joined as they are: each kept burst follows a
    /// rest of at least [`REST_S`] in which the plant came to rest, as it did before it in
    /// the whole record, up to where in the gap the gears rest — what the restart test of the
    /// predictability assessment weighs out (the rows keep their weights). The pre-roll stays
    /// with the first piece.
    pub fn thinned(&self, max_rows: usize) -> Data {
        let n = self.y.len();
        let k = n / max_rows.max(1);
        let starts = if k >= 2 { self.restarts() } else { Vec::new() };
        if starts.len() < 2 {
            return self.clone();
        }
        // Piece boundaries: where each burst begins (a piece is a burst with the rest after
        // it; the first also holds what precedes the second burst).
        // (The starts rise strictly and lie below n.)
        let cuts: Vec<usize> = std::iter::once(0)
            .chain(starts.iter().skip(1).map(|s| s.0))
            .chain(std::iter::once(n))
            .collect();
        let pieces: Vec<(usize, usize)> = cuts.windows(2).map(|w| (w[0], w[1])).collect();
        let keep: Vec<(usize, usize)> = pieces.iter().step_by(k).copied().collect();
        let take = |src: &[f64]| -> Vec<f64> {
            keep.iter()
                .flat_map(|&(a, b)| src.get(a..b).unwrap_or(&[]).iter().copied())
                .collect()
        };
        let weight = take(&self.weight);
        let y = take(&self.y);
        let (_, norm) = weighted_norm(&y, &weight);
        if norm <= 0.0 || !norm.is_finite() {
            return self.clone();
        }
        Data {
            volts: take(&self.volts),
            y,
            output: self.output.clone(),
            sample_period_s: self.sample_period_s,
            preroll: self.preroll,
            weight,
            norm,
            robust: self.robust,
            steps: self.steps,
            extra: self
                .extra
                .iter()
                .map(|c| Channel {
                    y: take(&c.y),
                    ..c.clone()
                })
                .collect(),
        }
    }
}

/// What a simulation gives besides the fitted output, for the regime analysis.
#[derive(Clone, Debug, Default)]
pub struct Trace {
    /// Model output (the column being fitted), one per row.
    pub y: Vec<f64>,
    /// Motor speed, rad/s.
    pub motor_speed: Vec<f64>,
    /// Armature current, A.
    pub current: Vec<f64>,
    /// Gears in contact.
    pub contact: Vec<bool>,
}

/// Runs `p` over `d` from rest (after the pre-roll); `None` if `p` is invalid.
pub fn simulate(p: &ActuatorParams, d: &Data) -> Option<Trace> {
    simulate_with(p, d, |_, _| {})
}

/// [`simulate`] with `hook(k, state)` called before the step that leaves row `k` (after the
/// row's outputs are taken): a hook may move the state (the predictability assessment moves
/// the gears within the gap at each start from rest).
pub fn simulate_with(
    p: &ActuatorParams,
    d: &Data,
    hook: impl FnMut(usize, &mut PlantState),
) -> Option<Trace> {
    let n = d.volts.len();
    let mut t = Trace {
        y: Vec::with_capacity(n),
        motor_speed: Vec::with_capacity(n),
        current: Vec::with_capacity(n),
        contact: Vec::with_capacity(n),
    };
    run(p, d, hook, |y, o| {
        t.y.push(y);
        t.motor_speed.push(f64::from(o.motor_speed_rad_s));
        t.current.push(f64::from(o.current_a));
        t.contact.push(o.in_contact);
    })?;
    Some(t)
}

/// The fitted output alone of [`simulate`] (what a cost needs: the searches run it tens of
/// thousands of times, and the other columns of a [`Trace`] cost a tenth of the run).
pub fn output(p: &ActuatorParams, d: &Data) -> Option<Vec<f64>> {
    output_with(p, d, |_, _| {})
}

/// Every output fitted of [`simulate`] in one run: the first output's rows, then each
/// further output's ([`Data::extra`]) in turn (what the costs need; [`nrmse_of`] reads the
/// first output's rows alone). [`output`] for a record with one output.
pub fn output_all(p: &ActuatorParams, d: &Data) -> Option<Vec<f64>> {
    if d.extra.is_empty() {
        return output(p, d);
    }
    let n = d.volts.len();
    let values: Vec<fn(&Outputs) -> f32> = d
        .extra
        .iter()
        .map(|c| column(&c.output).unwrap_or(&COLUMNS[0]).value)
        .collect();
    let mut y = Vec::with_capacity(n * (1 + values.len()));
    let mut rest = vec![Vec::with_capacity(n); values.len()];
    run(
        p,
        d,
        |_, _| {},
        |v, o| {
            y.push(v);
            for (r, f) in rest.iter_mut().zip(&values) {
                r.push(f64::from(f(o)));
            }
        },
    )?;
    for r in rest {
        y.extend(r);
    }
    Some(y)
}

/// [`output_all`] over each record of `data`: one run of the model per record, to cost on
/// any weighting of the same records ([`cost_of`]).
pub fn outputs(p: &ActuatorParams, data: &[Data]) -> Vec<Option<Vec<f64>>> {
    data.iter().map(|d| output_all(p, d)).collect()
}

/// The further outputs' share of a record's cost for a model whose outputs over it are `y`
/// ([`output_all`]): Σ over them and the weighted rows of (scale · residual)², over the
/// first output's norm squared (0 for a record with one output; ∞ for `None`).
fn extra_cost(y: Option<&[f64]>, d: &Data) -> f64 {
    if d.extra.is_empty() {
        return 0.0;
    }
    let Some(y) = y else { return f64::INFINITY };
    let n = d.y.len();
    let spans = offset_spans(d);
    let mut sum = 0.0;
    for (i, c) in d.extra.iter().enumerate() {
        let Some(model) = y.get((i + 1) * n..(i + 2) * n) else {
            return f64::INFINITY;
        };
        sum += channel_residual(model, c, d, &spans)
            .iter()
            .zip(&d.weight)
            .map(|(r, w)| w * (c.scale * r).powi(2))
            .sum::<f64>();
    }
    sum / (d.norm * d.norm)
}

/// The spans over which an angle output's offset is its own ([`channel_residual`]): the
/// runs of rows the fit keeps (weight ½ or more), cut where each start from rest begins
/// ([`Data::restarts`]; where a thinned record's pieces join, too).
fn offset_spans(d: &Data) -> Vec<(usize, usize)> {
    let n = d.y.len();
    let mut cuts = d.restarts().into_iter().map(|r| r.0).peekable();
    let mut out = Vec::new();
    let mut lo: Option<usize> = None;
    for (k, w) in d.weight.iter().enumerate().take(n) {
        let cut = cuts.peek() == Some(&k);
        if cut {
            cuts.next();
        }
        let keep = *w >= 0.5;
        if cut || !keep {
            if let Some(a) = lo.take() {
                out.push((a, k));
            }
        }
        if keep && lo.is_none() {
            lo = Some(k);
        }
    }
    if let Some(a) = lo {
        out.push((a, n));
    }
    out
}

/// The residual (measured − model) of the further output `c` whose model rows are `model`,
/// one per row. An angle is the integral of a speed: after a span the model cannot follow
/// (gear rattle: [`crate::predictability`]) the unit's position is lost by an amount no
/// model predicts, and it stays lost, so an angle is compared over each of `spans`
/// ([`offset_spans`]) with its weighted mean offset there taken out — its motion, not where
/// it drifted to — and not at all on the rows outside them. Every other output row by row.
fn channel_residual(model: &[f64], c: &Channel, d: &Data, spans: &[(usize, usize)]) -> Vec<f64> {
    let mut r: Vec<f64> = c.y.iter().zip(model).map(|(b, a)| b - a).collect();
    if !column(&c.output).is_some_and(|col| col.quantity == Quantity::Angle) {
        return r;
    }
    let mut kept = vec![false; r.len()];
    for &(a, b) in spans {
        let (Some(rs), Some(ws)) = (r.get_mut(a..b), d.weight.get(a..b)) else {
            continue;
        };
        let sw: f64 = ws.iter().sum();
        if sw > 0.0 {
            let mean = rs.iter().zip(ws).map(|(x, w)| x * w).sum::<f64>() / sw;
            rs.iter_mut().for_each(|x| *x -= mean);
        }
        if let Some(k) = kept.get_mut(a..b) {
            k.iter_mut().for_each(|x| *x = true);
        }
    }
    for (x, k) in r.iter_mut().zip(&kept) {
        if !k {
            *x = 0.0;
        }
    }
    r
}

/// [`output`] with [`simulate_with`]'s hook.
pub fn output_with(
    p: &ActuatorParams,
    d: &Data,
    hook: impl FnMut(usize, &mut PlantState),
) -> Option<Vec<f64>> {
    let mut y = Vec::with_capacity(d.volts.len());
    run(p, d, hook, |v, _| y.push(v))?;
    Some(y)
}

/// The run behind [`simulate_with`] and [`output_with`]: `take(y, outputs)` receives each
/// row's fitted output and all outputs, then `hook` may move the state before the row's
/// voltage is applied.
fn run(
    p: &ActuatorParams,
    d: &Data,
    mut hook: impl FnMut(usize, &mut PlantState),
    mut take: impl FnMut(f64, &Outputs),
) -> Option<()> {
    let mut q = *p;
    q.sample_period_s = d.sample_period_s;
    let plant = Plant::new(&q).ok()?;
    count_run(d.preroll + d.volts.len());
    let mut st = PlantState::REST;
    let v0 = d.volts.first().copied().unwrap_or(0.0) as f32;
    for _ in 0..d.preroll {
        plant.step(&mut st, v0);
    }
    // Data are made from the record's columns (`from_record`); the tachometer otherwise.
    let value = column(&d.output).unwrap_or(&COLUMNS[0]).value;
    let mut o = plant.outputs(&st);
    // An angle's steps ([`Data::steps`]): 0 at the first row.
    let mut prev = f64::from(value(&o));
    for (k, &v) in d.volts.iter().enumerate() {
        let now = f64::from(value(&o));
        take(if d.steps { now - prev } else { now }, &o);
        prev = now;
        hook(k, &mut st);
        o = plant.step(&mut st, v as f32);
    }
    Some(())
}

/// Simulations of a record run so far in this process ([`runs`]), and the plant steps
/// they took.
static RUNS: AtomicU64 = AtomicU64::new(0);
static ROWS: AtomicU64 = AtomicU64::new(0);

/// Counts one simulation of `rows` plant steps ([`runs`]).
fn count_run(rows: usize) {
    RUNS.fetch_add(1, Ordering::Relaxed);
    ROWS.fetch_add(rows as u64, Ordering::Relaxed);
}

/// Simulations of a record run so far in this process (every [`output`] and [`simulate`]),
/// and the plant steps they took: for the traces of where a diagnosis spends its time
/// (`RUST_LOG=geared_servo_host=debug`, docs/cost.md).
pub fn runs() -> (u64, u64) {
    (RUNS.load(Ordering::Relaxed), ROWS.load(Ordering::Relaxed))
}

/// NRMSE of `p` on `d` over its weighted rows (∞ if `p` is invalid).
pub fn nrmse(p: &ActuatorParams, d: &Data) -> f64 {
    nrmse_of(output(p, d).as_deref(), d)
}

/// The root of [`cost`] on the one record `d` (without its robust loss): every output it
/// fits, in its first output's unit ([`Channel`]); its [`nrmse`] when it has one output.
pub fn nrmse_all(p: &ActuatorParams, d: &Data) -> f64 {
    if d.extra.is_empty() {
        return nrmse(p, d);
    }
    record_cost(output_all(p, d).as_deref(), d).sqrt()
}

/// One record's share of [`cost_of`] for a model whose outputs over it are `y`
/// ([`output_all`]): the first output's NRMSE² and the further outputs' share.
fn record_cost(y: Option<&[f64]>, d: &Data) -> f64 {
    nrmse_of(y, d).powi(2) + extra_cost(y, d)
}

/// NRMSE over the weighted rows of `d` of a model output `y` already simulated over `d`'s
/// input ([`output`]; ∞ for `None`, a model that could not be run).
pub fn nrmse_of(y: Option<&[f64]>, d: &Data) -> f64 {
    match y {
        Some(y) => {
            y.iter()
                .zip(&d.y)
                .zip(&d.weight)
                .map(|((a, b), w)| w * (a - b).powi(2))
                .sum::<f64>()
                .sqrt()
                / d.norm
        }
        None => f64::INFINITY,
    }
}

/// [`cost`] of a model whose outputs over the records' inputs are `outputs` (one per record
/// of `data`, from [`output`]), without simulating again: the same records weighted
/// otherwise share the run (the rows both of two models keep, say). `None` when a record
/// has the robust loss, which needs the run's windows ([`cost`] then).
pub fn cost_of(outputs: &[Option<Vec<f64>>], data: &[Data]) -> Option<f64> {
    if data.iter().any(|d| d.robust.is_some()) || outputs.len() != data.len() {
        return None;
    }
    let sum: f64 = outputs
        .iter()
        .zip(data)
        .map(|(y, d)| record_cost(y.as_deref(), d))
        .sum();
    Some(sum / data.len().max(1) as f64)
}

/// Stacked normalised residuals (measured − model) over all records, each record's further
/// outputs after its first ([`Channel`], scaled into the first's unit): Σ r² = mean over
/// records of NRMSE² (with the further outputs' share, [`cost_of`]).
pub fn residuals(p: &ActuatorParams, data: &[Data]) -> DVector<f64> {
    let w = 1.0 / (data.len().max(1) as f64).sqrt();
    let m: usize = data.iter().map(|d| d.y.len() * (1 + d.extra.len())).sum();
    let mut r = Vec::with_capacity(m);
    for d in data {
        let n = d.y.len();
        let y = output_all(p, d);
        let spans = if d.extra.is_empty() {
            Vec::new()
        } else {
            offset_spans(d)
        };
        for i in 0..=d.extra.len() {
            let start = r.len();
            let model = y.as_deref().and_then(|y| y.get(i * n..(i + 1) * n));
            let (res, scale) = match (model, i.checked_sub(1).and_then(|j| d.extra.get(j))) {
                (Some(m), None) => (d.y.iter().zip(m).map(|(b, a)| b - a).collect(), 1.0),
                (Some(m), Some(c)) => (channel_residual(m, c, d, &spans), c.scale),
                (None, _) => (Vec::new(), 1.0),
            };
            if res.len() == n {
                r.extend(
                    res.iter()
                        .zip(&d.weight)
                        .map(|(e, wk)| w * wk.sqrt() * scale * e / d.norm),
                );
            } else {
                r.extend(std::iter::repeat_n(1e3, n));
            }
            // Each output's rows at its floor are the first's at its noise: one loss.
            if let (Some(rb), Some(rows)) = (d.robust, r.get_mut(start..)) {
                compress(rows, &d.weight, rb, w * w / (d.norm * d.norm));
            }
        }
    }
    DVector::from_vec(r)
}

/// Applies the robust window loss to one record's normalised residuals `rows` (each window's
/// rows scaled so that their energy becomes N c ln(1 + u/c), [`Robust`]); `unit` is the
/// factor that normalises a squared measurement (the rows' own scaling squared).
fn compress(rows: &mut [f64], weight: &[f64], rb: Robust, unit: f64) {
    let n2 = rb.sigma * rb.sigma * unit;
    for (chunk, wch) in rows.chunks_mut(rb.window).zip(weight.chunks(rb.window)) {
        let e: f64 = chunk.iter().map(|x| x * x).sum();
        let noise = n2 * wch.iter().sum::<f64>();
        if e > 0.0 && noise > 0.0 {
            let rho = noise * rb.scale * (e / noise / rb.scale).ln_1p();
            let f = (rho / e).sqrt();
            for x in chunk.iter_mut() {
                *x *= f;
            }
        }
    }
}

/// Mean over records of NRMSE² (with a record's robust loss when it has one: the search's
/// cost, [`Robust`]).
pub fn cost(p: &ActuatorParams, data: &[Data]) -> f64 {
    if data.iter().any(|d| d.robust.is_some()) {
        return residuals(p, data).norm_squared();
    }
    cost_of(&outputs(p, data), data).unwrap_or(f64::INFINITY)
}

/// The records with the robust window loss ([`Robust`]), each at its own noise level
/// estimated from the record ([`crate::noise::sigma`]).
pub fn robust(data: &[Data]) -> Vec<Data> {
    data.iter()
        .map(|d| d.with_robust(Some(Robust::new(d.sigma(), d.sample_period_s))))
        .collect()
}

/// The records as a global search sees them: each thinned to whole bursts
/// ([`Data::thinned`] with [`SEARCH_ROWS`]).
pub fn thinned(data: &[Data]) -> Vec<Data> {
    data.iter().map(|d| d.thinned(SEARCH_ROWS)).collect()
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use geared_servo::REFERENCE;

    /// A square wave of ±`v` V with 0.1 s halves, 0.5 s at 2 kHz, as a tachometer record
    /// of the reference actuator from rest, with `offset` V added to the tachometer; with
    /// `in_motion`, the record starts 0.25 s in (its first voltage held for 50 ms by then).
    fn square_record(v: f64, offset: f64, in_motion: bool) -> (Vec<f64>, Vec<f64>) {
        let volts: Vec<f64> = (0..1600)
            .map(|k| if (k / 200) % 2 == 0 { v } else { -v })
            .collect();
        let mut d = data_of(volts.clone(), H, None);
        d.output = "tach_voltage_v".to_string();
        let mut p = REFERENCE;
        p.sample_period_s = H;
        let y: Vec<f64> = output(&p, &d)
            .unwrap()
            .into_iter()
            .map(|t| t + offset)
            .collect();
        let skip = if in_motion { 500 } else { 0 };
        (volts[skip..].to_vec(), y[skip..].to_vec())
    }

    /// A record of `p` over `volts` (every 2 kHz row) with its tachometer (noise `sigma_t`
    /// V) and its load angle (noise `sigma_a` degrees, plus `angle_extra(row)`), as a reader
    /// gives it.
    fn two_output_record(
        p: &ActuatorParams,
        volts: &[f64],
        sigma_t: f64,
        sigma_a: f64,
        angle_extra: impl Fn(usize) -> f64,
    ) -> Record {
        use rand::SeedableRng;
        use rand_distr::{Distribution, StandardNormal};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut gauss = move || -> f64 { StandardNormal.sample(&mut rng) };
        let mut d = data_of(volts.to_vec(), H, None);
        d.output = "tach_voltage_v".into();
        let tach = output(p, &d).unwrap();
        d.output = "load_angle_deg".into();
        let angle = output(p, &d).unwrap();
        let n = volts.len();
        Record {
            metadata: Vec::new(),
            time_s: (0..n).map(|k| k as f64 * H).collect(),
            sample_period_s: H,
            motor_voltage_v: volts.to_vec(),
            outputs: vec![
                (
                    "tach_voltage_v".into(),
                    tach.iter().map(|y| y + sigma_t * gauss()).collect(),
                ),
                (
                    "load_angle_deg".into(),
                    angle
                        .iter()
                        .enumerate()
                        .map(|(k, y)| y + sigma_a * gauss() + angle_extra(k))
                        .collect(),
                ),
            ],
            warnings: Vec::new(),
        }
    }

    /// Two 0.4 s square-wave bursts of ±6 V, each after a 0.1 s rest (2 kHz).
    fn two_bursts() -> Vec<f64> {
        let mut v = Vec::new();
        for _ in 0..2 {
            v.extend(std::iter::repeat_n(0.0, 200));
            v.extend((0..800).map(|k| if (k / 100) % 2 == 0 { 6.0 } else { -6.0 }));
        }
        v
    }

    #[test]
    fn every_output_is_fitted_in_units_of_its_own_floor() {
        let mut p = REFERENCE;
        p.sample_period_s = H;
        let volts = two_bursts();
        let rec = two_output_record(&p, &volts, 0.02, 0.002, |_| 0.0);
        let d = Data::from_record(&rec, "r").unwrap();
        assert_eq!(d.columns(), ["tach_voltage_v", "load_angle_deg"]);
        let c = &d.extra[0];
        // Without a gap the angle's floor is its noise; with one it holds where in the gap
        // the load sits.
        assert!((c.noise / 0.002 - 1.0).abs() < 0.25, "noise {}", c.noise);
        assert_eq!(c.floor, c.noise);
        let g = d.with_backlash(0.05);
        let f = &g.extra[0];
        assert!((f.floor - (c.noise.powi(2) + 0.05f64.powi(2) / 12.0).sqrt()).abs() < 1e-12);
        let sigma = crate::noise::sigma(&d.y);
        assert!((f.scale - sigma / f.floor).abs() < 1e-12);
        // The costs agree with one another: the stored run, the stacked residuals, `cost`.
        let data = [g.clone()];
        let run = outputs(&p, &data);
        let c0 = cost_of(&run, &data).unwrap();
        assert!((residuals(&p, &data).norm_squared() / c0 - 1.0).abs() < 1e-9);
        assert_eq!(cost(&p, &data), c0);
        // The first output's NRMSE is unchanged by the second; the cost holds both.
        assert_eq!(nrmse(&p, &g), nrmse(&p, &data_of_first(&g)));
        assert!(c0 > nrmse(&p, &g).powi(2));
        // A wrong load inertia shows in the angle: the angle's share of the cost grows.
        let mut q = p;
        q.load.inertia_kg_m2 *= 1.2;
        let share = |p: &ActuatorParams| cost(p, &data) - nrmse(p, &g).powi(2);
        assert!(share(&q) > 4.0 * share(&p), "{} {}", share(&q), share(&p));
        // A record with one output costs as before.
        let one = data_of_first(&g);
        assert_eq!(
            cost(&p, std::slice::from_ref(&one)),
            nrmse(&p, &one).powi(2)
        );
    }

    /// `rec` with its load angle alone, shifted by `offset` degrees (an encoder's zero).
    fn angle_alone(rec: &Record, offset: f64) -> Record {
        let angle = rec.output("load_angle_deg").unwrap();
        Record {
            outputs: vec![(
                "load_angle_deg".into(),
                angle.iter().map(|a| a + offset).collect(),
            )],
            ..rec.clone()
        }
    }

    #[test]
    fn an_angle_alone_is_fitted_as_its_steps_and_as_itself_offset_free() {
        let mut p = REFERENCE;
        p.sample_period_s = H;
        let volts = two_bursts();
        let sigma_a = 0.002;
        let rec = two_output_record(&p, &volts, 0.02, sigma_a, |_| 0.0);
        let d = Data::from_record(&angle_alone(&rec, 0.0), "r").unwrap();
        assert!(d.steps);
        assert_eq!(d.columns(), ["load_angle_deg steps", "load_angle_deg"]);
        assert_eq!(d.y.len(), volts.len());
        assert_eq!(d.y[0], 0.0);
        // The steps carry √2 times the angle's noise.
        let s = d.sigma();
        assert!(
            (s / (std::f64::consts::SQRT_2 * sigma_a) - 1.0).abs() < 0.25,
            "sigma {s}"
        );
        // The model's steps are taken alike: at the truth the first output's NRMSE is its
        // floor (the noise alone), within the estimate's spread.
        let floor = crate::noise::floor_nrmse(s, &d.weight, d.norm);
        let e = nrmse(&p, &d);
        assert!((e / floor - 1.0).abs() < 0.3, "NRMSE {e} floor {floor}");
        // An encoder's zero that is not the model's changes nothing.
        let shifted = Data::from_record(&angle_alone(&rec, 37.0), "s").unwrap();
        let g = d.with_backlash(0.05);
        let gs = shifted.with_backlash(0.05);
        let c = cost(&p, std::slice::from_ref(&g));
        let cs = cost(&p, std::slice::from_ref(&gs));
        assert!((cs / c - 1.0).abs() < 1e-6, "{cs} {c}");
        // A wrong load inertia shows.
        let mut q = p;
        q.load.inertia_kg_m2 *= 1.2;
        let cq = cost(&q, std::slice::from_ref(&g));
        assert!(cq > 4.0 * c, "{cq} {c}");
        // The costs agree with one another.
        let data = [g.clone()];
        let c0 = cost_of(&outputs(&p, &data), &data).unwrap();
        assert!((residuals(&p, &data).norm_squared() / c0 - 1.0).abs() < 1e-9);
        // A thinned or reweighted record keeps its steps.
        assert!(g.with_weights(&vec![1.0; volts.len()]).steps);
        assert!(g.thinned(500).steps);
    }

    #[test]
    fn steps_of_an_angle_start_at_zero() {
        assert_eq!(steps_of(&[1.0, 1.5, 0.5]), [0.0, 0.5, -1.0]);
        assert_eq!(steps_of(&[]), Vec::<f64>::new());
        assert_eq!(steps_of(&[2.0]), [0.0]);
    }

    #[test]
    fn a_quantised_angle_at_rest_has_a_noise_level() {
        // An encoder of 0.01° counts that sits still most of the time: the steps' noise is
        // at least the count's, not 0.
        let theta: Vec<f64> = (0..4000)
            .map(|k| {
                if (k / 500) % 2 == 0 {
                    0.0
                } else {
                    0.01 * ((k % 500) / 50) as f64
                }
            })
            .collect();
        let mut d = data_of(vec![0.0; theta.len()], H, None);
        d.y = steps_of(&theta);
        d.steps = true;
        let q = 0.01 / 12f64.sqrt() * std::f64::consts::SQRT_2;
        assert!(d.sigma() >= 0.99 * q, "{} {q}", d.sigma());
    }

    /// `d` with its first output alone.
    fn data_of_first(d: &Data) -> Data {
        Data {
            extra: Vec::new(),
            ..d.clone()
        }
    }

    #[test]
    fn an_angle_lost_in_a_span_the_model_cannot_follow_costs_nothing_after_it() {
        // The unit's angle jumps by 0.5° in the second burst (a position lost where it
        // rattled) and stays there; with those rows weighted out, each span's offset is its
        // own and the jump costs nothing; without the weights it dominates.
        let mut p = REFERENCE;
        p.sample_period_s = H;
        let volts = two_bursts();
        let jump = |k: usize| if k >= 1400 { 0.5 } else { 0.0 };
        let rec = two_output_record(&p, &volts, 0.02, 0.002, jump);
        let clean = two_output_record(&p, &volts, 0.02, 0.002, |_| 0.0);
        let d = Data::from_record(&rec, "r").unwrap().with_backlash(0.05);
        let c = Data::from_record(&clean, "c").unwrap().with_backlash(0.05);
        let mut w = vec![1.0; volts.len()];
        w[1350..1450].iter_mut().for_each(|x| *x = 0.0);
        let (dw, cw) = (d.with_weights(&w), c.with_weights(&w));
        let cost1 = |x: &Data| cost(&p, std::slice::from_ref(x));
        assert!(
            (cost1(&dw) / cost1(&cw) - 1.0).abs() < 0.05,
            "{} {}",
            cost1(&dw),
            cost1(&cw)
        );
        assert!(cost1(&d) > 10.0 * cost1(&c), "{} {}", cost1(&d), cost1(&c));
        // Also across a start from rest (the second burst begins at row 1200): its offset
        // is its own.
        let at_rest = |k: usize| if k >= 1200 { 0.5 } else { 0.0 };
        let r2 = two_output_record(&p, &volts, 0.02, 0.002, at_rest);
        let d2 = Data::from_record(&r2, "r2").unwrap().with_backlash(0.05);
        assert!(
            (cost1(&d2) / cost1(&c) - 1.0).abs() < 0.05,
            "{} {}",
            cost1(&d2),
            cost1(&c)
        );
    }

    #[test]
    fn an_encoders_count_is_its_resolution() {
        let q = 0.09;
        let y: Vec<f64> = (0..500)
            .map(|k| (30.0 * (0.01 * k as f64).sin() / q).round() * q)
            .collect();
        assert!((resolution(&y) - q).abs() < 1e-9, "{}", resolution(&y));
        let smooth: Vec<f64> = (0..500).map(|k| (0.01 * k as f64).sin()).collect();
        assert_eq!(resolution(&smooth), 0.0);
        // Only the angle's floor holds the gap.
        assert_eq!(Channel::floor_of("current_a", 0.01, 0.05), 0.01);
        assert!(Channel::floor_of("load_angle_deg", 0.0, 0.12) > 0.034);
    }

    #[test]
    fn a_sensor_offset_at_rest_is_not_motion_at_the_start() {
        let out = "tach_voltage_v";
        // At rest, no offset: the first sample is zero.
        let (v, y) = square_record(8.0, 0.0, false);
        assert!(!starts_in_motion(&v, &y, out));
        // At rest with an offset above 5 % of the peak: still at rest (the record shows a
        // far larger output at that voltage later).
        let (v, y) = square_record(8.0, 0.2, false);
        let peak = y.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(
            0.2 > 0.05 * peak,
            "the offset must pass the first test: {peak}"
        );
        assert!(!starts_in_motion(&v, &y, out));
        // In motion, with or without the offset.
        for offset in [0.0, 0.2] {
            let (v, y) = square_record(8.0, offset, true);
            assert!(starts_in_motion(&v, &y, out), "offset {offset}");
        }
        // An output that is not speed-like keeps the first test alone.
        let (v, y) = square_record(8.0, 0.2, false);
        assert!(starts_in_motion(&v, &y, "current_a"));
    }

    #[test]
    fn a_run_costed_on_other_weights_is_the_cost() {
        let mut p = REFERENCE;
        p.sample_period_s = H;
        let volts: Vec<f64> = (0..1600)
            .map(|k| if (k / 200) % 2 == 0 { 6.0 } else { -6.0 })
            .collect();
        let mut q = p;
        q.load.inertia_kg_m2 *= 1.3;
        let d = data_of(volts, H, Some(&q));
        let runs = [output(&p, &d)];
        let half: Vec<f64> = (0..1600).map(|k| f64::from(u8::from(k % 3 != 0))).collect();
        for w in [d.clone(), d.with_weights(&half)] {
            let both = [w];
            let c = cost_of(&runs, &both).unwrap();
            assert_eq!(c, cost(&p, &both));
            assert!(c > 0.0);
        }
        // The robust loss needs the run's windows: not from a stored output.
        let r = [d.with_robust(Some(Robust::new(0.01, H)))];
        assert!(cost_of(&runs, &r).is_none());
        // An invalid model costs infinity either way.
        assert_eq!(
            cost_of(&[None], std::slice::from_ref(&d)),
            Some(f64::INFINITY)
        );
    }

    const H: f64 = 5e-4;
    /// Rows of one piece of [`stepped`]: a 0.1 s rest and a 0.3 s burst.
    const PIECE: usize = 800;

    /// A record of the commands `volts` sampled every `h` s whose output is `p`'s own
    /// tachometer (or the row index without `p`, to trace which rows a thinning keeps).
    pub(crate) fn data_of(volts: Vec<f64>, h: f64, p: Option<&ActuatorParams>) -> Data {
        let n = volts.len();
        let mut d = Data {
            volts,
            y: (0..n).map(|k| k as f64).collect(),
            output: "tach_v".to_string(),
            sample_period_s: h,
            preroll: 0,
            weight: vec![1.0; n],
            norm: 1.0,
            robust: None,
            extra: Vec::new(),
            steps: false,
        };
        if let Some(t) = p.and_then(|p| simulate(p, &d)) {
            d.y = t.y;
        }
        d.norm = weighted_norm(&d.y, &d.weight).1;
        d
    }

    /// A stepped sine of `bursts` bursts (0.3 s at 10 V, 20 Hz up in steps of 10 Hz), each
    /// after a 0.1 s rest ([`data_of`]).
    fn stepped(bursts: usize, p: Option<&ActuatorParams>) -> Data {
        let mut volts = Vec::new();
        for b in 0..bursts {
            volts.extend(std::iter::repeat_n(0.0, 200));
            let f = 20.0 + 10.0 * b as f64;
            volts.extend(
                (0..600).map(|k| 10.0 * (2.0 * std::f64::consts::PI * f * k as f64 * H).sin()),
            );
        }
        data_of(volts, H, p)
    }

    #[test]
    fn a_long_stepped_sine_is_searched_on_every_kth_burst_with_its_rest() {
        let mut d = stepped(10, None);
        // Weights travel with their rows.
        for k in (0..d.y.len()).filter(|k| k % 7 == 0) {
            d.weight[k] = 0.0;
        }
        let t = d.thinned(4000);
        // k = 8000 / 4000 = 2: bursts 0, 2, 4, 6, 8, each with the rest after it.
        for b in 0..10 {
            let middle = (b * PIECE + 500) as f64;
            assert_eq!(t.y.contains(&middle), b % 2 == 0, "burst {b}");
        }
        // The first piece also holds the rest before the first burst.
        assert!(
            t.y.len().abs_diff(5 * PIECE + 200) <= 10,
            "{} rows",
            t.y.len()
        );
        for (k, &row) in t.y.iter().enumerate() {
            let row = row as usize;
            assert_eq!(t.volts[k], d.volts[row]);
            assert_eq!(t.weight[k], d.weight[row]);
        }
        // Each kept piece ends with its whole rest.
        let jumps: Vec<usize> = (1..t.y.len())
            .filter(|&k| t.y[k] != t.y[k - 1] + 1.0)
            .collect();
        assert_eq!(jumps.len(), 4, "{jumps:?}");
        let rest = (REST_S / H).round() as usize;
        for &k in &jumps {
            assert!(
                t.volts[k - rest..k].iter().all(|v| v.abs() < 0.1),
                "row {k}"
            );
        }
        assert_eq!(t.norm, weighted_norm(&t.y, &t.weight).1);
        // k = ⌊8000 / 2700⌋ = 2 as well; ⌊8000 / 2000⌋ = 4: bursts 0, 4 and 8.
        assert_eq!(d.thinned(2700).y.len(), t.y.len());
        assert!(d.thinned(2000).y.len().abs_diff(3 * PIECE + 200) <= 10);
    }

    #[test]
    fn a_record_below_twice_the_rows_or_without_rests_is_searched_whole() {
        let d = stepped(10, None);
        assert_eq!(d.thinned(4001).y, d.y);
        assert_eq!(d.thinned(100_000).y, d.y);
        let mut sine = d.clone();
        sine.volts = (0..d.volts.len())
            .map(|k| 5.0 * (0.05 * k as f64).sin() + 6.0)
            .collect();
        assert_eq!(sine.thinned(1000).y, d.y);
    }

    #[test]
    fn the_thinned_record_is_what_the_model_does_in_the_whole_one() {
        // Each piece starts with a rest in which the plant comes to rest as it did in the
        // whole record: with one steady response per burst (heavy mesh damping), the model
        // run over the thinned record is the whole run's rows, up to where in the gap the
        // gears rest (a transient).
        let mut p = REFERENCE;
        p.effects.mesh_damping = 0.5;
        p.sample_period_s = H;
        let whole = stepped(10, Some(&p));
        let mut traced = stepped(10, None);
        traced.y = whole.y.clone();
        let mut rows = traced.clone();
        rows.y = (0..rows.y.len()).map(|k| k as f64).collect();
        let t = traced.thinned(4000);
        let kept = rows.thinned(4000);
        let run = simulate(&p, &t).map(|r| r.y).unwrap_or_default();
        assert_eq!(run.len(), t.y.len());
        let (mut diff, mut sig) = (0.0, 0.0);
        for (k, &row) in kept.y.iter().enumerate() {
            diff += (run[k] - whole.y[row as usize]).powi(2);
            sig += whole.y[row as usize].powi(2);
        }
        let nrmse = (diff / sig).sqrt();
        assert!(nrmse < 1e-3, "NRMSE {nrmse:.2e}");
    }
    #[test]
    fn the_output_alone_is_the_traced_output() {
        // The searches' run (`output`) is the reported one's fitted column, row for row,
        // also with a hook that moves the state (the restart copy of the predictability
        // assessment), and it is what the costs see.
        let mut p = REFERENCE;
        p.sample_period_s = H;
        let d = stepped(3, Some(&p));
        let kick = |k: usize, st: &mut PlantState| {
            if k.is_multiple_of(800) {
                st.twist_rad = -st.twist_rad;
            }
        };
        let traced = simulate_with(&p, &d, kick).map(|t| t.y);
        let alone = output_with(&p, &d, kick);
        assert!(traced.as_ref().is_some_and(|y| y.len() == d.y.len()));
        assert_eq!(traced, alone);
        // The hook did move the state.
        assert_ne!(traced, output(&p, &d));
        assert_eq!(simulate(&p, &d).map(|t| t.y), output(&p, &d));
        assert_eq!(nrmse(&p, &d), 0.0);
        let mut bad = p;
        bad.motor.inertia_kg_m2 = -1.0;
        assert_eq!(output(&bad, &d), None);
    }
}
