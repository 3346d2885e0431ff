//! One FMU instance in safe Rust: its parameters, the plant, its state and the FMI 2.0
//! co-simulation state machine. The C functions of `src/ffi.rs` only translate to and from
//! these calls; every error is a message for the importer's logger.

use geared_servo::{Plant, PlantState};
use geared_servo_host::fmu::{
    guid, FIRST_OUTPUT_VR, FIRST_PARAMETER_VR, INPUT, INPUT_VR, PARAMS_RESOURCE,
};
use geared_servo_host::param_list::{ParamList, Value};
use geared_servo_host::params_file;
use geared_servo_host::simulate::{row, SIMULATE_COLUMNS};
use std::path::Path;

/// An error for the importer: the message the logger receives with `fmi2Error`.
pub type Error = String;

/// Where an instance is in FMI 2.0's co-simulation state machine.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// After `fmi2Instantiate` or `fmi2Reset`: parameters may be set.
    Instantiated,
    /// Between `fmi2EnterInitializationMode` and `fmi2ExitInitializationMode`.
    Initialization,
    /// After `fmi2ExitInitializationMode`: `fmi2DoStep` advances the plant.
    Stepping,
    /// After `fmi2Terminate`.
    Terminated,
}

/// What a value reference designates.
enum Variable {
    Input,
    Output(usize),
    Parameter(usize),
}

/// An FMU instance (see the module's doc).
pub struct Instance {
    defaults: ParamList,
    params: ParamList,
    plant: Option<Plant>,
    state: PlantState,
    outputs: [f64; SIMULATE_COLUMNS.len()],
    input_v: f64,
    sample_period_s: f64,
    time_s: f64,
    mode: Mode,
}

/// What the parameters are called in messages (the prefix a parameter file's name takes).
const PARAMETERS: &str = "FMU parameters";

impl Instance {
    /// The instance of the FMU whose `resources` folder is `resources`, instantiated with the
    /// GUID `given_guid` from its `modelDescription.xml`.
    pub fn new(resources: &Path, given_guid: &str) -> Result<Instance, Error> {
        let path = resources.join(PARAMS_RESOURCE);
        let name = path.display().to_string();
        let text = std::fs::read_to_string(&path)
            .map_err(|e| format!("{name}: cannot read the FMU's parameter file: {e}"))?;
        let own = guid(&text);
        if given_guid != own {
            return Err(format!(
                "GUID {given_guid} does not match this library and {name} ({own}): rebuild the FMU with `geared-servo fmu`"
            ));
        }
        let p = params_file::parse(&text, &name).map_err(|e| e.message)?;
        let list = ParamList::new(&p).map_err(|e| e.message)?;
        Ok(Instance {
            defaults: list.clone(),
            params: list,
            plant: None,
            state: PlantState::REST,
            outputs: [0.0; SIMULATE_COLUMNS.len()],
            input_v: 0.0,
            sample_period_s: p.sample_period_s,
            time_s: 0.0,
            mode: Mode::Instantiated,
        })
    }

    /// The current mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// Simulated time of the last communication point, s.
    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    fn variable(&self, vr: u32) -> Result<Variable, Error> {
        let n_out = SIMULATE_COLUMNS.len();
        if vr == INPUT_VR {
            return Ok(Variable::Input);
        }
        if let Some(i) = vr.checked_sub(FIRST_OUTPUT_VR).map(|i| i as usize) {
            if i < n_out {
                return Ok(Variable::Output(i));
            }
        }
        if let Some(i) = vr.checked_sub(FIRST_PARAMETER_VR).map(|i| i as usize) {
            if i < self.params.entries().len() {
                return Ok(Variable::Parameter(i));
            }
        }
        Err(format!("no variable has value reference {vr}"))
    }

    /// `fmi2SetupExperiment`: the start time, s.
    pub fn setup_experiment(&mut self, start_time_s: f64) -> Result<(), Error> {
        self.expect(Mode::Instantiated, "fmi2SetupExperiment")?;
        if !start_time_s.is_finite() {
            return Err(format!("start time {start_time_s} is not finite"));
        }
        self.time_s = start_time_s;
        Ok(())
    }

    /// `fmi2EnterInitializationMode`.
    pub fn enter_initialization(&mut self) -> Result<(), Error> {
        self.expect(Mode::Instantiated, "fmi2EnterInitializationMode")?;
        self.mode = Mode::Initialization;
        Ok(())
    }

    /// `fmi2ExitInitializationMode`: validates the parameters (with the parameter file's
    /// messages) and builds the plant, at rest.
    pub fn exit_initialization(&mut self) -> Result<(), Error> {
        self.expect(Mode::Initialization, "fmi2ExitInitializationMode")?;
        let plant = self.build()?;
        self.state = PlantState::REST;
        self.outputs = row(&plant.outputs(&self.state));
        self.plant = Some(plant);
        self.mode = Mode::Stepping;
        Ok(())
    }

    /// The plant of the current parameter values; records their sample period.
    fn build(&mut self) -> Result<Plant, Error> {
        let p = self.params.to_params(PARAMETERS).map_err(|e| e.message)?;
        self.sample_period_s = p.sample_period_s;
        Plant::new(&p).map_err(|e| format!("{PARAMETERS}: {e}"))
    }

    /// `fmi2Terminate`.
    pub fn terminate(&mut self) -> Result<(), Error> {
        self.expect(Mode::Stepping, "fmi2Terminate")?;
        self.mode = Mode::Terminated;
        Ok(())
    }

    /// `fmi2Reset`: back to the state after instantiation, parameters at their start values.
    pub fn reset(&mut self) {
        self.params = self.defaults.clone();
        self.plant = None;
        self.state = PlantState::REST;
        self.outputs = [0.0; SIMULATE_COLUMNS.len()];
        self.input_v = 0.0;
        self.time_s = 0.0;
        self.mode = Mode::Instantiated;
    }

    fn expect(&self, mode: Mode, call: &str) -> Result<(), Error> {
        if self.mode == mode {
            Ok(())
        } else {
            Err(format!(
                "{call} is not allowed in mode {:?} (expected {mode:?})",
                self.mode
            ))
        }
    }

    /// `fmi2GetReal` of one variable. Outputs before the plant exists (initialization mode)
    /// are those of the plant at rest with the current parameters.
    pub fn get_real(&mut self, vr: u32) -> Result<f64, Error> {
        match self.variable(vr)? {
            Variable::Input => Ok(self.input_v),
            Variable::Output(i) => {
                if self.plant.is_none() {
                    let plant = self.build()?;
                    self.outputs = row(&plant.outputs(&PlantState::REST));
                }
                self.outputs
                    .get(i)
                    .copied()
                    .ok_or_else(|| format!("no output {i}"))
            }
            Variable::Parameter(i) => match self.params.entries().get(i).map(|e| e.value) {
                Some(Value::Real(x)) => Ok(x),
                _ => Err(self.not_of_type(vr, "Real")),
            },
        }
    }

    /// `fmi2SetReal` of one variable: the input at any time before termination, a parameter
    /// before the end of initialization.
    pub fn set_real(&mut self, vr: u32, value: f64) -> Result<(), Error> {
        match self.variable(vr)? {
            Variable::Input => {
                if self.mode == Mode::Terminated {
                    return Err(format!("`{INPUT}` cannot be set after fmi2Terminate"));
                }
                // A NaN voltage would poison the state for good; the importer hears of it.
                if !value.is_finite() {
                    return Err(format!("`{INPUT}` = {value} is not a finite voltage"));
                }
                self.input_v = value;
                Ok(())
            }
            Variable::Output(i) => Err(format!(
                "`{}` is an output and cannot be set",
                SIMULATE_COLUMNS.get(i).unwrap_or(&"?")
            )),
            Variable::Parameter(i) => self.set_parameter(i, Value::Real(value)),
        }
    }

    /// `fmi2GetBoolean` of one variable (the flag parameters).
    pub fn get_bool(&self, vr: u32) -> Result<bool, Error> {
        match self.variable(vr)? {
            Variable::Parameter(i) => match self.params.entries().get(i).map(|e| e.value) {
                Some(Value::Bool(b)) => Ok(b),
                _ => Err(self.not_of_type(vr, "Boolean")),
            },
            _ => Err(self.not_of_type(vr, "Boolean")),
        }
    }

    /// `fmi2SetBoolean` of one variable (the flag parameters).
    pub fn set_bool(&mut self, vr: u32, value: bool) -> Result<(), Error> {
        match self.variable(vr)? {
            Variable::Parameter(i) => self.set_parameter(i, Value::Bool(value)),
            _ => Err(self.not_of_type(vr, "Boolean")),
        }
    }

    fn set_parameter(&mut self, i: usize, value: Value) -> Result<(), Error> {
        if !matches!(self.mode, Mode::Instantiated | Mode::Initialization) {
            let key = self.params.entries().get(i).map(|e| e.key.as_str());
            return Err(format!(
                "parameter `{}` is fixed: set it before fmi2ExitInitializationMode",
                key.unwrap_or("?")
            ));
        }
        self.plant = None;
        self.params.set(i, value).map_err(|e| e.message)
    }

    fn not_of_type(&self, vr: u32, ty: &str) -> Error {
        let name = match self.variable(vr) {
            Ok(Variable::Input) => INPUT.to_string(),
            Ok(Variable::Output(i)) => SIMULATE_COLUMNS.get(i).unwrap_or(&"?").to_string(),
            Ok(Variable::Parameter(i)) => self
                .params
                .entries()
                .get(i)
                .map(|e| e.key.clone())
                .unwrap_or_default(),
            Err(e) => return e,
        };
        format!("variable `{name}` (value reference {vr}) is not of {ty} type")
    }

    /// `fmi2DoStep`: the plant's `step()` once per sample period from `t_s` to `t_s + h_s`,
    /// the input held. `h_s` must be a whole number of sample periods.
    pub fn do_step(&mut self, t_s: f64, h_s: f64) -> Result<(), Error> {
        self.expect(Mode::Stepping, "fmi2DoStep")?;
        let dt = self.sample_period_s;
        let n = (h_s / dt).round();
        // Within rounding of the importer's time arithmetic; one period at least.
        if !(h_s.is_finite() && n >= 1.0 && (h_s - n * dt).abs() <= 1e-9 * h_s) {
            return Err(format!(
                "communication step {h_s} s is not a whole number of sample periods ({dt} s, parameter `sample_period_s`)"
            ));
        }
        let plant = self
            .plant
            .as_ref()
            .ok_or_else(|| "no plant: initialization did not complete".to_string())?;
        let v = self.input_v as f32;
        let mut o = plant.outputs(&self.state);
        for _ in 0..n as u64 {
            o = plant.step(&mut self.state, v);
        }
        self.outputs = row(&o);
        self.time_s = t_s + h_s;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use geared_servo::REFERENCE;
    use geared_servo_host::fmu::params_resource;
    use geared_servo_host::simulate::simulate_columns;

    /// An instance of an FMU of `p`, its resources in a fresh temporary folder.
    fn instance(p: &geared_servo::ActuatorParams, tag: &str) -> Instance {
        let dir = std::env::temp_dir().join(format!("gs-fmu-{}-{tag}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let text = params_resource(p, &[]).unwrap();
        std::fs::write(dir.join(PARAMS_RESOURCE), &text).unwrap();
        Instance::new(&dir, &guid(&text)).unwrap()
    }

    fn vr(key: &str, inst: &Instance) -> u32 {
        FIRST_PARAMETER_VR + inst.params.find(key).unwrap() as u32
    }

    #[test]
    fn steps_are_the_simulate_steps_exactly() {
        let p = REFERENCE.with_backlash_deg(0.08);
        let mut inst = instance(&p, "exact");
        inst.setup_experiment(0.0).unwrap();
        inst.enter_initialization().unwrap();
        inst.exit_initialization().unwrap();
        let volts: Vec<f64> = (0..400)
            .map(|k| if k % 100 < 50 { 10.0 } else { -10.0 })
            .collect();
        let cols = simulate_columns(&p, p.sample_period_s, &volts).unwrap();
        for (k, &v) in volts.iter().enumerate() {
            for (i, c) in cols.iter().enumerate() {
                assert_eq!(inst.get_real(FIRST_OUTPUT_VR + i as u32).unwrap(), c[k]);
            }
            inst.set_real(INPUT_VR, v).unwrap();
            inst.do_step(k as f64 * p.sample_period_s, p.sample_period_s)
                .unwrap();
        }
    }

    #[test]
    fn a_long_step_is_whole_sample_periods_and_nothing_else() {
        let p = REFERENCE;
        let mut inst = instance(&p, "long");
        inst.enter_initialization().unwrap();
        inst.exit_initialization().unwrap();
        inst.set_real(INPUT_VR, 10.0).unwrap();
        inst.do_step(0.0, 4.0 * p.sample_period_s).unwrap();
        let cols = simulate_columns(&p, p.sample_period_s, &[10.0; 5]).unwrap();
        assert_eq!(inst.get_real(FIRST_OUTPUT_VR).unwrap(), cols[0][4]);
        let e = inst.do_step(0.002, 1.5 * p.sample_period_s).unwrap_err();
        assert!(
            e.starts_with("communication step 0.00075 s is not a whole number"),
            "{e}"
        );
    }

    #[test]
    fn bad_parameters_are_refused_at_initialization_with_the_key() {
        let mut inst = instance(&REFERENCE, "bad");
        let j = vr("load.inertia_kg_m2", &inst);
        inst.set_real(j, -1.0).unwrap();
        inst.enter_initialization().unwrap();
        assert_eq!(
            inst.exit_initialization().unwrap_err(),
            "FMU parameters: key `load.inertia_kg_m2` must be greater than zero"
        );
        inst.set_real(j, f64::NAN).unwrap();
        assert_eq!(
            inst.exit_initialization().unwrap_err(),
            "FMU parameters: key `load.inertia_kg_m2` must be a finite number"
        );
        inst.set_real(j, 2e-3).unwrap();
        inst.exit_initialization().unwrap();
        let e = inst.set_real(j, 1e-3).unwrap_err();
        assert!(e.contains("is fixed"), "{e}");
        inst.reset();
        assert_eq!(inst.get_real(j).unwrap(), 1e-3);
    }

    #[test]
    fn the_flag_is_a_boolean_and_the_numbers_are_reals() {
        let mut inst = instance(&REFERENCE, "types");
        let r = vr("gear_stage_2.revolving", &inst);
        assert!(inst.get_bool(r).unwrap());
        assert!(inst.get_real(r).is_err());
        inst.set_bool(r, false).unwrap();
        assert!(inst.set_real(r, 1.0).is_err());
        assert!(inst.get_bool(FIRST_OUTPUT_VR).is_err());
        assert!(inst
            .get_real(10_000)
            .unwrap_err()
            .contains("value reference 10000"));
    }

    #[test]
    fn a_guid_from_another_file_is_refused() {
        let dir = std::env::temp_dir().join(format!("gs-fmu-{}-guid", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let text = params_resource(&REFERENCE, &[]).unwrap();
        std::fs::write(dir.join(PARAMS_RESOURCE), &text).unwrap();
        let other = guid(&params_resource(&REFERENCE.with_backlash_deg(1.0), &[]).unwrap());
        let e = Instance::new(&dir, &other).err().unwrap();
        assert!(e.contains("does not match"), "{e}");
    }
}
