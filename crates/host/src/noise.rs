//! The noise floor of a record, estimated from the record alone.
//!
//! The third difference y\[k+3\] − 3 y\[k+2\] + 3 y\[k+1\] − y\[k\] of white noise of standard
//! deviation σ has variance 20 σ², while that of a smooth signal is small (a sine of
//! frequency f loses a factor (2 sin(π f h))³: 0.004 at 50 Hz and 2 kHz sampling). Over short
//! windows of a record the mean square third difference is therefore noise wherever the
//! motion is slow or at rest (the rests of a stepped sine, the plateaus of a square wave) and
//! larger elsewhere; a low quantile over the windows, corrected for the quantile's own bias
//! on pure noise, estimates σ. Where no window is quiet the estimate is an upper bound, which
//! makes decisions against the floor conservative (fewer effects are claimed).

/// Rows per window.
pub const WINDOW: usize = 64;

/// Quantile of the window estimates taken (a tenth: a record at rest a tenth of the time is
/// enough).
pub const QUANTILE: f64 = 0.1;

/// The quantile's bias on white noise: on pure noise the 10 % quantile of 64-row windows of
/// mean square third differences over 20 is this fraction of σ² (measured over 10⁵ windows;
/// the test below checks it).
pub const QUANTILE_BIAS: f64 = 0.68;

/// The spread of the estimate: on white noise, the relative standard deviation of σ² as
/// [`sigma`] estimates it, times the square root of the number of windows (measured over
/// 400 records each of 93, 274 and 625 windows: 0.477, 0.468, 0.494; the test below checks
/// it).
pub const QUANTILE_REL_SD: f64 = 0.48;

/// Relative standard deviation of σ² as [`sigma`] estimates it from `rows` rows of white
/// noise (infinite below two windows). Where fewer windows are quiet than the quantile
/// assumes, the estimate is biased upwards rather than spread more.
pub fn sigma2_rel_sd(rows: usize) -> f64 {
    let m = rows.saturating_sub(3) / WINDOW;
    if m < 2 {
        f64::INFINITY
    } else {
        QUANTILE_REL_SD / (m as f64).sqrt()
    }
}

/// Estimated standard deviation of the additive white noise in `y`, in `y`'s unit; 0 for a
/// record shorter than two windows.
pub fn sigma(y: &[f64]) -> f64 {
    let d3: Vec<f64> = y
        .windows(4)
        .map(|w| match w {
            [a, b, c, d] => d - 3.0 * c + 3.0 * b - a,
            _ => 0.0,
        })
        .collect();
    let mut v: Vec<f64> = d3
        .chunks_exact(WINDOW)
        .map(|c| c.iter().map(|x| x * x).sum::<f64>() / (20.0 * WINDOW as f64))
        .collect();
    if v.len() < 2 {
        return 0.0;
    }
    v.sort_by(f64::total_cmp);
    let i = ((v.len() as f64 * QUANTILE).floor() as usize).min(v.len() - 1);
    let q = v.get(i).copied().unwrap_or(0.0);
    (q / QUANTILE_BIAS).max(0.0).sqrt()
}

/// The NRMSE that the noise alone gives on a record of norm `norm` (‖√w (y − ȳ)‖) and
/// weights `w`: σ √(Σ w) / norm.
pub fn floor_nrmse(sigma: f64, w: &[f64], norm: f64) -> f64 {
    let sw: f64 = w.iter().sum();
    if norm > 0.0 {
        sigma * sw.sqrt() / norm
    } else {
        f64::INFINITY
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    fn noise(n: usize, s: f64, seed: u64) -> Vec<f64> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let nd = Normal::new(0.0, s).unwrap();
        (0..n).map(|_| nd.sample(&mut rng)).collect()
    }

    #[test]
    fn pure_noise_is_measured_within_five_percent() {
        for seed in 0..4 {
            let y = noise(200_000, 0.3, seed);
            let s = sigma(&y);
            assert!((s / 0.3 - 1.0).abs() < 0.05, "seed {seed}: {s}");
        }
    }

    #[test]
    fn the_spread_of_the_estimate_is_as_stated() {
        let rows = 17_600;
        let est: Vec<f64> = (0..200)
            .map(|seed| sigma(&noise(rows, 1.0, 100 + seed)).powi(2))
            .collect();
        let m = est.iter().sum::<f64>() / est.len() as f64;
        let sd =
            (est.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (est.len() - 1) as f64).sqrt() / m;
        let stated = sigma2_rel_sd(rows);
        assert!((sd / stated - 1.0).abs() < 0.2, "{sd} vs {stated}");
    }

    #[test]
    fn a_stepped_sine_with_rests_does_not_hide_its_noise() {
        // 0.3 s bursts 10-300 Hz with 0.1 s rests, 2 kHz, noise 2 % of the signal's RMS.
        let h = 0.0005;
        let mut y = Vec::new();
        for b in 0..22 {
            let f = 10.0 * (30.0f64).powf(b as f64 / 21.0);
            for k in 0..600 {
                y.push((2.0 * std::f64::consts::PI * f * k as f64 * h).sin());
            }
            y.extend(std::iter::repeat_n(0.0, 200));
        }
        let rms = (y.iter().map(|v| v * v).sum::<f64>() / y.len() as f64).sqrt();
        let e = noise(y.len(), 0.02 * rms, 9);
        let noisy: Vec<f64> = y.iter().zip(&e).map(|(a, b)| a + b).collect();
        let s = sigma(&noisy);
        assert!(
            (s / (0.02 * rms) - 1.0).abs() < 0.15,
            "{s} vs {}",
            0.02 * rms
        );
    }
}
