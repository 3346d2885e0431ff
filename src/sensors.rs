//! Emulated sensors, as firmware reads them: tachometer and potentiometer through ADCs, a
//! quadrature encoder counter, and the physical values in Q16.16 fixed point ([`Physical`],
//! converted on demand by [`crate::VirtualActuator::physical`]).
//!
//! Sampling happens once per [`crate::VirtualActuator::step`], at the end of the step (an ADC
//! conversion triggered at the control tick); reading a [`Readings`] is free and pure.
//!
//! * **ADC** ([`AdcChannel`]): `counts = clamp(round((x − min) / lsb + offset_counts + noise),
//!   0, 2^bits − 1)` with `lsb = (max − min) / (2^bits − 1)`; `min` reads 0 and `max` reads
//!   full scale, beyond them the converter saturates. A NaN input reads 0.
//! * **Encoder** ([`EncoderConfig`]): an ideal quadrature counter with `counts_per_rev` edges
//!   per revolution (4× the line count), reading 0 at construction. It accumulates the angle
//!   *increment* of each step, so its count stays exact over many revolutions even where an
//!   absolute `f32` angle has lost its fractional part; the count wraps like a 32-bit timer.
//! * **Noise**: optional, per ADC channel, uniform in ±`noise_lsb` counts added before rounding,
//!   from a xorshift32 generator seeded by [`SensorConfig::noise_seed`]; the same seed gives the
//!   same counts on every platform.

use fixed::types::I16F16;

use crate::faults::{ActuatorFaults, SensorFault};
use crate::{math, Outputs, ParamError};

/// Converts `x` to Q16.16, rounding to nearest (ties away from zero), saturating at
/// [`I16F16::MIN`] / [`I16F16::MAX`], NaN to 0. Never panics; a handful of instructions (the
/// float-to-int cast saturates by itself).
#[inline]
pub fn to_fixed(x: f32) -> I16F16 {
    let y = x * 65536.0; // exact: a power-of-two scaling (overflow gives ±∞, which saturates)
    let bits = if math::abs(y) < 8_388_608.0 {
        // Below 2^23 the ±0.5 is exact, so this rounds; above, y is already an integer.
        (if y >= 0.0 { y + 0.5 } else { y - 0.5 }) as i32
    } else {
        y as i32
    };
    I16F16::from_bits(bits)
}

/// One ADC channel: resolution, the physical range it spans and its offset error.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AdcChannel {
    /// Resolution, bits (1..=16).
    pub bits: u8,
    /// Physical value that reads 0 counts (the sensor's unit: V for the tachometer, rad for
    /// the potentiometer).
    pub min: f32,
    /// Physical value that reads full scale, 2^bits − 1 counts; greater than `min`.
    pub max: f32,
    /// Offset error added to every conversion, counts.
    pub offset_counts: i16,
    /// Peak of the uniform noise added before rounding, counts (0 = noiseless); ≥ 0.
    pub noise_lsb: f32,
}

impl AdcChannel {
    /// A noiseless channel with no offset error spanning `min..=max` (sensor units) in `bits`.
    pub const fn new(bits: u8, min: f32, max: f32) -> AdcChannel {
        AdcChannel {
            bits,
            min,
            max,
            offset_counts: 0,
            noise_lsb: 0.0,
        }
    }

    /// Checks the fields; errors name them as `<name>.<field>` (e.g. `sensors.tach.bits`).
    pub fn validate(&self, name: &'static [&'static str; 4]) -> Result<(), ParamError> {
        let [bits, min, max, noise] = *name;
        if self.bits == 0 || self.bits > 16 {
            return Err(ParamError::OutOfRange(bits));
        }
        if !self.min.is_finite() {
            return Err(ParamError::NonFinite(min));
        }
        if !self.max.is_finite() {
            return Err(ParamError::NonFinite(max));
        }
        if self.max <= self.min {
            return Err(ParamError::OutOfRange(max));
        }
        if !self.noise_lsb.is_finite() {
            return Err(ParamError::NonFinite(noise));
        }
        if self.noise_lsb < 0.0 {
            return Err(ParamError::Negative(noise));
        }
        Ok(())
    }

    /// Full-scale reading 2^bits − 1, counts.
    #[inline]
    pub fn full_scale_counts(&self) -> u16 {
        let bits = u32::from(self.bits.clamp(1, 16));
        u16::try_from((1u32 << bits) - 1).unwrap_or(u16::MAX)
    }

    /// One count in sensor units: (max − min) / (2^bits − 1).
    #[inline]
    pub fn lsb(&self) -> f32 {
        (self.max - self.min) / f32::from(self.full_scale_counts())
    }

    /// Counts per sensor unit, 1/lsb = (2^bits − 1) / (max − min).
    #[inline]
    pub fn counts_per_unit(&self) -> f32 {
        f32::from(self.full_scale_counts()) / (self.max - self.min)
    }

    /// Converts the physical value `x` (sensor units) with `noise` counts added before
    /// rounding; saturates at 0 and full scale.
    #[inline]
    pub fn convert(&self, x: f32, noise: f32) -> u16 {
        self.convert_scaled(self.counts_per_unit(), x, noise)
    }

    /// [`AdcChannel::convert`] with [`AdcChannel::counts_per_unit`] precomputed.
    #[inline(always)]
    fn convert_scaled(&self, counts_per_unit: f32, x: f32, noise: f32) -> u16 {
        let full = self.full_scale_counts();
        let c = (x - self.min) * counts_per_unit + f32::from(self.offset_counts) + noise;
        if c >= f32::from(full) {
            full
        } else if c > 0.0 {
            // 0 < c < full: c + 0.5 < full + 0.5 truncates to at most `full`.
            (c + 0.5) as u16
        } else {
            // Also NaN.
            0
        }
    }

    /// What firmware computes back from `counts`: `min + (counts − offset) · lsb`, sensor units.
    #[inline]
    pub fn to_physical(&self, counts: u16) -> f32 {
        self.min + (f32::from(counts) - f32::from(self.offset_counts)) * self.lsb()
    }

    /// [`AdcChannel::to_physical`] in Q16.16 (saturating).
    #[inline]
    pub fn to_fixed(&self, counts: u16) -> I16F16 {
        to_fixed(self.to_physical(counts))
    }
}

/// Which shaft carries the encoder.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EncoderShaft {
    /// The motor shaft (`Outputs::motor_angle_rad`).
    Motor,
    /// The load (fin) shaft (`Outputs::load_angle_rad`).
    Load,
}

/// Quadrature encoder: resolution and shaft.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EncoderConfig {
    /// Counted edges per revolution (4 × lines for a quadrature decoder), counts/rev; ≥ 1.
    pub counts_per_rev: u32,
    /// Shaft the encoder is mounted on.
    pub shaft: EncoderShaft,
}

/// Every emulated sensor's configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SensorConfig {
    /// Tachometer voltage ADC (sensor unit V).
    pub tach: AdcChannel,
    /// Load potentiometer ADC (sensor unit rad of load angle).
    pub pot: AdcChannel,
    /// Encoder counter.
    pub encoder: EncoderConfig,
    /// Seed of the noise generator (any value; 0 is replaced by a fixed non-zero seed).
    pub noise_seed: u32,
}

impl SensorConfig {
    /// 12-bit tachometer ADC over ±12 V (the reference tachometer at 1200 rad/s, the
    /// no-load speed on a 24 V bus), 12-bit potentiometer over ±60° of fin angle, a
    /// 512-count (128-line) encoder on the motor; noiseless.
    pub const REFERENCE: SensorConfig = SensorConfig {
        tach: AdcChannel::new(12, -12.0, 12.0),
        pot: AdcChannel::new(
            12,
            -60.0 * core::f32::consts::PI / 180.0,
            60.0 * core::f32::consts::PI / 180.0,
        ),
        encoder: EncoderConfig {
            counts_per_rev: 512,
            shaft: EncoderShaft::Motor,
        },
        noise_seed: 0,
    };

    /// Checks every field; errors name them as `sensors.<sensor>.<field>`.
    pub fn validate(&self) -> Result<(), ParamError> {
        self.tach.validate(&[
            "sensors.tach.bits",
            "sensors.tach.min",
            "sensors.tach.max",
            "sensors.tach.noise_lsb",
        ])?;
        self.pot.validate(&[
            "sensors.pot.bits",
            "sensors.pot.min",
            "sensors.pot.max",
            "sensors.pot.noise_lsb",
        ])?;
        if self.encoder.counts_per_rev == 0 {
            return Err(ParamError::NonPositive("sensors.encoder.counts_per_rev"));
        }
        Ok(())
    }
}

/// Ideal physical values in Q16.16 (the same instant as the counts): what a firmware written
/// in Q-formats would compute from perfectly calibrated sensors.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Physical {
    /// Tachometer voltage, V.
    pub tach_voltage_v: I16F16,
    /// Motor speed, rad/s.
    pub motor_speed_rad_s: I16F16,
    /// Load (fin) angle, rad.
    pub load_angle_rad: I16F16,
    /// Load (fin) speed, rad/s.
    pub load_speed_rad_s: I16F16,
    /// Armature current, A.
    pub current_a: I16F16,
}

impl Physical {
    /// The plant outputs `o` in Q16.16 (computed on demand, not every step: see
    /// [`crate::VirtualActuator::physical`]).
    #[inline]
    pub fn from_outputs(o: &Outputs) -> Physical {
        Physical {
            tach_voltage_v: to_fixed(o.tach_voltage_v),
            motor_speed_rad_s: to_fixed(o.motor_speed_rad_s),
            load_angle_rad: to_fixed(o.load_angle_rad),
            load_speed_rad_s: to_fixed(o.load_speed_rad_s),
            current_a: to_fixed(o.current_a),
        }
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for Physical {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(
            f,
            "Physical {{ tach_voltage_v: {=f32}, motor_speed_rad_s: {=f32}, load_angle_rad: {=f32}, load_speed_rad_s: {=f32}, current_a: {=f32} }}",
            self.tach_voltage_v.to_num::<f32>(),
            self.motor_speed_rad_s.to_num::<f32>(),
            self.load_angle_rad.to_num::<f32>(),
            self.load_speed_rad_s.to_num::<f32>(),
            self.current_a.to_num::<f32>()
        )
    }
}

/// What the firmware reads after a step.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Readings {
    /// Tachometer ADC, counts.
    pub tach_counts: u16,
    /// Load potentiometer ADC, counts.
    pub pot_counts: u16,
    /// Encoder counter, counts (wrapping).
    pub encoder_count: i32,
}

impl Readings {
    /// The encoder counter as a 16-bit hardware timer would hold it (wrapping), counts.
    pub fn encoder_count_u16(&self) -> u16 {
        self.encoder_count as u16
    }
}

/// xorshift32 (Marsaglia 2003): tiny, deterministic, identical on every platform.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct XorShift32(u32);

impl XorShift32 {
    /// Seeded generator; seed 0 (a fixed point of xorshift) is replaced by 0x9E37_79B9.
    pub const fn new(seed: u32) -> XorShift32 {
        XorShift32(if seed == 0 { 0x9E37_79B9 } else { seed })
    }

    /// Next 32 random bits.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let mut x = self.0;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        self.0 = x;
        x
    }

    /// Uniform in [−1, 1), dimensionless (24 random bits).
    #[inline]
    pub fn next_signed_unit(&mut self) -> f32 {
        ((self.next_u32() >> 8) as f32) * (2.0 / 16_777_216.0) - 1.0
    }
}

/// The sensor block: configuration, noise generator, encoder accumulator and the latest
/// readings.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Sensors {
    config: SensorConfig,
    rng: XorShift32,
    counts_per_rad: f32,
    tach_counts_per_v: f32,
    pot_counts_per_rad: f32,
    /// Encoder shaft angle at the previous sample, rad.
    last_angle_rad: f32,
    /// Fraction of a count accumulated since the last edge, in [0, 1).
    fraction: f32,
    /// Encoder count as the shaft turned (what a healthy encoder reads).
    true_count: i32,
    readings: Readings,
}

impl Sensors {
    /// Validates `config` and samples `now` (the plant's outputs at construction); the encoder
    /// reads 0 there.
    pub fn new(config: &SensorConfig, now: &Outputs) -> Result<Sensors, ParamError> {
        config.validate()?;
        let mut s = Sensors {
            config: *config,
            rng: XorShift32::new(config.noise_seed),
            counts_per_rad: config.encoder.counts_per_rev as f32 / core::f32::consts::TAU,
            tach_counts_per_v: config.tach.counts_per_unit(),
            pot_counts_per_rad: config.pot.counts_per_unit(),
            last_angle_rad: 0.0,
            fraction: 0.0,
            true_count: 0,
            readings: Readings::default(),
        };
        s.last_angle_rad = s.encoder_angle(now);
        s.sample(now);
        Ok(s)
    }

    /// The configuration.
    pub fn config(&self) -> &SensorConfig {
        &self.config
    }

    /// The latest readings.
    #[inline]
    pub fn readings(&self) -> &Readings {
        &self.readings
    }

    #[inline]
    fn encoder_angle(&self, o: &Outputs) -> f32 {
        match self.config.encoder.shaft {
            EncoderShaft::Motor => o.motor_angle_rad,
            EncoderShaft::Load => o.load_angle_rad,
        }
    }

    #[inline]
    fn noise(&mut self, peak: f32) -> f32 {
        if peak > 0.0 {
            peak * self.rng.next_signed_unit()
        } else {
            0.0
        }
    }

    /// Converts the plant outputs `o` into new readings.
    pub fn sample(&mut self, o: &Outputs) {
        self.sample_faulty(o, &ActuatorFaults::NONE);
    }

    /// [`Sensors::sample`] with the sensor faults of `f` (a fault changes what is read,
    /// not what is measured: the encoder keeps counting underneath, so a cleared fault reads
    /// the true count again).
    pub fn sample_faulty(&mut self, o: &Outputs, faults: &ActuatorFaults) {
        let fl = faults;
        let n_tach = self.noise(self.config.tach.noise_lsb);
        let n_pot = self.noise(self.config.pot.noise_lsb);
        let tach = self.config.tach.convert_scaled(
            self.tach_counts_per_v,
            o.tach_voltage_v * fl.tach.gain(),
            n_tach,
        );
        let pot = self.config.pot.convert_scaled(
            self.pot_counts_per_rad,
            o.load_angle_rad * fl.pot.gain(),
            n_pot,
        );
        self.readings.tach_counts =
            self.faulty_adc(&fl.tach, tach, self.config.tach.full_scale_counts());
        self.readings.pot_counts =
            self.faulty_adc(&fl.pot, pot, self.config.pot.full_scale_counts());

        let angle = self.encoder_angle(o);
        let f = self.fraction + (angle - self.last_angle_rad) * self.counts_per_rad;
        self.last_angle_rad = angle;
        // floor(f) without a library call; `as` saturates (and maps NaN to 0), so no panic.
        let mut whole = f as i32;
        if (whole as f32) > f {
            whole = whole.wrapping_sub(1);
        }
        let rest = f - whole as f32;
        self.fraction = if (0.0..1.0).contains(&rest) {
            rest
        } else {
            0.0
        };
        self.true_count = self.true_count.wrapping_add(whole);
        let enc = faults.encoder;
        self.readings.encoder_count = if enc == SensorFault::None {
            self.true_count
        } else {
            let base = if enc.gain() == 1.0 {
                i64::from(self.true_count)
            } else {
                (self.true_count as f32 * enc.gain()) as i64
            };
            let noise = if matches!(enc, SensorFault::NoiseBurst(_)) {
                self.rng.next_signed_unit()
            } else {
                0.0
            };
            enc.apply_counts(base, i64::from(i32::MIN), i64::from(i32::MAX), noise) as i32
        };
    }

    fn faulty_adc(&mut self, fault: &SensorFault, counts: u16, full: u16) -> u16 {
        if *fault == SensorFault::None {
            return counts;
        }
        let noise = if matches!(fault, SensorFault::NoiseBurst(_)) {
            self.rng.next_signed_unit()
        } else {
            0.0
        };
        fault.apply_counts(i64::from(counts), 0, i64::from(full), noise) as u16
    }
}
