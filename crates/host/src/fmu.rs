//! The FMI 2.0 co-simulation FMU of a parameter set: its variables, `modelDescription.xml`
//! and the `.fmu` archive (`geared-servo fmu`). The shared library inside it is the crate
//! `geared-servo-fmu`, which reads the same variables from the same functions here.
//!
//! Variables, by value reference:
//! - 0: the input [`INPUT`] (`motor_voltage_v`, V), held over each communication step;
//! - 1 …: the outputs, the columns of `simulate` ([`SIMULATE_COLUMNS`]) in their order;
//! - [`FIRST_PARAMETER_VR`] …: the parameters, one per key of the parameter file in the
//!   order of [`ParamList`], named by their key paths (`motor.resistance_ohm`), each with
//!   the value of the file the FMU was built from as its start value.
//!
//! The file itself travels in the archive as `resources/params.toml`; the library reads it
//! at instantiation and builds the same list from it. The GUID is a hash of that file and
//! of this crate's version, so a library and a description that disagree are refused.

use crate::error::HostError;
use crate::param_list::{unit_of, ParamList, Value, DIMENSIONLESS};
use crate::params_file;
use crate::simulate::{COLUMNS, SIMULATE_COLUMNS};
use geared_servo::ActuatorParams;
use std::fmt::Write as _;
use std::path::Path;

/// The `modelIdentifier`: the name of the library in `binaries/linux64/` (without `.so`)
/// and of the crate `geared-servo-fmu`'s library.
pub const MODEL_IDENTIFIER: &str = "geared_servo_fmu";

/// The platform folder of the library in the archive: FMI 2.0's name for Linux x86-64.
pub const PLATFORM: &str = "linux64";

/// The parameter file in the archive's `resources/` folder.
pub const PARAMS_RESOURCE: &str = "params.toml";

/// The input: the motor voltage, V.
pub const INPUT: &str = "motor_voltage_v";

/// Value reference of [`INPUT`].
pub const INPUT_VR: u32 = 0;

/// Value reference of the first output; output `i` of [`SIMULATE_COLUMNS`] is this plus `i`.
pub const FIRST_OUTPUT_VR: u32 = 1;

/// Value reference of the first parameter; entry `i` of the [`ParamList`] is this plus `i`.
pub const FIRST_PARAMETER_VR: u32 = FIRST_OUTPUT_VR + SIMULATE_COLUMNS.len() as u32;

/// SI base-unit exponents (kg, m, s, A, rad) and factor of each unit the variables use, for
/// `<UnitDefinitions>`. A test checks that every unit of the variables is here.
const UNIT_DEFINITIONS: &[(&str, [i8; 5], f64)] = &[
    ("V", [1, 2, -3, -1, 0], 1.0),
    ("A", [0, 0, 0, 1, 0], 1.0),
    ("ohm", [1, 2, -3, -2, 0], 1.0),
    ("V/A", [1, 2, -3, -2, 0], 1.0),
    ("H", [1, 2, -2, -2, 0], 1.0),
    ("N*m/A", [1, 2, -2, -1, 0], 1.0),
    ("V*s/rad", [1, 2, -2, -1, -1], 1.0),
    ("kg*m^2", [1, 2, 0, 0, 0], 1.0),
    ("N*m", [1, 2, -2, 0, 0], 1.0),
    ("N*m/rad", [1, 2, -2, 0, -1], 1.0),
    ("N*m*s/rad", [1, 2, -1, 0, -1], 1.0),
    ("m", [0, 1, 0, 0, 0], 1.0),
    ("Pa", [1, -1, -2, 0, 0], 1.0),
    ("s", [0, 0, 1, 0, 0], 1.0),
    ("rad/s", [0, 0, -1, 0, 1], 1.0),
    ("deg", [0, 0, 0, 0, 1], std::f64::consts::PI / 180.0),
];

/// The text of `resources/params.toml` for `p`: the file written back (every key), with
/// `header` as leading comments.
pub fn params_resource(p: &ActuatorParams, header: &[String]) -> Result<String, HostError> {
    params_file::to_toml(p, header)
}

/// The GUID of an FMU whose `resources/params.toml` is `params_text`.
pub fn guid(params_text: &str) -> String {
    // FNV-1a, twice with different offsets: 128 bits, stable across Rust versions.
    let fnv = |offset: u64| {
        let text = format!("{}\n{params_text}", env!("CARGO_PKG_VERSION"));
        text.bytes().fold(offset, |h, b| {
            (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
        })
    };
    let (a, b) = (fnv(0xcbf2_9ce4_8422_2325), fnv(0x6c62_272e_07bb_0142));
    format!(
        "{{{:08x}-{:04x}-{:04x}-{:04x}-{:012x}}}",
        a >> 32,
        (a >> 16) & 0xffff,
        a & 0xffff,
        b >> 48,
        b & 0xffff_ffff_ffff
    )
}

/// `s` with the five XML special characters escaped.
fn xml(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace('\'', "&apos;")
}

/// `unit="…"` for a unit, nothing for a dimensionless quantity.
fn unit_attr(unit: &str) -> String {
    if unit == DIMENSIONLESS {
        String::new()
    } else {
        format!(" unit=\"{}\"", xml(unit))
    }
}

/// `modelDescription.xml` of the FMU whose `resources/params.toml` is `params_text`.
pub fn model_description(params_text: &str) -> Result<String, HostError> {
    let p = params_file::parse(params_text, PARAMS_RESOURCE)?;
    let list = ParamList::new(&p)?;
    let mut units: Vec<&str> = vec![unit_of(INPUT).unwrap_or(DIMENSIONLESS)];
    units.extend(COLUMNS.iter().map(|c| c.unit));
    units.extend(list.entries().iter().map(|e| e.unit));
    let mut used: Vec<&str> = Vec::new();
    for u in units {
        if u != DIMENSIONLESS && !used.contains(&u) {
            used.push(u);
        }
    }

    let mut s = String::new();
    let w = &mut s;
    // `write!` into a String cannot fail.
    let _ = writeln!(w, r#"<?xml version="1.0" encoding="UTF-8"?>"#);
    let _ = writeln!(
        w,
        r#"<fmiModelDescription fmiVersion="2.0" modelName="geared-servo" guid="{}" description="DC-motor servo with a two-stage gear reducer and backlash: the plant step of the geared-servo firmware crate" generationTool="geared-servo {}" variableNamingConvention="structured" numberOfEventIndicators="0">"#,
        guid(params_text),
        env!("CARGO_PKG_VERSION")
    );
    let _ = writeln!(
        w,
        r#"  <CoSimulation modelIdentifier="{MODEL_IDENTIFIER}" canHandleVariableCommunicationStepSize="true" canInterpolateInputs="false" canNotUseMemoryManagementFunctions="true" canGetAndSetFMUstate="false" canSerializeFMUstate="false"/>"#
    );
    let _ = writeln!(w, "  <UnitDefinitions>");
    for u in &used {
        let (_, exps, factor) = UNIT_DEFINITIONS
            .iter()
            .find(|(n, _, _)| n == u)
            .ok_or_else(|| {
                HostError::other(format!(
                    "unit `{u}` has no SI definition (fmu::UNIT_DEFINITIONS)"
                ))
            })?;
        let mut base = String::new();
        for (name, e) in ["kg", "m", "s", "A", "rad"].iter().zip(exps) {
            if *e != 0 {
                let _ = write!(base, r#" {name}="{e}""#);
            }
        }
        if *factor != 1.0 {
            let _ = write!(base, r#" factor="{factor:e}""#);
        }
        let _ = writeln!(w, r#"    <Unit name="{}"><BaseUnit{base}/></Unit>"#, xml(u));
    }
    let _ = writeln!(w, "  </UnitDefinitions>");
    let _ = writeln!(
        w,
        r#"  <DefaultExperiment startTime="0" stepSize="{:e}"/>"#,
        p.sample_period_s
    );
    let _ = writeln!(w, "  <ModelVariables>");
    let _ = writeln!(
        w,
        r#"    <ScalarVariable name="{INPUT}" valueReference="{INPUT_VR}" description="motor voltage, held over each communication step" causality="input" variability="continuous"><Real{} start="0"/></ScalarVariable>"#,
        unit_attr(unit_of(INPUT).unwrap_or(DIMENSIONLESS))
    );
    for (i, c) in COLUMNS.iter().enumerate() {
        let _ = writeln!(
            w,
            r#"    <ScalarVariable name="{}" valueReference="{}" description="{}" causality="output" variability="continuous" initial="calculated"><Real{}/></ScalarVariable>"#,
            c.name,
            FIRST_OUTPUT_VR + i as u32,
            xml(c.description),
            unit_attr(c.unit)
        );
    }
    for (i, e) in list.entries().iter().enumerate() {
        let value = match e.value {
            Value::Real(x) => format!(r#"<Real{} start="{x:e}"/>"#, unit_attr(e.unit)),
            Value::Bool(b) => format!(r#"<Boolean start="{b}"/>"#),
        };
        let _ = writeln!(
            w,
            r#"    <ScalarVariable name="{}" valueReference="{}" description="{}" causality="parameter" variability="fixed" initial="exact">{value}</ScalarVariable>"#,
            xml(&e.key),
            FIRST_PARAMETER_VR + i as u32,
            xml(&e.description),
        );
    }
    let _ = writeln!(w, "  </ModelVariables>");
    let _ = writeln!(w, "  <ModelStructure>");
    // Indices are 1-based positions in ModelVariables: the input is 1, the outputs follow.
    for section in ["Outputs", "InitialUnknowns"] {
        let _ = writeln!(w, "    <{section}>");
        for i in 0..SIMULATE_COLUMNS.len() {
            let _ = writeln!(w, r#"      <Unknown index="{}"/>"#, i + 2);
        }
        let _ = writeln!(w, "    </{section}>");
    }
    let _ = writeln!(w, "  </ModelStructure>");
    let _ = writeln!(w, "</fmiModelDescription>");
    Ok(s)
}

/// Writes the `.fmu` archive of `p` to `out`: `modelDescription.xml`,
/// `binaries/linux64/geared_servo_fmu.so` (the bytes `library`, the crate
/// `geared-servo-fmu` built for Linux x86-64) and `resources/params.toml` (with `header`).
pub fn write(
    p: &ActuatorParams,
    header: &[String],
    library: &[u8],
    out: &Path,
) -> Result<(), HostError> {
    use std::io::Write;
    use zip::write::SimpleFileOptions;
    let params_text = params_resource(p, header)?;
    let description = model_description(&params_text)?;
    let name = out.display().to_string();
    let file = std::fs::File::create(out)
        .map_err(|e| HostError::other(format!("{name}: cannot create: {e}")))?;
    let mut zip = zip::ZipWriter::new(file);
    let deflated =
        SimpleFileOptions::default().compression_method(zip::CompressionMethod::Deflated);
    let entries: [(String, &[u8], SimpleFileOptions); 3] = [
        (
            "modelDescription.xml".to_string(),
            description.as_bytes(),
            deflated,
        ),
        (
            format!("binaries/{PLATFORM}/{MODEL_IDENTIFIER}.so"),
            library,
            deflated.unix_permissions(0o755),
        ),
        (
            format!("resources/{PARAMS_RESOURCE}"),
            params_text.as_bytes(),
            deflated,
        ),
    ];
    let failed = |e: &dyn std::fmt::Display| HostError::other(format!("{name}: write failed: {e}"));
    for (path, bytes, options) in entries {
        zip.start_file(path, options).map_err(|e| failed(&e))?;
        zip.write_all(bytes).map_err(|e| failed(&e))?;
    }
    zip.finish().map_err(|e| failed(&e))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use geared_servo::REFERENCE;

    fn kord() -> ActuatorParams {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../data/kord-geartrain.toml"
        ))
        .unwrap();
        params_file::parse(&text, "kord").unwrap()
    }

    #[test]
    fn every_unit_of_both_stiffness_forms_has_an_si_definition() {
        for p in [REFERENCE, kord()] {
            let text = params_resource(&p, &[]).unwrap();
            let md = model_description(&text).unwrap();
            assert!(
                md.contains(r#"<Unit name="ohm"><BaseUnit kg="1" m="2" s="-3" A="-2"/></Unit>"#)
            );
        }
    }

    #[test]
    fn description_lists_input_outputs_and_every_key_with_its_start_value() {
        let text = params_resource(&REFERENCE.with_backlash_deg(0.08), &[]).unwrap();
        let md = model_description(&text).unwrap();
        let list = ParamList::new(&REFERENCE).unwrap();
        let vars = md.matches("<ScalarVariable ").count();
        assert_eq!(vars, 1 + SIMULATE_COLUMNS.len() + list.entries().len());
        assert!(md.contains(r#"name="backlash.total_deg" valueReference="#));
        assert!(md.contains(r#"<Real unit="deg" start="8e-2"/>"#), "{md}");
        assert!(md.contains(r#"name="gear_stage_2.revolving""#));
        assert!(md.contains(r#"<Boolean start="true"/>"#));
        assert!(md.contains(&format!(r#"guid="{}""#, guid(&text))));
    }

    #[test]
    fn guid_changes_with_the_file() {
        let a = params_resource(&REFERENCE, &[]).unwrap();
        let b = params_resource(&REFERENCE.with_backlash_deg(0.08), &[]).unwrap();
        assert_ne!(guid(&a), guid(&b));
        assert_eq!(guid(&a), guid(&a.clone()));
        assert_eq!(guid(&a).len(), 38);
    }
}
