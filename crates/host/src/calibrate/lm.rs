//! Levenberg–Marquardt on the simulation error (the `levenberg-marquardt` crate, a port of
//! MINPACK's `lmder`): central-difference Jacobian in the knobs' internal coordinates, the
//! point alone or with Gauss–Newton standard errors.

use super::{cost, get, largest_change, residuals, set, Data, Fit, Knob};
use geared_servo::ActuatorParams;
use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::{storage::Owned, DMatrix, DVector, Dyn};
use rayon::prelude::*;

/// `p0` with `knobs` set from their internal coordinates `z`.
pub fn apply(p0: &ActuatorParams, knobs: &[Knob], z: &[f64]) -> ActuatorParams {
    let mut p = *p0;
    for (k, &zi) in knobs.iter().zip(z) {
        set(&mut p, k.param, k.from_z(zi));
    }
    p
}

struct Problem<'a> {
    p0: ActuatorParams,
    knobs: &'a [Knob],
    data: &'a [Data],
    z: DVector<f64>,
    r: DVector<f64>,
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for Problem<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, z: &DVector<f64>) {
        // Project into bounds so the optimiser's own copy cannot wander outside them.
        let zc: Vec<f64> = self
            .knobs
            .iter()
            .zip(z.iter())
            .map(|(k, &zi)| k.to_z(k.from_z(zi)))
            .collect();
        self.z = DVector::from_vec(zc);
        self.r = residuals(&apply(&self.p0, self.knobs, self.z.as_slice()), self.data);
    }
    fn params(&self) -> DVector<f64> {
        self.z.clone()
    }
    fn residuals(&self) -> Option<DVector<f64>> {
        Some(self.r.clone())
    }
    fn jacobian(&self) -> Option<DMatrix<f64>> {
        Some(jacobian(&self.p0, self.knobs, self.data, self.z.as_slice()))
    }
}

/// Central-difference Jacobian of [`residuals`] with respect to the internal coordinates `z`
/// of `knobs` (columns in parallel).
pub fn jacobian(p0: &ActuatorParams, knobs: &[Knob], data: &[Data], z: &[f64]) -> DMatrix<f64> {
    let cols: Vec<DVector<f64>> = (0..knobs.len())
        .into_par_iter()
        .map(|j| {
            let hj = knobs.get(j).map(|k| k.fd_step).unwrap_or(0.02);
            let mut zp = z.to_vec();
            let mut zm = z.to_vec();
            if let (Some(a), Some(b)) = (zp.get_mut(j), zm.get_mut(j)) {
                *a += hj;
                *b -= hj;
            }
            let rp = residuals(&apply(p0, knobs, &zp), data);
            let rm = residuals(&apply(p0, knobs, &zm), data);
            (rp - rm) / (2.0 * hj)
        })
        .collect();
    DMatrix::from_columns(&cols)
}

/// Levenberg–Marquardt over `knobs` from `p0` (no coarse search; see [`coarse_search`](super::coarse_search)).
pub fn levenberg_marquardt(p0: &ActuatorParams, knobs: &[Knob], data: &[Data]) -> Fit {
    levenberg_marquardt_with(p0, knobs, data, 20)
}

/// [`levenberg_marquardt()`] with MINPACK's `patience` (at most patience·(knobs + 1) residual
/// evaluations). Tolerances: a relative cost change of 1e-5 is far below the statistical
/// resolution of the cost (about √(2/n), 0.7 % for 40 000 samples).
pub fn levenberg_marquardt_with(
    p0: &ActuatorParams,
    knobs: &[Knob],
    data: &[Data],
    patience: usize,
) -> Fit {
    let (z, point, cost_start, evaluations) = lm_point(p0, knobs, data, patience);
    let z0: Vec<f64> = knobs.iter().map(|k| k.to_z(get(p0, k.param))).collect();
    let moved = largest_change(&z, &z0);
    let values: Vec<f64> = knobs.iter().zip(&z).map(|(k, &zi)| k.from_z(zi)).collect();
    let (std_errors, correlations) = covariance(p0, knobs, data, &z, point.cost);
    Fit {
        params: point.params,
        knobs: knobs.to_vec(),
        values,
        std_errors,
        correlations,
        cost_start,
        cost: point.cost,
        moved,
        evaluations,
    }
}

/// A point of the parameter space and its cost: what a search step hands to the next, which
/// needs no standard errors (their Jacobian costs two runs per knob).
#[derive(Clone, Copy, Debug)]
pub struct Point {
    /// The parameters.
    pub params: ActuatorParams,
    /// Their cost (mean over records of NRMSE²) on the rows the step was judged on.
    pub cost: f64,
}

impl From<&Fit> for Point {
    fn from(f: &Fit) -> Point {
        Point {
            params: f.params,
            cost: f.cost,
        }
    }
}

/// Levenberg–Marquardt from `p0` as in [`levenberg_marquardt_with`], without the
/// covariance: (internal coordinates, the point and its cost, the start's cost, residual
/// evaluations).
pub(super) fn lm_point(
    p0: &ActuatorParams,
    knobs: &[Knob],
    data: &[Data],
    patience: usize,
) -> (Vec<f64>, Point, f64, usize) {
    let z0: Vec<f64> = knobs.iter().map(|k| k.to_z(get(p0, k.param))).collect();
    let cost_start = cost(p0, data);
    let mut prob = Problem {
        p0: *p0,
        knobs,
        data,
        z: DVector::zeros(knobs.len()),
        r: DVector::zeros(0),
    };
    prob.set_params(&DVector::from_vec(z0.clone()));
    let (prob, report) = LevenbergMarquardt::new()
        .with_patience(patience)
        .with_ftol(1e-5)
        .with_xtol(1e-5)
        .minimize(prob);
    let mut z = prob.z.as_slice().to_vec();
    let mut params = apply(p0, knobs, &z);
    let mut c = cost(&params, data);
    if c.is_nan() || c > cost_start {
        // The optimiser can stop at a worse point when the cost is not smooth: keep the start.
        z = z0;
        params = *p0;
        c = cost_start;
    }
    (
        z,
        Point { params, cost: c },
        cost_start,
        report.number_of_evaluations,
    )
}

/// Gauss–Newton covariance σ² (JᵀJ)⁻¹ at `z`, mapped to standard errors in each unit.
fn covariance(
    p0: &ActuatorParams,
    knobs: &[Knob],
    data: &[Data],
    z: &[f64],
    c: f64,
) -> (Vec<f64>, Vec<Vec<f64>>) {
    let n = knobs.len();
    let j = jacobian(p0, knobs, data, z);
    let m = j.nrows();
    let rss = c; // Σ r² of the stacked residuals
    let dof = (m.saturating_sub(n)).max(1) as f64;
    let jtj = j.transpose() * &j;
    let Some(inv) = jtj.clone().try_inverse() else {
        return (vec![f64::INFINITY; n], vec![vec![f64::NAN; n]; n]);
    };
    let cov = inv * (rss / dof);
    let sd: Vec<f64> = (0..n)
        .map(|i| cov.get((i, i)).copied().unwrap_or(0.0).max(0.0).sqrt())
        .collect();
    let se = knobs
        .iter()
        .zip(&sd)
        .zip(z)
        .map(|((k, s), &zi)| if k.log { k.from_z(zi) * s } else { *s })
        .collect();
    let corr = (0..n)
        .map(|a| {
            (0..n)
                .map(|b| {
                    let d = sd.get(a).copied().unwrap_or(0.0) * sd.get(b).copied().unwrap_or(0.0);
                    if d > 0.0 {
                        cov.get((a, b)).copied().unwrap_or(f64::NAN) / d
                    } else {
                        f64::NAN
                    }
                })
                .collect()
        })
        .collect();
    (se, corr)
}
