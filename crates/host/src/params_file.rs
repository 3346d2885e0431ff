//! The parameter file (TOML): reading with errors that name the file and the key, and
//! writing in the same schema (for calibrated parameter sets).
//!
//! The schema is `reference-actuator.toml` (INTERFACES.md, "Parameter file"): unknown keys,
//! missing keys, wrong types and non-physical values are errors naming the key.

use crate::error::HostError;
use geared_servo::params::{
    ActuatorParams, Effects, GearTrain, LoadParams, MotorParams, Shaft, Stiffness, ToothGeometry,
};
use serde::Deserialize;
use std::path::Path;

/// The reference actuator's file, compiled in: the default of every `--params`.
pub const REFERENCE_TOML: &str = include_str!("../../../data/reference-actuator.toml");

/// Name shown in messages for the compiled-in reference file.
pub const REFERENCE_NAME: &str = "<bundled reference-actuator.toml>";

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileT {
    sample_period_s: Option<f64>,
    motor: MotorT,
    gear_stage_1: StageT,
    rotating_shaft: Option<ShaftT>,
    gear_stage_2: StageT,
    fixed_shaft: Option<ShaftT>,
    stiffness: Option<StiffnessT>,
    load: LoadT,
    backlash: BacklashT,
    effects: Option<EffectsT>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MotorT {
    resistance_ohm: f64,
    inductance_h: f64,
    torque_constant_nm_per_a: f64,
    back_emf_v_s_per_rad: f64,
    tach_v_s_per_rad: f64,
    inertia_kg_m2: f64,
    coulomb_friction_nm: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct StageT {
    ratio: f64,
    revolving: Option<bool>,
    gear_pitch_diameter_m: Option<f64>,
    face_width_m: Option<f64>,
    pinion_lewis_factor: Option<f64>,
    gear_lewis_factor: Option<f64>,
    pinion_youngs_modulus_pa: Option<f64>,
    gear_youngs_modulus_pa: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ShaftT {
    shear_modulus_pa: f64,
    diameter_m: f64,
    length_m: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct StiffnessT {
    k1_nm_per_rad: f64,
    k2_nm_per_rad: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LoadT {
    inertia_kg_m2: f64,
    coulomb_friction_nm: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct BacklashT {
    total_deg: f64,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct EffectsT {
    motor_viscous: Option<f64>,
    load_viscous: Option<f64>,
    mesh_damping: Option<f64>,
    hinge_stiffness: Option<f64>,
    input_delay: Option<f64>,
    voltage_limit: Option<f64>,
    tach_gain: Option<f64>,
}

impl StageT {
    fn geometry_keys(&self) -> [(&'static str, Option<f64>); 6] {
        [
            ("gear_pitch_diameter_m", self.gear_pitch_diameter_m),
            ("face_width_m", self.face_width_m),
            ("pinion_lewis_factor", self.pinion_lewis_factor),
            ("gear_lewis_factor", self.gear_lewis_factor),
            ("pinion_youngs_modulus_pa", self.pinion_youngs_modulus_pa),
            ("gear_youngs_modulus_pa", self.gear_youngs_modulus_pa),
        ]
    }

    fn geometry(&self, table: &str, file: &str) -> Result<ToothGeometry, HostError> {
        let mut v = [0.0; 6];
        for (slot, (key, val)) in v.iter_mut().zip(self.geometry_keys()) {
            *slot = val.ok_or_else(|| {
                HostError::input(format!(
                    "{file}: missing key `{table}.{key}` (give the gear geometry, or k1 and k2 in a [stiffness] table)"
                ))
            })?;
        }
        let [gear_pitch_diameter_m, face_width_m, pinion_lewis_factor, gear_lewis_factor, pinion_youngs_modulus_pa, gear_youngs_modulus_pa] =
            v;
        Ok(ToothGeometry {
            gear_pitch_diameter_m,
            face_width_m,
            pinion_lewis_factor,
            gear_lewis_factor,
            pinion_youngs_modulus_pa,
            gear_youngs_modulus_pa,
        })
    }
}

impl ShaftT {
    fn shaft(&self) -> Shaft {
        Shaft {
            shear_modulus_pa: self.shear_modulus_pa,
            diameter_m: self.diameter_m,
            length_m: self.length_m,
        }
    }
}

/// Parses a parameter file's text; `name` is used in messages. Validates the values.
pub fn parse(text: &str, name: &str) -> Result<ActuatorParams, HostError> {
    let f: FileT =
        toml::from_str(text).map_err(|e| HostError::input(toml_message(name, text, &e)))?;
    let revolving = f.gear_stage_2.revolving.unwrap_or(true);
    if f.gear_stage_1.revolving.is_some() {
        return Err(HostError::input(format!(
            "{name}: key `gear_stage_1.revolving` is not allowed (only stage 2 can revolve)"
        )));
    }
    let stiffness = match &f.stiffness {
        Some(st) => {
            for (table, stage) in [
                ("gear_stage_1", &f.gear_stage_1),
                ("gear_stage_2", &f.gear_stage_2),
            ] {
                if let Some((key, _)) = stage.geometry_keys().into_iter().find(|(_, v)| v.is_some())
                {
                    return Err(HostError::input(format!(
                        "{name}: key `{table}.{key}` conflicts with the [stiffness] table (give either geometry or measured stiffness)"
                    )));
                }
            }
            for (table, shaft) in [
                ("rotating_shaft", &f.rotating_shaft),
                ("fixed_shaft", &f.fixed_shaft),
            ] {
                if shaft.is_some() {
                    return Err(HostError::input(format!(
                        "{name}: table [{table}] conflicts with the [stiffness] table (give either geometry or measured stiffness)"
                    )));
                }
            }
            Stiffness::Measured {
                k1_nm_per_rad: st.k1_nm_per_rad,
                k2_nm_per_rad: st.k2_nm_per_rad,
            }
        }
        None => {
            let missing = |t: &str| {
                HostError::input(format!(
                    "{name}: missing table [{t}] (give the shaft geometry, or k1 and k2 in a [stiffness] table)"
                ))
            };
            Stiffness::Geometry {
                stage1: f.gear_stage_1.geometry("gear_stage_1", name)?,
                shaft1: f
                    .rotating_shaft
                    .as_ref()
                    .ok_or_else(|| missing("rotating_shaft"))?
                    .shaft(),
                stage2: f.gear_stage_2.geometry("gear_stage_2", name)?,
                shaft2: f
                    .fixed_shaft
                    .as_ref()
                    .ok_or_else(|| missing("fixed_shaft"))?
                    .shaft(),
            }
        }
    };
    let e = f.effects.unwrap_or_default();
    let m = &f.motor;
    let p = ActuatorParams {
        sample_period_s: f.sample_period_s.unwrap_or(0.0005),
        motor: MotorParams {
            resistance_ohm: m.resistance_ohm,
            inductance_h: m.inductance_h,
            torque_constant_nm_per_a: m.torque_constant_nm_per_a,
            back_emf_v_s_per_rad: m.back_emf_v_s_per_rad,
            tach_v_s_per_rad: m.tach_v_s_per_rad,
            inertia_kg_m2: m.inertia_kg_m2,
            coulomb_friction_nm: m.coulomb_friction_nm,
        },
        gears: GearTrain {
            stage1_ratio: f.gear_stage_1.ratio,
            stage2_ratio: f.gear_stage_2.ratio,
            revolving,
            stiffness,
        },
        load: LoadParams {
            inertia_kg_m2: f.load.inertia_kg_m2,
            coulomb_friction_nm: f.load.coulomb_friction_nm,
        },
        backlash_deg: f.backlash.total_deg,
        effects: Effects {
            motor_viscous: e.motor_viscous.unwrap_or(0.0),
            load_viscous: e.load_viscous.unwrap_or(0.0),
            mesh_damping: e.mesh_damping.unwrap_or(0.0),
            hinge_stiffness: e.hinge_stiffness.unwrap_or(0.0),
            input_delay: e.input_delay.unwrap_or(0.0),
            voltage_limit: e.voltage_limit.unwrap_or(0.0),
            tach_gain: e.tach_gain.unwrap_or(0.0),
        },
    };
    validate(&p, name)?;
    Ok(p)
}

/// Validates a parameter set and builds its plant once, so that a set that passes here also
/// builds on the target; the error names `name` and the key.
pub fn validate(p: &ActuatorParams, name: &str) -> Result<(), HostError> {
    geared_servo::Plant::new(p)
        .map(|_| ())
        .map_err(|e| HostError::input(format!("{name}: key `{}` {}", e.field(), e.reason())))
}

/// Reads and validates a parameter file; `None` gives the bundled reference actuator.
pub fn load(path: Option<&Path>) -> Result<ActuatorParams, HostError> {
    match path {
        None => parse(REFERENCE_TOML, REFERENCE_NAME),
        Some(p) => {
            let name = p.display().to_string();
            let text = std::fs::read_to_string(p).map_err(|e| {
                HostError::input(format!("{name}: cannot read parameter file: {e}"))
            })?;
            parse(&text, &name)
        }
    }
}

fn toml_message(name: &str, text: &str, e: &toml::de::Error) -> String {
    let msg = e.message().replace('\n', " ");
    let Some(span) = e.span() else {
        return format!("{name}: {}", top_level(&msg));
    };
    let before = text.get(..span.start).unwrap_or("");
    let line = before.matches('\n').count() + 1;
    let col = before.len() - before.rfind('\n').map(|i| i + 1).unwrap_or(0) + 1;
    // The table the span lies in: the header at the span itself (missing keys point at
    // their table's header) or the last header before it.
    let here = text
        .get(span.start..span.end)
        .unwrap_or("")
        .lines()
        .next()
        .unwrap_or("")
        .trim();
    // A header starts its line; `[1]` in a value does not.
    let at_line_start = before
        .rsplit('\n')
        .next()
        .is_some_and(|l| l.trim().is_empty());
    let header_here = at_line_start && here.starts_with('[');
    let table = if header_here {
        Some(
            here.trim_matches(|c| c == '[' || c == ']')
                .trim()
                .to_string(),
        )
    } else {
        before
            .lines()
            .rev()
            .map(str::trim)
            .find(|l| l.starts_with('['))
            .and_then(|l| l.split(']').next())
            .map(|l| l.trim_start_matches('[').trim().to_string())
    };
    let quoted = |prefix: &str| {
        msg.strip_prefix(prefix)
            .and_then(|r| r.split('`').next())
            .map(str::to_string)
    };
    let keyed = |k: &str| match &table {
        Some(t) if !t.is_empty() => format!("{t}.{k}"),
        _ => k.to_string(),
    };
    let what = if let Some(k) = quoted("missing field `") {
        if header_here || table.is_some() {
            format!("missing key `{}`", keyed(&k))
        } else {
            top_level(&msg)
        }
    } else if let Some(k) = quoted("unknown field `") {
        let expected = msg
            .split_once(", expected")
            .map(|(_, r)| format!(" (expected{r})"))
            .unwrap_or_default();
        format!("unknown key `{}`{expected}", keyed(&k))
    } else {
        // A bad value: name the key written on the span's line.
        let line_text = text.lines().nth(line - 1).unwrap_or("");
        match line_text.split_once('=') {
            Some((k, _)) if !line_text.trim_start().starts_with('[') => {
                format!("key `{}`: {msg}", keyed(k.trim()))
            }
            _ => msg.clone(),
        }
    };
    format!("{name}: line {line}, column {col}: {what}")
}

fn top_level(msg: &str) -> String {
    if let Some(k) = msg
        .strip_prefix("missing field `")
        .and_then(|r| r.split('`').next())
    {
        if k == "sample_period_s" {
            return format!("missing key `{k}`");
        }
        return format!("missing table [{k}]");
    }
    msg.to_string()
}

/// Writes a parameter set in the schema of `reference-actuator.toml`, every value with its
/// unit in a comment; `header` lines become leading `#` comments.
pub fn to_toml(p: &ActuatorParams, header: &[String]) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    for h in header {
        let _ = writeln!(s, "# {h}");
    }
    let m = &p.motor;
    let _ = writeln!(s, "sample_period_s = {:e}   # s\n", p.sample_period_s);
    let _ = writeln!(s, "[motor]");
    let _ = writeln!(s, "resistance_ohm = {:e}   # ohm", m.resistance_ohm);
    let _ = writeln!(s, "inductance_h = {:e}   # H", m.inductance_h);
    let _ = writeln!(
        s,
        "torque_constant_nm_per_a = {:e}   # N*m/A",
        m.torque_constant_nm_per_a
    );
    let _ = writeln!(
        s,
        "back_emf_v_s_per_rad = {:e}   # V*s/rad",
        m.back_emf_v_s_per_rad
    );
    let _ = writeln!(s, "tach_v_s_per_rad = {:e}   # V*s/rad", m.tach_v_s_per_rad);
    let _ = writeln!(s, "inertia_kg_m2 = {:e}   # kg*m^2", m.inertia_kg_m2);
    let _ = writeln!(
        s,
        "coulomb_friction_nm = {:e}   # N*m\n",
        m.coulomb_friction_nm
    );
    let g = &p.gears;
    let geo = |s: &mut String, t: &ToothGeometry| {
        let _ = writeln!(
            s,
            "gear_pitch_diameter_m = {:e}   # m",
            t.gear_pitch_diameter_m
        );
        let _ = writeln!(s, "face_width_m = {:e}   # m", t.face_width_m);
        let _ = writeln!(s, "pinion_lewis_factor = {:e}", t.pinion_lewis_factor);
        let _ = writeln!(s, "gear_lewis_factor = {:e}", t.gear_lewis_factor);
        let _ = writeln!(
            s,
            "pinion_youngs_modulus_pa = {:e}   # Pa",
            t.pinion_youngs_modulus_pa
        );
        let _ = writeln!(
            s,
            "gear_youngs_modulus_pa = {:e}   # Pa",
            t.gear_youngs_modulus_pa
        );
    };
    let shaft = |s: &mut String, t: &str, sh: &Shaft| {
        let _ = writeln!(s, "[{t}]");
        let _ = writeln!(s, "shear_modulus_pa = {:e}   # Pa", sh.shear_modulus_pa);
        let _ = writeln!(s, "diameter_m = {:e}   # m", sh.diameter_m);
        let _ = writeln!(s, "length_m = {:e}   # m\n", sh.length_m);
    };
    let _ = writeln!(s, "[gear_stage_1]\nratio = {:e}", g.stage1_ratio);
    match &g.stiffness {
        Stiffness::Geometry {
            stage1,
            shaft1,
            stage2,
            shaft2,
        } => {
            geo(&mut s, stage1);
            s.push('\n');
            shaft(&mut s, "rotating_shaft", shaft1);
            let _ = writeln!(
                s,
                "[gear_stage_2]\nratio = {:e}\nrevolving = {}",
                g.stage2_ratio, g.revolving
            );
            geo(&mut s, stage2);
            s.push('\n');
            shaft(&mut s, "fixed_shaft", shaft2);
        }
        Stiffness::Measured {
            k1_nm_per_rad,
            k2_nm_per_rad,
        } => {
            let _ = writeln!(
                s,
                "\n[gear_stage_2]\nratio = {:e}\nrevolving = {}\n",
                g.stage2_ratio, g.revolving
            );
            let _ = writeln!(s, "[stiffness]");
            let _ = writeln!(
                s,
                "k1_nm_per_rad = {k1_nm_per_rad:e}   # N*m/rad at the rotating shaft"
            );
            let _ = writeln!(
                s,
                "k2_nm_per_rad = {k2_nm_per_rad:e}   # N*m/rad at the load\n"
            );
        }
    }
    let _ = writeln!(s, "[load]");
    let _ = writeln!(s, "inertia_kg_m2 = {:e}   # kg*m^2", p.load.inertia_kg_m2);
    let _ = writeln!(
        s,
        "coulomb_friction_nm = {:e}   # N*m\n",
        p.load.coulomb_friction_nm
    );
    let _ = writeln!(s, "[backlash]\ntotal_deg = {:e}   # deg\n", p.backlash_deg);
    let e = &p.effects;
    let _ = writeln!(s, "[effects]");
    let _ = writeln!(s, "motor_viscous = {:e}   # N*m*s/rad", e.motor_viscous);
    let _ = writeln!(s, "load_viscous = {:e}   # N*m*s/rad", e.load_viscous);
    let _ = writeln!(s, "mesh_damping = {:e}   # N*m*s/rad", e.mesh_damping);
    let _ = writeln!(s, "hinge_stiffness = {:e}   # N*m/rad", e.hinge_stiffness);
    let _ = writeln!(s, "input_delay = {:e}   # s", e.input_delay);
    let _ = writeln!(s, "voltage_limit = {:e}   # V (0 = none)", e.voltage_limit);
    let _ = writeln!(s, "tach_gain = {:e}   # relative", e.tach_gain);
    s
}
