//! Stepped-sine frequency-response analyser: sine bookkeeping, first-harmonic correlation over
//! blocks of whole periods, settling detection. `no_std`, allocation-free: firmware can run it.
//!
//! The sine's phase at sample k is `2π·frac(k f h)`, tracked as a cycle fraction in f64 so it
//! does not drift over long records. Each block spans the whole number of periods that lasts
//! at least [`AnalyserConfig::min_block_s`], rounded to the nearest whole sample count; since
//! that is not exactly whole periods, the block's fundamental comes from least squares on
//! `{sin φ_k, cos φ_k, 1}` (3 × 3 normal equations, f64), not from plain correlation.
//!
//! Settling: after `warmup_blocks` discarded blocks, the analyser keeps the last `avg_blocks`
//! block phasors of every channel; it is settled when each of them lies within
//! `rel_tol·|mean| + abs_tol[c]` of their mean, and then reports that mean. If that never
//! happens within `max_blocks` (chaotic gear rattle does this), it reports the mean of all
//! blocks after the warm-up and their standard deviation, flagged as not settled.

use crate::linear::Complex;
use crate::plant::{Outputs, Plant, PlantState, SineDrive};
use core::ops::{Add, Sub};

/// Most blocks kept for the settling test.
pub const RING: usize = 8;

/// Analyser settings. Frequencies in Hz, times in s.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnalyserConfig {
    /// Excitation frequency, Hz (> 0, below the Nyquist frequency).
    pub freq_hz: f64,
    /// Sample period h, s.
    pub sample_period_s: f64,
    /// Shortest block, s: a block is the smallest whole number of periods at least this long.
    pub min_block_s: f64,
    /// Blocks discarded before any is kept.
    pub warmup_blocks: u32,
    /// Blocks that must agree to call the response settled (2..=[`RING`]).
    pub avg_blocks: u32,
    /// Blocks after which the analyser stops regardless (≥ warmup + avg).
    pub max_blocks: u32,
    /// Relative agreement of the kept blocks, –.
    pub rel_tol: f64,
}

/// Why a configuration was rejected: the name of the [`AnalyserConfig`] field that is
/// non-finite, out of range, or inconsistent with the others (e.g. a frequency at or above
/// Nyquist for the sample period).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ConfigError(pub &'static str);

impl ConfigError {
    /// The offending field of [`AnalyserConfig`] (`"freq_hz"`).
    pub const fn field(&self) -> &'static str {
        self.0
    }
}

impl core::fmt::Display for ConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "analyser configuration: `{}` is not finite, out of range, or inconsistent with the sample period",
            self.0
        )
    }
}

impl core::error::Error for ConfigError {}

/// The validated analyser for `C` channels. Configuration only; the run lives in
/// [`AnalyserState`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Analyser<const C: usize> {
    cfg: AnalyserConfig,
    cycles_per_sample: f64,
    block_samples: u32,
    periods_per_block: u32,
    abs_tol: [f64; C],
}

/// First harmonic of one channel per volt of input: `y ≈ Im(H·V·e^{jφ})`.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Harmonic {
    /// Phasor per volt of input amplitude (unit of the channel per V).
    pub phasor: Complex,
    /// Standard deviation of the block phasors around it (same unit): the spread.
    pub spread: f64,
}

impl Harmonic {
    /// |H| in dB (20 log10).
    pub fn gain_db(&self) -> f64 {
        20.0 * libm::log10(self.phasor.abs())
    }
    /// Phase of H, degrees in (−180, 180].
    pub fn phase_deg(&self) -> f64 {
        self.phasor.arg().to_degrees()
    }
}

/// What one measurement produced.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measurement<const C: usize> {
    /// Per channel.
    pub channels: [Harmonic; C],
    /// True when the kept blocks agreed within tolerance.
    pub settled: bool,
    /// Blocks averaged into the result.
    pub blocks_averaged: u32,
    /// Samples simulated in all (warm-up included).
    pub samples: u32,
}

/// Running state of one measurement. `Copy`, fixed size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnalyserState<const C: usize> {
    cycle: f64,
    in_block: u32,
    blocks: u32,
    samples: u32,
    gram: [f64; 6],
    rhs: [[f64; 3]; C],
    ring: [[Complex; C]; RING],
    kept: u32,
    sum: [Complex; C],
    sum_sq: [f64; C],
    done: Option<bool>,
}

impl<const C: usize> Analyser<C> {
    /// Validates the configuration. `abs_tol[c]` is the absolute agreement for channel c, in
    /// its unit per volt (it matters where the response is near zero, e.g. at a notch).
    pub fn new(cfg: AnalyserConfig, abs_tol: [f64; C]) -> Result<Self, ConfigError> {
        let h = cfg.sample_period_s;
        if !(h.is_finite() && h > 0.0) {
            return Err(ConfigError("sample_period_s"));
        }
        if !(cfg.freq_hz.is_finite() && cfg.freq_hz > 0.0 && cfg.freq_hz * h < 0.5) {
            return Err(ConfigError("freq_hz"));
        }
        if !(cfg.min_block_s.is_finite() && cfg.min_block_s >= 0.0) {
            return Err(ConfigError("min_block_s"));
        }
        if cfg.avg_blocks < 2 || cfg.avg_blocks as usize > RING {
            return Err(ConfigError("avg_blocks"));
        }
        if cfg.max_blocks < cfg.warmup_blocks + cfg.avg_blocks {
            return Err(ConfigError("max_blocks"));
        }
        if !(cfg.rel_tol.is_finite() && cfg.rel_tol >= 0.0) {
            return Err(ConfigError("rel_tol"));
        }
        let periods = libm::ceil(cfg.min_block_s * cfg.freq_hz).max(1.0);
        let samples = libm::round(periods / (cfg.freq_hz * h));
        if !(4.0..=1.0e8).contains(&samples) || periods > 1.0e6 {
            return Err(ConfigError("min_block_s"));
        }
        Ok(Analyser {
            cfg,
            cycles_per_sample: cfg.freq_hz * h,
            block_samples: samples as u32,
            periods_per_block: periods as u32,
            abs_tol,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &AnalyserConfig {
        &self.cfg
    }

    /// Samples per block.
    pub fn block_samples(&self) -> u32 {
        self.block_samples
    }

    /// Whole periods per block.
    pub fn periods_per_block(&self) -> u32 {
        self.periods_per_block
    }

    /// How far a block is from whole periods, in periods (at most half a sample's worth).
    /// Least squares with an offset removes the leakage of the fundamental and of the mean;
    /// higher harmonics of the response (backlash makes them) are not in the basis and leak
    /// into the fundamental in proportion to their amplitude and to
    /// `period_mismatch() / periods_per_block()` (a third harmonic 3× the fundamental moved
    /// a 228 Hz gain by 3 % with a 0.016-period mismatch over 5 periods).
    pub fn period_mismatch(&self) -> f64 {
        let m = f64::from(self.block_samples) * self.cycles_per_sample;
        let d = m - f64::from(self.periods_per_block);
        if d < 0.0 {
            -d
        } else {
            d
        }
    }

    /// A fresh measurement, sine phase 0 at the first sample.
    pub fn start(&self) -> AnalyserState<C> {
        AnalyserState {
            cycle: 0.0,
            in_block: 0,
            blocks: 0,
            samples: 0,
            gram: [0.0; 6],
            rhs: [[0.0; 3]; C],
            ring: [[Complex::default(); C]; RING],
            kept: 0,
            sum: [Complex::default(); C],
            sum_sq: [0.0; C],
            done: None,
        }
    }

    /// Phase of the sine at the current sample, rad in [0, 2π): the drive's phase for the
    /// step that follows this sample.
    pub fn phase_rad(&self, st: &AnalyserState<C>) -> f64 {
        2.0 * core::f64::consts::PI * st.cycle
    }

    /// Feeds the outputs `y` sampled at the current instant (before the step that follows) for
    /// an input amplitude `amplitude_v` (V), then advances the phase. Returns true once the
    /// measurement is finished (settled or capped).
    pub fn push(&self, st: &mut AnalyserState<C>, y: [f32; C], amplitude_v: f64) -> bool {
        if st.done.is_some() {
            return true;
        }
        let (s, c) = libm::sincos(self.phase_rad(st));
        let g = &mut st.gram;
        g[0] += s * s;
        g[1] += s * c;
        g[2] += s;
        g[3] += c * c;
        g[4] += c;
        g[5] += 1.0;
        for (r, &v) in st.rhs.iter_mut().zip(y.iter()) {
            let v = f64::from(v);
            r[0] += v * s;
            r[1] += v * c;
            r[2] += v;
        }
        st.samples += 1;
        st.cycle += self.cycles_per_sample;
        st.cycle -= libm::floor(st.cycle);
        st.in_block += 1;
        if st.in_block >= self.block_samples {
            self.end_block(st, amplitude_v);
        }
        st.done.is_some()
    }

    fn end_block(&self, st: &mut AnalyserState<C>, amplitude_v: f64) {
        let [a, b, c, d, e, f] = st.gram;
        // Normal equations [[a b c][b d e][c e f]] [p_s p_c p_0]' = rhs (Cramer's rule).
        let det = a * (d * f - e * e) - b * (b * f - c * e) + c * (b * e - c * d);
        let mut block = [Complex::default(); C];
        for (h, r) in block.iter_mut().zip(st.rhs.iter()) {
            let [r0, r1, r2] = *r;
            let ps = r0 * (d * f - e * e) - b * (r1 * f - e * r2) + c * (r1 * e - d * r2);
            let pc = a * (r1 * f - e * r2) - r0 * (b * f - c * e) + c * (b * r2 - r1 * c);
            // y = ps sin φ + pc cos φ = Im((ps + j pc) e^{jφ})
            *h = Complex::new(ps, pc).scale(1.0 / (det * amplitude_v));
        }
        st.gram = [0.0; 6];
        st.rhs = [[0.0; 3]; C];
        st.in_block = 0;
        st.blocks += 1;
        if st.blocks <= self.cfg.warmup_blocks {
            return;
        }
        let slot = (st.kept as usize) % RING;
        if let Some(r) = st.ring.get_mut(slot) {
            *r = block;
        }
        st.kept += 1;
        for ((sum, sq), h) in st
            .sum
            .iter_mut()
            .zip(st.sum_sq.iter_mut())
            .zip(block.iter())
        {
            *sum = sum.add(*h);
            *sq += h.re * h.re + h.im * h.im;
        }
        let n = self.cfg.avg_blocks;
        if st.kept >= n && self.ring_agrees(st) {
            st.done = Some(true);
        } else if st.blocks >= self.cfg.max_blocks {
            st.done = Some(false);
        }
    }

    fn ring_stats(&self, st: &AnalyserState<C>, ch: usize) -> (Complex, f64) {
        let n = self.cfg.avg_blocks.min(st.kept) as usize;
        let mut mean = Complex::default();
        let mut sq = 0.0;
        for i in 0..n {
            let slot = (st.kept as usize + RING - 1 - i) % RING;
            if let Some(h) = st.ring.get(slot).and_then(|r| r.get(ch)) {
                mean = mean.add(*h);
                sq += h.re * h.re + h.im * h.im;
            }
        }
        let nf = n.max(1) as f64;
        let mean = mean.scale(1.0 / nf);
        let var = (sq / nf - (mean.re * mean.re + mean.im * mean.im)).max(0.0);
        (mean, libm::sqrt(var))
    }

    fn ring_agrees(&self, st: &AnalyserState<C>) -> bool {
        let n = self.cfg.avg_blocks as usize;
        (0..C).all(|ch| {
            let (mean, _) = self.ring_stats(st, ch);
            let tol = self.cfg.rel_tol * mean.abs() + self.abs_tol.get(ch).copied().unwrap_or(0.0);
            (0..n).all(|i| {
                let slot = (st.kept as usize + RING - 1 - i) % RING;
                st.ring
                    .get(slot)
                    .and_then(|r| r.get(ch))
                    .is_some_and(|h| h.sub(mean).abs() <= tol)
            })
        })
    }

    /// The result so far (final once [`Analyser::push`] returned true).
    pub fn result(&self, st: &AnalyserState<C>) -> Measurement<C> {
        let settled = st.done == Some(true);
        let mut channels = [Harmonic::default(); C];
        for (ch, out) in channels.iter_mut().enumerate() {
            *out = if settled || st.kept <= self.cfg.avg_blocks {
                let (phasor, spread) = self.ring_stats(st, ch);
                Harmonic { phasor, spread }
            } else {
                let n = st.kept.max(1) as f64;
                let s = st.sum.get(ch).copied().unwrap_or_default();
                let sq = st.sum_sq.get(ch).copied().unwrap_or(0.0);
                let mean = s.scale(1.0 / n);
                let var = (sq / n - (mean.re * mean.re + mean.im * mean.im)).max(0.0);
                Harmonic {
                    phasor: mean,
                    spread: libm::sqrt(var),
                }
            };
        }
        Measurement {
            channels,
            settled,
            blocks_averaged: if settled {
                self.cfg.avg_blocks
            } else {
                st.kept
            },
            samples: st.samples,
        }
    }
}

/// The settings of a stepped-sine sweep point, shared by the host sweeps and the on-target
/// example so both measure with the same analyser.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SweepSettings {
    /// Shortest block, s (whole periods, at least one).
    pub min_block_s: f64,
    /// Blocks discarded first.
    pub warmup_blocks: u32,
    /// Blocks that must agree.
    pub avg_blocks: u32,
    /// Simulated time after which a point stops even if not settled, s.
    pub max_time_s: f64,
    /// Relative agreement of the blocks, –.
    pub rel_tol: f64,
    /// Absolute agreement per channel (V/V, A/V): what limits how deep a notch is resolved.
    pub abs_tol: [f64; CHANNELS],
}

impl SweepSettings {
    /// The defaults: 20 ms blocks, one discarded, three that agree to 0.1 % (0.01 dB), at most
    /// 1 s of simulated time per frequency (chaotic points average over that second).
    pub const DEFAULT: SweepSettings = SweepSettings {
        min_block_s: 0.02,
        warmup_blocks: 1,
        avg_blocks: 3,
        max_time_s: 1.0,
        rel_tol: 1e-3,
        abs_tol: ABS_TOL,
    };
}

/// Absolute agreement per channel of [`measure`]: 1e-4 V/V on `V_t/V_m` (−80 dB, far below
/// any notch the plots resolve) and 3e-6 A/V on `I/V_m` (1e-4 of the stalled-motor 1/R of
/// the reference actuator).
pub const ABS_TOL: [f64; CHANNELS] = [1e-4, 3e-6];

/// The analyser for one sweep point at `freq_hz` (Hz) and sample period `h` (s): the block
/// cap is the number of blocks that fill `settings.max_time_s`.
pub fn for_sweep(
    freq_hz: f64,
    h: f64,
    settings: &SweepSettings,
) -> Result<Analyser<CHANNELS>, ConfigError> {
    let probe = AnalyserConfig {
        freq_hz,
        sample_period_s: h,
        min_block_s: settings.min_block_s,
        warmup_blocks: settings.warmup_blocks,
        avg_blocks: settings.avg_blocks,
        max_blocks: settings.warmup_blocks + settings.avg_blocks,
        rel_tol: settings.rel_tol,
    };
    let a = Analyser::new(probe, settings.abs_tol)?;
    if !(settings.max_time_s.is_finite() && settings.max_time_s > 0.0) {
        return Err(ConfigError("max_time_s"));
    }
    let block_s = f64::from(a.block_samples()) * h;
    let cap = libm::ceil(settings.max_time_s / block_s).min(1.0e6) as u32;
    Analyser::new(
        AnalyserConfig {
            max_blocks: cap.max(probe.max_blocks),
            ..probe
        },
        settings.abs_tol,
    )
}

/// How the sine reaches the winding.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Hold {
    /// A continuous sine within every step (as the paper's Simulink model), via
    /// [`Plant::step_sine`]: measures the continuous plant sampled at h.
    #[default]
    Continuous,
    /// The sine sampled at each t_k and held for the step (as firmware applies it), via
    /// [`Plant::step`]: measures the sampled, held system (its notch is about 1 Hz higher
    /// for the reference actuator: aliasing of the hold's images).
    Zoh,
}

/// The channels [`measure`] correlates: tachometer voltage (V) and armature current (A).
pub const CHANNELS: usize = 2;

/// Runs one stepped-sine measurement on `plant` from `state` (warm start or rest): samples the
/// tachometer voltage and the current at each t_k, then applies the sine of amplitude
/// `amplitude_v` (V) over the step. Returns `V_t/V_m` (V/V) and `I/V_m` (A/V).
/// `drive` must be built for the analyser's frequency and the plant's parameters.
pub fn measure(
    plant: &Plant,
    drive: &SineDrive,
    analyser: &Analyser<CHANNELS>,
    amplitude_v: f64,
    hold: Hold,
    mut state: PlantState,
) -> Measurement<CHANNELS> {
    let mut st = analyser.start();
    let mut o: Outputs = plant.outputs(&state);
    let a = amplitude_v as f32;
    loop {
        let phase = analyser.phase_rad(&st);
        if analyser.push(&mut st, [o.tach_voltage_v, o.current_a], amplitude_v) {
            break;
        }
        o = match hold {
            Hold::Continuous => plant.step_sine(&mut state, drive, a, phase as f32),
            Hold::Zoh => plant.step(&mut state, (amplitude_v * libm::sin(phase)) as f32),
        };
    }
    analyser.result(&st)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn cfg(f: f64) -> AnalyserConfig {
        AnalyserConfig {
            freq_hz: f,
            sample_period_s: 5e-4,
            min_block_s: 0.02,
            warmup_blocks: 0,
            avg_blocks: 3,
            max_blocks: 10,
            rel_tol: 1e-9,
        }
    }

    #[test]
    fn recovers_an_exact_sinusoid_with_offset_over_non_whole_blocks() {
        for f in [10.0, 37.3, 127.6, 299.0] {
            let an = Analyser::<1>::new(cfg(f), [1e-12]).unwrap();
            let mut st = an.start();
            let (gain, ph) = (0.37, 1.1);
            loop {
                let phi = an.phase_rad(&st);
                let y = 2.0 * gain * libm::sin(phi + ph) + 0.25;
                if an.push(&mut st, [y as f32], 2.0) {
                    break;
                }
            }
            let m = an.result(&st);
            let h = m.channels[0].phasor;
            assert!((h.abs() - gain).abs() < 1e-6, "{f}: {}", h.abs());
            assert!((h.arg() - ph).abs() < 1e-6, "{f}: {}", h.arg());
        }
    }

    #[test]
    fn rejects_bad_configuration_naming_the_field() {
        let mut c = cfg(10.0);
        c.freq_hz = 1500.0;
        assert_eq!(Analyser::<1>::new(c, [0.0]), Err(ConfigError("freq_hz")));
        let mut c = cfg(10.0);
        c.avg_blocks = 1;
        assert_eq!(Analyser::<1>::new(c, [0.0]), Err(ConfigError("avg_blocks")));
    }
}
