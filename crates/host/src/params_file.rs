//! The parameter file (TOML): reading with errors that name the file and the key, and
//! writing in the same schema (for calibrated parameter sets).
//!
//! The schema is `reference-actuator.toml` (INTERFACES.md, "Parameter file"): unknown keys,
//! missing keys, wrong types and non-physical values are errors naming the key.

use crate::error::HostError;
use geared_servo::params::{
    ActuatorParams, GearTrain, LoadParams, MotorParams, Shaft, Stiffness, ToothGeometry,
};
use geared_servo::{Effect, Effects};
use serde::de::{self, Deserializer, MapAccess, Visitor};
use serde::ser::{SerializeStruct, Serializer};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::path::Path;

/// The reference actuator's file, compiled in: the default of every `--params`.
pub const REFERENCE_TOML: &str = include_str!("../../../data/reference-actuator.toml");

/// Name shown in messages for the compiled-in reference file.
pub const REFERENCE_NAME: &str = "<bundled reference-actuator.toml>";

/// The file, table by table: the schema of INTERFACES.md "Parameter file", read and written
/// by these derives. Unknown keys are errors (`deny_unknown_fields`); optional keys are
/// `Option`s and are left out when written.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileT {
    /// Default 0.0005 s (2 kHz).
    sample_period_s: Option<f64>,
    #[serde(with = "MotorT")]
    motor: MotorParams,
    gear_stage_1: StageT,
    #[serde(skip_serializing_if = "Option::is_none")]
    rotating_shaft: Option<ShaftT>,
    gear_stage_2: StageT,
    #[serde(skip_serializing_if = "Option::is_none")]
    fixed_shaft: Option<ShaftT>,
    /// Measured stiffness, instead of the geometry of the stages and shafts.
    #[serde(skip_serializing_if = "Option::is_none")]
    stiffness: Option<StiffnessT>,
    #[serde(with = "LoadT")]
    load: LoadParams,
    backlash: BacklashT,
    /// Every effect off when absent.
    effects: Option<EffectsT>,
}

/// `[motor]`: the core's [`MotorParams`], key for field (serde checks the two agree).
#[derive(Serialize, Deserialize)]
#[serde(remote = "MotorParams", deny_unknown_fields)]
struct MotorT {
    resistance_ohm: f64,
    inductance_h: f64,
    torque_constant_nm_per_a: f64,
    back_emf_v_s_per_rad: f64,
    tach_v_s_per_rad: f64,
    inertia_kg_m2: f64,
    coulomb_friction_nm: f64,
}

/// `[gear_stage_1]`, `[gear_stage_2]`: the ratio, the layout (stage 2 only) and, unless a
/// `[stiffness]` table is given, the tooth geometry.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct StageT {
    ratio: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    revolving: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    gear_pitch_diameter_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    face_width_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pinion_lewis_factor: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    gear_lewis_factor: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pinion_youngs_modulus_pa: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    gear_youngs_modulus_pa: Option<f64>,
}

/// `[rotating_shaft]`, `[fixed_shaft]`: the core's [`Shaft`].
#[derive(Serialize, Deserialize)]
#[serde(remote = "Shaft", deny_unknown_fields)]
struct ShaftDef {
    shear_modulus_pa: f64,
    diameter_m: f64,
    length_m: f64,
}

/// A [`Shaft`] table (a wrapper, so that it can be optional).
#[derive(Serialize, Deserialize)]
struct ShaftT(#[serde(with = "ShaftDef")] Shaft);

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct StiffnessT {
    k1_nm_per_rad: f64,
    k2_nm_per_rad: f64,
}

/// `[load]`: the core's [`LoadParams`].
#[derive(Serialize, Deserialize)]
#[serde(remote = "LoadParams", deny_unknown_fields)]
struct LoadT {
    inertia_kg_m2: f64,
    coulomb_friction_nm: f64,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct BacklashT {
    total_deg: f64,
}

/// `[effects]`: one key per entry of the effect registry ([`Effect::ALL`]), each optional
/// (off when absent); any other key is an unknown field, as in the derived tables.
struct EffectsT(Effects);

impl Serialize for EffectsT {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut t = s.serialize_struct("EffectsT", Effect::ALL.len())?;
        for e in Effect::ALL {
            t.serialize_field(e.name(), &self.0.get(e))?;
        }
        t.end()
    }
}

impl<'de> Deserialize<'de> for EffectsT {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        /// A key of `[effects]`, rejected as serde's derive rejects an unknown field.
        struct Key(Effect);
        impl<'de> Deserialize<'de> for Key {
            fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                struct Name;
                impl Visitor<'_> for Name {
                    type Value = Key;
                    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                        f.write_str("field identifier")
                    }
                    fn visit_str<E: de::Error>(self, v: &str) -> Result<Key, E> {
                        Effect::from_name(v)
                            .map(Key)
                            .map_err(|_| E::unknown_field(v, &Effect::NAMES))
                    }
                }
                d.deserialize_identifier(Name)
            }
        }
        struct Table;
        impl<'de> Visitor<'de> for Table {
            type Value = EffectsT;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("struct EffectsT")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<EffectsT, A::Error> {
                let mut e = Effects::NONE;
                while let Some(Key(k)) = map.next_key()? {
                    e.set(k, map.next_value()?);
                }
                Ok(EffectsT(e))
            }
        }
        d.deserialize_struct("EffectsT", &Effect::NAMES, Table)
    }
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

    /// A stage of `ratio` with the given geometry (`None`: measured stiffness).
    fn new(ratio: f64, revolving: Option<bool>, g: Option<&ToothGeometry>) -> StageT {
        StageT {
            ratio,
            revolving,
            gear_pitch_diameter_m: g.map(|g| g.gear_pitch_diameter_m),
            face_width_m: g.map(|g| g.face_width_m),
            pinion_lewis_factor: g.map(|g| g.pinion_lewis_factor),
            gear_lewis_factor: g.map(|g| g.gear_lewis_factor),
            pinion_youngs_modulus_pa: g.map(|g| g.pinion_youngs_modulus_pa),
            gear_youngs_modulus_pa: g.map(|g| g.gear_youngs_modulus_pa),
        }
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

impl FileT {
    /// The file form of `p`: every key written, geometry or `[stiffness]` as `p` has it.
    fn new(p: &ActuatorParams) -> FileT {
        let g = &p.gears;
        let (stage1, shaft1, stage2, shaft2, stiffness) = match &g.stiffness {
            Stiffness::Geometry {
                stage1,
                shaft1,
                stage2,
                shaft2,
            } => (
                Some(stage1),
                Some(*shaft1),
                Some(stage2),
                Some(*shaft2),
                None,
            ),
            Stiffness::Measured {
                k1_nm_per_rad,
                k2_nm_per_rad,
            } => (
                None,
                None,
                None,
                None,
                Some(StiffnessT {
                    k1_nm_per_rad: *k1_nm_per_rad,
                    k2_nm_per_rad: *k2_nm_per_rad,
                }),
            ),
        };
        FileT {
            sample_period_s: Some(p.sample_period_s),
            motor: p.motor,
            gear_stage_1: StageT::new(g.stage1_ratio, None, stage1),
            rotating_shaft: shaft1.map(ShaftT),
            gear_stage_2: StageT::new(g.stage2_ratio, Some(g.revolving), stage2),
            fixed_shaft: shaft2.map(ShaftT),
            stiffness,
            load: p.load,
            backlash: BacklashT {
                total_deg: p.backlash_deg,
            },
            effects: Some(EffectsT(p.effects)),
        }
    }

    /// The parameter set (not validated); errors for what the derives cannot say: a key
    /// allowed only in one of the two stiffness forms, or missing in the one given.
    fn params(self, name: &str) -> Result<ActuatorParams, HostError> {
        let f = self;
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
                    if let Some((key, _)) =
                        stage.geometry_keys().into_iter().find(|(_, v)| v.is_some())
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
                        .0,
                    stage2: f.gear_stage_2.geometry("gear_stage_2", name)?,
                    shaft2: f
                        .fixed_shaft
                        .as_ref()
                        .ok_or_else(|| missing("fixed_shaft"))?
                        .0,
                }
            }
        };
        Ok(ActuatorParams {
            sample_period_s: f.sample_period_s.unwrap_or(0.0005),
            motor: f.motor,
            gears: GearTrain {
                stage1_ratio: f.gear_stage_1.ratio,
                stage2_ratio: f.gear_stage_2.ratio,
                revolving: f.gear_stage_2.revolving.unwrap_or(true),
                stiffness,
            },
            load: f.load,
            backlash_deg: f.backlash.total_deg,
            effects: f.effects.map(|e| e.0).unwrap_or(Effects::NONE),
        })
    }
}

/// Parses a parameter file's text; `name` is used in messages. Validates the values.
pub fn parse(text: &str, name: &str) -> Result<ActuatorParams, HostError> {
    let f: FileT =
        toml::from_str(text).map_err(|e| HostError::input(toml_message(name, text, &e)))?;
    let p = f.params(name)?;
    validate(&p, name)?;
    Ok(p)
}

/// Validates a parameter set and builds its plant once, so that a set that passes here also
/// builds on the target; the error names `name` and the key.
pub fn validate(p: &ActuatorParams, name: &str) -> Result<(), HostError> {
    geared_servo::Plant::new(p)
        .map(|_| ())
        .map_err(|e| HostError::from(e).at(name))
}

/// Validates `p` at the sample period of a record named `record` (`dt`, s): the record's
/// rate is the one it runs at, and it must suit the parameters.
pub fn validate_for_record(p: &ActuatorParams, dt: f64, record: &str) -> Result<(), HostError> {
    let mut p = *p;
    p.sample_period_s = dt;
    validate(&p, &format!("{record} (sample period of the record)"))
}

/// `p` with the total backlash of `--backlash-deg`, degrees, validated; the message says
/// what is wrong with the value (`--backlash-deg: value must not be negative`).
pub fn with_backlash(p: &ActuatorParams, backlash_deg: f64) -> Result<ActuatorParams, HostError> {
    let mut p = *p;
    p.backlash_deg = backlash_deg;
    validate(&p, "--backlash-deg")
        .map_err(|e| HostError::input(e.message.replace("key `backlash.total_deg`", "value")))?;
    Ok(p)
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

/// Writes a parameter set in the schema of `reference-actuator.toml` (every key, so that
/// it reads back to the identical set); `header` lines become leading `#` comments. Numbers
/// are written in scientific notation with the fewest digits that read back exactly, and
/// each effect with its unit in a comment (the other keys name their unit).
pub fn to_toml(p: &ActuatorParams, header: &[String]) -> Result<String, HostError> {
    let failed =
        |e: &dyn fmt::Display| HostError::other(format!("cannot write a parameter file: {e}"));
    let body = toml::to_string(&FileT::new(p)).map_err(|e| failed(&e))?;
    let mut doc: toml_edit::DocumentMut = body.parse().map_err(|e| failed(&e))?;
    for (_, item) in doc.iter_mut() {
        match item {
            toml_edit::Item::Value(v) => scientific(v),
            toml_edit::Item::Table(t) => t.iter_mut().for_each(|(_, i)| {
                if let Some(v) = i.as_value_mut() {
                    scientific(v);
                }
            }),
            _ => {}
        }
    }
    if let Some(t) = doc.get_mut("effects").and_then(|i| i.as_table_mut()) {
        for e in Effect::ALL {
            if let Some(v) = t.get_mut(e.name()).and_then(|i| i.as_value_mut()) {
                v.decor_mut().set_suffix(format!("   # {}", e.unit()));
            }
        }
    }
    let mut s = String::new();
    for h in header {
        s.push_str("# ");
        s.push_str(h);
        s.push('\n');
    }
    s.push_str(&doc.to_string());
    Ok(s)
}

/// A finite float in `{:e}` form (`2.5e-7`, not `0.00000025`); anything else unchanged.
fn scientific(v: &mut toml_edit::Value) {
    let Some(x) = v.as_float().filter(|x| x.is_finite()) else {
        return;
    };
    if let Ok(mut e) = format!("{x:e}").parse::<toml_edit::Value>() {
        *e.decor_mut() = v.decor().clone();
        *v = e;
    }
}
