//! The part of a residual that repeats with the input.
//!
//! A record driven by a periodic command (a square wave, with or without a small multisine on
//! top) answers each period alike where the unit is predictable. A residual that comes back
//! in every period at the same phase is a deterministic response the model lacks (a
//! structural mode ringing after each edge, a friction the model does not have); gear rattle
//! is chaotic (MODEL.md, "Gear rattle"), so what it leaves in the residual differs from one
//! period to the next and averages out over the periods, as the noise does. The synchronous
//! average over the periods tells the two apart: its mean square, less what noise and rattle
//! leave in a mean of that many periods, estimates the mean square of the repeating part
//! without bias.

/// Largest share of the command's variance the command may change by from one period to the
/// next and still count as periodic: a 9 V square wave with a 2 V multisine of incommensurate
/// tones on top (the validation records of the foreign suite) changes by 0.7 %.
pub const PERIODIC_SHARE: f64 = 0.05;

/// Fewest periods a record must hold for its repeating part to be estimated.
pub const MIN_PERIODS: usize = 4;

/// Shortest period looked for, rows.
pub const MIN_PERIOD_ROWS: usize = 8;

/// The command's period in rows: the shortest lag at which the command repeats to within
/// [`PERIODIC_SHARE`] of its variance once it has moved by its variance (a mean square change
/// of at least the variance at a shorter lag: a slow square wave changes only at its edges at
/// short lags), moved to the best lag within a fifth of it (a square wave's edges repeat well
/// a row or two early); `None` when it repeats at no lag that leaves [`MIN_PERIODS`] periods
/// in the record.
pub fn command_period(volts: &[f64]) -> Option<usize> {
    let n = volts.len();
    if n < 2 * MIN_PERIOD_ROWS {
        return None;
    }
    let mean = volts.iter().sum::<f64>() / n as f64;
    let var = volts.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64;
    if var.is_nan() || var <= 0.0 {
        return None;
    }
    // Σ (v[i+p] − v[i])² over i < n − p for every lag at once: the two sums of squares from
    // prefix sums, the cross term Σ v[i+p] v[i] (the autocorrelation) by FFT, so a record of
    // 40 000 rows costs milliseconds, not a scan of every lag.
    let centred: Vec<f64> = volts.iter().map(|v| v - mean).collect();
    let cross = autocorrelation(&centred);
    let mut prefix = Vec::with_capacity(n + 1);
    prefix.push(0.0);
    for v in &centred {
        prefix.push(prefix.last().copied().unwrap_or(0.0) + v * v);
    }
    let total = prefix.last().copied().unwrap_or(0.0);
    let change = |p: usize| {
        let head = prefix.get(n - p).copied().unwrap_or(0.0);
        let tail = total - prefix.get(p).copied().unwrap_or(0.0);
        let r = cross.get(p).copied().unwrap_or(0.0);
        ((head + tail - 2.0 * r) / ((n - p) as f64 * var)).max(0.0)
    };
    let longest = n / MIN_PERIODS;
    let mut moved = false;
    let first = (1..=longest).find(|&p| {
        let c = change(p);
        moved |= c >= 1.0;
        moved && p >= MIN_PERIOD_ROWS && c < PERIODIC_SHARE
    })?;
    (first..=(first + first / 5).min(longest))
        .map(|p| (change(p), p))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, p)| p)
}

/// Σ x[i+p] x[i] over i < n − p, for p = 0..n, by FFT (zero-padded to avoid wrapping).
fn autocorrelation(x: &[f64]) -> Vec<f64> {
    use rustfft::{num_complex::Complex, FftPlanner};
    let n = x.len();
    let m = (2 * n).next_power_of_two();
    let mut planner = FftPlanner::<f64>::new();
    let mut buf: Vec<Complex<f64>> = x
        .iter()
        .map(|&v| Complex::new(v, 0.0))
        .chain(std::iter::repeat(Complex::new(0.0, 0.0)))
        .take(m)
        .collect();
    planner.plan_fft_forward(m).process(&mut buf);
    for b in &mut buf {
        *b = Complex::new(b.norm_sqr(), 0.0);
    }
    planner.plan_fft_inverse(m).process(&mut buf);
    buf.iter().take(n).map(|c| c.re / m as f64).collect()
}

/// What repeats of a residual over the periods of its command.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Repeating {
    /// The command's period, rows ([`command_period`]).
    pub period_rows: usize,
    /// The same in seconds.
    pub period_s: f64,
    /// Whole periods in the record.
    pub periods: usize,
    /// The record's noise standard deviation, in the output's unit (given).
    pub noise_sigma: f64,
    /// Mean square of the residual over the rows counted, in the output's unit squared.
    pub mean_square: f64,
    /// Unbiased estimate of the mean square of its repeating part over the same rows (0 when
    /// the estimate is negative: nothing repeats beyond chance).
    pub repeating_mean_square: f64,
    /// Rows counted: those of weight at least one half whose phase is counted in at least
    /// two periods.
    pub rows: usize,
}

/// The repeating part of the residual `e` (measured less modelled, one per row) of a record
/// whose command is `volts`, sampled every `h` seconds, with noise of standard deviation
/// `sigma` (carried for the report), over the rows of weight `w` at least one half (every row when
/// `w` is empty): per phase of the period, the mean over the periods m and the spread s² of
/// the n rows counted there; m² − s²/n estimates the square of the repeating part at that
/// phase without bias, whatever the noise and the rattle leave. `None` when the command is
/// not periodic ([`command_period`]) or no phase is counted twice.
pub fn repeating(volts: &[f64], e: &[f64], w: &[f64], h: f64, sigma: f64) -> Option<Repeating> {
    let p = command_period(volts)?;
    let k = e.len().min(volts.len()) / p;
    if k < MIN_PERIODS {
        return None;
    }
    let kept = |i: usize| w.get(i).is_none_or(|&x| x >= 0.5);
    let (mut rows, mut total, mut rep) = (0usize, 0.0, 0.0);
    for j in 0..p {
        let vals: Vec<f64> = (0..k)
            .map(|q| q * p + j)
            .filter(|&i| kept(i))
            .filter_map(|i| e.get(i).copied())
            .collect();
        let n = vals.len();
        if n < 2 {
            continue;
        }
        let m = vals.iter().sum::<f64>() / n as f64;
        let s2 = vals.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1) as f64;
        rows += n;
        total += vals.iter().map(|v| v * v).sum::<f64>();
        rep += n as f64 * (m * m - s2 / n as f64);
    }
    (rows > 0).then(|| Repeating {
        period_rows: p,
        period_s: p as f64 * h,
        periods: k,
        noise_sigma: sigma,
        mean_square: total / rows as f64,
        repeating_mean_square: (rep / rows as f64).max(0.0),
        rows,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic pseudo-random sequence in (−1, 1) (no dependency for a test).
    fn noise(n: usize, seed: u64) -> Vec<f64> {
        let mut s = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (0..n)
            .map(|_| {
                s = s
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                ((s >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
            })
            .collect()
    }

    fn square(n: usize, half: usize) -> Vec<f64> {
        (0..n)
            .map(|i| {
                if (i / half).is_multiple_of(2) {
                    9.0
                } else {
                    -9.0
                }
            })
            .collect()
    }

    #[test]
    fn the_autocorrelation_by_fft_is_the_direct_sum() {
        let x = noise(301, 7);
        let r = autocorrelation(&x);
        for p in [0, 1, 17, 150, 300] {
            let direct: f64 = x[p..].iter().zip(&x).map(|(a, b)| a * b).sum();
            assert!(
                (r[p] - direct).abs() < 1e-9,
                "lag {p}: {} against {direct}",
                r[p]
            );
        }
    }

    #[test]
    fn the_period_of_a_square_wave_with_a_small_aperiodic_part_is_found() {
        let n = 6000;
        let small = noise(n, 3);
        let v: Vec<f64> = square(n, 250)
            .iter()
            .zip(&small)
            .map(|(a, b)| a + 0.6 * b)
            .collect();
        assert_eq!(command_period(&v), Some(500));
        // A command without a period has none.
        assert_eq!(command_period(&noise(n, 5)), None);
        // Nor has a constant one, nor a record too short for four periods.
        assert_eq!(command_period(&vec![1.0; n]), None);
        assert_eq!(command_period(&square(1500, 250)), None);
        // A slow square wave changes little at short lags: its period is still the period.
        assert_eq!(command_period(&square(20_000, 2000)), Some(4000));
    }

    #[test]
    fn a_ringing_that_repeats_is_told_from_noise_and_chaos_that_do_not() {
        let (n, half) = (6000, 250);
        let v = square(n, half);
        let sigma = 0.05;
        let white: Vec<f64> = noise(n, 11)
            .iter()
            .map(|x| x * sigma * 3f64.sqrt())
            .collect();
        // Rattle after each edge: as large, but a different burst every time.
        let chaos = noise(n, 17);
        let rattle: Vec<f64> = (0..n)
            .map(|i| {
                let since = i % half;
                white[i]
                    + if since < 60 {
                        0.15 * chaos[i] * 3f64.sqrt()
                    } else {
                        0.0
                    }
            })
            .collect();
        // A mode ringing the same way after each edge.
        let ring: Vec<f64> = (0..n)
            .map(|i| {
                let since = (i % half) as f64;
                let sign = if (i / half).is_multiple_of(2) {
                    1.0
                } else {
                    -1.0
                };
                white[i] + sign * 0.15 * (-since / 30.0).exp() * (0.65 * since).sin()
            })
            .collect();
        let r = repeating(&v, &white, &[], 5e-4, sigma).unwrap();
        assert_eq!((r.period_rows, r.periods, r.rows), (500, 12, 6000));
        assert!((r.period_s - 0.25).abs() < 1e-12);
        assert!((r.mean_square / sigma.powi(2) - 1.0).abs() < 0.1, "{r:?}");
        assert!(r.repeating_mean_square < 0.05 * sigma.powi(2), "{r:?}");
        let r = repeating(&v, &rattle, &[], 5e-4, sigma).unwrap();
        assert!(r.mean_square > 2.0 * sigma.powi(2), "{r:?}");
        assert!(r.repeating_mean_square < 0.1 * sigma.powi(2), "{r:?}");
        let r = repeating(&v, &ring, &[], 5e-4, sigma).unwrap();
        let truth = (0..500)
            .map(|i| {
                let since = (i % half) as f64;
                (0.15 * (-since / 30.0).exp() * (0.65 * since).sin()).powi(2)
            })
            .sum::<f64>()
            / 500.0;
        assert!(
            (r.repeating_mean_square / truth - 1.0).abs() < 0.15,
            "{r:?} against {truth}"
        );
        // Rows weighted out are not counted.
        let mut w = vec![1.0; n];
        w[..500].iter_mut().for_each(|x| *x = 0.0);
        assert_eq!(repeating(&v, &ring, &w, 5e-4, sigma).unwrap().rows, 5500);
    }
}
