//! The parameter file as a flat list of values, each with its key path, unit and meaning:
//! the FMU's parameters and the Python package's attributes.
//!
//! The list is not declared here. It is the leaves of the file that [`params_file::to_toml`]
//! writes for a parameter set, in the file's order: the serde schema the reader uses, with
//! the registry's effects. A key added to the file, or an effect added to the registry,
//! appears in both front ends without touching them. Which stiffness form a set has
//! (geometry or a `[stiffness]` table) decides which keys its list holds.
//!
//! A value is changed in the document and the set is read back through
//! [`params_file::parse`], so a changed value is validated with the file's messages.

use crate::error::HostError;
use crate::params_file;
use geared_servo::{ActuatorParams, Effect};

/// The unit of a dimensionless quantity, as [`Effect::unit`] writes it.
pub const DIMENSIONLESS: &str = "-";

/// Unit of a key or column by the suffix its name ends with (INTERFACES.md: SI units, the key
/// says which), longest suffix first; names that are dimensionless by nature are listed. A
/// test checks every key of the reference file against the unit its comment gives.
const SUFFIX_UNITS: &[(&str, &str)] = &[
    ("_v_s_per_rad", "V*s/rad"),
    ("_nm_per_rad", "N*m/rad"),
    ("_nm_per_a", "N*m/A"),
    ("_rad_s", "rad/s"),
    ("_kg_m2", "kg*m^2"),
    ("_ohm", "ohm"),
    ("_deg", "deg"),
    ("_pa", "Pa"),
    ("_nm", "N*m"),
    ("_h", "H"),
    ("_m", "m"),
    ("_s", "s"),
    ("_v", "V"),
    ("_a", "A"),
    // Dimensionless by nature: ratios, form factors, flags.
    ("ratio", DIMENSIONLESS),
    ("_factor", DIMENSIONLESS),
    ("revolving", DIMENSIONLESS),
    ("in_contact", DIMENSIONLESS),
];

/// The unit of parameter key path `key` (`"motor.resistance_ohm"` → `"ohm"`) or of a record
/// column (`"motor_speed_rad_s"` → `"rad/s"`): an effect's own unit, else the unit its
/// suffix names; `None` when the name follows no rule.
pub fn unit_of(key: &str) -> Option<&'static str> {
    if let Some(e) = key
        .strip_prefix("effects.")
        .and_then(|n| Effect::from_name(n).ok())
    {
        return Some(e.unit());
    }
    let leaf = key.rsplit('.').next().unwrap_or(key);
    SUFFIX_UNITS
        .iter()
        .find(|(suffix, _)| leaf.ends_with(suffix))
        .map(|(_, unit)| *unit)
}

/// A value of the list: the file has numbers and one flag (`gear_stage_2.revolving`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value {
    /// A number, in the key's unit.
    Real(f64),
    /// A flag.
    Bool(bool),
}

/// One key of the parameter file.
#[derive(Clone, Debug, PartialEq)]
pub struct Entry {
    /// Key path as the file and the error messages name it (`"motor.resistance_ohm"`,
    /// `"sample_period_s"`, `"effects.mesh_damping"`).
    pub key: String,
    /// Unit ([`unit_of`]); [`DIMENSIONLESS`] for a ratio or a flag.
    pub unit: &'static str,
    /// Meaning, from the comment of the key in the bundled reference file; for an effect
    /// that file does not list, the registry's [`Effect::meaning`] (empty for any other key
    /// the file lacks or a comment with no words beyond the unit).
    pub description: String,
    /// The value.
    pub value: Value,
}

/// A parameter set as its file's flat list of values (see the module's doc).
#[derive(Clone, Debug)]
pub struct ParamList {
    doc: toml_edit::DocumentMut,
    entries: Vec<Entry>,
}

impl ParamList {
    /// The list of `p`: every key [`params_file::to_toml`] writes for it, in the file's order.
    /// Fails only if a key follows no unit rule (a test keeps that from happening).
    pub fn new(p: &ActuatorParams) -> Result<ParamList, HostError> {
        let text = params_file::to_toml(p, &[])?;
        let doc: toml_edit::DocumentMut = text
            .parse()
            .map_err(|e| HostError::other(format!("cannot read back a parameter file: {e}")))?;
        let reference: Option<toml_edit::DocumentMut> = params_file::REFERENCE_TOML.parse().ok();
        let mut entries = Vec::new();
        let mut leaf = |key: String, item: &toml_edit::Item| -> Result<(), HostError> {
            let value = match item.as_value() {
                Some(toml_edit::Value::Float(f)) => Value::Real(*f.value()),
                Some(toml_edit::Value::Integer(i)) => Value::Real(*i.value() as f64),
                Some(toml_edit::Value::Boolean(b)) => Value::Bool(*b.value()),
                _ => {
                    return Err(HostError::other(format!(
                        "key `{key}` of the parameter file is neither a number nor a flag"
                    )))
                }
            };
            let unit = unit_of(&key).ok_or_else(|| {
                HostError::other(format!(
                    "key `{key}` of the parameter file names no unit (param_list::SUFFIX_UNITS)"
                ))
            })?;
            let description = reference
                .as_ref()
                .and_then(|r| lookup(r.as_item(), &key))
                .map(comment_words)
                .or_else(|| Effect::from_key(&key).map(|e| e.meaning().trim().to_string()))
                .unwrap_or_default();
            entries.push(Entry {
                key,
                unit,
                description,
                value,
            });
            Ok(())
        };
        for (name, item) in doc.iter() {
            match item.as_table() {
                Some(t) => {
                    for (k, v) in t.iter() {
                        leaf(format!("{name}.{k}"), v)?;
                    }
                }
                None => leaf(name.to_string(), item)?,
            }
        }
        Ok(ParamList { doc, entries })
    }

    /// Every key with its unit, meaning and current value, in the file's order.
    pub fn entries(&self) -> &[Entry] {
        &self.entries
    }

    /// Index of key path `key` in [`entries`](Self::entries).
    pub fn find(&self, key: &str) -> Option<usize> {
        self.entries.iter().position(|e| e.key == key)
    }

    /// Sets entry `index` (not validated: [`to_params`](Self::to_params) does that, since a
    /// value may be valid only together with others). A number for a flag or a flag for a
    /// number is an error naming the key.
    pub fn set(&mut self, index: usize, value: Value) -> Result<(), HostError> {
        let entry = self
            .entries
            .get_mut(index)
            .ok_or_else(|| HostError::input(format!("no parameter number {index}")))?;
        let new = match (entry.value, value) {
            (Value::Real(_), Value::Real(x)) => toml_edit::Value::from(x),
            (Value::Bool(_), Value::Bool(b)) => toml_edit::Value::from(b),
            (Value::Real(_), Value::Bool(_)) => {
                return Err(HostError::input(format!(
                    "key `{}` is a number, not a flag",
                    entry.key
                )))
            }
            (Value::Bool(_), Value::Real(_)) => {
                return Err(HostError::input(format!(
                    "key `{}` is a flag (true or false), not a number",
                    entry.key
                )))
            }
        };
        let slot = match entry.key.split_once('.') {
            Some((table, key)) => self
                .doc
                .get_mut(table)
                .and_then(|t| t.as_table_like_mut())
                .and_then(|t| t.get_mut(key)),
            None => self.doc.get_mut(&entry.key),
        };
        let slot = slot
            .and_then(toml_edit::Item::as_value_mut)
            .ok_or_else(|| HostError::other(format!("key `{}` went missing", entry.key)))?;
        let decor = slot.decor().clone();
        *slot = new;
        *slot.decor_mut() = decor;
        entry.value = value;
        Ok(())
    }

    /// Sets key path `key`; an unknown key is an error that lists the keys.
    pub fn set_key(&mut self, key: &str, value: Value) -> Result<(), HostError> {
        let i = self.find(key).ok_or_else(|| self.unknown(key))?;
        self.set(i, value)
    }

    /// The error for a key this list does not have, naming the keys it has.
    pub fn unknown(&self, key: &str) -> HostError {
        HostError::input(format!(
            "unknown parameter `{}` (expected one of {})",
            crate::error::shown(key),
            self.entries
                .iter()
                .map(|e| format!("`{}`", e.key))
                .collect::<Vec<_>>()
                .join(", ")
        ))
    }

    /// The parameter set, read back and validated as a file named `name` is: the messages
    /// are those of `--params` (`"NAME: key `load.inertia_kg_m2` must be greater than zero"`).
    pub fn to_params(&self, name: &str) -> Result<ActuatorParams, HostError> {
        params_file::parse(&self.doc.to_string(), name)
    }
}

/// The item at key path `key` of a document.
fn lookup<'a>(root: &'a toml_edit::Item, key: &str) -> Option<&'a toml_edit::Item> {
    key.split('.').try_fold(root, |item, k| item.get(k))
}

/// The words of a reference-file comment after its unit column:
/// `# ohm     armature resistance` → `armature resistance`.
fn comment_words(item: &toml_edit::Item) -> String {
    let suffix = item
        .as_value()
        .and_then(|v| v.decor().suffix())
        .and_then(|s| s.as_str())
        .unwrap_or("");
    let text = suffix.trim().trim_start_matches('#').trim();
    text.split_once(char::is_whitespace)
        .map(|(_, rest)| rest.trim().to_string())
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;
    use geared_servo::REFERENCE;

    /// The unit column of every key's comment in the reference file (`# ohm  armature ...`).
    fn reference_units() -> Vec<(String, String)> {
        let doc: toml_edit::DocumentMut = params_file::REFERENCE_TOML.parse().unwrap();
        let mut out = Vec::new();
        for (name, item) in doc.iter() {
            let mut one = |key: String, item: &toml_edit::Item| {
                let c = item.as_value().unwrap().decor().suffix().unwrap();
                let c = c.as_str().unwrap().trim().trim_start_matches('#').trim();
                out.push((key, c.split_whitespace().next().unwrap().to_string()));
            };
            match item.as_table() {
                Some(t) => t.iter().for_each(|(k, v)| one(format!("{name}.{k}"), v)),
                None => one(name.to_string(), item),
            }
        }
        out
    }

    #[test]
    fn units_agree_with_the_reference_file_comments() {
        let units = reference_units();
        assert!(units.len() > 30, "{units:?}");
        for (key, unit) in units {
            assert_eq!(unit_of(&key), Some(unit.as_str()), "{key}");
        }
    }

    #[test]
    fn list_is_the_reference_files_keys_in_order() {
        let list = ParamList::new(&REFERENCE).unwrap();
        let mut keys: Vec<String> = reference_units().into_iter().map(|(k, _)| k).collect();
        // Effects the reference file predates follow its keys, in the registry's order.
        for e in Effect::ALL {
            if !keys.iter().any(|k| k == e.key()) {
                keys.push(e.key().to_string());
            }
        }
        let listed: Vec<&str> = list.entries().iter().map(|e| e.key.as_str()).collect();
        assert_eq!(listed, keys);
        let lag = &list.entries()[list.find("effects.tach_lag").unwrap()];
        assert!(lag.description.starts_with("Time constant"), "{lag:?}");
        let r = &list.entries()[list.find("motor.resistance_ohm").unwrap()];
        assert_eq!(r.value, Value::Real(32.5));
        assert_eq!(r.unit, "ohm");
        assert!(r.description.starts_with("armature resistance"), "{r:?}");
        let n = list.find("gear_stage_2.revolving").unwrap();
        assert_eq!(list.entries()[n].value, Value::Bool(true));
    }

    #[test]
    fn every_effect_is_listed_with_its_unit() {
        let list = ParamList::new(&REFERENCE).unwrap();
        for e in Effect::ALL {
            let i = list.find(e.key()).unwrap();
            assert_eq!(list.entries()[i].unit, e.unit());
        }
    }

    #[test]
    fn measured_stiffness_lists_k1_and_k2_instead_of_geometry() {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../data/kord-geartrain.toml"
        ))
        .unwrap();
        let p = params_file::parse(&text, "kord").unwrap();
        let list = ParamList::new(&p).unwrap();
        let k1 = list.find("stiffness.k1_nm_per_rad").unwrap();
        assert_eq!(list.entries()[k1].unit, "N*m/rad");
        assert!(list.find("gear_stage_1.face_width_m").is_none());
        assert_eq!(list.to_params("kord").unwrap(), p);
    }

    #[test]
    fn a_changed_value_reads_back_and_a_bad_one_names_the_key() {
        let mut list = ParamList::new(&REFERENCE).unwrap();
        list.set_key("backlash.total_deg", Value::Real(0.08))
            .unwrap();
        list.set_key("gear_stage_2.revolving", Value::Bool(false))
            .unwrap();
        let p = list.to_params("x").unwrap();
        assert_eq!(p.backlash_deg, 0.08);
        assert!(!p.gears.revolving);
        list.set_key("load.inertia_kg_m2", Value::Real(-1.0))
            .unwrap();
        assert_eq!(
            list.to_params("FMU").unwrap_err().message,
            "FMU: key `load.inertia_kg_m2` must be greater than zero"
        );
        list.set_key("load.inertia_kg_m2", Value::Real(f64::NAN))
            .unwrap();
        assert_eq!(
            list.to_params("FMU").unwrap_err().message,
            "FMU: key `load.inertia_kg_m2` must be a finite number"
        );
        let e = list
            .set_key("gear_stage_2.revolving", Value::Real(1.0))
            .unwrap_err();
        assert!(e.message.contains("is a flag"), "{e}");
        let e = list.set_key("motor.nope", Value::Real(1.0)).unwrap_err();
        assert!(
            e.message.starts_with("unknown parameter `motor.nope`"),
            "{e}"
        );
    }

    #[test]
    fn record_columns_have_units() {
        for c in crate::simulate::SIMULATE_COLUMNS {
            assert!(unit_of(c).is_some(), "{c}");
        }
        assert_eq!(unit_of("motor_speed_rad_s"), Some("rad/s"));
        assert_eq!(unit_of("motor_voltage_v"), Some("V"));
        assert_eq!(unit_of("motor.mystery_furlongs"), None);
    }
}
