//! Fault scenario files (TOML) for `simulate --scenario`.
//!
//! ```toml
//! # Events in time order; each applies or clears one fault.
//! [[event]]
//! at_s = 0.5
//! apply = "load_torque"      # profile "step" (default) or "gust"
//! profile = "gust"
//! amplitude_nm = 0.2
//! duration_s = 0.05
//!
//! [[event]]
//! at_s = 1.0
//! apply = "jam"              # here; or at `angle_deg`
//!
//! [[event]]
//! at_s = 1.5
//! clear = "jam"
//! ```
//!
//! Faults: `load_torque` (profile, amplitude_nm, duration_s), `jam` (angle_deg optional),
//! `backlash_wear` (extra_deg), `friction_factor` (factor), `broken_tooth` (angle_deg,
//! width_deg, torque_loss), `open_winding`, `shorted_winding`, `bus_sag` (factor on the bus
//! voltage), `pwm_stuck` (duty, signed counts), and for each sensor `tach_`, `pot_`,
//! `encoder_`: `…_stuck` (counts), `…_offset` (counts), `…_gain` (drift, relative),
//! `…_dropout` (level = "zero" or "full"), `…_noise` (peak_counts), `…_lost_lsbs` (bits).
//! Sensor faults and a stuck PWM act on the virtual actuator's sensors and bridge
//! (`VirtualActuator`); `simulate`, which has neither, refuses them.
//!
//! Values beyond their physical range (the bounds in `geared_servo::faults`: a negative
//! friction factor or wear, a torque beyond ±1e6 N·m, an angle beyond ±1e6 rad, ...) are
//! refused with the file, line, event and key, never clamped silently.

use crate::error::{shown, HostError};
use geared_servo::faults::{
    BrokenTooth, Jam, SensorFault, Winding, MAX_BACKLASH_WEAR_DEG, MAX_BUS_FACTOR,
    MAX_FAULT_ANGLE_RAD, MAX_FRICTION_FACTOR, MAX_GAIN_DRIFT, MAX_LOAD_TORQUE_NM, MAX_LOST_LSBS,
    MAX_NOISE_PEAK_COUNTS,
};
use geared_servo::scenario::{Fault, Scenario, ScenarioError, SensorChannel, TorqueProfile};
use serde::Deserialize;
use std::path::Path;

/// Events a scenario file may hold.
pub const CAPACITY: usize = 64;

/// A scenario as the host plays it.
pub type HostScenario = Scenario<CAPACITY>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileT {
    #[serde(default)]
    event: Vec<toml::Spanned<EventT>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct EventT {
    at_s: f64,
    apply: Option<String>,
    clear: Option<String>,
    profile: Option<String>,
    amplitude_nm: Option<f64>,
    duration_s: Option<f64>,
    angle_deg: Option<f64>,
    extra_deg: Option<f64>,
    factor: Option<f64>,
    width_deg: Option<f64>,
    torque_loss: Option<f64>,
    counts: Option<i64>,
    drift: Option<f64>,
    level: Option<String>,
    peak_counts: Option<f64>,
    bits: Option<u8>,
    duty: Option<i64>,
}

const FAULTS: [&str; 27] = [
    "load_torque",
    "jam",
    "backlash_wear",
    "friction_factor",
    "broken_tooth",
    "open_winding",
    "shorted_winding",
    "bus_sag",
    "pwm_stuck",
    "tach_stuck",
    "tach_offset",
    "tach_gain",
    "tach_dropout",
    "tach_noise",
    "tach_lost_lsbs",
    "pot_stuck",
    "pot_offset",
    "pot_gain",
    "pot_dropout",
    "pot_noise",
    "pot_lost_lsbs",
    "encoder_stuck",
    "encoder_offset",
    "encoder_gain",
    "encoder_dropout",
    "encoder_noise",
    "encoder_lost_lsbs",
];

/// Index of the first sensor or bridge fault of a scenario, if any (those need the virtual
/// actuator's sensors and bridge, not just the plant).
pub fn has_io_faults(sc: &HostScenario) -> Option<usize> {
    sc.events()
        .iter()
        .position(|e| matches!(e.fault, Fault::Sensor(..) | Fault::PwmStuck(_)))
}

/// Reads a scenario for a run of `steps` steps of `dt` seconds.
pub fn load(path: &Path, dt: f64, steps: usize) -> Result<HostScenario, HostError> {
    let name = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .map_err(|e| HostError::input(format!("{name}: cannot read: {e}")))?;
    parse(&text, &name, dt, steps)
}

/// Parses a scenario; `name` is used in messages.
pub fn parse(text: &str, name: &str, dt: f64, steps: usize) -> Result<HostScenario, HostError> {
    let f: FileT = toml::from_str(text).map_err(|e| {
        let line = e.span().map(|s| line_of(text, s.start)).unwrap_or(0);
        HostError::input(format!(
            "{name}: line {line}: {}",
            e.message().replace('\n', " ")
        ))
    })?;
    if f.event.len() > CAPACITY {
        return Err(HostError::input(format!(
            "{name}: {} events, more than the scenario capacity of {CAPACITY}",
            f.event.len()
        )));
    }
    let mut sc = HostScenario::new();
    // Which faults are in force, to refuse overlapping contradictions.
    let mut active: Vec<(&'static str, usize)> = Vec::new();
    let mut prev_at = f64::NEG_INFINITY;
    for (i, ev) in f.event.iter().enumerate() {
        let line = line_of(text, ev.span().start);
        let e = ev.get_ref();
        let here =
            |msg: String| HostError::input(format!("{name}: line {line} (event {}): {msg}", i + 1));
        if !e.at_s.is_finite() || e.at_s < 0.0 {
            return Err(here(format!(
                "`at_s` = {} must be a finite time ≥ 0",
                e.at_s
            )));
        }
        if e.at_s < prev_at {
            return Err(here("events must be in time order".into()));
        }
        prev_at = e.at_s;
        let step = (e.at_s / dt).round();
        if step >= steps as f64 {
            return Err(here(format!(
                "at {} s, past the end of the run ({} s)",
                e.at_s,
                steps as f64 * dt
            )));
        }
        let (kind, clearing) = match (&e.apply, &e.clear) {
            (Some(a), None) => (a.as_str(), false),
            (None, Some(c)) => (c.as_str(), true),
            (Some(_), Some(_)) => return Err(here("give `apply` or `clear`, not both".into())),
            (None, None) => return Err(here("missing `apply` or `clear`".into())),
        };
        let Some(kind) = FAULTS.iter().copied().find(|k| *k == kind) else {
            return Err(here(format!(
                "unknown fault `{}` (known: {})",
                shown(kind),
                FAULTS.join(", ")
            )));
        };
        let num = |v: Option<f64>, key: &str| -> Result<f64, HostError> {
            let v = v.ok_or_else(|| here(format!("`{kind}` needs `{key}`")))?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(here(format!("`{key}` must be finite")))
            }
        };
        // `v` of `key` within [lo, hi] (the core's bounds, widened to f64).
        let within = |v: f64, key: &str, lo: f32, hi: f32| -> Result<f64, HostError> {
            let (lo, hi) = (f64::from(lo), f64::from(hi));
            if (lo..=hi).contains(&v) {
                Ok(v)
            } else if lo == -hi {
                Err(here(format!("`{key}` = {v} must be within ±{hi}")))
            } else if lo < 0.0 {
                Err(here(format!("`{key}` = {v} must be within {lo} to {hi}")))
            } else {
                Err(here(format!("`{key}` = {v} must be within {lo}–{hi}")))
            }
        };
        // An angle in degrees whose radians are within the core's bound.
        let angle = |v: Option<f64>, key: &str| -> Result<f32, HostError> {
            let v = num(v, key)?;
            let max = f64::from(MAX_FAULT_ANGLE_RAD);
            if v.to_radians().abs() <= max {
                Ok(v.to_radians() as f32)
            } else {
                Err(here(format!(
                    "`{key}` = {v} must be within ±{max:e} rad (±{:.0} degrees)",
                    max.to_degrees()
                )))
            }
        };
        let fault = if clearing {
            match kind {
                "load_torque" => Fault::ClearLoadTorque,
                "jam" => Fault::Jam(Jam::None),
                "backlash_wear" => Fault::BacklashWear(0.0),
                "friction_factor" => Fault::FrictionFactor(1.0),
                "broken_tooth" => Fault::BrokenTooth(None),
                "open_winding" | "shorted_winding" => Fault::Winding(Winding::Normal),
                "bus_sag" => Fault::BusSag(1.0),
                "pwm_stuck" => Fault::PwmStuck(None),
                k => Fault::Sensor(channel(k), SensorFault::None),
            }
        } else {
            match kind {
                "load_torque" => {
                    let amplitude_nm = within(
                        num(e.amplitude_nm, "amplitude_nm")?,
                        "amplitude_nm",
                        -MAX_LOAD_TORQUE_NM,
                        MAX_LOAD_TORQUE_NM,
                    )? as f32;
                    match e.profile.as_deref().unwrap_or("step") {
                        "step" => Fault::LoadTorque(TorqueProfile::Step { amplitude_nm }),
                        "gust" => {
                            let d = num(e.duration_s, "duration_s")?;
                            if d <= 0.0 {
                                return Err(here("`duration_s` must be > 0".into()));
                            }
                            let duration_steps = (d / dt).round().max(1.0) as u32;
                            Fault::LoadTorque(TorqueProfile::Gust {
                                amplitude_nm,
                                duration_steps,
                            })
                        }
                        other => {
                            return Err(here(format!(
                                "unknown profile `{}` (step, gust)",
                                shown(other)
                            )))
                        }
                    }
                }
                "jam" => match e.angle_deg {
                    None => Fault::Jam(Jam::Here),
                    Some(a) => Fault::Jam(Jam::AtAngle(angle(Some(a), "angle_deg")?)),
                },
                "backlash_wear" => {
                    let w = num(e.extra_deg, "extra_deg")?;
                    Fault::BacklashWear(within(w, "extra_deg", 0.0, MAX_BACKLASH_WEAR_DEG)? as f32)
                }
                "friction_factor" => {
                    let k = num(e.factor, "factor")?;
                    if k < 0.0 {
                        return Err(here("`factor` must be ≥ 0".into()));
                    }
                    Fault::FrictionFactor(within(k, "factor", 0.0, MAX_FRICTION_FACTOR)? as f32)
                }
                "broken_tooth" => {
                    let loss = num(e.torque_loss, "torque_loss")?;
                    if !(0.0..=1.0).contains(&loss) {
                        return Err(here("`torque_loss` must be within 0–1".into()));
                    }
                    // A width has no sign: its magnitude is taken.
                    let width = num(e.width_deg, "width_deg")?.abs();
                    Fault::BrokenTooth(Some(BrokenTooth {
                        angle_rad: angle(e.angle_deg, "angle_deg")?,
                        width_rad: within(width, "width_deg", 0.0, 360.0)?.to_radians() as f32,
                        torque_loss: loss as f32,
                    }))
                }
                "open_winding" => Fault::Winding(Winding::Open),
                "shorted_winding" => Fault::Winding(Winding::Shorted),
                "bus_sag" => {
                    let k = num(e.factor, "factor")?;
                    Fault::BusSag(within(k, "factor", 0.0, MAX_BUS_FACTOR)? as f32)
                }
                "pwm_stuck" => {
                    let d = e
                        .duty
                        .ok_or_else(|| here("`pwm_stuck` needs `duty`".into()))?;
                    Fault::PwmStuck(Some(
                        d.clamp(i64::from(i32::MIN), i64::from(i32::MAX)) as i32
                    ))
                }
                k => {
                    let what = k.split_once('_').map_or("", |(_, w)| w);
                    let counts = |key: &str| -> Result<i32, HostError> {
                        let c = e
                            .counts
                            .ok_or_else(|| here(format!("`{k}` needs `{key}`")))?;
                        i32::try_from(c).map_err(|_| here(format!("`{key}` = {c} is out of range")))
                    };
                    let sf = match what {
                        "stuck" => SensorFault::StuckAt(counts("counts")?),
                        "offset" => SensorFault::Offset(counts("counts")?),
                        "gain" => SensorFault::GainDrift(within(
                            num(e.drift, "drift")?,
                            "drift",
                            -1.0,
                            MAX_GAIN_DRIFT,
                        )? as f32),
                        "dropout" => match e.level.as_deref().unwrap_or("zero") {
                            "zero" => SensorFault::Dropout(false),
                            "full" => SensorFault::Dropout(true),
                            other => {
                                return Err(here(format!(
                                    "`level` = `{}` (zero, full)",
                                    shown(other)
                                )))
                            }
                        },
                        "noise" => {
                            let p = num(e.peak_counts, "peak_counts")?;
                            if p < 0.0 {
                                return Err(here("`peak_counts` must be ≥ 0".into()));
                            }
                            let max = MAX_NOISE_PEAK_COUNTS;
                            SensorFault::NoiseBurst(within(p, "peak_counts", 0.0, max)? as f32)
                        }
                        _ => {
                            let b = e.bits.ok_or_else(|| here(format!("`{k}` needs `bits`")))?;
                            if b > MAX_LOST_LSBS {
                                return Err(here(format!(
                                    "`bits` must be at most {MAX_LOST_LSBS}"
                                )));
                            }
                            SensorFault::LostLsbs(b)
                        }
                    };
                    Fault::Sensor(channel(k), sf)
                }
            }
        };
        // Overlaps: a fault applied again, or the other winding fault, while one is in force.
        let group = match kind {
            "open_winding" | "shorted_winding" => "winding",
            k if k.starts_with("tach_") => "tach",
            k if k.starts_with("pot_") => "pot",
            k if k.starts_with("encoder_") => "encoder",
            k => k,
        };
        if clearing {
            active.retain(|(g, _)| *g != group);
        } else if let Some((_, since)) = active.iter().find(|(g, _)| *g == group) {
            return Err(here(format!(
                "`{kind}` overlaps the {group} fault applied by event {since} (clear it first)"
            )));
        } else if !matches!(kind, "backlash_wear" | "friction_factor" | "bus_sag") {
            active.push((group, i + 1));
        }
        sc.push(step as u32, fault).map_err(|err| match err {
            ScenarioError::Contradiction => {
                here("contradicts another event at the same instant".into())
            }
            other => here(other.to_string()),
        })?;
    }
    Ok(sc)
}

fn channel(kind: &str) -> SensorChannel {
    if kind.starts_with("tach_") {
        SensorChannel::Tach
    } else if kind.starts_with("pot_") {
        SensorChannel::Pot
    } else {
        SensorChannel::Encoder
    }
}

fn line_of(text: &str, offset: usize) -> usize {
    text.get(..offset)
        .map(|s| s.matches('\n').count() + 1)
        .unwrap_or(0)
}
