//! What a simulated frequency response is made of: the measured points and the features
//! located on them. Plain data, shared by the sweeps ([`crate::fr`]) and by the judgement of
//! whether a feature is resolved ([`crate::no_answer`]).

use geared_servo::analyser::Harmonic;

/// One simulated frequency.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point {
    /// Frequency, Hz.
    pub freq_hz: f64,
    /// `V_t/V_m`, V/V.
    pub tach: Harmonic,
    /// `I/V_m`, A/V.
    pub current: Harmonic,
    /// The blocks agreed within tolerance.
    pub settled: bool,
    /// Samples simulated.
    pub samples: u32,
    /// Blocks averaged into the harmonics.
    pub blocks: u32,
}

impl Point {
    /// |V_t/V_m|, V/V.
    pub fn gain(&self) -> f64 {
        self.tach.phasor.abs()
    }
    /// |I/V_m|, A/V.
    pub fn current_gain(&self) -> f64 {
        self.current.phasor.abs()
    }
}

/// One located frequency with its uncertainty: a resolved feature (an extremum that is not
/// is a [`crate::no_answer::NoAnswer`] instead).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Located {
    /// Best estimate, Hz.
    pub freq_hz: f64,
    /// Lowest and highest frequency (Hz) of the contiguous run of simulated points around the
    /// extremum whose values are within two standard errors (block spread / √blocks) of it:
    /// how blurred the feature is.
    pub band_hz: (f64, f64),
    /// Value there (|V_t/V_m| in V/V or |I/V_m| in A/V).
    pub value: f64,
    /// All the points used settled.
    pub settled: bool,
}
