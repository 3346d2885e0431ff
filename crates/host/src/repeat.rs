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

impl Repeating {
    /// The repeating part is the majority ([`COHERENT_MAJORITY`]) of what the residual's
    /// mean square exceeds the noise's by: a response the model lacks, not rattle, which
    /// does not come back period after period (the summary's reading of the line).
    pub fn mostly_repeats(&self) -> bool {
        let excess = self.mean_square - self.noise_sigma * self.noise_sigma;
        excess > 0.0 && self.repeating_mean_square > COHERENT_MAJORITY * excess
    }
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

/// Least share of a span's command energy a single sinusoid must hold for the span to count
/// as a sine burst: a stepped sine's burst with tapered ends holds 95 % or more; a square
/// wave's fundamental holds 81 % (8/π²), so a square wave is not taken for one.
pub const SINE_SHARE: f64 = 0.9;

/// Share of a burst's residual above the noise that its coherent part must reach for the
/// burst to count as a deterministic miss. Where the unit rattles the response's fundamental
/// fluctuates from cycle to cycle and a model's statistics there differ by part of it (up to
/// 31 % of the excess on the clean units of the foreign suite, at their final models); a
/// response the model lacks (a second structural mode near the burst's frequency: 69-79 %)
/// leaves most of its residual at the command's frequency and its harmonics.
pub const COHERENT_MAJORITY: f64 = 0.5;

/// Harmonics of a burst's frequency counted in its coherent part (those below 0.45 of the
/// sampling rate).
pub const HARMONICS: usize = 3;

/// What of a residual is coherent with a stepped sine's bursts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coherent {
    /// Sine bursts found in the command ([`sine_bursts`]).
    pub bursts: usize,
    /// Of them, those whose coherent part is the majority of their residual above the noise
    /// ([`COHERENT_MAJORITY`]) and at least the noise's mean square (a response the noise
    /// does not hide), less those the model reaches from another rest position of the gears
    /// ([`BurstPart::other_response`]).
    pub coherent_bursts: usize,
    /// Mostly coherent bursts whose response the model reaches from another rest position of
    /// the gears in the gap: the other of two coexisting responses (counted apart, left out
    /// of the coherent part and of the worst burst).
    pub other_response_bursts: usize,
    /// The record's noise standard deviation, in the output's unit (given).
    pub noise_sigma: f64,
    /// Mean square of the residual over every row, in the output's unit squared.
    pub mean_square: f64,
    /// The coherent parts of the bursts that are mostly coherent, as a mean square over every
    /// row of the record (unbiased: what a residual without a coherent part leaves in the
    /// projection taken out), in the output's unit squared.
    pub coherent_mean_square: f64,
    /// The burst with the largest coherent part: its frequency, Hz.
    pub worst_hz: f64,
    /// Its coherent part's RMS, in the output's unit.
    pub worst_rms: f64,
    /// Its coherent part's share of its residual above the noise.
    pub worst_share: f64,
}

/// The sine bursts of a command sampled every `h` seconds: spans between rests (at least 20
/// rows within 2 % of the command's largest magnitude) that hold four periods or more of one
/// sinusoid carrying at least [`SINE_SHARE`] of the span's energy. Returns (first row, end
/// row, frequency in Hz) per burst.
pub fn sine_bursts(volts: &[f64], h: f64) -> Vec<(usize, usize, f64)> {
    let peak = volts.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    if !(peak > 0.0 && h > 0.0) {
        return Vec::new();
    }
    let quiet = |v: &f64| v.abs() <= 0.02 * peak;
    let mut spans = Vec::new();
    let (mut start, mut run) = (None::<usize>, 0usize);
    for (i, v) in volts.iter().enumerate() {
        if quiet(v) {
            run += 1;
            if run >= 20 {
                if let Some(s) = start.take() {
                    spans.push((s, i + 1 - run));
                }
            }
        } else {
            run = 0;
            start.get_or_insert(i);
        }
    }
    if let Some(s) = start {
        spans.push((s, volts.len()));
    }
    spans
        .into_iter()
        .filter_map(|(a, b)| {
            let v = volts.get(a..b)?;
            let f = peak_frequency(v, h)?;
            let periods = (b - a) as f64 * h * f;
            let (_, share) = harmonic_fit(v, f, h, 1);
            (periods >= 4.0 && f * h < 0.45 && share >= SINE_SHARE).then_some((a, b, f))
        })
        .collect()
}

/// The frequency (Hz) of the largest peak of `v`'s spectrum (Hann window, zero-padded to
/// 64 times its length, the peak refined by a parabola through the log magnitudes).
fn peak_frequency(v: &[f64], h: f64) -> Option<f64> {
    use rustfft::{num_complex::Complex, FftPlanner};
    let n = v.len();
    if n < 16 {
        return None;
    }
    let m = (64 * n).next_power_of_two().min(1 << 20);
    let mut buf: Vec<Complex<f64>> = v
        .iter()
        .enumerate()
        .map(|(i, &x)| {
            let w = 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / (n - 1) as f64).cos();
            Complex::new(x * w, 0.0)
        })
        .chain(std::iter::repeat(Complex::new(0.0, 0.0)))
        .take(m)
        .collect();
    FftPlanner::<f64>::new()
        .plan_fft_forward(m)
        .process(&mut buf);
    let mag: Vec<f64> = buf.iter().take(m / 2).map(|c| c.norm()).collect();
    let k = (1..mag.len().saturating_sub(1)).max_by(|&a, &b| mag[a].total_cmp(&mag[b]))?;
    let (a, b, c) = (
        mag.get(k - 1)?.max(1e-300).ln(),
        mag.get(k)?.max(1e-300).ln(),
        mag.get(k + 1)?.max(1e-300).ln(),
    );
    let den = a - 2.0 * b + c;
    let d = if den < 0.0 { 0.5 * (a - c) / den } else { 0.0 };
    Some((k as f64 + d) / (m as f64 * h))
}

/// Least-squares fit of `x` by a constant and `harmonics` harmonics of `f` (those below 0.45
/// of the sampling rate): the fit's mean square and its share of `x`'s mean square, with the
/// number of columns fitted.
fn harmonic_fit(x: &[f64], f: f64, h: f64, harmonics: usize) -> ((f64, usize), f64) {
    use nalgebra::{DMatrix, DVector};
    let n = x.len();
    let ks: Vec<usize> = (1..=harmonics)
        .filter(|&k| k as f64 * f * h < 0.45)
        .collect();
    let cols = 1 + 2 * ks.len();
    let a = DMatrix::from_fn(n, cols, |i, j| {
        if j == 0 {
            return 1.0;
        }
        let k = ks.get((j - 1) / 2).copied().unwrap_or(1) as f64;
        let ph = 2.0 * std::f64::consts::PI * k * f * i as f64 * h;
        if j % 2 == 1 {
            ph.sin()
        } else {
            ph.cos()
        }
    });
    let y = DVector::from_column_slice(x);
    let total = y.norm_squared() / n.max(1) as f64;
    let fitted = a
        .clone()
        .svd(true, true)
        .solve(&y, 1e-12)
        .map(|c| (&a * c).norm_squared() / n.max(1) as f64)
        .unwrap_or(0.0);
    (
        (fitted, cols),
        if total > 0.0 { fitted / total } else { 0.0 },
    )
}

/// The part of the residual `e` (measured less modelled, one per row, every row) of a
/// record whose command `volts`, sampled every `h` seconds, is a stepped sine, that is
/// coherent with each burst ([`burst_parts`]). Rattle is chaotic and a response the model
/// lacks is not; see [`COHERENT_MAJORITY`]. `sigma` is the record's noise standard
/// deviation. `None` when the command has no sine bursts.
pub fn coherent(volts: &[f64], e: &[f64], h: f64, sigma: f64) -> Option<Coherent> {
    Coherent::of(&burst_parts(volts, e, h, sigma), e, sigma)
}

impl Coherent {
    /// The record's summary of its bursts' `parts` ([`burst_parts`] of the residual `e`, every
    /// row, with the record's noise standard deviation `sigma`); `None` without bursts.
    pub fn of(parts: &[BurstPart], e: &[f64], sigma: f64) -> Option<Coherent> {
        if parts.is_empty() || e.is_empty() {
            return None;
        }
        let n_all = e.len() as f64;
        let mut out = Coherent {
            bursts: parts.len(),
            coherent_bursts: 0,
            other_response_bursts: 0,
            noise_sigma: sigma,
            mean_square: e.iter().map(|x| x * x).sum::<f64>() / n_all,
            coherent_mean_square: 0.0,
            worst_hz: f64::NAN,
            worst_rms: 0.0,
            worst_share: 0.0,
        };
        for b in parts {
            let c = b.coherent_mean_square;
            if b.other_response {
                out.other_response_bursts += 1;
                continue;
            }
            if c > out.worst_rms.powi(2) {
                (out.worst_hz, out.worst_rms, out.worst_share) = (b.hz, c.sqrt(), b.share);
            }
            if b.mostly_coherent {
                out.coherent_bursts += 1;
                out.coherent_mean_square += c * (b.end - b.start) as f64 / n_all;
            }
        }
        Some(out)
    }
}

/// One sine burst's residual and its part coherent with the burst ([`burst_parts`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BurstPart {
    /// First row of the burst.
    pub start: usize,
    /// One past its last row.
    pub end: usize,
    /// The burst's frequency, Hz.
    pub hz: f64,
    /// The residual's mean square over the burst, in the output's unit squared.
    pub mean_square: f64,
    /// Its coherent part's mean square over the burst (unbiased), in the output's unit
    /// squared.
    pub coherent_mean_square: f64,
    /// The coherent part's share of the burst's residual above the noise (at most 1).
    pub share: f64,
    /// The coherent part is the majority of the residual above the noise
    /// ([`COHERENT_MAJORITY`]) and at least the noise's mean square: a deterministic
    /// response the model lacks, unless it is one the model has ([`Self::other_response`]).
    pub mostly_coherent: bool,
    /// The model reaches the unit's response over this burst from another rest position of
    /// the gears in the gap (`predictability::restart_reaches`): the other of two
    /// coexisting responses, not one the model lacks. Set by the caller, who has the model.
    pub other_response: bool,
}

/// Each sine burst of `volts` ([`sine_bursts`]) with the part of the residual `e` coherent
/// with it: its fit by the burst's frequency and [`HARMONICS`] harmonics, less what a
/// residual without such a part leaves in that fit (the columns' share of the burst's mean
/// square). `sigma` is the record's noise standard deviation. Bursts of fewer than 16 rows
/// inside `e` are left out.
pub fn burst_parts(volts: &[f64], e: &[f64], h: f64, sigma: f64) -> Vec<BurstPart> {
    sine_bursts(volts, h)
        .into_iter()
        .filter_map(|(a, b, f)| {
            let end = b.min(e.len());
            let r = e.get(a..end)?;
            let n = r.len() as f64;
            if n < 16.0 {
                return None;
            }
            let ms = r.iter().map(|x| x * x).sum::<f64>() / n;
            let ((fitted, cols), _) = harmonic_fit(r, f, h, HARMONICS);
            let c = (fitted - cols as f64 * ms / n).max(0.0);
            // At most 1: a residual at the noise level leaves an excess of the order of
            // the estimate's own error, and the share then says nothing.
            let share = if c > 0.0 {
                c / (ms - sigma * sigma).max(c)
            } else {
                0.0
            };
            Some(BurstPart {
                start: a,
                end,
                hz: f,
                mean_square: ms,
                coherent_mean_square: c,
                share,
                mostly_coherent: share >= COHERENT_MAJORITY && c >= sigma * sigma,
                other_response: false,
            })
        })
        .collect()
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
    /// A stepped sine as the foreign suite's: bursts of 0.3 s with cosine-tapered ends
    /// (30 ms), 0.05 s rests, sampled every 0.5 ms; with each burst's (first row, end row).
    fn stepped_sine(freqs: &[f64]) -> (Vec<f64>, Vec<(usize, usize)>) {
        let h = 5e-4;
        let (on, rest, taper) = (600, 100, 60);
        let mut v = Vec::new();
        let mut spans = Vec::new();
        for &f in freqs {
            v.extend(std::iter::repeat_n(0.0, rest));
            spans.push((v.len(), v.len() + on));
            for i in 0..on {
                let edge = i.min(on - 1 - i);
                let w = if edge < taper {
                    0.5 - 0.5 * (std::f64::consts::PI * edge as f64 / taper as f64).cos()
                } else {
                    1.0
                };
                v.push(10.0 * w * (2.0 * std::f64::consts::PI * f * i as f64 * h).sin());
            }
        }
        v.extend(std::iter::repeat_n(0.0, rest));
        (v, spans)
    }

    #[test]
    fn a_stepped_sines_bursts_are_found_and_a_square_wave_is_not_one() {
        let freqs = [20.0, 43.0, 97.5, 184.5];
        let (v, spans) = stepped_sine(&freqs);
        let b = sine_bursts(&v, 5e-4);
        assert_eq!(b.len(), 4, "{b:?}");
        // The spans found start and end where the taper leaves the rests' 2 % band.
        for ((a, e, f), (&want, &(sa, se))) in b.iter().zip(freqs.iter().zip(&spans)) {
            assert!((f / want - 1.0).abs() < 2e-3, "{f} Hz for {want}");
            assert!(
                a.abs_diff(sa) <= 10 && e.abs_diff(se) <= 10,
                "{a}..{e} for {sa}..{se}"
            );
        }
        // A burst of fewer than four periods is not one (5 Hz over 0.3 s: 1.5).
        assert_eq!(sine_bursts(&stepped_sine(&[5.0, 43.0]).0, 5e-4).len(), 1);
        // A square wave is periodic, not a sine burst; nor is noise.
        assert!(sine_bursts(&square(6000, 250), 5e-4).is_empty());
        assert!(sine_bursts(&noise(6000, 3), 5e-4).is_empty());
        assert!(coherent(&square(6000, 250), &noise(6000, 4), 5e-4, 0.1).is_none());
    }

    #[test]
    fn a_response_at_the_bursts_frequency_is_told_from_noise_and_chaos() {
        let h = 5e-4;
        let freqs = [20.0, 43.0, 97.5, 184.5];
        let (v, spans) = stepped_sine(&freqs);
        let n = v.len();
        let sigma = 0.01;
        let white: Vec<f64> = noise(n, 21)
            .iter()
            .map(|x| x * sigma * 3f64.sqrt())
            .collect();
        let r = coherent(&v, &white, h, sigma).unwrap();
        assert_eq!((r.bursts, r.coherent_bursts), (4, 0), "{r:?}");
        assert!(r.coherent_mean_square < 0.02 * sigma * sigma, "{r:?}");
        // Rattle in the second and third bursts: ten times the noise, broadband, chaotic.
        let chaos = noise(n, 23);
        let in_burst = |i: usize, k: usize| spans.get(k).is_some_and(|&(a, b)| (a..b).contains(&i));
        let rattle: Vec<f64> = (0..n)
            .map(|i| {
                let big = in_burst(i, 1) || in_burst(i, 2);
                white[i]
                    + if big {
                        10.0 * sigma * 3f64.sqrt() * chaos[i]
                    } else {
                        0.0
                    }
            })
            .collect();
        let r = coherent(&v, &rattle, h, sigma).unwrap();
        assert!(r.mean_square > 20.0 * sigma * sigma, "{r:?}");
        assert_eq!(r.coherent_bursts, 0, "{r:?}");
        assert!(r.coherent_mean_square == 0.0, "{r:?}");
        assert!(r.worst_rms < 0.5 * sigma, "{r:?}");
        // A mode the model lacks answering the 184.5 Hz burst (five times the noise): the
        // burst's frequency, out of phase, and its second harmonic.
        let (a4, b4) = spans[3];
        let response = |i: usize| {
            if !(a4..b4).contains(&i) {
                return 0.0;
            }
            let ph = 2.0 * std::f64::consts::PI * 184.5 * (i - a4) as f64 * h;
            0.05 * (ph + 0.7).sin() + 0.02 * (2.0 * ph).sin()
        };
        let mode: Vec<f64> = (0..n).map(|i| rattle[i] + response(i)).collect();
        let r = coherent(&v, &mode, h, sigma).unwrap();
        let truth = (0..n).map(|i| response(i).powi(2)).sum::<f64>() / n as f64;
        assert_eq!(r.coherent_bursts, 1, "{r:?}");
        assert!((r.worst_hz - 184.5).abs() < 0.5, "{r:?}");
        assert!(r.worst_share > 0.8, "{r:?}");
        assert!(
            (r.coherent_mean_square / truth - 1.0).abs() < 0.1,
            "{r:?} against {truth}"
        );
        // The same burst marked as one the model reaches from another rest position of the
        // gears (the other of two coexisting responses): counted apart, its coherent part
        // left out.
        let mut parts = burst_parts(&v, &mode, h, sigma);
        assert_eq!(parts.iter().filter(|b| b.mostly_coherent).count(), 1);
        assert!(
            parts.iter().all(|b| (0.0..=1.0).contains(&b.share)),
            "{parts:?}"
        );
        for b in parts.iter_mut().filter(|b| b.mostly_coherent) {
            b.other_response = true;
        }
        let r = Coherent::of(&parts, &mode, sigma).unwrap();
        assert_eq!(
            (r.coherent_bursts, r.other_response_bursts),
            (0, 1),
            "{r:?}"
        );
        assert_eq!(r.coherent_mean_square, 0.0, "{r:?}");
        assert!(r.worst_rms < 0.5 * sigma, "{r:?}");
    }
}
