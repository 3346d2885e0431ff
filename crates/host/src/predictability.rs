//! Predictability: where the model itself says that it cannot be followed sample by sample.
//!
//! With backlash and little damping some regimes are chaotic (gear rattle, MODEL.md): two
//! copies of the same actuator whose parameters differ by a hundredth of a percent part within
//! a fraction of a second, and no calibration can make a model follow a real rig there. The
//! model says so itself: an ensemble of copies, each with the parameters moved by a small
//! amount (10⁻³ of the inertias and stiffness, 5·10⁻³ of the frictions and backlash), stays
//! together where the motion is predictable (the spread is proportional to the perturbation:
//! about 10⁻² of the signal even at a lightly damped resonance, whose sensitivity to a
//! parameter is some tens) and parts where it is not (the spread grows exponentially to the
//! size of the signal). A window is unpredictable when the spread passes 5 % of the signal.
//! Rows inside unpredictable spans are weighted out of fits and decisions, their share is
//! reported, and they are compared by statistics instead (RMS level).
//!
//! No single size of the perturbation marks everything ([`assess`] runs two, and the restart
//! test below, and keeps a row only where all keep it):
//! - 10⁻³ / 5·10⁻³ with a 5 % line (the default [`Settings`]) keeps the resonance bursts, which
//!   are predictable but sensitive and tell inertia from stiffness, but also, on two of the
//!   foreign suite's 48 units, bursts where the rig settled on the other of two coexisting
//!   responses, which copies moved by 10⁻³ never reach (the emulator at the truth there: 8.9
//!   and 15.8 times the noise floor on the kept rows; `host-tests/examples/calib_probe.rs`,
//!   `ENSEMBLES=1`).
//! - Ten times that with a 10 % line ([`WIDE`]) marks those, but on three other units keeps
//!   rows its copies happen to agree on while the chaos goes on (1.1–1.6 times).
//! - Both together: the truth at 0.83–0.95 times the estimated floor on every unit (the
//!   estimate reads about 10 % high), 14–30 % of a lightly damped stepped sine kept.
//! - Smaller ones (10⁻⁴ and 5·10⁻⁴, a 2 % line) mark long spans after every reversal of a
//!   lightly damped gear train as well, because copies that parted by 10⁻⁴ must come back
//!   within 0.5 % to be counted together again: 67 % of a square-wave record of a soft
//!   data-sheet rig (`datasheet_init.rs`).
//!
//! - Neither marks a burst with two coexisting responses when the model sits firmly on one of
//!   them: near its parameters every copy reaches the same one, while the rig, whose gears a
//!   rattling burst before left elsewhere in the gap, may reach the other. [`assess_restarts`]
//!   moves the *state* instead: each burst that starts from rest is run again with the gears
//!   resting elsewhere in the gap.
//!
//! A search from some percent away needs yet another view, the rows where the model is
//! *smooth* in its parameters at that scale ([`assess_smooth`]): a fit is searched there and
//! polished and judged on the predictable rows.

use crate::calibrate::{self, Data, Param};
use geared_servo::ActuatorParams;
use rayon::prelude::*;

/// Settings of the assessment.
#[derive(Clone, Copy, Debug)]
pub struct Settings {
    /// Relative perturbation of the inertias and the stiffness in each ensemble member.
    pub inertia_perturbation: f64,
    /// Relative perturbation of the frictions and the backlash.
    pub friction_perturbation: f64,
    /// Window over which the spread is compared with the signal, s.
    pub window_s: f64,
    /// A window is unpredictable when the ensemble's RMS spread exceeds this share of the
    /// signal's RMS there.
    pub threshold: f64,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            inertia_perturbation: 1e-3,
            friction_perturbation: 5e-3,
            window_s: 0.025,
            threshold: 0.05,
        }
    }
}

/// The parameters an ensemble member moves, with the sign pattern of each of the four
/// members (columns of a 4×4 Hadamard matrix without the constant one, repeated): every
/// parameter moves both ways and no two members move the same way.
const MOVES: [(Param, bool, [f64; 4]); 6] = [
    (Param::MotorInertia, true, [1.0, -1.0, 1.0, -1.0]),
    (Param::LoadInertia, true, [1.0, 1.0, -1.0, -1.0]),
    (Param::StiffnessKeq, true, [1.0, -1.0, -1.0, 1.0]),
    (Param::MotorFriction, false, [-1.0, 1.0, 1.0, -1.0]),
    (Param::LoadFriction, false, [1.0, 1.0, -1.0, -1.0]),
    (Param::Backlash, false, [-1.0, 1.0, -1.0, 1.0]),
];

/// Where one record can be followed.
#[derive(Clone, Debug, PartialEq)]
pub struct Predictability {
    /// Weight of each row: 1 predictable, 0 not.
    pub weight: Vec<f64>,
    /// Share of the rows that are not predictable.
    pub excluded_share: f64,
    /// Unpredictable spans as (first row, one past the last row).
    pub spans: Vec<(usize, usize)>,
}

impl Predictability {
    /// Every row predictable (a record of `n` rows).
    pub fn all(n: usize) -> Predictability {
        Predictability {
            weight: vec![1.0; n],
            excluded_share: 0.0,
            spans: Vec::new(),
        }
    }
}

/// Ensemble member `m` (0–3, repeating) of `p` under `s`: each perturbed parameter moved by
/// its member's sign times its share; the stiffness needs the measured form (as
/// [`calibrate::set`]).
pub fn member(p: &ActuatorParams, m: usize, s: &Settings) -> ActuatorParams {
    let mut q = *p;
    for (param, inertial, signs) in MOVES {
        let share = if inertial {
            s.inertia_perturbation
        } else {
            s.friction_perturbation
        };
        let v = calibrate::get(p, param);
        if v.is_finite() && v > 0.0 {
            let sign = signs.get(m % 4).copied().unwrap_or(1.0);
            calibrate::set(&mut q, param, v * (1.0 + sign * share));
        }
    }
    q
}

/// The second ensemble of [`assess`]: ten times the default perturbations, a 10 % line.
pub const WIDE: Settings = Settings {
    inertia_perturbation: 1e-2,
    friction_perturbation: 5e-2,
    window_s: 0.025,
    threshold: 0.1,
};

/// Assesses `d` under `p`: a row is predictable when both the default ensemble
/// ([`Settings::default`]) and the [`WIDE`] one keep it, and the restart test
/// ([`assess_restarts`]) does.
///
/// One ensemble is not enough, measured on the foreign suite's 48 cases at their true
/// parameters (`host-tests/examples/calib_probe.rs`, `ENSEMBLES=1`; the emulator at the truth
/// on the kept rows over the noise floor estimated from the record, which reads about 10 %
/// high): the default one keeps rows where a resonance burst of the rig settled on the other
/// of two coexisting responses, which copies moved by 10⁻³ do not reach (8.9 and 15.8 times
/// the floor on two cases), and the wide one keeps, on three other cases, rows that copies
/// moved by 10⁻² happen to agree on while the chaos goes on (1.1–1.6 times). Together they
/// keep 14–30 % of a stepped sine and the truth sits at 0.83–0.95 times the floor on every
/// case but one (tach_current_coupling/0, 1.6 with every setting).
pub fn assess(p: &ActuatorParams, d: &Data) -> Predictability {
    let d = &*d.motion();
    // The model's own run is shared by the three tests.
    let Some(center) = calibrate::output(p, d) else {
        return Predictability::all(d.y.len());
    };
    let ((a, b), c) = rayon::join(
        || {
            rayon::join(
                || assess_around(p, d, &Settings::default(), &center),
                || assess_around(p, d, &WIDE, &center),
            )
        },
        || restarts_around(p, d, &center),
    );
    let weight: Vec<f64> = a
        .weight
        .iter()
        .zip(&b.weight)
        .zip(&c)
        .map(|((x, y), z)| x.min(*y).min(*z))
        .collect();
    let n = weight.len();
    let mut spans: Vec<(usize, usize)> = Vec::new();
    for (k, &x) in weight.iter().enumerate() {
        if x >= 0.5 {
            continue;
        }
        match spans.last_mut() {
            Some(last) if last.1 == k => last.1 = k + 1,
            _ => spans.push((k, k + 1)),
        }
    }
    Predictability {
        excluded_share: weight.iter().filter(|x| **x < 0.5).count() as f64 / n.max(1) as f64,
        weight,
        spans,
    }
}

pub use crate::calibrate::REST_S;
/// A restarted copy is compared with the model from this long after the start, s (the
/// transient of the moved gears has decayed by then at 1 % of critical damping and 100 Hz).
pub const RESTART_SETTLE_S: f64 = 0.1;
/// ... and the burst is unpredictable when their RMS difference there exceeds this share of
/// the model's RMS (the [`WIDE`] line).
pub const RESTART_LINE: f64 = 0.1;

/// Row weights of the restart test: a burst that starts from rest is unpredictable when a copy
/// of the model whose gears rest elsewhere in the gap at its start (mirrored about the gap's
/// centre, or moved by half the gap when near it) ends on another response. A lightly damped
/// gear train driven through its resonance can have two coexisting steady responses (with and
/// without impacts, say), and which one a burst reaches depends on where the gears rested
/// before it, which after a rattling burst neither the rig nor any model controls: copies with
/// moved parameters reach the same one, the rig may not. The two are compared from
/// [`RESTART_SETTLE_S`] after the start, when a mere transient has decayed; every row weighs 1
/// on a record without starts from rest (a square wave, a multisine).
pub fn assess_restarts(p: &ActuatorParams, d: &Data) -> Vec<f64> {
    let d = &*d.motion();
    match calibrate::output(p, d) {
        Some(center) => restarts_around(p, d, &center),
        None => vec![1.0; d.y.len()],
    }
}

/// Rest positions of the gears across the gap that [`restart_reaches`] tries: evenly from
/// one flank (−δ) to the other (+δ), a quarter of the half gap apart.
pub const RESTART_POSITIONS: usize = 9;

/// The model `p`'s output over `d` with the gears moved at each row of `starts` (sorted):
/// the twist `x` there replaced by `place(x)`. `None` when the model cannot be run.
fn restarted(
    p: &ActuatorParams,
    d: &Data,
    starts: &[usize],
    place: impl Fn(f32) -> f32,
) -> Option<Vec<f64>> {
    calibrate::output_with(p, d, |k, st| {
        if starts.binary_search(&k).is_ok() {
            st.twist_rad = place(st.twist_rad);
        }
    })
}

/// For each burst of `d` as (first row, one past the last row), whether the model `p`, whose
/// residual over `d` (measured less modelled, every row) is `e`, reaches the measured
/// response there from another rest position of the gears in the gap
/// ([`RESTART_POSITIONS`], one run each with every burst so restarted): whether one of the
/// runs takes away the majority ([`crate::repeat::COHERENT_MAJORITY`]) of the burst's
/// residual above the noise (`sigma`, the record's noise standard deviation), compared from
/// [`RESTART_SETTLE_S`] after the burst's start. A burst with two coexisting responses, of
/// which the unit took one and the model from its own rest position the other, is reached;
/// a response the model lacks is not (measured on the foreign suite's units whose final
/// models miss a burst coherently, `host-tests/examples/calib_probe.rs`, `UNEXCUSE=1`:
/// stiction_ratio/60 at 184.5 Hz and tach_gain/63 at 157 Hz, missed by 63 and 77 σ, are
/// followed to the noise from 7 and 4 of the 9 positions; second_mode/63 at 157 Hz, 117 σ,
/// from none, the best leaving 0.99 of the excess). All false when the model cannot be run.
pub fn restart_reaches(
    p: &ActuatorParams,
    d: &Data,
    e: &[f64],
    bursts: &[(usize, usize)],
    sigma: f64,
) -> Vec<bool> {
    let none = vec![false; bursts.len()];
    let Some(delta) = p.derived().ok().map(|x| x.delta_rad as f32) else {
        return none;
    };
    if bursts.is_empty() || delta.is_nan() || delta <= 0.0 {
        return none;
    }
    let settle = (RESTART_SETTLE_S / d.sample_period_s).round() as usize;
    // The mean square of a residual `r` over a burst from `settle` rows after its start,
    // less the noise's.
    let excess = |r: &[f64], (a, b): (usize, usize)| -> Option<f64> {
        let m = r.get(a + settle..b.min(r.len()))?;
        if m.is_empty() {
            return None;
        }
        Some(m.iter().map(|x| x * x).sum::<f64>() / m.len() as f64 - sigma * sigma)
    };
    let mut starts: Vec<usize> = bursts.iter().map(|b| b.0).collect();
    starts.sort_unstable();
    // The residual of each restarted run.
    let runs: Vec<Vec<f64>> = (0..RESTART_POSITIONS)
        .into_par_iter()
        .filter_map(|j| {
            let x = -delta + 2.0 * delta * j as f32 / (RESTART_POSITIONS - 1) as f32;
            let run = restarted(p, d, &starts, |_| x)?;
            Some(d.y.iter().zip(&run).map(|(y, m)| y - m).collect())
        })
        .collect();
    let keep = 1.0 - crate::repeat::COHERENT_MAJORITY;
    bursts
        .iter()
        .map(|&b| {
            let Some(own) = excess(e, b).filter(|x| *x > 0.0) else {
                return false;
            };
            runs.iter()
                .any(|r| excess(r, b).is_some_and(|x| x <= keep * own))
        })
        .collect()
}

/// [`assess_restarts`] given the model's own run `center` over `d`.
fn restarts_around(p: &ActuatorParams, d: &Data, center: &[f64]) -> Vec<f64> {
    let n = d.y.len();
    let mut weight = vec![1.0; n];
    let starts = d.restarts();
    let Some(delta) = p.derived().ok().map(|x| x.delta_rad as f32) else {
        return weight;
    };
    if starts.is_empty() || delta <= 0.0 {
        return weight;
    }
    let kicks: Vec<usize> = starts.iter().map(|s| s.0).collect();
    let moved = restarted(p, d, &kicks, |x| {
        if x.abs() > 0.25 * delta {
            -x.clamp(-delta, delta)
        } else if x >= 0.0 {
            x - 0.5 * delta
        } else {
            x + 0.5 * delta
        }
    });
    let Some(moved) = moved else {
        return weight;
    };
    let settle = (RESTART_SETTLE_S / d.sample_period_s).round() as usize;
    for &(start, end) in &starts {
        let lo = start + settle;
        if lo >= end {
            continue;
        }
        let (mut diff, mut sig) = (0.0, 0.0);
        for k in lo..end {
            let c = center.get(k).copied().unwrap_or(0.0);
            let m = moved.get(k).copied().unwrap_or(c);
            diff += (m - c).powi(2);
            sig += c * c;
        }
        if diff > RESTART_LINE.powi(2) * sig {
            for x in weight.get_mut(start..end).unwrap_or(&mut []) {
                *x = 0.0;
            }
        }
    }
    weight
}

/// Assesses `d` under `p`: runs the model and four perturbed copies over the record and marks
/// the windows where the copies' RMS spread exceeds `threshold` times the RMS of the model's
/// output there (against a floor of 2 % of the record's RMS, so that a quiet window is not
/// judged by a ratio of two small numbers). A span so started lasts until the model comes to
/// rest or the copies have stayed together for three windows (copies that parted stay parted
/// while the motion goes on, even where their spread happens to be small), and is widened by
/// one window on each side. Everything is predictable when the model cannot be run.
pub fn assess_with(p: &ActuatorParams, d: &Data, s: &Settings) -> Predictability {
    let d = &*d.motion();
    match calibrate::output(p, d) {
        Some(center) => assess_around(p, d, s, &center),
        None => Predictability::all(d.y.len()),
    }
}

/// [`assess_with`] given the model's own run `center` over `d`.
fn assess_around(p: &ActuatorParams, d: &Data, s: &Settings, center: &[f64]) -> Predictability {
    let n = d.y.len();
    let members: Vec<Vec<f64>> = (0..4)
        .into_par_iter()
        .filter_map(|m| calibrate::output(&member(p, m, s), d))
        .collect();
    if members.is_empty() || n == 0 {
        return Predictability::all(n);
    }
    let spread2: Vec<f64> = (0..n)
        .map(|k| {
            let c = center.get(k).copied().unwrap_or(0.0);
            members
                .iter()
                .map(|y| (y.get(k).copied().unwrap_or(c) - c).powi(2))
                .sum::<f64>()
                / members.len() as f64
        })
        .collect();
    let global_ms = center.iter().map(|v| v * v).sum::<f64>() / n as f64;
    let w = ((s.window_s / d.sample_period_s).round() as usize).max(4);
    let windows = n.div_ceil(w);
    // Per window: the spread's ratio to the signal (squared), and whether the model is
    // quiet there (at rest: below 2 % of the record's RMS).
    let stats: Vec<(f64, bool)> = (0..windows)
        .map(|j| {
            let lo = j * w;
            let hi = (lo + w).min(n);
            let len = (hi - lo).max(1) as f64;
            let sp = spread2.get(lo..hi).unwrap_or(&[]).iter().sum::<f64>() / len;
            let sig = center
                .get(lo..hi)
                .unwrap_or(&[])
                .iter()
                .map(|v| v * v)
                .sum::<f64>()
                / len;
            let quiet_line = 0.02f64.powi(2) * global_ms;
            (sp / sig.max(quiet_line), sig < quiet_line)
        })
        .collect();
    // Trajectories that have parted stay parted until dissipation brings them together again:
    // a span runs from the first window over the line until the model is quiet (a rest) or
    // the spread has stayed under a quarter of the line for three windows.
    let line = s.threshold.powi(2);
    let flags: Vec<(bool, bool, bool)> = stats
        .iter()
        .map(|&(ratio, quiet)| (ratio > line, ratio < line / 16.0, quiet))
        .collect();
    spans_from(&flags, w, n)
}

/// Row weights from per-window flags (over the line, calm, quiet), windows of `w` rows over
/// `n` rows: a span starts at a window over the line and lasts until the model is quiet or
/// three windows in a row are calm; it is widened by one window on each side.
fn spans_from(flags: &[(bool, bool, bool)], w: usize, n: usize) -> Predictability {
    let windows = flags.len();
    let mut bad = vec![false; windows];
    let mut inside = false;
    let mut calm = 0usize;
    for (j, &(over, is_calm, quiet)) in flags.iter().enumerate() {
        if over {
            inside = true;
            calm = 0;
        } else if inside {
            calm = if is_calm { calm + 1 } else { 0 };
            if (quiet && is_calm) || calm >= 3 {
                inside = false;
            }
        }
        if let Some(b) = bad.get_mut(j) {
            *b = inside;
        }
    }
    // Widen by one window each side: a trajectory parts before the spread crosses the line.
    let widened: Vec<bool> = (0..windows)
        .map(|j| {
            bad.get(j).copied().unwrap_or(false)
                || (j > 0 && bad.get(j - 1).copied().unwrap_or(false))
                || bad.get(j + 1).copied().unwrap_or(false)
        })
        .collect();
    let mut weight = vec![1.0; n];
    let mut spans: Vec<(usize, usize)> = Vec::new();
    for (j, &b) in widened.iter().enumerate() {
        if !b {
            continue;
        }
        let lo = j * w;
        let hi = (lo + w).min(n);
        for x in weight.get_mut(lo..hi).unwrap_or(&mut []) {
            *x = 0.0;
        }
        match spans.last_mut() {
            Some(last) if last.1 == lo => last.1 = hi,
            _ => spans.push((lo, hi)),
        }
    }
    let excluded = weight.iter().filter(|x| **x < 0.5).count() as f64 / n.max(1) as f64;
    Predictability {
        weight,
        excluded_share: excluded,
        spans,
    }
}

/// Settings of the smoothness test ([`assess_smooth`]).
#[derive(Clone, Copy, Debug)]
pub struct Smoothness {
    /// Relative step of the inertias and the stiffness in each antithetic pair.
    pub inertia_step: f64,
    /// Relative step of the frictions, the backlash and the mesh damping.
    pub friction_step: f64,
    /// Antithetic pairs (at most 4: the Hadamard columns of the move table).
    pub pairs: usize,
    /// Window, s.
    pub window_s: f64,
    /// A window is rough when its even (curvature) part exceeds this share of the whole
    /// change.
    pub even_share: f64,
    /// ... and the change is at least this many noise standard deviations (RMS per row).
    pub min_change_sigmas: f64,
}

impl Default for Smoothness {
    fn default() -> Self {
        Smoothness {
            inertia_step: 0.02,
            friction_step: 0.05,
            pairs: 4,
            window_s: 0.025,
            even_share: 0.35,
            min_change_sigmas: 0.5,
        }
    }
}

/// `p` moved along Hadamard column `m` with `sign` (±1) by the steps of `s`, the mesh damping
/// with the frictions.
fn moved(p: &ActuatorParams, m: usize, sign: f64, s: &Smoothness) -> ActuatorParams {
    let mut q = *p;
    let mesh_sign = [1.0, -1.0, -1.0, 1.0];
    let list = MOVES
        .iter()
        .map(|&(param, inertial, signs)| (param, inertial, signs))
        .chain(std::iter::once((
            Param::Effect(geared_servo::Effect::MeshDamping),
            false,
            mesh_sign,
        )));
    for (param, inertial, signs) in list {
        let step = if inertial {
            s.inertia_step
        } else {
            s.friction_step
        };
        let v = calibrate::get(p, param);
        if v.is_finite() && v > 0.0 {
            let d = sign * signs.get(m % 4).copied().unwrap_or(1.0);
            calibrate::set(&mut q, param, v * (1.0 + d * step));
        }
    }
    q
}

/// Where the model's output is a *smooth* function of its parameters over the accuracy a
/// calibration can reach: antithetic pairs p ± δ (inertias and stiffness by 2 %, frictions,
/// backlash and mesh damping by 5 %, Hadamard sign patterns). Per window the change splits
/// into an odd part (y₊ − y₋)/2, what a linear response gives, and an even part
/// (y₊ + y₋)/2 − y₀, which a linear response does not have. Where the gears rattle
/// chaotically, or a resonance burst can settle on either of two coexisting responses, the
/// three runs are unrelated and the even part is as large as the odd one; where the motion
/// is smooth in the parameters it is a small curvature. A window is rough when the even part
/// exceeds [`Smoothness::even_share`] of the change and the change is at least
/// [`Smoothness::min_change_sigmas`] noise standard deviations (`sigma`); spans of rough
/// windows are weighted out as in [`assess_with`].
///
/// This is the test for fitting from afar: on rows that are rough at the scale of a few
/// percent a search sees a patchwork of basins, and two units that differ by that much (or
/// one unit whose temperature changes) do not agree there sample by sample.
pub fn assess_smooth(p: &ActuatorParams, d: &Data, s: &Smoothness, sigma: f64) -> Predictability {
    let n = d.y.len();
    let Some(center) = calibrate::output(p, d) else {
        return Predictability::all(n);
    };
    let runs: Vec<(Vec<f64>, Vec<f64>)> = (0..s.pairs.clamp(1, 4))
        .into_par_iter()
        .filter_map(|m| {
            let a = calibrate::output(&moved(p, m, 1.0, s), d)?;
            let b = calibrate::output(&moved(p, m, -1.0, s), d)?;
            Some((a, b))
        })
        .collect();
    if runs.is_empty() || n == 0 {
        return Predictability::all(n);
    }
    let w = ((s.window_s / d.sample_period_s).round() as usize).max(4);
    let windows = n.div_ceil(w);
    let global_ms = center.iter().map(|v| v * v).sum::<f64>() / n as f64;
    let flags: Vec<(bool, bool, bool)> = (0..windows)
        .map(|j| {
            let lo = j * w;
            let hi = (lo + w).min(n);
            let (mut odd, mut even) = (0.0, 0.0);
            for (a, b) in &runs {
                for k in lo..hi {
                    let c = center.get(k).copied().unwrap_or(0.0);
                    let (ya, yb) = (
                        a.get(k).copied().unwrap_or(c),
                        b.get(k).copied().unwrap_or(c),
                    );
                    odd += (0.5 * (ya - yb)).powi(2);
                    even += (0.5 * (ya + yb) - c).powi(2);
                }
            }
            let rows = ((hi - lo) * runs.len()).max(1) as f64;
            let change = (odd + even) / rows;
            let sig = center
                .get(lo..hi)
                .unwrap_or(&[])
                .iter()
                .map(|v| v * v)
                .sum::<f64>()
                / (hi - lo).max(1) as f64;
            let quiet = sig < 0.02f64.powi(2) * global_ms;
            let material = change > (s.min_change_sigmas * sigma).powi(2);
            let rough = material && even > s.even_share * (odd + even);
            let calm = !material || even < 0.25 * s.even_share * (odd + even);
            (rough, calm, quiet)
        })
        .collect();
    spans_from(&flags, w, n)
}

/// `d` weighted by its smoothness under `p` ([`assess_smooth`] with the default settings and
/// the record's own noise level, [`crate::noise::sigma`]).
pub fn weigh_smooth(p: &ActuatorParams, d: &Data) -> (Data, Predictability) {
    let pr = assess_smooth(p, d, &Smoothness::default(), d.sigma());
    (d.with_weights(&pr.weight), pr)
}

/// `d` weighted by its predictability under `p`.
pub fn weigh(p: &ActuatorParams, d: &Data) -> (Data, Predictability) {
    let pr = assess(p, d);
    (d.with_weights(&pr.weight), pr)
}

/// Shortest unpredictable span whose level [`span_levels`] compares, in seconds: one to a
/// few cycles of the bursts that rattle (about 20 to 80 Hz on a stepped sine at 10 V); a
/// shorter span's RMS says more about where in a cycle it starts and ends than about the
/// motion.
pub const SPAN_MIN_S: f64 = 0.05;

/// One unpredictable span compared by statistics: the measured and the modelled output's
/// RMS over its rows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpanLevel {
    /// The span's rows: (first row, one past the last row).
    pub rows: (usize, usize),
    /// The same span in seconds from the record's first row: (start, end).
    pub seconds: (f64, f64),
    /// RMS of the measured output over the span with the noise taken out
    /// (√(mean y² − σ²), 0 when the noise explains it all), in the output's unit.
    pub measured_rms: f64,
    /// RMS of the modelled output over the span, in the output's unit.
    pub model_rms: f64,
}

impl SpanLevel {
    /// Modelled over measured RMS, the measured level floored at the noise level `sigma` (a
    /// span quieter than the noise reads as the noise).
    pub fn ratio(&self, sigma: f64) -> f64 {
        self.model_rms / self.measured_rms.max(sigma).max(f64::MIN_POSITIVE)
    }
}

/// The level of every unpredictable span of at least [`SPAN_MIN_S`] (maximal runs of rows
/// whose `weight` is below ½), measured against modelled: where no model can be followed
/// sample by sample its level still can (two faithful models of a rattling gear train agree
/// in RMS to a few per cent over such a span, while a model that jumped to another of two
/// coexisting responses does not). `sigma` is the measurement noise (standard deviation, the
/// output's unit), `period_s` the sample period.
pub fn span_levels(
    measured: &[f64],
    model: &[f64],
    weight: &[f64],
    sigma: f64,
    period_s: f64,
) -> Vec<SpanLevel> {
    let n = measured.len().min(model.len()).min(weight.len());
    let min_rows = if period_s > 0.0 {
        ((SPAN_MIN_S / period_s).ceil() as usize).max(1)
    } else {
        usize::MAX
    };
    let mut out = Vec::new();
    let mut start = None;
    for k in 0..=n {
        let out_of_span = weight.get(k).is_none_or(|w| *w >= 0.5) || k == n;
        match (start, out_of_span) {
            (None, false) => start = Some(k),
            (Some(a), true) => {
                start = None;
                if k - a < min_rows {
                    continue;
                }
                let ms = |x: &[f64]| {
                    let c = x.get(a..k).unwrap_or(&[]);
                    c.iter().map(|v| v * v).sum::<f64>() / c.len().max(1) as f64
                };
                out.push(SpanLevel {
                    rows: (a, k),
                    seconds: (a as f64 * period_s, k as f64 * period_s),
                    measured_rms: (ms(measured) - sigma * sigma).max(0.0).sqrt(),
                    model_rms: ms(model).sqrt(),
                });
            }
            _ => {}
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use geared_servo::REFERENCE;

    const H: f64 = 5e-4;

    fn rows(s: f64) -> usize {
        (s / H).round() as usize
    }

    /// A record of `segments` (seconds, amplitude V, frequency Hz; amplitude 0 = rest) whose
    /// output is the reference model's own tachometer.
    fn record(segments: &[(f64, f64, f64)], p: &ActuatorParams) -> Data {
        let mut volts = Vec::new();
        for &(secs, amp, f) in segments {
            for k in 0..rows(secs) {
                let t = k as f64 * H;
                volts.push(amp * (2.0 * core::f64::consts::PI * f * t).sin());
            }
        }
        crate::calibrate::tests::data_of(volts, H, Some(p))
    }

    #[test]
    fn restarts_are_the_ends_of_zero_runs_of_at_least_rest_s() {
        let d = record(
            &[
                (0.1, 0.0, 0.0),
                (0.2, 5.0, 40.0),
                (0.02, 0.0, 0.0),
                (0.1, 5.0, 40.0),
                (0.1, 0.0, 0.0),
                (0.1, 5.0, 40.0),
            ],
            &REFERENCE,
        );
        let s = d.restarts();
        // The first sample of each sine is 0 and belongs to the zero run before it; the
        // 20 ms pause is shorter than REST_S and starts nothing.
        assert_eq!(s.len(), 2, "{s:?}");
        assert_eq!(s[0].0, rows(0.1) + 1);
        assert_eq!(s[1].0, rows(0.52) + 1);
        // A burst lasts until the next rest begins: the sine's last rows near zero stay
        // above 1 % of the peak for all but a few rows.
        assert!(s[0].1 > rows(0.41) && s[0].1 <= rows(0.42) + 1, "{s:?}");
        assert_eq!(s[1].1, d.volts.len());
    }

    /// A record of the current alone is judged by the motion behind it (`Data::motion`):
    /// its weights are those of the tachometer's record of the same run, while the current
    /// itself, mostly V/R, spreads too little to mark the rattling burst.
    #[test]
    fn a_current_record_is_judged_by_its_motion() {
        let mut p = REFERENCE;
        p.sample_period_s = H;
        let segments = [
            (0.1, 0.0, 0.0),
            (0.3, 10.0, 15.0),
            (0.1, 0.0, 0.0),
            (0.3, 10.0, 250.0),
        ];
        let tach = record(&segments, &p);
        let mut current = tach.clone();
        current.output = "current_a".to_string();
        current.y = calibrate::output(&p, &current).unwrap();
        let (a, b) = (assess(&p, &tach), assess(&p, &current));
        assert_eq!(a.weight, b.weight);
        assert!(a.excluded_share > 0.2, "{}", a.excluded_share);
        let raw = assess_around(&p, &current, &Settings::default(), &current.y);
        assert!(
            raw.excluded_share < 0.5 * a.excluded_share,
            "{} {}",
            raw.excluded_share,
            a.excluded_share
        );
    }

    #[test]
    fn a_record_without_rests_keeps_every_row() {
        let d = record(&[(0.6, 8.0, 120.0)], &REFERENCE);
        assert!(d.restarts().is_empty());
        assert!(assess_restarts(&REFERENCE, &d).iter().all(|w| *w == 1.0));
    }

    #[test]
    fn a_well_damped_burst_reaches_the_same_response_from_anywhere_in_the_gap() {
        // Heavy mesh damping (0.5 N·m·s/rad): one steady response, whatever the start.
        let mut p = REFERENCE;
        p.effects.mesh_damping = 0.5;
        let d = record(
            &[
                (0.1, 0.0, 0.0),
                (0.3, 10.0, 150.0),
                (0.1, 0.0, 0.0),
                (0.3, 10.0, 60.0),
            ],
            &p,
        );
        assert_eq!(d.restarts().len(), 2);
        let w = assess_restarts(&p, &d);
        assert!(w.iter().all(|x| *x == 1.0));
    }

    /// A lightly damped unit: the final model of the foreign suite's stiction_ratio/60 (no
    /// stiction in it), whose response to a 10 V burst at 206 Hz depends on where in the gap
    /// the gears rest at its start (8 times the signal's RMS apart from the two flanks).
    const COEXISTING: &str = "sample_period_s = 5e-4
[motor]
resistance_ohm = 32.5
inductance_h = 8e-4
torque_constant_nm_per_a = 2e-2
back_emf_v_s_per_rad = 2e-2
tach_v_s_per_rad = 1e-2
inertia_kg_m2 = 2.4826e-7
coulomb_friction_nm = 2.2476e-4
[gear_stage_1]
ratio = 5
[gear_stage_2]
ratio = 9
revolving = true
[stiffness]
k1_nm_per_rad = 92.415
k2_nm_per_rad = 825.61
[load]
inertia_kg_m2 = 8.6103e-4
coulomb_friction_nm = 2.7276e-3
[backlash]
total_deg = 5.3248e-2
[effects]
mesh_damping = 5.9344e-3
";

    #[test]
    fn a_burst_the_model_reaches_from_another_rest_position_is_the_other_response_a_sinusoid_it_lacks_is_not(
    ) {
        let p = crate::params_file::parse(COEXISTING, "test").unwrap();
        let mut d = record(
            &[
                (0.1, 0.0, 0.0),
                (0.3, 10.0, 206.0),
                (0.1, 0.0, 0.0),
                (0.3, 10.0, 150.0),
            ],
            &p,
        );
        let bursts = d.restarts();
        assert_eq!(bursts.len(), 2, "{bursts:?}");
        let delta = p.derived().unwrap().delta_rad as f32;
        // The unit: the model itself, but with the gears resting on the far flank at the
        // first burst's start, and with a 150 Hz response the model lacks in the second.
        let first = bursts[0].0;
        let other = calibrate::output_with(&p, &d, |k, st| {
            if k == first {
                st.twist_rad = delta;
            }
        })
        .unwrap();
        let own = calibrate::output(&p, &d).unwrap();
        let rms = |y: &[f64], (a, b): (usize, usize)| {
            (y[a..b].iter().map(|x| x * x).sum::<f64>() / (b - a) as f64).sqrt()
        };
        let a = rms(&own, bursts[1]);
        let (lo, hi) = bursts[1];
        d.y = other
            .iter()
            .enumerate()
            .map(|(k, y)| {
                let t = k as f64 * H;
                let lacks = if (lo..hi).contains(&k) {
                    0.2 * a * (2.0 * core::f64::consts::PI * 150.0 * t).cos()
                } else {
                    0.0
                };
                y + lacks
            })
            .collect();
        // The precondition: from its own rest position the model takes the other response.
        let diff: Vec<f64> = own.iter().zip(&other).map(|(a, b)| a - b).collect();
        assert!(
            rms(&diff, bursts[0]) > 0.3 * rms(&own, bursts[0]),
            "one response only at 206 Hz: {} against {}",
            rms(&diff, bursts[0]),
            rms(&own, bursts[0])
        );
        let sigma = 1e-3 * a;
        let e: Vec<f64> = d.y.iter().zip(&own).map(|(y, m)| y - m).collect();
        assert_eq!(
            restart_reaches(&p, &d, &e, &bursts, sigma),
            vec![true, false]
        );
        // A model that cannot be run reaches nothing.
        let mut broken = p;
        broken.load.inertia_kg_m2 = -1.0;
        assert_eq!(
            restart_reaches(&broken, &d, &e, &bursts, sigma),
            vec![false, false]
        );
    }

    #[test]
    fn span_levels_compare_each_long_enough_unpredictable_span_with_the_noise_taken_out() {
        // 1 s at H: rows 200..400 (0.1 s) and 600..620 (10 ms, too short) unpredictable.
        let n = rows(1.0);
        let mut weight = vec![1.0; n];
        for k in (200..400).chain(600..620) {
            weight[k] = 0.0;
        }
        // Measured: a constant level whose square is 0.3² plus the noise's 0.1²; the model 0.6.
        let sigma = 0.1;
        let measured = vec![(0.3f64 * 0.3 + sigma * sigma).sqrt(); n];
        let model = vec![0.6; n];
        let levels = span_levels(&measured, &model, &weight, sigma, H);
        assert_eq!(levels.len(), 1, "{levels:?}");
        let l = levels[0];
        assert_eq!(l.rows, (200, 400));
        assert!((l.measured_rms - 0.3).abs() < 1e-12, "{l:?}");
        assert!((l.model_rms - 0.6).abs() < 1e-12, "{l:?}");
        assert!((l.ratio(sigma) - 2.0).abs() < 1e-12);
        // A span quieter than the noise reads as the noise; a span at the record's end counts.
        let mut w = vec![1.0; n];
        for x in &mut w[n - 200..] {
            *x = 0.0;
        }
        let quiet = span_levels(&vec![0.05; n], &vec![0.2; n], &w, sigma, H);
        assert_eq!(quiet.len(), 1);
        assert_eq!(quiet[0].rows, (n - 200, n));
        assert_eq!(quiet[0].measured_rms, 0.0);
        assert!((quiet[0].ratio(sigma) - 2.0).abs() < 1e-12);
        // No span, a broken time base, mismatched lengths: nothing compared, nothing panics.
        assert!(span_levels(&measured, &model, &vec![1.0; n], sigma, H).is_empty());
        assert!(span_levels(&measured, &model, &weight, sigma, 0.0).is_empty());
        assert_eq!(
            span_levels(&measured[..300], &model, &weight, sigma, H).len(),
            1
        );
    }
}
