//! The command line's arguments (clap): every command and option, in one place. The
//! commands themselves live in their own modules and take these as input.

use clap::{Args, Parser, Subcommand, ValueEnum};
use geared_servo::analyser::Hold;
use geared_servo_host::error::HostError;
use geared_servo_host::fr::SweepOptions;
use geared_servo_host::synth::Excitation;
use std::path::PathBuf;

/// Emulator of a DC-motor servo with a two-stage gear reducer and backlash.
#[derive(Parser, Debug)]
#[command(name = "geared-servo", version, about, long_about = None)]
pub struct Cli {
    /// Parameter file (TOML); default: the bundled reference actuator.
    #[arg(long, global = true, value_name = "FILE")]
    pub params: Option<PathBuf>,
    /// Print one JSON object on stdout and nothing else there.
    #[arg(long, global = true)]
    pub json: bool,
    /// The command.
    #[command(subcommand)]
    pub command: Command,
}

/// The commands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Derived quantities of a parameter set (closed form, no backlash).
    Info,
    /// Time-domain run on a voltage record, from rest.
    Simulate {
        /// Input CSV with `time_s` and `motor_voltage_v`.
        #[arg(long, value_name = "IN.csv")]
        input: PathBuf,
        /// Output CSV.
        #[arg(long, value_name = "OUT.csv")]
        output: PathBuf,
        /// Override the total backlash, degrees.
        #[arg(long, value_name = "B")]
        backlash_deg: Option<f64>,
        /// Fault scenario (TOML, see docs/faults.md).
        #[arg(long, value_name = "FAULTS.toml")]
        scenario: Option<PathBuf>,
    },
    /// Stepped-sine frequency response of V_t/V_m, simulated.
    Bode {
        /// Voltage amplitude, V.
        #[arg(long, value_name = "V")]
        vpk: f64,
        /// Override the total backlash, degrees.
        #[arg(long, value_name = "B")]
        backlash_deg: Option<f64>,
        /// First frequency, Hz.
        #[arg(long, default_value_t = 10.0)]
        from: f64,
        /// Last frequency, Hz.
        #[arg(long, default_value_t = 300.0)]
        to: f64,
        /// Frequency step, Hz.
        #[arg(long, default_value_t = 1.0)]
        step: f64,
        /// Write `freq_hz,gain_db,phase_deg` (+ spread, settled) to this CSV file.
        #[arg(long, value_name = "OUT")]
        csv: Option<PathBuf>,
        /// Measurement options.
        #[command(flatten)]
        measure: MeasureArgs,
    },
    /// Anti-resonance and resonance located on the simulated response (refined).
    Resonances {
        /// Voltage amplitude, V.
        #[arg(long, value_name = "V")]
        vpk: f64,
        /// Override the total backlash, degrees.
        #[arg(long, value_name = "B")]
        backlash_deg: Option<f64>,
        /// Measurement options.
        #[command(flatten)]
        measure: MeasureArgs,
    },
    /// Largest total backlash whose simulated f_AR is still >= the bandwidth.
    MaxBacklash {
        /// Required bandwidth (anti-resonance), Hz.
        #[arg(long, value_name = "F")]
        bandwidth_hz: f64,
        /// Voltage amplitude, V.
        #[arg(long, value_name = "V")]
        vpk: f64,
        /// Measurement options.
        #[command(flatten)]
        measure: MeasureArgs,
    },
    /// Smallest voltage amplitude whose simulated f_AR is >= the bandwidth.
    MinVoltage {
        /// Required bandwidth (anti-resonance), Hz.
        #[arg(long, value_name = "F")]
        bandwidth_hz: f64,
        /// Total backlash, degrees.
        #[arg(long, value_name = "B")]
        backlash_deg: f64,
        /// Measurement options.
        #[command(flatten)]
        measure: MeasureArgs,
    },
    /// Regenerates the paper's Fig. 3-6 (CSV + SVG) in DIR and prints the design points.
    Paper {
        /// Output directory (created if missing).
        #[arg(long, value_name = "DIR")]
        out: PathBuf,
        /// Bandwidth whose contour Fig. 6 draws and the design points use, Hz.
        #[arg(long, default_value_t = 100.0, value_name = "F")]
        bandwidth_hz: f64,
    },
    /// Synthetic measured data: excitation, extra effects, tachometer noise, seed.
    Synth(SynthArgs),
    /// Calibrate, analyse the residual, trace it to a missing effect, report before/after.
    Diagnose(DiagnoseArgs),
    /// FMI 2.0 co-simulation FMU (Linux x86-64) of the parameter file: input motor voltage,
    /// the outputs of `simulate`, every key of the file as a parameter.
    Fmu {
        /// Output archive.
        #[arg(long, value_name = "OUT.fmu")]
        out: PathBuf,
        /// The FMU library (default: libgeared_servo_fmu.so beside this executable, built by
        /// `cargo build --release -p geared-servo-fmu`).
        #[arg(long, value_name = "LIB.so")]
        library: Option<PathBuf>,
    },
    /// A parameter file from a gear motor's data sheet (figures at the output shaft); what
    /// a data sheet does not give is marked GUESS for `diagnose` to calibrate.
    Init(InitArgs),
}

/// How the sine reaches the winding (`--hold`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum, Default)]
pub enum HoldArg {
    /// Continuous sine within each step, output sampled every step (the paper's Simulink).
    #[default]
    Continuous,
    /// Sine sampled and held for each step (what firmware applies); its notch sits ~1 Hz
    /// higher for the reference actuator (the held system's aliasing).
    Zoh,
}

/// Measurement options shared by the frequency-response commands.
#[derive(Args, Debug, Clone)]
pub struct MeasureArgs {
    /// Sine input: continuous (paper) or zero-order hold (firmware).
    #[arg(long, value_enum, default_value_t = HoldArg::Continuous)]
    pub hold: HoldArg,
    /// Longest simulated time per frequency when the response does not settle, s.
    #[arg(long, default_value_t = 1.0, value_name = "S")]
    pub max_time_s: f64,
    /// Start every frequency from rest instead of the linearised steady state (slower to
    /// settle; with backlash it may land on another branch of the response).
    #[arg(long)]
    pub cold_start: bool,
}

impl MeasureArgs {
    /// The sweep options for amplitude `vpk` (V).
    pub fn options(&self, vpk: f64) -> Result<SweepOptions, HostError> {
        let hold = match self.hold {
            HoldArg::Continuous => Hold::Continuous,
            HoldArg::Zoh => Hold::Zoh,
        };
        geared_servo_host::fr_report::sweep_options(vpk, hold, self.max_time_s, self.cold_start)
    }
}

/// Arguments of `geared-servo synth`.
#[derive(clap::Args, Debug, Clone)]
pub struct SynthArgs {
    /// Output CSV (measured-data format).
    #[arg(long, value_name = "OUT.csv")]
    pub output: std::path::PathBuf,
    /// Excitation waveform.
    #[arg(long, default_value = "multisine", value_parser = excitation_parser())]
    pub excitation: Excitation,
    /// Peak voltage, V.
    #[arg(long, default_value_t = 10.0)]
    pub amplitude: f64,
    /// Lowest frequency (square-wave frequency), Hz.
    #[arg(long, default_value_t = 2.0)]
    pub f_min: f64,
    /// Highest frequency (PRBS clock), Hz.
    #[arg(long, default_value_t = 300.0)]
    pub f_max: f64,
    /// Frequencies of the stepped sine / lines of the multisine.
    #[arg(long, default_value_t = 40)]
    pub steps: usize,
    /// Record length, s.
    #[arg(long, default_value_t = 4.0)]
    pub duration: f64,
    /// Sample period, s (default: the parameter file's).
    #[arg(long)]
    pub sample_period: Option<f64>,
    /// An effect present in the data, NAME=VALUE (repeatable).
    #[arg(long = "effect", value_name = "NAME=VALUE")]
    pub effects: Vec<String>,
    /// Standard deviation of the tachometer noise, V.
    #[arg(long, default_value_t = 0.0)]
    pub noise: f64,
    /// Seed of the random generator.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

/// Arguments of `geared-servo diagnose`.
#[derive(clap::Args, Debug, Clone)]
pub struct DiagnoseArgs {
    /// Measured record (CSV); repeat for several records fitted together.
    #[arg(long, value_name = "MEAS.csv", required = true)]
    pub data: Vec<std::path::PathBuf>,
    /// Validation record, not fitted: an effect must also lower its error.
    #[arg(long, value_name = "VAL.csv")]
    pub validate: Option<std::path::PathBuf>,
    /// Directory for plots and the calibrated parameter file.
    #[arg(long, value_name = "DIR")]
    pub out: Option<std::path::PathBuf>,
    /// Candidate effects (comma-separated; default: all).
    #[arg(long, value_delimiter = ',')]
    pub candidates: Option<Vec<String>>,
    /// Most effects added.
    #[arg(long, default_value_t = 3)]
    pub max_steps: usize,
    /// Parameters to calibrate instead of the default set (comma-separated key paths, e.g.
    /// `motor.inertia_kg_m2,load.inertia_kg_m2,motor.resistance_ohm`).
    #[arg(long, value_delimiter = ',')]
    pub fit: Option<Vec<String>>,
    /// Also bound each effect not added (comma-separated; alone: every candidate): the largest
    /// value the records do not rule out, every other parameter refitted at each value (a
    /// profile per effect: minutes on long records).
    #[arg(long, value_delimiter = ',', num_args = 0.., value_name = "EFFECTS")]
    pub limits: Option<Vec<String>>,
}

/// Arguments of `geared-servo init` (docs/datasheet.md). Figures of the gear motor at its
/// output shaft, on the supply voltage.
#[derive(clap::Args, Debug, Clone)]
pub struct InitArgs {
    /// Parameter file to write (TOML).
    #[arg(long, value_name = "RIG.toml")]
    pub output: std::path::PathBuf,
    /// Supply voltage the figures are given at, V.
    #[arg(long, value_name = "V", allow_negative_numbers = true)]
    pub supply_v: f64,
    /// No-load speed at the output shaft, rpm.
    #[arg(long, value_name = "RPM", allow_negative_numbers = true)]
    pub no_load_rpm: f64,
    /// Stall torque at the output shaft, N*m (this, the stall current, or both).
    #[arg(long, value_name = "N*m", allow_negative_numbers = true)]
    pub stall_torque_nm: Option<f64>,
    /// Stall current, A.
    #[arg(long, value_name = "A", allow_negative_numbers = true)]
    pub stall_current_a: Option<f64>,
    /// No-load current, A (sets the motor's friction; a guess otherwise).
    #[arg(long, value_name = "A", allow_negative_numbers = true)]
    pub no_load_current_a: Option<f64>,
    /// Gear ratio (motor turns per output turn).
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    pub gear_ratio: f64,
    /// Load inertia at the output shaft, kg*m^2 (a rough figure does).
    #[arg(long, value_name = "KG_M2", allow_negative_numbers = true)]
    pub load_inertia: f64,
    /// Rotor inertia, kg*m^2 (a guess otherwise).
    #[arg(long, value_name = "KG_M2", allow_negative_numbers = true)]
    pub motor_inertia: Option<f64>,
    /// Armature inductance, H (a guess otherwise).
    #[arg(long, value_name = "H", allow_negative_numbers = true)]
    pub inductance_h: Option<f64>,
    /// Emulator step, s.
    #[arg(long, default_value_t = 0.0005, allow_negative_numbers = true)]
    pub sample_period: f64,
}

/// `--excitation` takes the names the host library defines, listed in `--help`.
fn excitation_parser() -> impl clap::builder::TypedValueParser<Value = Excitation> {
    use clap::builder::TypedValueParser;
    clap::builder::PossibleValuesParser::new(Excitation::ALL.map(Excitation::name))
        .try_map(|s| s.parse::<Excitation>())
}
