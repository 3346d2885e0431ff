//! Host side of the frequency-response tools: parallel stepped-sine sweeps (rayon), location of
//! the anti-resonance and the resonance with sub-grid refinement, and the design queries
//! `max-backlash` / `min-voltage`. Every simulated point runs the `no_std`
//! [`geared_servo::analyser::measure`], the same code the firmware example runs on target.
//! A located extremum is reported only when it is resolved ([`crate::no_answer`]); otherwise
//! the answer is the reason there is none.

use crate::error::HostError;
use crate::no_answer::{self, Answer, Cause, Expectation, Extremum, Feature, NoAnswer};
use crate::progress::Progress;
pub use crate::response::{Located, Point};
use geared_servo::analyser::{self, Hold, SweepSettings};
use geared_servo::describing;
use geared_servo::linear::LinearModel;
use geared_servo::{ActuatorParams, Plant, SineDrive};
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// How each frequency is measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SweepOptions {
    /// Voltage amplitude V_pk, V.
    pub vpk: f64,
    /// Continuous sine (paper) or zero-order hold (firmware).
    pub hold: Hold,
    /// Analyser settings.
    pub settings: SweepSettings,
    /// Start each frequency on the linearised steady state (true) or from rest (false).
    pub warm_start: bool,
}

impl Default for SweepOptions {
    fn default() -> Self {
        SweepOptions {
            vpk: 10.0,
            hold: Hold::Continuous,
            settings: SweepSettings::DEFAULT,
            warm_start: true,
        }
    }
}

/// Sine drives already built, shared by the benches of one computation. A drive (the exact
/// discretisation of the sine input at one frequency) depends on the parameters but not on
/// the backlash, and `paper` and the design queries revisit the same frequencies for many
/// backlash values. Keyed exactly: the parameters (backlash set to 0) compared by value and
/// the frequency by its bits. Bounded; cleared when full. Owned by the caller (no process
/// state): share one through an `Arc` between benches, threads included.
#[derive(Debug, Default)]
pub struct Drives {
    sets: Mutex<Vec<(ActuatorParams, HashMap<u64, SineDrive>)>>,
}

/// Most drives one [`Drives`] keeps (about 0.5 kB each).
const DRIVE_CACHE_MAX: usize = 20_000;

impl Drives {
    /// An empty cache, ready to share.
    pub fn shared() -> Arc<Drives> {
        Arc::new(Drives::default())
    }

    /// The drive of `params` at `freq_hz`, built on first use.
    fn get(&self, params: &ActuatorParams, freq_hz: f64) -> Result<SineDrive, HostError> {
        let key = params.with_backlash_deg(0.0);
        let bits = freq_hz.to_bits();
        if let Ok(sets) = self.sets.lock() {
            if let Some(d) = sets
                .iter()
                .find(|(p, _)| *p == key)
                .and_then(|(_, m)| m.get(&bits))
            {
                return Ok(*d);
            }
        }
        let d = SineDrive::new(params, freq_hz)?;
        if let Ok(mut sets) = self.sets.lock() {
            if sets.iter().map(|(_, m)| m.len()).sum::<usize>() >= DRIVE_CACHE_MAX {
                sets.clear();
            }
            match sets.iter_mut().find(|(p, _)| *p == key) {
                Some((_, m)) => {
                    m.insert(bits, d);
                }
                None => sets.push((key, HashMap::from([(bits, d)]))),
            }
        }
        Ok(d)
    }
}

/// A parameter set ready to be measured at any frequency: the plant and the warm-start model.
pub struct Bench {
    drives: Arc<Drives>,
    params: ActuatorParams,
    plant: Plant,
    warm: LinearModel,
    opts: SweepOptions,
}

impl Bench {
    /// Builds the plant for `params` and the linear warm-start model (stiffness k_eff from
    /// the describing function at the anti-resonance for `opts.vpk`).
    pub fn new(params: &ActuatorParams, opts: SweepOptions) -> Result<Bench, HostError> {
        Bench::with_drives(params, opts, Drives::shared())
    }

    /// [`Bench::new`] taking its sine drives from `drives`, shared with other benches of the
    /// same parameters (the backlash aside).
    pub fn with_drives(
        params: &ActuatorParams,
        opts: SweepOptions,
        drives: Arc<Drives>,
    ) -> Result<Bench, HostError> {
        if !(opts.vpk.is_finite() && opts.vpk > 0.0) {
            return Err(HostError::input(format!(
                "the voltage amplitude must be a positive number of volts, got {}",
                opts.vpk
            )));
        }
        let plant = Plant::new(params)?;
        let warm = describing::warm_start_model(params, opts.vpk)?;
        Ok(Bench {
            drives,
            params: *params,
            plant,
            warm,
            opts,
        })
    }

    /// The options.
    pub fn options(&self) -> &SweepOptions {
        &self.opts
    }

    /// Measures one frequency (Hz).
    pub fn point(&self, freq_hz: f64) -> Result<Point, HostError> {
        let o = &self.opts;
        let h = self.params.sample_period_s;
        let bad = |what: &str| {
            HostError::input(format!(
                "cannot measure at {freq_hz} Hz (sample period {h} s): {what}"
            ))
        };
        let drive = self.drives.get(&self.params, freq_hz)?;
        let a = analyser::for_sweep(freq_hz, h, &o.settings).map_err(|e| bad(e.0))?;
        let start = if o.warm_start {
            self.warm.steady_state(freq_hz, o.vpk)
        } else {
            geared_servo::PlantState::REST
        };
        let m = analyser::measure(&self.plant, &drive, &a, o.vpk, o.hold, start);
        let [tach, current] = m.channels;
        Ok(Point {
            freq_hz,
            tach,
            current,
            settled: m.settled,
            samples: m.samples,
            blocks: m.blocks_averaged,
        })
    }

    /// Measures every frequency in parallel, ticking `progress` once per point.
    pub fn sweep(&self, freqs: &[f64], progress: &dyn Progress) -> Result<Vec<Point>, HostError> {
        freqs
            .par_iter()
            .map(|&f| {
                let p = self.point(f);
                progress.advance(1);
                p
            })
            .collect()
    }
}

/// The grid `from, from + step, …` up to `to` (inclusive within 1e-9 step).
pub fn grid(from: f64, to: f64, step: f64) -> Result<Vec<f64>, HostError> {
    if !(from.is_finite() && to.is_finite() && step.is_finite() && from > 0.0 && to >= from) {
        return Err(HostError::input(format!(
            "frequency range must satisfy 0 < first <= last, got {from}..{to} Hz"
        )));
    }
    if step <= 0.0 || (to - from) / step > 1.0e6 {
        return Err(HostError::input(format!(
            "frequency step must be positive and give at most a million points, got {step} Hz"
        )));
    }
    let n = ((to - from) / step + 1e-9).floor() as usize;
    Ok((0..=n).map(|i| from + i as f64 * step).collect())
}

/// Where the anti-resonance and the resonance are on a simulated response.
#[derive(Clone, Debug, PartialEq)]
pub struct Resonances {
    /// Anti-resonance: minimum of |V_t/V_m| (eq. 17a in the linear case).
    pub anti_resonance: Answer<Located>,
    /// Resonance of `Ωm/T_m`: minimum of |I/V_m| above the anti-resonance's grid point
    /// (eq. 17b in the linear case: the back-EMF cancels the voltage where `Ωm/T_m` has its
    /// pole). `None` when not searched ([`LocateOptions::resonance`] false).
    pub resonance: Option<Answer<Located>>,
    /// Peak of |V_t/V_m| above the anti-resonance's grid point (back-EMF damping puts it a
    /// little above 17b: 205.80 vs 205.72 Hz for the reference actuator). `None` when not
    /// searched.
    pub gain_peak: Option<Answer<Located>>,
    /// Points simulated.
    pub evaluations: usize,
}

/// How [`locate`] searches.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocateOptions {
    /// Lowest frequency of the coarse grid, Hz.
    pub from_hz: f64,
    /// Highest frequency of the coarse grid, Hz.
    pub to_hz: f64,
    /// Coarse grid spacing, Hz.
    pub step_hz: f64,
    /// Refinement stops when the bracket is this narrow, Hz.
    pub tol_hz: f64,
    /// Also locate the resonance and the gain peak.
    pub resonance: bool,
}

impl Default for LocateOptions {
    fn default() -> Self {
        LocateOptions {
            from_hz: 10.0,
            to_hz: 300.0,
            step_hz: 4.0,
            tol_hz: 0.005,
            resonance: true,
        }
    }
}

const INV_PHI: f64 = 0.618_033_988_749_894_9;

/// Golden-section search for the minimum of `value(point)` on `[a, b]`, recording every point.
fn golden(
    bench: &Bench,
    mut a: f64,
    mut b: f64,
    tol: f64,
    value: &dyn Fn(&Point) -> f64,
    seen: &mut Vec<Point>,
) -> Result<(), HostError> {
    let eval = |f: f64, seen: &mut Vec<Point>| -> Result<f64, HostError> {
        let p = bench.point(f)?;
        seen.push(p);
        Ok(value(&p))
    };
    let mut c = b - INV_PHI * (b - a);
    let mut d = a + INV_PHI * (b - a);
    let mut fc = eval(c, seen)?;
    let mut fd = eval(d, seen)?;
    while b - a > tol {
        if fc <= fd {
            b = d;
            d = c;
            fd = fc;
            c = b - INV_PHI * (b - a);
            fc = eval(c, seen)?;
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + INV_PHI * (b - a);
            fd = eval(d, seen)?;
        }
    }
    Ok(())
}

/// A refined extremum before it is judged.
struct Refined {
    located: Located,
    evaluations: usize,
    band_open: bool,
    std_error: f64,
}

/// Refines the extremum of `value` (minimised) around grid index `i` on re-simulated points
/// of `bench` (without a bench: takes the grid as it is) and summarises it.
fn refine(
    bench: Option<&Bench>,
    coarse: &[Point],
    i: usize,
    tol: f64,
    value: &dyn Fn(&Point) -> f64,
    spread: &dyn Fn(&Point) -> f64,
    lo_limit: f64,
) -> Result<Refined, HostError> {
    let at = |j: usize| coarse.get(j).map(|p| p.freq_hz);
    let f0 = at(i).unwrap_or(lo_limit);
    let a = at(i.wrapping_sub(1)).unwrap_or(f0).max(lo_limit);
    let b = at(i + 1).unwrap_or(f0);
    let mut seen: Vec<Point> = coarse.to_vec();
    let before = seen.len();
    if let (Some(bench), true) = (bench, b > a) {
        golden(bench, a, b, tol, value, &mut seen)?;
    }
    let evaluations = seen.len() - before;
    let best = seen
        .iter()
        .filter(|p| p.freq_hz >= a && p.freq_hz <= b)
        .min_by(|x, y| value(x).total_cmp(&value(y)))
        .copied()
        .ok_or_else(|| HostError::other("no point to refine"))?;
    let (v0, s0) = (value(&best), spread(&best));
    // The band: walk outwards from the best point along frequency while the points stay
    // within two standard errors of it (a contiguous blur, not every noisy point of the sweep).
    let mut pts: Vec<&Point> = seen.iter().filter(|p| p.freq_hz >= lo_limit).collect();
    pts.sort_by(|x, y| x.freq_hz.total_cmp(&y.freq_hz));
    pts.dedup_by(|x, y| x.freq_hz == y.freq_hz);
    let near = |p: &Point| value(p) - 2.0 * spread(p) <= v0 + 2.0 * s0;
    let ib = pts
        .iter()
        .position(|p| p.freq_hz == best.freq_hz)
        .unwrap_or(0);
    let mut band = (best.freq_hz, best.freq_hz);
    let mut settled = best.settled;
    for p in pts.iter().skip(ib + 1).take_while(|p| near(p)) {
        band.1 = p.freq_hz;
        settled &= p.settled;
    }
    for p in pts.iter().take(ib).rev().take_while(|p| near(p)) {
        band.0 = p.freq_hz;
        settled &= p.settled;
    }
    // The band reaching the first or last point searched: the response never rose clear of
    // the extremum on that side.
    let ends = (
        pts.first().map_or(band.0, |p| p.freq_hz),
        pts.last().map_or(band.1, |p| p.freq_hz),
    );
    Ok(Refined {
        located: Located {
            freq_hz: best.freq_hz,
            band_hz: band,
            value: v0,
            settled,
        },
        evaluations,
        band_open: band.0 <= ends.0 || band.1 >= ends.1,
        std_error: s0,
    })
}

fn argmin_from(coarse: &[Point], start: usize, value: &dyn Fn(&Point) -> f64) -> Option<usize> {
    coarse
        .iter()
        .enumerate()
        .skip(start)
        .min_by(|(_, x), (_, y)| value(x).total_cmp(&value(y)))
        .map(|(i, _)| i)
}

/// Locates the anti-resonance (and optionally the resonance and the gain peak) of `bench`:
/// coarse parallel sweep, then golden-section refinement on re-simulated points, then the
/// judgement of [`crate::no_answer`]. Returns the coarse sweep too (empty when the model puts
/// every feature above the Nyquist frequency: nothing is simulated then).
pub fn locate(
    bench: &Bench,
    lo: &LocateOptions,
    progress: &dyn Progress,
) -> Result<(Resonances, Vec<Point>), HostError> {
    let freqs = grid(lo.from_hz, lo.to_hz, lo.step_hz)?;
    let expect = Expectation::new(&bench.params, bench.opts.vpk)?;
    let range = (lo.from_hz, lo.to_hz);
    let prior_ar = expect.rules_out(Feature::AntiResonance, range);
    let prior_r = expect.rules_out(Feature::Resonance, range);
    let prior_peak = expect.rules_out(Feature::GainPeak, range);
    // f_R lies above f_AR: with the anti-resonance above Nyquist there is nothing to simulate.
    if let (Some(ar), Some(r), Some(peak)) = (&prior_ar, &prior_r, &prior_peak) {
        if ar.cause == Cause::AboveNyquist {
            return Ok((
                Resonances {
                    anti_resonance: Err(ar.clone()),
                    resonance: lo.resonance.then(|| Err(r.clone())),
                    gain_peak: lo.resonance.then(|| Err(peak.clone())),
                    evaluations: 0,
                },
                Vec::new(),
            ));
        }
    }
    let coarse = bench.sweep(&freqs, progress)?;
    let floor = bench.opts.settings.abs_tol;
    let gain = |p: &Point| p.gain();
    let gain_spread = |p: &Point| p.tach.spread / f64::from(p.blocks.max(1)).sqrt();
    let i_ar = argmin_from(&coarse, 0, &gain).ok_or_else(|| HostError::input("empty grid"))?;
    let mut evals = coarse.len();
    let judged =
        |feature, start: usize, index: usize, r: &Refined, value: &dyn Fn(&Point) -> f64, floor| {
            let x = Extremum {
                feature,
                range,
                coarse: &coarse,
                start,
                index,
                located: r.located,
                band_open: r.band_open,
                std_error: r.std_error,
                value,
                floor,
            };
            match no_answer::judge(&x, &expect) {
                Some(na) => Err(na),
                None => Ok(r.located),
            }
        };
    let (anti_resonance, ar_hz) = match prior_ar {
        Some(na) => (Err(na), coarse.get(i_ar).map_or(lo.from_hz, |p| p.freq_hz)),
        None => {
            let r = refine(
                Some(bench),
                &coarse,
                i_ar,
                lo.tol_hz,
                &gain,
                &gain_spread,
                lo.from_hz,
            )?;
            evals += r.evaluations;
            let floor = floor.first().copied().unwrap_or(0.0);
            (
                judged(Feature::AntiResonance, 0, i_ar, &r, &gain, floor),
                r.located.freq_hz,
            )
        }
    };
    let (mut resonance, mut gain_peak) = (None, None);
    if lo.resonance {
        let none_above = |feature| {
            Err(NoAnswer {
                cause: Cause::AtRangeEdge,
                reason: format!(
                    "no resolvable {} in {}–{} Hz: no simulated frequency above the lowest |V_t/V_m|",
                    if feature == Feature::Resonance { "resonance" } else { "gain peak" },
                    no_answer::hz(range.0),
                    no_answer::hz(range.1)
                ),
            })
        };
        let cur = |p: &Point| p.current_gain();
        let cur_spread = |p: &Point| p.current.spread / f64::from(p.blocks.max(1)).sqrt();
        resonance = Some(match (&prior_r, argmin_from(&coarse, i_ar + 1, &cur)) {
            (Some(na), _) => Err(na.clone()),
            (None, Some(i)) if i_ar + 2 < coarse.len() => {
                let r = refine(Some(bench), &coarse, i, lo.tol_hz, &cur, &cur_spread, ar_hz)?;
                evals += r.evaluations;
                let floor = floor.get(1).copied().unwrap_or(0.0);
                judged(Feature::Resonance, i_ar + 1, i, &r, &cur, floor)
            }
            _ => none_above(Feature::Resonance),
        });
        let neg = |p: &Point| -p.gain();
        gain_peak = Some(match (&prior_peak, argmin_from(&coarse, i_ar + 1, &neg)) {
            (Some(na), _) => Err(na.clone()),
            (None, Some(i)) if i_ar + 2 < coarse.len() => {
                let mut r = refine(
                    Some(bench),
                    &coarse,
                    i,
                    lo.tol_hz,
                    &neg,
                    &gain_spread,
                    ar_hz,
                )?;
                r.located.value = -r.located.value;
                evals += r.evaluations;
                judged(Feature::GainPeak, i_ar + 1, i, &r, &gain, 0.0)
            }
            _ => none_above(Feature::GainPeak),
        });
    }
    Ok((
        Resonances {
            anti_resonance,
            resonance,
            gain_peak,
            evaluations: evals,
        },
        coarse,
    ))
}

/// Why the grid `pts` (as `bode` simulates it, ascending frequencies) has no anti-resonance
/// although one might be expected there: `Some` when the model rules the anti-resonance out
/// (above the Nyquist frequency, load not driven), or when it predicts one within the grid's
/// range and the grid does not resolve it ([`no_answer::judge`], without refinement).
pub fn unresolved_notch(bench: &Bench, pts: &[Point]) -> Result<Option<NoAnswer>, HostError> {
    let range = (
        pts.first().map_or(0.0, |p| p.freq_hz),
        pts.last().map_or(0.0, |p| p.freq_hz),
    );
    let expect = Expectation::new(&bench.params, bench.opts.vpk)?;
    if let Some(na) = expect.rules_out(Feature::AntiResonance, range) {
        return Ok(Some(na));
    }
    if expect.f_ar_hz < range.0 || expect.f_ar_hz > range.1 {
        return Ok(None);
    }
    let gain = |p: &Point| p.gain();
    let gain_spread = |p: &Point| p.tach.spread / f64::from(p.blocks.max(1)).sqrt();
    let Some(i) = argmin_from(pts, 0, &gain) else {
        return Ok(None);
    };
    let r = refine(None, pts, i, 0.0, &gain, &gain_spread, range.0)?;
    let x = Extremum {
        feature: Feature::AntiResonance,
        range,
        coarse: pts,
        start: 0,
        index: i,
        located: r.located,
        band_open: r.band_open,
        std_error: r.std_error,
        value: &gain,
        floor: bench.opts.settings.abs_tol.first().copied().unwrap_or(0.0),
    };
    Ok(no_answer::judge(&x, &expect))
}

/// Spread of a gain in dB: the dB width of ±spread around |H|.
pub fn spread_db(spread: f64, gain: f64) -> f64 {
    if gain <= 0.0 {
        return f64::INFINITY;
    }
    let hi = 20.0 * ((gain + spread) / gain).log10();
    let lo = if spread < gain {
        20.0 * (gain / (gain - spread)).log10()
    } else {
        f64::INFINITY
    };
    0.5 * (hi + lo)
}
