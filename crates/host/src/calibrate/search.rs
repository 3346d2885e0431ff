//! The global and coarse searches of a calibration: a one-dimensional coarse search per knob,
//! a start read off the record's own frequency response, and CMA-ES over a box around the
//! start.

use super::{apply, cost, get, set, Data, Knob, Param};
use geared_servo::ActuatorParams;
use nalgebra::DVector;
use rayon::prelude::*;

/// Coarse one-dimensional search: for each knob in turn, the best of a few multiples of its
/// value (log knobs) or of a few offsets (linear knobs); two passes. Returns the new
/// parameters and their cost.
pub fn coarse_search(
    p0: &ActuatorParams,
    knobs: &[Knob],
    data: &[Data],
    passes: usize,
) -> (ActuatorParams, f64) {
    let mut best = *p0;
    let mut best_c = cost(&best, data);
    for pass in 0..passes {
        let spread = if pass == 0 { 1.0 } else { 0.5 };
        for k in knobs {
            let v = get(&best, k.param);
            let cands: Vec<f64> = if k.log {
                [-0.7, -0.35, -0.15, 0.15, 0.35, 0.7]
                    .iter()
                    .map(|f| k.from_z(k.to_z(v) + f * spread))
                    .collect()
            } else {
                let w = (k.hi - k.lo) * 0.05 * spread;
                [-2.0, -1.0, -0.5, 0.5, 1.0, 2.0]
                    .iter()
                    .map(|f| (v + f * w).clamp(k.lo, k.hi))
                    .collect()
            };
            let scored: Vec<(f64, ActuatorParams)> = cands
                .par_iter()
                .map(|&c| {
                    let mut q = best;
                    set(&mut q, k.param, c);
                    (cost(&q, data), q)
                })
                .collect();
            for (c, q) in scored {
                if c < best_c {
                    best_c = c;
                    best = q;
                }
            }
        }
    }
    (best, best_c)
}

/// Anti-resonance and resonance read off the record's own frequency response (Welch
/// estimate S_uy/S_uu over the bins the input excites, times f to flatten the integrator
/// roll-off): the deepest dip below the highest peak. `None` when the record does not show a
/// clear pair (peak at least twice the dip).
pub fn frf_notch_peak(d: &Data) -> Option<(f64, f64)> {
    use rustfft::{num_complex::Complex, FftPlanner};
    let n = d.y.len();
    let seg = (n / 4)
        .clamp(64, 2048)
        .next_power_of_two()
        .min(n.next_power_of_two() / 2);
    if seg < 64 || n < seg {
        return None;
    }
    let fft = FftPlanner::<f64>::new().plan_fft_forward(seg);
    let win: Vec<f64> = (0..seg)
        .map(|k| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * k as f64 / seg as f64).cos())
        .collect();
    let half = seg / 2;
    let mut suu = vec![0.0; half];
    let mut suy = vec![Complex::new(0.0, 0.0); half];
    let mut start = 0;
    while start + seg <= n {
        let seg_of = |x: &[f64]| -> Vec<Complex<f64>> {
            let c = x.get(start..start + seg).unwrap_or(&[]);
            let m = c.iter().sum::<f64>() / seg as f64;
            c.iter()
                .zip(&win)
                .map(|(a, w)| Complex::new((a - m) * w, 0.0))
                .collect()
        };
        let mut u = seg_of(&d.volts);
        let mut y = seg_of(&d.y);
        fft.process(&mut u);
        fft.process(&mut y);
        for (k, (uk, yk)) in u.iter().zip(&y).take(half).enumerate() {
            if let (Some(a), Some(b)) = (suu.get_mut(k), suy.get_mut(k)) {
                *a += uk.norm_sqr();
                *b += uk.conj() * yk;
            }
        }
        start += seg / 2;
    }
    let h = d.sample_period_s;
    let smax = suu.iter().cloned().fold(0.0, f64::max);
    let bins: Vec<(f64, f64)> = suu
        .iter()
        .zip(&suy)
        .enumerate()
        .filter_map(|(k, (a, b))| {
            let f = k as f64 / (seg as f64 * h);
            (f >= 2.0 && f <= 0.45 / h && *a > 1e-3 * smax).then(|| (f, (b / a).norm() * f))
        })
        .collect();
    let (fp, gp) = bins
        .iter()
        .copied()
        .fold((0.0, -1.0), |b, x| if x.1 > b.1 { x } else { b });
    let (fn_, gn) = bins
        .iter()
        .copied()
        .filter(|(f, _)| *f < fp)
        .fold((0.0, f64::INFINITY), |b, x| if x.1 < b.1 { x } else { b });
    (fn_ > 0.0 && gp > 2.0 * gn).then_some((fn_, fp))
}

/// A start for the fit from the frequency response (eqs. 17a/b): with J_L from the file,
/// k_eq = J_L (2π f_AR)² and N² J_m = J_L / ((f_R / f_AR)² − 1).
pub fn frf_start(p: &ActuatorParams, d: &Data) -> Option<ActuatorParams> {
    let (f_ar, f_r) = frf_notch_peak(d)?;
    let n = p.derived().ok()?.n_total;
    let jl = p.load.inertia_kg_m2;
    let w = 2.0 * std::f64::consts::PI * f_ar;
    let ratio = (f_r / f_ar).powi(2) - 1.0;
    if ratio <= 0.0 {
        return None;
    }
    let mut q = *p;
    set(&mut q, Param::StiffnessKeq, jl * w * w);
    set(&mut q, Param::MotorInertia, jl / ratio / (n * n));
    q.derived().ok().map(|_| q)
}

/// Half-width of the box [`explore`] samples around the start, in the internal coordinate:
/// inertias and stiffness within a factor 1.5 (a data sheet is rarely further off), friction,
/// backlash and effects within a factor 3, linear knobs within a fifth of their range.
fn explore_half_width(k: &Knob) -> f64 {
    match k.param {
        _ if !k.log => 0.2 * (k.hi - k.lo),
        Param::MotorInertia | Param::LoadInertia | Param::StiffnessKeq => 1.5f64.ln(),
        _ => 3.0f64.ln(),
    }
}

/// Global exploration of the cost around `p0`: `samples` points of a Latin hypercube (seeded,
/// so a run is reproducible) in a box around `p0` (inertias and stiffness within a factor 1.5,
/// friction, backlash and effects within a factor 3), each simulated once.
/// Returns (cost, parameters) sorted best first, `p0` included.
pub fn explore(
    p0: &ActuatorParams,
    knobs: &[Knob],
    data: &[Data],
    samples: usize,
) -> Vec<(f64, ActuatorParams)> {
    use rand::seq::SliceRandom;
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0x5eed);
    let m = samples.max(1);
    // One stratum per sample in every coordinate, shuffled independently.
    let columns: Vec<Vec<f64>> = knobs
        .iter()
        .map(|_| {
            let mut c: Vec<f64> = (0..m)
                .map(|i| (i as f64 + rng.gen::<f64>()) / m as f64)
                .collect();
            c.shuffle(&mut rng);
            c
        })
        .collect();
    let z0: Vec<f64> = knobs.iter().map(|k| k.to_z(get(p0, k.param))).collect();
    let points: Vec<ActuatorParams> = (0..m)
        .map(|i| {
            let z: Vec<f64> = knobs
                .iter()
                .zip(&z0)
                .zip(&columns)
                .map(|((k, &zc), col)| {
                    let u = col.get(i).copied().unwrap_or(0.5);
                    zc + (2.0 * u - 1.0) * explore_half_width(k)
                })
                .collect();
            apply(p0, knobs, &z)
        })
        .collect();
    let mut out: Vec<(f64, ActuatorParams)> = points
        .into_par_iter()
        .chain(rayon::iter::once(*p0))
        .map(|q| (cost(&q, data), q))
        .filter(|(c, _)| c.is_finite())
        .collect();
    out.sort_by(|a, b| a.0.total_cmp(&b.0));
    out
}

/// Evolution-strategy search (CMA-ES, the `cmaes` crate) of the cost around `p0`: the
/// knobs' internal coordinates scaled by the exploration box ([`explore`]), a start at `p0`
/// with a step of half the box, `population` members per generation, at most `budget`
/// simulations of the records, a fixed seed. Returns the best point seen and its cost.
pub fn evolve(
    p0: &ActuatorParams,
    knobs: &[Knob],
    data: &[Data],
    population: usize,
    budget: usize,
) -> (f64, ActuatorParams) {
    evolve_with(p0, knobs, data, population, budget, 0.5, 0)
}

/// [`evolve`] with the initial step `step` in units of the exploration box and the search's
/// random stream `seed` (a run is reproducible for a given seed, on any thread count).
pub fn evolve_with(
    p0: &ActuatorParams,
    knobs: &[Knob],
    data: &[Data],
    population: usize,
    budget: usize,
    step: f64,
    seed: u64,
) -> (f64, ActuatorParams) {
    let z0: Vec<f64> = knobs.iter().map(|k| k.to_z(get(p0, k.param))).collect();
    let hw: Vec<f64> = knobs.iter().map(explore_half_width).collect();
    let point = |u: &DVector<f64>| -> ActuatorParams {
        let z: Vec<f64> = z0
            .iter()
            .zip(&hw)
            .zip(u.iter())
            .map(|((a, h), ui)| a + h * ui)
            .collect();
        apply(p0, knobs, &z)
    };
    let objective = |u: &DVector<f64>| -> f64 {
        let c = cost(&point(u), data);
        if c.is_finite() {
            c
        } else {
            1e6
        }
    };
    let c0 = cost(p0, data);
    let Ok(mut es) = cmaes::CMAESOptions::new(vec![0.0; knobs.len()], step)
        .population_size(population.max(4))
        .max_function_evals(budget.max(population))
        .tol_fun(1e-9)
        .seed(0x5eed_u64.wrapping_add(seed))
        .build(objective)
    else {
        return (c0, *p0);
    };
    let best = es.run_parallel().overall_best;
    match best {
        Some(b) if b.value < c0 => (b.value, point(&b.point)),
        _ => (c0, *p0),
    }
}

/// Members per generation of the global search of [`calibrate`](super::calibrate) (CMA-ES).
pub const POPULATION: usize = 24;

/// Simulations per knob the global search of [`calibrate`](super::calibrate) may spend (split between its
/// starts).
pub const EVALS_PER_KNOB: usize = 360;

/// Members and simulations per knob of a local search ([`refine`](super::refine)).
pub const LOCAL: (usize, usize) = (16, 120);
