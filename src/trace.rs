//! A fixed-capacity trace of the last `N` steps, on [`heapless::HistoryBuffer`]: record every
//! step in the control loop, dump after the fact (over defmt, semihosting or a UART).
//!
//! The recorded type is the firmware's choice ([`Trace<T, N>`] for any `Copy` `T`);
//! [`TraceSample`] is a ready-made one holding the usual signals.
//!
//! ```
//! use geared_servo::trace::{Trace, TraceSample};
//! use geared_servo::{DriveConfig, Plant, SensorConfig, VirtualActuator, REFERENCE};
//!
//! let plant = Plant::new(&REFERENCE)?;
//! let mut act = VirtualActuator::new(plant, &DriveConfig::REFERENCE, &SensorConfig::REFERENCE)?;
//! let mut trace: Trace<TraceSample, 64> = Trace::new();
//! act.set_signed_duty(-300).ok();
//! for _ in 0..100 {
//!     act.step();
//!     trace.record(TraceSample::capture(&act));
//! }
//! assert_eq!(trace.len(), 64); // the last 64 of 100 steps
//! assert_eq!(trace.oldest_first().next().map(|s| s.step), Some(37));
//! for s in trace.oldest_first() {
//!     let _line = format!("{s}"); // or hprintln!("{}", s) / defmt::info!("{}", s)
//! }
//! # Ok::<(), geared_servo::ParamError>(())
//! ```

use heapless::HistoryBuffer;

use crate::VirtualActuator;

/// Ring buffer of the last `N` recorded values (`N` ≥ 1); older ones are overwritten.
#[derive(Clone)]
pub struct Trace<T: Copy, const N: usize> {
    buf: HistoryBuffer<T, N>,
}

impl<T: Copy, const N: usize> Trace<T, N> {
    /// Empty trace; `const`, so it can live in a `static`.
    pub const fn new() -> Self {
        Trace {
            buf: HistoryBuffer::new(),
        }
    }

    /// Records `value`, overwriting the oldest when full.
    #[inline]
    pub fn record(&mut self, value: T) {
        self.buf.write(value);
    }

    /// Number of values held (≤ N).
    pub fn len(&self) -> usize {
        self.buf.len()
    }

    /// True when nothing has been recorded.
    pub fn is_empty(&self) -> bool {
        self.buf.len() == 0
    }

    /// Capacity N.
    pub const fn capacity(&self) -> usize {
        N
    }

    /// Forgets everything recorded.
    pub fn clear(&mut self) {
        self.buf.clear();
    }

    /// The most recent value.
    pub fn latest(&self) -> Option<&T> {
        self.buf.recent()
    }

    /// The held values, oldest first.
    pub fn oldest_first(&self) -> impl Iterator<Item = &T> + '_ {
        self.buf.oldest_ordered()
    }

    /// Calls `line` with each held value, oldest first (e.g. `|s| hprintln!("{}", s)`).
    pub fn dump(&self, mut line: impl FnMut(&T)) {
        for v in self.buf.oldest_ordered() {
            line(v);
        }
    }
}

impl<T: Copy, const N: usize> Default for Trace<T, N> {
    fn default() -> Self {
        Trace::new()
    }
}

impl<T: Copy + core::fmt::Debug, const N: usize> core::fmt::Debug for Trace<T, N> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_list().entries(self.buf.oldest_ordered()).finish()
    }
}

/// The usual signals of one step: the command, the truth and the readings.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TraceSample {
    /// Step number (steps since the actuator was built).
    pub step: u32,
    /// Voltage applied over the step, V.
    pub applied_voltage_v: f32,
    /// Armature current at the end of the step, A.
    pub current_a: f32,
    /// Motor speed, rad/s.
    pub motor_speed_rad_s: f32,
    /// Load (fin) angle, rad.
    pub load_angle_rad: f32,
    /// Gears in contact.
    pub in_contact: bool,
    /// Tachometer ADC, counts.
    pub tach_counts: u16,
    /// Potentiometer ADC, counts.
    pub pot_counts: u16,
    /// Encoder counter, counts.
    pub encoder_count: i32,
}

impl TraceSample {
    /// Column names of the [`core::fmt::Display`] line, space-separated.
    pub const HEADER: &'static str =
        "step applied_voltage_v current_a motor_speed_rad_s load_angle_rad in_contact tach_counts pot_counts encoder_count";

    /// The actuator's signals after its last step.
    #[inline]
    pub fn capture(act: &VirtualActuator) -> TraceSample {
        let o = act.outputs();
        let r = act.readings();
        TraceSample {
            step: act.steps(),
            applied_voltage_v: o.applied_voltage_v,
            current_a: o.current_a,
            motor_speed_rad_s: o.motor_speed_rad_s,
            load_angle_rad: o.load_angle_rad,
            in_contact: o.in_contact,
            tach_counts: r.tach_counts,
            pot_counts: r.pot_counts,
            encoder_count: r.encoder_count,
        }
    }
}

/// One line in the order of [`TraceSample::HEADER`].
impl core::fmt::Display for TraceSample {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "{} {} {} {} {} {} {} {} {}",
            self.step,
            self.applied_voltage_v,
            self.current_a,
            self.motor_speed_rad_s,
            self.load_angle_rad,
            u8::from(self.in_contact),
            self.tach_counts,
            self.pot_counts,
            self.encoder_count
        )
    }
}
