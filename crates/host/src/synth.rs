//! Synthetic "measured" data (`geared-servo synth`): an excitation signal, optional effects,
//! tachometer noise from a seeded generator, written in the measured-data format with the
//! settings in `# key: value` lines so that a record says how it was made.

use crate::error::HostError;
use geared_servo::{ActuatorParams, Plant, PlantState};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// Excitation waveforms.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Excitation {
    /// Sines at `steps` log-spaced frequencies from f_min to f_max, equal dwell each.
    SteppedSine,
    /// Logarithmic chirp (exponential sweep) from f_min to f_max over the duration.
    Chirp,
    /// Sum of sines on a log grid of `steps` lines from f_min to f_max, random phases,
    /// scaled to the amplitude's peak.
    Multisine,
    /// Pseudo-random binary sequence (±amplitude) changing at most every 1/f_max s.
    Prbs,
    /// Square wave (±amplitude) at f_min.
    Square,
}

impl Excitation {
    /// Every waveform, in the order the command line lists them.
    pub const ALL: [Excitation; 5] = [
        Excitation::SteppedSine,
        Excitation::Chirp,
        Excitation::Multisine,
        Excitation::Prbs,
        Excitation::Square,
    ];

    /// The name `synth --excitation` takes.
    pub fn name(self) -> &'static str {
        match self {
            Excitation::SteppedSine => "stepped-sine",
            Excitation::Chirp => "chirp",
            Excitation::Multisine => "multisine",
            Excitation::Prbs => "prbs",
            Excitation::Square => "square",
        }
    }
}

impl std::str::FromStr for Excitation {
    type Err = HostError;

    /// Parses a waveform from its [`Excitation::name`].
    fn from_str(s: &str) -> Result<Self, HostError> {
        Excitation::ALL
            .into_iter()
            .find(|e| e.name() == s)
            .ok_or_else(|| {
                let names: Vec<&str> = Excitation::ALL.iter().map(|e| e.name()).collect();
                HostError::input(format!(
                    "unknown excitation `{s}` (known: {})",
                    names.join(", ")
                ))
            })
    }
}

/// Everything that defines a synthetic record besides the parameter set.
#[derive(Clone, Debug, PartialEq)]
pub struct SynthSpec {
    /// Waveform.
    pub excitation: Excitation,
    /// Peak voltage, V.
    pub amplitude_v: f64,
    /// Lowest frequency, Hz.
    pub f_min_hz: f64,
    /// Highest frequency, Hz.
    pub f_max_hz: f64,
    /// Frequencies of the stepped sine / lines of the multisine.
    pub steps: usize,
    /// Record length, s.
    pub duration_s: f64,
    /// Sample period, s.
    pub sample_period_s: f64,
    /// Standard deviation of white Gaussian noise added to the tachometer, V.
    pub tach_noise_v: f64,
    /// Seed of the ChaCha8 generator (phases, PRBS, noise).
    pub seed: u64,
}

impl SynthSpec {
    /// Checks ranges; errors name the option.
    pub fn validate(&self) -> Result<(), HostError> {
        let bad = |o: &str, why: &str| Err(HostError::input(format!("--{o}: {why}")));
        if !(self.amplitude_v.is_finite() && self.amplitude_v >= 0.0) {
            return bad("amplitude", "must be finite and >= 0");
        }
        if !(self.f_min_hz.is_finite() && self.f_min_hz > 0.0) {
            return bad("f-min", "must be > 0");
        }
        if !(self.f_max_hz.is_finite() && self.f_max_hz >= self.f_min_hz) {
            return bad("f-max", "must be >= f-min");
        }
        if !(self.sample_period_s.is_finite() && self.sample_period_s > 0.0) {
            return bad("sample-period", "must be > 0");
        }
        if self.f_max_hz >= 0.5 / self.sample_period_s {
            return bad("f-max", "must be below the Nyquist frequency");
        }
        if !(self.duration_s.is_finite() && self.duration_s >= 2.0 * self.sample_period_s) {
            return bad("duration", "must cover at least two samples");
        }
        if self.duration_s / self.sample_period_s > 1e8 {
            return bad("duration", "more than 1e8 samples");
        }
        if self.steps == 0 {
            return bad("steps", "must be >= 1");
        }
        if !(self.tach_noise_v.is_finite() && self.tach_noise_v >= 0.0) {
            return bad("noise", "must be finite and >= 0");
        }
        Ok(())
    }

    /// Number of rows.
    pub fn samples(&self) -> usize {
        (self.duration_s / self.sample_period_s).round() as usize
    }

    /// `# key: value` lines describing the settings.
    pub fn comments(&self) -> Vec<String> {
        vec![
            format!("excitation: {}", self.excitation.name()),
            format!("amplitude_v: {}", self.amplitude_v),
            format!("f_min_hz: {}", self.f_min_hz),
            format!("f_max_hz: {}", self.f_max_hz),
            format!("steps: {}", self.steps),
            format!("duration_s: {}", self.duration_s),
            format!("sample_period_s: {}", self.sample_period_s),
            format!("tach_noise_v: {}", self.tach_noise_v),
            format!("seed: {}", self.seed),
        ]
    }
}

fn log_freqs(spec: &SynthSpec) -> Vec<f64> {
    let n = spec.steps;
    if n == 1 {
        return vec![spec.f_min_hz];
    }
    let r = (spec.f_max_hz / spec.f_min_hz).ln();
    (0..n)
        .map(|k| spec.f_min_hz * (r * k as f64 / (n - 1) as f64).exp())
        .collect()
}

/// The commanded voltage, one value per row (held until the next row), V.
pub fn excitation(spec: &SynthSpec, rng: &mut ChaCha8Rng) -> Vec<f64> {
    use std::f64::consts::PI;
    let n = spec.samples();
    let h = spec.sample_period_s;
    let a = spec.amplitude_v;
    let t = |k: usize| k as f64 * h;
    match spec.excitation {
        Excitation::SteppedSine => {
            let f = log_freqs(spec);
            let per = n.div_ceil(f.len()).max(1);
            (0..n)
                .map(|k| {
                    let fi = f.get(k / per).copied().unwrap_or(spec.f_max_hz);
                    let tl = (k % per) as f64 * h;
                    a * (2.0 * PI * fi * tl).sin()
                })
                .collect()
        }
        Excitation::Chirp => {
            let d = spec.duration_s;
            let r = (spec.f_max_hz / spec.f_min_hz).ln();
            (0..n)
                .map(|k| {
                    // Phase of an exponential sweep: 2π f0 d/ln(r) (e^{t ln(r)/d} − 1).
                    let ph = if r > 0.0 {
                        2.0 * PI * spec.f_min_hz * d / r * ((t(k) * r / d).exp() - 1.0)
                    } else {
                        2.0 * PI * spec.f_min_hz * t(k)
                    };
                    a * ph.sin()
                })
                .collect()
        }
        Excitation::Multisine => {
            let f = log_freqs(spec);
            let ph: Vec<f64> = f.iter().map(|_| rng.gen::<f64>() * 2.0 * PI).collect();
            let raw: Vec<f64> = (0..n)
                .map(|k| {
                    f.iter()
                        .zip(&ph)
                        .map(|(fi, p)| (2.0 * PI * fi * t(k) + p).sin())
                        .sum()
                })
                .collect();
            let peak = raw.iter().fold(0.0f64, |m, x| m.max(x.abs())).max(1e-12);
            raw.into_iter().map(|x| a * x / peak).collect()
        }
        Excitation::Prbs => {
            let hold = ((1.0 / (spec.f_max_hz * h)).round() as usize).max(1);
            let mut level = a;
            (0..n)
                .map(|k| {
                    if k % hold == 0 {
                        level = if rng.gen::<bool>() { a } else { -a };
                    }
                    level
                })
                .collect()
        }
        Excitation::Square => (0..n)
            .map(|k| {
                if (t(k) * spec.f_min_hz).fract() < 0.5 {
                    a
                } else {
                    -a
                }
            })
            .collect(),
    }
}

/// A synthetic record: rows' times, commanded voltages and the (noisy) tachometer.
#[derive(Clone, Debug, PartialEq)]
pub struct Synthetic {
    /// Sample instants, s.
    pub time_s: Vec<f64>,
    /// Commanded voltage per row, V.
    pub motor_voltage_v: Vec<f64>,
    /// Tachometer voltage sampled at each row (noise included), V.
    pub tach_voltage_v: Vec<f64>,
}

/// Simulates `p` (at the spec's sample period) on the spec's excitation from rest and adds
/// the tachometer noise. Deterministic for a given seed.
pub fn synthesize(p: &ActuatorParams, spec: &SynthSpec) -> Result<Synthetic, HostError> {
    spec.validate()?;
    let mut p = *p;
    p.sample_period_s = spec.sample_period_s;
    let plant = Plant::new(&p).map_err(HostError::from)?;
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
    let volts = excitation(spec, &mut rng);
    let noise = Normal::new(0.0, spec.tach_noise_v)
        .map_err(|e| HostError::input(format!("tachometer noise: {e}")))?;
    let mut st = PlantState::REST;
    let mut o = plant.outputs(&st);
    let mut tach = Vec::with_capacity(volts.len());
    for &v in &volts {
        tach.push(f64::from(o.tach_voltage_v) + noise.sample(&mut rng));
        o = plant.step(&mut st, v as f32);
    }
    let time_s = (0..volts.len())
        .map(|k| k as f64 * spec.sample_period_s)
        .collect();
    Ok(Synthetic {
        time_s,
        motor_voltage_v: volts,
        tach_voltage_v: tach,
    })
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn spec(e: Excitation) -> SynthSpec {
        SynthSpec {
            excitation: e,
            amplitude_v: 5.0,
            f_min_hz: 2.0,
            f_max_hz: 200.0,
            steps: 8,
            duration_s: 0.5,
            sample_period_s: 0.0005,
            tach_noise_v: 0.01,
            seed: 7,
        }
    }

    #[test]
    fn every_excitation_stays_within_its_amplitude() {
        for e in [
            Excitation::SteppedSine,
            Excitation::Chirp,
            Excitation::Multisine,
            Excitation::Prbs,
            Excitation::Square,
        ] {
            let s = spec(e);
            let v = excitation(&s, &mut ChaCha8Rng::seed_from_u64(1));
            assert_eq!(v.len(), 1000);
            let peak = v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            assert!(peak <= 5.0 + 1e-12 && peak > 4.0, "{e:?}: {peak}");
        }
    }

    #[test]
    fn same_seed_same_record_other_seed_other_noise() {
        let p = geared_servo::REFERENCE;
        let a = synthesize(&p, &spec(Excitation::Multisine)).unwrap();
        let b = synthesize(&p, &spec(Excitation::Multisine)).unwrap();
        assert_eq!(a, b);
        let mut s2 = spec(Excitation::Multisine);
        s2.seed = 8;
        let c = synthesize(&p, &s2).unwrap();
        assert_ne!(a.tach_voltage_v, c.tach_voltage_v);
    }
}
