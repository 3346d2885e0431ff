//! Residual analysis: NRMSE and fit, whiteness (autocorrelation against its 99 % bounds),
//! cross-correlation with the input, and where the residual's energy lies in frequency
//! (bands of a Welch spectrum) and in the operating regime (near velocity reversals, at
//! large currents, in contact or in the gap).

use crate::calibrate::Trace;
use rustfft::{num_complex::Complex, FftPlanner};
use serde_json::{json, Value};

/// 99 % two-sided normal quantile, for the autocorrelation bounds ±z/√n.
pub const Z99: f64 = 2.576;

/// Lags tested for whiteness and input correlation.
pub const LAGS: usize = 25;

/// Frequency band edges, Hz (the last band runs to Nyquist).
pub const BAND_EDGES_HZ: [f64; 7] = [0.0, 1.0, 5.0, 20.0, 80.0, 250.0, 600.0];

/// The analysis of one residual.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Analysis {
    /// ‖e‖ / ‖y − ȳ‖.
    pub nrmse: f64,
    /// 100 (1 − nrmse).
    pub fit_percent: f64,
    /// Normalised autocorrelation at lags 1..=LAGS.
    pub autocorrelation: Vec<f64>,
    /// Bound ±Z99/√n.
    pub bound: f64,
    /// Lags outside the bound.
    pub lags_outside: usize,
    /// At most one lag of LAGS outside (P ≈ 2.6 % of rejecting white noise).
    pub white: bool,
    /// Largest |cross-correlation| of input and residual over lags 0..=LAGS.
    pub max_input_correlation: f64,
    /// Whether that exceeds the bound.
    pub input_correlated: bool,
    /// (low Hz, high Hz, share of residual energy).
    pub bands: Vec<(f64, f64, f64)>,
    /// Frequency of the largest spectral line of the residual, Hz.
    pub peak_hz: f64,
    /// (regime, share of samples, share of residual energy).
    pub regimes: Vec<(String, f64, f64)>,
}

fn autocorr(x: &[f64], y: &[f64], lag: usize) -> f64 {
    let n = x.len().min(y.len());
    let mx = x.iter().sum::<f64>() / n.max(1) as f64;
    let my = y.iter().sum::<f64>() / n.max(1) as f64;
    let sx = x.iter().map(|a| (a - mx).powi(2)).sum::<f64>().sqrt();
    let sy = y.iter().map(|a| (a - my).powi(2)).sum::<f64>().sqrt();
    if sx == 0.0 || sy == 0.0 || lag >= n {
        return 0.0;
    }
    let s: f64 = x
        .iter()
        .take(n - lag)
        .zip(y.iter().skip(lag))
        .map(|(a, b)| (a - mx) * (b - my))
        .sum();
    s / (sx * sy)
}

/// Welch power spectrum (Hann, 50 % overlap) of `x` sampled every `h` s: (frequencies Hz,
/// power per bin, arbitrary scale).
pub fn spectrum(x: &[f64], h: f64) -> (Vec<f64>, Vec<f64>) {
    let seg = x.len().min(1024).next_power_of_two().min(x.len().max(2));
    let seg = if seg > x.len() { seg / 2 } else { seg }.max(2);
    let mut planner = FftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(seg);
    let win: Vec<f64> = (0..seg)
        .map(|k| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * k as f64 / seg as f64).cos())
        .collect();
    let half = seg / 2 + 1;
    let mut p = vec![0.0; half];
    let mut start = 0;
    let mut count = 0;
    while start + seg <= x.len() {
        let chunk = x.get(start..start + seg).unwrap_or(&[]);
        let mean = chunk.iter().sum::<f64>() / seg as f64;
        let mut buf: Vec<Complex<f64>> = chunk
            .iter()
            .zip(&win)
            .map(|(a, w)| Complex::new((a - mean) * w, 0.0))
            .collect();
        fft.process(&mut buf);
        for (pk, b) in p.iter_mut().zip(&buf) {
            *pk += b.norm_sqr();
        }
        count += 1;
        start += seg / 2;
    }
    for v in &mut p {
        *v /= count.max(1) as f64;
    }
    let f = (0..half).map(|k| k as f64 / (seg as f64 * h)).collect();
    (f, p)
}

/// Weighted mean ȳ_w and ‖√w (y − ȳ_w)‖₂ of `y` with weights `w` (the NRMSE denominator);
/// (0, 0) when the weights sum to zero.
pub fn weighted_norm(y: &[f64], w: &[f64]) -> (f64, f64) {
    let sw: f64 = w.iter().sum();
    if sw <= 0.0 {
        return (0.0, 0.0);
    }
    let mean = y.iter().zip(w).map(|(a, b)| a * b).sum::<f64>() / sw;
    let ss: f64 = y.iter().zip(w).map(|(a, b)| b * (a - mean).powi(2)).sum();
    (mean, ss.sqrt())
}

/// Analyses the residual `y − model.y`; `u` is the input, `h` the sample period.
pub fn analyse(y: &[f64], model: &Trace, u: &[f64], h: f64) -> Analysis {
    analyse_weighted(y, model, u, h, &[])
}

/// [`analyse`] over the rows of weight `w` (0 to 1; missing rows weigh 1): the residual is
/// `√w (y − model.y)`, so rows weighted out (unpredictable spans) count as zero residual, and
/// the NRMSE is taken over the weighted rows.
pub fn analyse_weighted(y: &[f64], model: &Trace, u: &[f64], h: f64, w: &[f64]) -> Analysis {
    let wk = |k: usize| w.get(k).copied().unwrap_or(1.0).clamp(0.0, 1.0);
    let e: Vec<f64> = y
        .iter()
        .zip(&model.y)
        .enumerate()
        .map(|(k, (a, b))| wk(k).sqrt() * (a - b))
        .collect();
    let n = e.len().max(1);
    let weights: Vec<f64> = (0..y.len()).map(wk).collect();
    let (_, norm) = weighted_norm(y, &weights);
    let enorm = e.iter().map(|v| v * v).sum::<f64>().sqrt();
    let nrmse = if norm > 0.0 {
        enorm / norm
    } else {
        f64::INFINITY
    };
    let shape = Shape::of(&e, u, h);

    // Regimes: near a reversal of the model's motor speed (within 5 % of its peak), large
    // current (above half its peak), contact versus gap (only when there is a gap).
    let wpk = model.motor_speed.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let ipk = model.current.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let e2: f64 = e.iter().map(|v| v * v).sum::<f64>().max(1e-300);
    let share = |mask: &dyn Fn(usize) -> bool| {
        let mut cnt = 0usize;
        let mut en = 0.0;
        for (k, ek) in e.iter().enumerate() {
            if mask(k) {
                cnt += 1;
                en += ek * ek;
            }
        }
        (cnt as f64 / n as f64, en / e2)
    };
    let mut regimes = Vec::new();
    let near_rev = |k: usize| {
        model
            .motor_speed
            .get(k)
            .is_some_and(|w| w.abs() < 0.05 * wpk)
    };
    let (a, b) = share(&near_rev);
    regimes.push(("near_velocity_reversal".to_string(), a, b));
    let large_i = |k: usize| model.current.get(k).is_some_and(|i| i.abs() > 0.5 * ipk);
    let (a, b) = share(&large_i);
    regimes.push(("large_current".to_string(), a, b));
    if model.contact.iter().any(|c| !c) {
        let gap = |k: usize| model.contact.get(k).is_some_and(|c| !c);
        let (a, b) = share(&gap);
        regimes.push(("in_gap".to_string(), a, b));
    }

    let mut out = Analysis {
        nrmse,
        fit_percent: 100.0 * (1.0 - nrmse),
        regimes,
        ..Analysis::default()
    };
    shape.into(&mut out);
    out
}

/// [`analyse_weighted`] of an angle fitted as its steps from sample to sample
/// (`calibrate::Data::steps`): the NRMSE and the regimes are the steps', the whiteness, the
/// input correlation and the spectrum are of the angle's residual rebuilt from them over
/// each run of kept rows (weight ½ or more), its mean there taken out and 0 elsewhere. The
/// steps' own noise, `e[k] − e[k−1]`, is not white (−½ at lag 1): the angle's is, and a slow
/// error shows in the angle where its steps spread it over every row.
pub fn analyse_steps(y: &[f64], model: &Trace, u: &[f64], h: f64, w: &[f64]) -> Analysis {
    let mut out = analyse_weighted(y, model, u, h, w);
    let wk = |k: usize| w.get(k).copied().unwrap_or(1.0);
    let mut z = vec![0.0; y.len().min(model.y.len())];
    let mut runs: Vec<(usize, usize)> = Vec::new();
    let (mut acc, mut lo) = (0.0, None);
    for (k, zk) in z.iter_mut().enumerate() {
        if wk(k) >= 0.5 {
            acc += y.get(k).copied().unwrap_or(0.0) - model.y.get(k).copied().unwrap_or(0.0);
            *zk = acc;
            lo.get_or_insert(k);
        } else {
            acc = 0.0;
            if let Some(a) = lo.take() {
                runs.push((a, k));
            }
        }
    }
    if let Some(a) = lo {
        runs.push((a, z.len()));
    }
    for (a, b) in runs {
        if let Some(span) = z.get_mut(a..b) {
            let m = span.iter().sum::<f64>() / span.len().max(1) as f64;
            span.iter_mut().for_each(|x| *x -= m);
        }
    }
    Shape::of(&z, u, h).into(&mut out);
    out
}

/// What the whiteness test, the input correlation and the spectrum say of a residual.
struct Shape {
    autocorrelation: Vec<f64>,
    bound: f64,
    lags_outside: usize,
    max_input_correlation: f64,
    bands: Vec<(f64, f64, f64)>,
    peak_hz: f64,
}

impl Shape {
    /// Of the residual `e` (rows weighted already) against the input `u`, sampled every `h` s.
    fn of(e: &[f64], u: &[f64], h: f64) -> Shape {
        let n = e.len().max(1);
        let bound = Z99 / (n as f64).sqrt();
        let ac: Vec<f64> = (1..=LAGS).map(|k| autocorr(e, e, k)).collect();
        let outside = ac.iter().filter(|r| r.abs() > bound).count();
        let xc = (0..=LAGS)
            .map(|k| autocorr(u, e, k).abs())
            .fold(0.0, f64::max);
        let (bands, peak_hz) = Shape::spectral(e, h);
        Shape {
            autocorrelation: ac,
            bound,
            lags_outside: outside,
            max_input_correlation: xc,
            bands,
            peak_hz,
        }
    }

    fn into(self, a: &mut Analysis) {
        a.white = self.lags_outside <= 1;
        a.input_correlated = self.max_input_correlation > self.bound;
        a.autocorrelation = self.autocorrelation;
        a.bound = self.bound;
        a.lags_outside = self.lags_outside;
        a.max_input_correlation = self.max_input_correlation;
        a.bands = self.bands;
        a.peak_hz = self.peak_hz;
    }

    /// The residual's energy by band and the frequency of its largest line.
    fn spectral(e: &[f64], h: f64) -> (Vec<(f64, f64, f64)>, f64) {
        let (f, p) = spectrum(e, h);
        let total: f64 = p.iter().sum::<f64>().max(1e-300);
        let nyq = 0.5 / h;
        let mut edges: Vec<f64> = BAND_EDGES_HZ.iter().copied().filter(|&x| x < nyq).collect();
        edges.push(nyq);
        let bands = edges
            .iter()
            .zip(edges.iter().skip(1))
            .map(|(&lo, &hi)| {
                let s: f64 = f
                    .iter()
                    .zip(&p)
                    .filter(|(fk, _)| **fk >= lo && (**fk < hi || hi >= nyq))
                    .map(|(_, pk)| pk)
                    .sum();
                (lo, hi, s / total)
            })
            .collect();
        let peak_hz = f
            .iter()
            .zip(&p)
            .skip(1)
            .fold(
                (0.0, -1.0),
                |(bf, bp), (fk, pk)| {
                    if *pk > bp {
                        (*fk, *pk)
                    } else {
                        (bf, bp)
                    }
                },
            )
            .0;
        (bands, peak_hz)
    }
}

impl Analysis {
    /// The band holding the largest share of the residual's energy: (low, high, share).
    pub fn dominant_band(&self) -> (f64, f64, f64) {
        self.bands
            .iter()
            .copied()
            .fold((0.0, 0.0, -1.0), |b, x| if x.2 > b.2 { x } else { b })
    }

    /// Regimes holding at least 5 % of the residual energy and at least 1.5× their share of
    /// the samples.
    pub fn concentrated_regimes(&self) -> Vec<String> {
        self.regimes
            .iter()
            .filter(|(_, s, e)| *s > 0.0 && *e >= 0.05 && *e > 1.5 * s)
            .map(|(n, s, e)| {
                format!(
                    "{n} ({:.0} % of the energy in {:.0} % of the time)",
                    100.0 * e,
                    100.0 * s
                )
            })
            .collect()
    }

    /// JSON form.
    pub fn to_json(&self) -> Value {
        let (lo, hi, sh) = self.dominant_band();
        json!({
            "nrmse": self.nrmse,
            "fit_percent": self.fit_percent,
            "residual_white": self.white,
            "autocorrelation_lags_outside_99": self.lags_outside,
            "autocorrelation_lags_tested": LAGS,
            "autocorrelation_bound": self.bound,
            "max_input_cross_correlation": self.max_input_correlation,
            "input_correlated": self.input_correlated,
            "peak_hz": self.peak_hz,
            "dominant_band_hz": [lo, hi],
            "dominant_band_share": sh,
            "bands": self.bands.iter().map(|(a, b, s)| json!({"from_hz": a, "to_hz": b, "share": s})).collect::<Vec<_>>(),
            "regimes": self.regimes.iter().map(|(n, s, e)| json!({"regime": n, "time_share": s, "energy_share": e})).collect::<Vec<_>>(),
        })
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn trace(y: Vec<f64>) -> Trace {
        let n = y.len();
        Trace {
            y,
            motor_speed: vec![1.0; n],
            current: vec![0.0; n],
            contact: vec![true; n],
        }
    }

    #[test]
    fn a_sine_residual_is_not_white_and_its_band_is_found() {
        let h = 0.0005;
        let y: Vec<f64> = (0..8000)
            .map(|k| (2.0 * std::f64::consts::PI * 120.0 * k as f64 * h).sin())
            .collect();
        let model = trace(vec![0.0; 8000]);
        let a = analyse(&y, &model, &vec![0.0; 8000], h);
        assert!(!a.white);
        let (lo, hi, share) = a.dominant_band();
        assert!((80.0..=250.0).contains(&lo) || (lo <= 120.0 && hi > 120.0));
        assert!(share > 0.9, "{share}");
        assert!((a.peak_hz - 120.0).abs() < 2.0, "{}", a.peak_hz);
    }

    #[test]
    fn an_angles_steps_are_judged_white_by_the_angle_they_rebuild() {
        // Steps of white noise (e[k] − e[k−1]) are not white; the angle rebuilt from them
        // is, over each run of kept rows; the NRMSE is the steps'.
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let nd = Normal::new(0.0, 1e-3).unwrap();
        let n = 4000;
        let e: Vec<f64> = (0..n).map(|_| nd.sample(&mut rng)).collect();
        let steps: Vec<f64> = std::iter::once(0.0)
            .chain(e.windows(2).map(|w| w[1] - w[0]))
            .collect();
        let y: Vec<f64> = (0..n).map(|k| (k as f64 * 0.01).sin() + steps[k]).collect();
        let model = trace((0..n).map(|k| (k as f64 * 0.01).sin()).collect());
        let u = vec![0.0; n];
        let mut w = vec![1.0; n];
        w[1000..1200].iter_mut().for_each(|x| *x = 0.0);
        let plain = analyse_weighted(&y, &model, &u, 5e-4, &w);
        let a = analyse_steps(&y, &model, &u, 5e-4, &w);
        assert!(!plain.white, "steps judged white");
        assert!(a.white, "{} lags outside", a.lags_outside);
        assert_eq!(a.nrmse, plain.nrmse);
        // A slow error is not white in the angle.
        let drift: Vec<f64> = (0..n)
            .map(|k| y[k] + 2e-3 * (k as f64 * 0.003).sin())
            .collect();
        assert!(!analyse_steps(&drift, &model, &u, 5e-4, &w).white);
    }

    #[test]
    fn white_noise_passes_the_whiteness_test() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let nd = Normal::new(0.0, 1.0).unwrap();
        let y: Vec<f64> = (0..8000).map(|_| nd.sample(&mut rng)).collect();
        let a = analyse(&y, &trace(vec![0.0; 8000]), &vec![0.0; 8000], 0.0005);
        assert!(a.white, "{} lags outside", a.lags_outside);
        assert!((a.nrmse - 1.0).abs() < 0.01);
    }
}
