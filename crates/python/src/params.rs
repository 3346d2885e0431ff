//! `geared_servo.Params`: a validated parameter set, read from and written to the parameter
//! file, its keys as items (`p["motor.resistance_ohm"]`) and, through the tables that
//! `__init__.py` builds from [`schema`], as attributes (`p.motor.resistance_ohm`).

use crate::{py_err, InputError};
use geared_servo::{ActuatorParams, Stiffness, REFERENCE};
use geared_servo_host::error::HostError;
use geared_servo_host::param_list::{Entry, ParamList, Value};
use geared_servo_host::params_file;
use pyo3::exceptions::{PyAttributeError, PyKeyError};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyBool, PyDict};
use std::path::PathBuf;

/// The classes of the tables (`motor`, `gear_stage_1`, ...), by name, from `__init__.py`.
static TABLES: PyOnceLock<Py<PyDict>> = PyOnceLock::new();

/// The parameters of one actuator, validated: every key of the parameter file
/// (docs/INTERFACES.md), in SI units except angles in degrees where the key ends in `_deg`.
///
/// Read one with `Params.from_toml(path)`, `Params.from_string(text)` or `Params.reference()`
/// (the bundled reference actuator); write it with `to_toml()`. Keys are items
/// (`p["motor.resistance_ohm"]`, `p.keys()`) and attributes by table
/// (`p.motor.resistance_ohm`, `p.effects.mesh_damping`, `p.sample_period_s`); `help()` on a
/// table (`help(type(p.motor))`) lists its keys with their units, and `p.unit(key)` and
/// `p.description(key)` give them too. Setting a key validates the set at once and raises
/// `InputError` with the parameter file's message (`NAME: key `load.inertia_kg_m2` must be
/// greater than zero`), leaving the set unchanged.
#[pyclass(module = "geared_servo", name = "Params")]
#[derive(Clone)]
pub struct Params {
    pub(crate) p: ActuatorParams,
    /// What messages call it: the file's path, or `<bundled reference-actuator.toml>`.
    pub(crate) name: String,
}

impl Params {
    fn list(&self) -> PyResult<ParamList> {
        ParamList::new(&self.p).map_err(py_err)
    }

    fn entry(&self, key: &str) -> PyResult<Entry> {
        let list = self.list()?;
        match list.find(key).and_then(|i| list.entries().get(i)) {
            Some(e) => Ok(e.clone()),
            None => Err(PyKeyError::new_err(list.unknown(key).message)),
        }
    }

    fn set(&mut self, key: &str, value: &Bound<'_, PyAny>) -> PyResult<()> {
        let mut list = self.list()?;
        let i = list
            .find(key)
            .ok_or_else(|| PyKeyError::new_err(list.unknown(key).message))?;
        let v = if value.is_instance_of::<PyBool>() {
            Value::Bool(value.extract()?)
        } else {
            Value::Real(value.extract().map_err(|_| {
                InputError::new_err(format!(
                    "key `{key}`: expected a number, got {}",
                    value
                        .get_type()
                        .name()
                        .map(|n| n.to_string())
                        .unwrap_or_default()
                ))
            })?)
        };
        list.set(i, v).map_err(py_err)?;
        self.p = list.to_params(&self.name).map_err(py_err)?;
        Ok(())
    }

    /// The names of the tables this set has (`motor`, ..., `effects`).
    fn tables(&self) -> PyResult<Vec<String>> {
        let mut out: Vec<String> = Vec::new();
        for e in self.list()?.entries() {
            if let Some((t, _)) = e.key.split_once('.') {
                if !out.iter().any(|x| x == t) {
                    out.push(t.to_string());
                }
            }
        }
        Ok(out)
    }
}

fn to_py(py: Python<'_>, v: Value) -> PyResult<Py<PyAny>> {
    Ok(match v {
        Value::Real(x) => x.into_pyobject(py)?.into_any().unbind(),
        Value::Bool(b) => PyBool::new(py, b).to_owned().into_any().unbind(),
    })
}

#[pymethods]
impl Params {
    /// Reads and validates a parameter file (TOML); `path` is a str or a path.
    #[staticmethod]
    fn from_toml(path: PathBuf) -> PyResult<Params> {
        let p = params_file::load(Some(&path)).map_err(py_err)?;
        Ok(Params {
            p,
            name: path.display().to_string(),
        })
    }

    /// Reads and validates the text of a parameter file; `name` is what messages call it.
    #[staticmethod]
    #[pyo3(signature = (text, name = "<string>"))]
    fn from_string(text: &str, name: &str) -> PyResult<Params> {
        let p = params_file::parse(text, name).map_err(py_err)?;
        Ok(Params {
            p,
            name: name.to_string(),
        })
    }

    /// The reference actuator (the bundled `reference-actuator.toml`).
    #[staticmethod]
    fn reference() -> PyResult<Params> {
        let p = params_file::load(None).map_err(py_err)?;
        Ok(Params {
            p,
            name: params_file::REFERENCE_NAME.to_string(),
        })
    }

    /// The parameter file's text: every key, reading back to the identical set.
    fn to_toml(&self) -> PyResult<String> {
        params_file::to_toml(&self.p, &[]).map_err(py_err)
    }

    /// What messages call this set: the file it was read from.
    #[getter]
    fn name(&self) -> String {
        self.name.clone()
    }

    /// Every key path, in the file's order.
    fn keys(&self) -> PyResult<Vec<String>> {
        Ok(self
            .list()?
            .entries()
            .iter()
            .map(|e| e.key.clone())
            .collect())
    }

    /// `{key: value}` for every key.
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for e in self.list()?.entries() {
            d.set_item(&e.key, to_py(py, e.value)?)?;
        }
        Ok(d)
    }

    /// The unit of `key` (`"ohm"`; `"-"` when dimensionless).
    fn unit(&self, key: &str) -> PyResult<&'static str> {
        Ok(self.entry(key)?.unit)
    }

    /// What `key` means (from the reference file's comment; may be empty).
    fn description(&self, key: &str) -> PyResult<String> {
        Ok(self.entry(key)?.description)
    }

    /// The same actuator with another total backlash, degrees (validated as
    /// `--backlash-deg` is).
    fn with_backlash_deg(&self, backlash_deg: f64) -> PyResult<Params> {
        Ok(Params {
            p: params_file::with_backlash(&self.p, backlash_deg).map_err(py_err)?,
            name: self.name.clone(),
        })
    }

    /// A copy.
    fn copy(&self) -> Params {
        self.clone()
    }

    fn __copy__(&self) -> Params {
        self.clone()
    }

    fn __deepcopy__(&self, _memo: &Bound<'_, PyAny>) -> Params {
        self.clone()
    }

    fn __getitem__(&self, py: Python<'_>, key: &str) -> PyResult<Py<PyAny>> {
        to_py(py, self.entry(key)?.value)
    }

    fn __setitem__(&mut self, key: &str, value: &Bound<'_, PyAny>) -> PyResult<()> {
        self.set(key, value)
    }

    fn __contains__(&self, key: &str) -> PyResult<bool> {
        Ok(self.list()?.find(key).is_some())
    }

    fn __len__(&self) -> PyResult<usize> {
        Ok(self.list()?.entries().len())
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<Params>()
            .map(|o| o.borrow().p == self.p)
            .unwrap_or(false)
    }

    fn __repr__(&self) -> String {
        format!("Params({:?})", self.name)
    }

    /// The parameter file's text.
    fn __str__(&self) -> PyResult<String> {
        self.to_toml()
    }

    /// A table (`p.motor`, whose attributes are its keys) or a top-level key
    /// (`p.sample_period_s`).
    fn __getattr__(slf: &Bound<'_, Self>, name: &str) -> PyResult<Py<PyAny>> {
        let py = slf.py();
        let me = slf.borrow();
        if let Ok(e) = me.entry(name) {
            return to_py(py, e.value);
        }
        if me.tables()?.iter().any(|t| t == name) {
            let tables = TABLES.get(py).ok_or_else(|| {
                PyAttributeError::new_err("import geared_servo (not geared_servo._native)")
            })?;
            if let Some(cls) = tables.bind(py).get_item(name)? {
                return Ok(cls.call1((slf,))?.unbind());
            }
        }
        Err(PyAttributeError::new_err(format!(
            "Params has no table or key `{name}` (tables: {}; keys: p.keys())",
            me.tables()?.join(", ")
        )))
    }

    /// Sets a top-level key (`p.sample_period_s = 0.001`); keys in tables are set through
    /// their table (`p.motor.resistance_ohm = 30`).
    fn __setattr__(&mut self, name: &str, value: &Bound<'_, PyAny>) -> PyResult<()> {
        if self.list()?.find(name).is_some() {
            return self.set(name, value);
        }
        Err(PyAttributeError::new_err(format!(
            "cannot set `{name}`: set a key, as `p.motor.resistance_ohm = 30` or `p[\"motor.resistance_ohm\"] = 30`"
        )))
    }

    fn __dir__(&self) -> PyResult<Vec<String>> {
        let mut names = self.tables()?;
        names.extend(
            self.list()?
                .entries()
                .iter()
                .filter(|e| !e.key.contains('.'))
                .map(|e| e.key.clone()),
        );
        names.extend(
            [
                "from_toml",
                "from_string",
                "reference",
                "to_toml",
                "name",
                "keys",
                "to_dict",
                "unit",
                "description",
                "with_backlash_deg",
                "copy",
            ]
            .map(String::from),
        );
        Ok(names)
    }
}

/// `(key, unit, description)` of every key a parameter file can have, in the file's order:
/// both stiffness forms (geometry, then `[stiffness]`). `__init__.py` builds the tables'
/// attributes from it.
#[pyfunction]
pub fn schema() -> PyResult<Vec<(String, &'static str, String)>> {
    let geometry = ParamList::new(&REFERENCE).map_err(py_err)?;
    let d = REFERENCE
        .derived()
        .map_err(|e| py_err(HostError::from(e)))?;
    let mut measured = REFERENCE;
    measured.gears.stiffness = Stiffness::Measured {
        k1_nm_per_rad: d.k1_nm_per_rad,
        k2_nm_per_rad: d.k2_nm_per_rad,
    };
    let measured = ParamList::new(&measured).map_err(py_err)?;
    let mut out: Vec<(String, &'static str, String)> = Vec::new();
    for e in geometry.entries().iter().chain(measured.entries()) {
        if !out.iter().any(|(k, _, _)| *k == e.key) {
            out.push((e.key.clone(), e.unit, e.description.clone()));
        }
    }
    Ok(out)
}

/// Registers the table classes `{name: class}` that `Params.__getattr__` instantiates with
/// the set (`__init__.py` calls it once, at import).
#[pyfunction]
pub fn register_tables(py: Python<'_>, tables: Bound<'_, PyDict>) -> PyResult<()> {
    TABLES
        .set(py, tables.unbind())
        .map_err(|_| PyAttributeError::new_err("the tables are registered already"))
}
