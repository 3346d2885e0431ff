//! The fmi2 C functions of a co-simulation FMU (FMI 2.0.4, `fmi2Functions.h`): the only
//! `unsafe` code of the workspace outside the standard library.
//!
//! Each function turns its C arguments into Rust values, calls [`Instance`] inside
//! [`std::panic::catch_unwind`], and turns the result into an `fmi2Status`: an error is
//! `fmi2Error` with its message sent to the importer's logger, a panic is `fmi2Fatal` with
//! its message (it never unwinds into C). The `unsafe` is of three kinds, each commented
//! where it occurs: dereferencing the component pointer this library handed out, reading
//! the arrays and strings the importer passes, and calling the importer's logger.
//!
//! Safety contract of every function (FMI 2.0, section 2.1): `c` is a component returned by
//! [`fmi2Instantiate`] and not yet freed, used by one thread at a time; arrays have the
//! lengths given with them; strings are NUL-terminated. These are the importer's duties.
#![allow(non_snake_case, clippy::missing_safety_doc)]

use crate::instance::{Instance, Mode};
use std::ffi::{c_char, c_int, c_uint, c_void, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::PathBuf;

// The C types of fmi2TypesPlatform.h ("default" platform) and fmi2FunctionTypes.h.
type Fmi2Component = *mut c_void;
type Fmi2ComponentEnvironment = *mut c_void;
type Fmi2FMUstate = *mut c_void;
type Fmi2ValueReference = c_uint;
type Fmi2Real = f64;
type Fmi2Integer = c_int;
/// `fmi2True` is 1, `fmi2False` 0.
type Fmi2Boolean = c_int;
type Fmi2String = *const c_char;
type Fmi2Byte = c_char;
/// `fmi2Status`, an enum: the values below.
type Fmi2Status = c_int;
/// `fmi2StatusKind`, an enum: `fmi2DoStepStatus` 0, `fmi2PendingStatus` 1,
/// `fmi2LastSuccessfulTime` 2, `fmi2Terminated` 3.
type Fmi2StatusKind = c_int;

const FMI2_OK: Fmi2Status = 0;
const FMI2_DISCARD: Fmi2Status = 2;
const FMI2_ERROR: Fmi2Status = 3;
const FMI2_FATAL: Fmi2Status = 4;
/// `fmi2Type`: only co-simulation is offered.
const FMI2_CO_SIMULATION: c_int = 1;
const FMI2_LAST_SUCCESSFUL_TIME: Fmi2StatusKind = 2;
const FMI2_TERMINATED: Fmi2StatusKind = 3;

/// `fmi2CallbackLogger`: C-variadic (the message is a printf format; we pass no arguments
/// and escape `%`).
type Logger = unsafe extern "C" fn(
    Fmi2ComponentEnvironment,
    Fmi2String,
    Fmi2Status,
    Fmi2String,
    Fmi2String,
    ...
);

/// `fmi2CallbackFunctions`: field order and types as in the header.
#[repr(C)]
pub struct CallbackFunctions {
    logger: Option<Logger>,
    // Laid out for C; this library allocates with Rust's allocator and steps synchronously.
    #[allow(dead_code)]
    allocate_memory: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    #[allow(dead_code)]
    free_memory: Option<unsafe extern "C" fn(*mut c_void)>,
    #[allow(dead_code)]
    step_finished: Option<unsafe extern "C" fn(Fmi2ComponentEnvironment, Fmi2Status)>,
    component_environment: Fmi2ComponentEnvironment,
}

/// What an `fmi2Component` points to.
struct Component {
    instance: Instance,
    log: Log,
}

/// The importer's logger and what it needs.
struct Log {
    logger: Option<Logger>,
    env: Fmi2ComponentEnvironment,
    name: CString,
}

impl Log {
    fn send(&self, status: Fmi2Status, message: &str) {
        let Some(logger) = self.logger else { return };
        let category = match status {
            FMI2_FATAL => c"logStatusFatal",
            FMI2_ERROR => c"logStatusError",
            _ => c"logStatusWarning",
        };
        // A printf format without arguments: `%` doubled, NUL (which would cut it) dropped.
        let text = CString::new(message.replace('%', "%%").replace('\0', "")).unwrap_or_default();
        // SAFETY: the importer gave this logger for this environment (fmi2Instantiate); every
        // pointer passed is a valid NUL-terminated string that outlives the call.
        unsafe {
            logger(
                self.env,
                self.name.as_ptr(),
                status,
                category.as_ptr(),
                text.as_ptr(),
            )
        };
    }
}

/// A panic's message.
fn panic_text(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".to_string())
}

/// Runs `f` on the instance behind `c`: `fmi2OK`, or the error or panic logged and its status.
unsafe fn with(
    c: Fmi2Component,
    call: &str,
    f: impl FnOnce(&mut Instance) -> Result<(), String>,
) -> Fmi2Status {
    if c.is_null() {
        return FMI2_ERROR;
    }
    // SAFETY: `c` is a `Box<Component>` from fmi2Instantiate, not freed, used by one thread
    // at a time (the contract in the module's doc).
    let comp = unsafe { &mut *c.cast::<Component>() };
    let Component { instance, log } = comp;
    match catch_unwind(AssertUnwindSafe(|| f(instance))) {
        Ok(Ok(())) => FMI2_OK,
        Ok(Err(message)) => {
            log.send(FMI2_ERROR, &format!("{call}: {message}"));
            FMI2_ERROR
        }
        Err(p) => {
            log.send(
                FMI2_FATAL,
                &format!("{call}: internal error: {}", panic_text(p.as_ref())),
            );
            FMI2_FATAL
        }
    }
}

/// The `n` elements at `ptr` (none when `n` is 0, whatever `ptr`).
unsafe fn slice<'a, T>(ptr: *const T, n: usize) -> Result<&'a [T], String> {
    if n == 0 {
        return Ok(&[]);
    }
    if ptr.is_null() {
        return Err("null array".to_string());
    }
    // SAFETY: non-null, and the importer passes `n` elements (the module's contract).
    Ok(unsafe { std::slice::from_raw_parts(ptr, n) })
}

/// The `n` elements at `ptr`, writable.
unsafe fn slice_mut<'a, T>(ptr: *mut T, n: usize) -> Result<&'a mut [T], String> {
    if n == 0 {
        return Ok(&mut []);
    }
    if ptr.is_null() {
        return Err("null array".to_string());
    }
    // SAFETY: as in `slice`, and the importer's array is not aliased during the call.
    Ok(unsafe { std::slice::from_raw_parts_mut(ptr, n) })
}

/// A C string as UTF-8 (`None` for a null pointer).
unsafe fn text<'a>(s: Fmi2String) -> Option<&'a str> {
    if s.is_null() {
        return None;
    }
    // SAFETY: non-null and NUL-terminated (the module's contract).
    unsafe { CStr::from_ptr(s) }.to_str().ok()
}

/// The folder of a `fmuResourceLocation` URI (`file:///tmp/x/resources`,
/// `file:/tmp/x/resources`, `file://localhost/...`), percent-escapes decoded.
fn resource_folder(uri: &str) -> Result<PathBuf, String> {
    let path = ["file://localhost/", "file:///", "file:/"]
        .iter()
        .find_map(|p| uri.strip_prefix(p))
        .ok_or_else(|| format!("resource location `{uri}` is not a file:// URI"))?;
    let mut bytes = Vec::with_capacity(path.len() + 1);
    bytes.push(b'/');
    let mut it = path.bytes();
    while let Some(b) = it.next() {
        if b == b'%' {
            let hex: Vec<u8> = it.by_ref().take(2).collect();
            let decoded = std::str::from_utf8(&hex)
                .ok()
                .and_then(|h| u8::from_str_radix(h, 16).ok())
                .ok_or_else(|| format!("resource location `{uri}`: bad percent-escape"))?;
            bytes.push(decoded);
        } else {
            bytes.push(b);
        }
    }
    let s =
        String::from_utf8(bytes).map_err(|_| format!("resource location `{uri}` is not UTF-8"))?;
    Ok(PathBuf::from(s))
}

#[no_mangle]
pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    c"default".as_ptr()
}

#[no_mangle]
pub extern "C" fn fmi2GetVersion() -> *const c_char {
    c"2.0".as_ptr()
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetDebugLogging(
    c: Fmi2Component,
    _logging_on: Fmi2Boolean,
    _n_categories: usize,
    _categories: *const Fmi2String,
) -> Fmi2Status {
    // Errors are always logged; there is nothing else to log.
    unsafe { with(c, "fmi2SetDebugLogging", |_| Ok(())) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2Instantiate(
    instance_name: Fmi2String,
    fmu_type: c_int,
    fmu_guid: Fmi2String,
    fmu_resource_location: Fmi2String,
    functions: *const CallbackFunctions,
    _visible: Fmi2Boolean,
    _logging_on: Fmi2Boolean,
) -> Fmi2Component {
    // SAFETY: `functions` is null or points to the importer's callback table.
    let (logger, env) = match unsafe { functions.as_ref() } {
        Some(f) => (f.logger, f.component_environment),
        None => (None, std::ptr::null_mut()),
    };
    // SAFETY: NUL-terminated strings or null (the module's contract).
    let name = unsafe { text(instance_name) }.unwrap_or("geared_servo");
    let log = Log {
        logger,
        env,
        name: CString::new(name.replace('\0', "")).unwrap_or_default(),
    };
    let made = catch_unwind(AssertUnwindSafe(|| {
        if fmu_type != FMI2_CO_SIMULATION {
            return Err("this FMU is for co-simulation only".to_string());
        }
        // SAFETY: as above.
        let guid = unsafe { text(fmu_guid) }.ok_or("no GUID given")?;
        // SAFETY: as above.
        let uri = unsafe { text(fmu_resource_location) }.ok_or("no resource location given")?;
        Instance::new(&resource_folder(uri)?, guid)
    }));
    match made {
        Ok(Ok(instance)) => Box::into_raw(Box::new(Component { instance, log })).cast(),
        Ok(Err(message)) => {
            log.send(FMI2_ERROR, &format!("fmi2Instantiate: {message}"));
            std::ptr::null_mut()
        }
        Err(p) => {
            log.send(
                FMI2_FATAL,
                &format!(
                    "fmi2Instantiate: internal error: {}",
                    panic_text(p.as_ref())
                ),
            );
            std::ptr::null_mut()
        }
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2FreeInstance(c: Fmi2Component) {
    if !c.is_null() {
        // SAFETY: `c` came from `Box::into_raw` in fmi2Instantiate and is freed only here.
        drop(unsafe { Box::from_raw(c.cast::<Component>()) });
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetupExperiment(
    c: Fmi2Component,
    _tolerance_defined: Fmi2Boolean,
    _tolerance: Fmi2Real,
    start_time: Fmi2Real,
    _stop_time_defined: Fmi2Boolean,
    _stop_time: Fmi2Real,
) -> Fmi2Status {
    unsafe { with(c, "fmi2SetupExperiment", |i| i.setup_experiment(start_time)) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2EnterInitializationMode(c: Fmi2Component) -> Fmi2Status {
    unsafe {
        with(
            c,
            "fmi2EnterInitializationMode",
            Instance::enter_initialization,
        )
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2ExitInitializationMode(c: Fmi2Component) -> Fmi2Status {
    unsafe {
        with(
            c,
            "fmi2ExitInitializationMode",
            Instance::exit_initialization,
        )
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2Terminate(c: Fmi2Component) -> Fmi2Status {
    unsafe { with(c, "fmi2Terminate", Instance::terminate) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2Reset(c: Fmi2Component) -> Fmi2Status {
    unsafe {
        with(c, "fmi2Reset", |i| {
            i.reset();
            Ok(())
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetReal(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut Fmi2Real,
) -> Fmi2Status {
    unsafe {
        with(c, "fmi2GetReal", |i| {
            let (vr, value) = (slice(vr, nvr)?, slice_mut(value, nvr)?);
            for (r, v) in vr.iter().zip(value.iter_mut()) {
                *v = i.get_real(*r)?;
            }
            Ok(())
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetReal(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const Fmi2Real,
) -> Fmi2Status {
    unsafe {
        with(c, "fmi2SetReal", |i| {
            for (r, v) in slice(vr, nvr)?.iter().zip(slice(value, nvr)?) {
                i.set_real(*r, *v)?;
            }
            Ok(())
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetBoolean(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut Fmi2Boolean,
) -> Fmi2Status {
    unsafe {
        with(c, "fmi2GetBoolean", |i| {
            let (vr, value) = (slice(vr, nvr)?, slice_mut(value, nvr)?);
            for (r, v) in vr.iter().zip(value.iter_mut()) {
                *v = Fmi2Boolean::from(i.get_bool(*r)?);
            }
            Ok(())
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetBoolean(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const Fmi2Boolean,
) -> Fmi2Status {
    unsafe {
        with(c, "fmi2SetBoolean", |i| {
            for (r, v) in slice(vr, nvr)?.iter().zip(slice(value, nvr)?) {
                i.set_bool(*r, *v != 0)?;
            }
            Ok(())
        })
    }
}

/// The FMU has no variables of this type: only an empty request succeeds.
unsafe fn none_of_type(c: Fmi2Component, call: &str, nvr: usize) -> Fmi2Status {
    unsafe {
        with(c, call, |_| {
            if nvr == 0 {
                Ok(())
            } else {
                Err("this FMU has no variables of this type".to_string())
            }
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetInteger(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    nvr: usize,
    _value: *mut Fmi2Integer,
) -> Fmi2Status {
    unsafe { none_of_type(c, "fmi2GetInteger", nvr) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetInteger(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    nvr: usize,
    _value: *const Fmi2Integer,
) -> Fmi2Status {
    unsafe { none_of_type(c, "fmi2SetInteger", nvr) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetString(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    nvr: usize,
    _value: *mut Fmi2String,
) -> Fmi2Status {
    unsafe { none_of_type(c, "fmi2GetString", nvr) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetString(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    nvr: usize,
    _value: *const Fmi2String,
) -> Fmi2Status {
    unsafe { none_of_type(c, "fmi2SetString", nvr) }
}

/// A capability the model description does not declare.
unsafe fn unsupported(c: Fmi2Component, call: &str) -> Fmi2Status {
    unsafe { with(c, call, |_| Err("not supported by this FMU".to_string())) }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetFMUstate(c: Fmi2Component, _s: *mut Fmi2FMUstate) -> Fmi2Status {
    unsafe { unsupported(c, "fmi2GetFMUstate") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetFMUstate(c: Fmi2Component, _s: Fmi2FMUstate) -> Fmi2Status {
    unsafe { unsupported(c, "fmi2SetFMUstate") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2FreeFMUstate(c: Fmi2Component, _s: *mut Fmi2FMUstate) -> Fmi2Status {
    unsafe { unsupported(c, "fmi2FreeFMUstate") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
    c: Fmi2Component,
    _s: Fmi2FMUstate,
    _size: *mut usize,
) -> Fmi2Status {
    unsafe { unsupported(c, "fmi2SerializedFMUstateSize") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SerializeFMUstate(
    c: Fmi2Component,
    _s: Fmi2FMUstate,
    _bytes: *mut Fmi2Byte,
    _size: usize,
) -> Fmi2Status {
    unsafe { unsupported(c, "fmi2SerializeFMUstate") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
    c: Fmi2Component,
    _bytes: *const Fmi2Byte,
    _size: usize,
    _s: *mut Fmi2FMUstate,
) -> Fmi2Status {
    unsafe { unsupported(c, "fmi2DeSerializeFMUstate") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
    c: Fmi2Component,
    _unknowns: *const Fmi2ValueReference,
    _n_unknowns: usize,
    _knowns: *const Fmi2ValueReference,
    _n_knowns: usize,
    _dv_known: *const Fmi2Real,
    _dv_unknown: *mut Fmi2Real,
) -> Fmi2Status {
    unsafe { unsupported(c, "fmi2GetDirectionalDerivative") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    _nvr: usize,
    _order: *const Fmi2Integer,
    _value: *const Fmi2Real,
) -> Fmi2Status {
    unsafe { unsupported(c, "fmi2SetRealInputDerivatives") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    _nvr: usize,
    _order: *const Fmi2Integer,
    _value: *mut Fmi2Real,
) -> Fmi2Status {
    unsafe { unsupported(c, "fmi2GetRealOutputDerivatives") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2DoStep(
    c: Fmi2Component,
    current_communication_point: Fmi2Real,
    communication_step_size: Fmi2Real,
    _no_set_fmu_state_prior: Fmi2Boolean,
) -> Fmi2Status {
    unsafe {
        with(c, "fmi2DoStep", |i| {
            i.do_step(current_communication_point, communication_step_size)
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2CancelStep(c: Fmi2Component) -> Fmi2Status {
    // fmi2DoStep always completes before it returns: there is nothing to cancel.
    unsafe { unsupported(c, "fmi2CancelStep") }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetStatus(
    _c: Fmi2Component,
    _kind: Fmi2StatusKind,
    _value: *mut Fmi2Status,
) -> Fmi2Status {
    // Only for asynchronous steps (fmi2Pending), which this FMU never returns.
    FMI2_DISCARD
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealStatus(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    value: *mut Fmi2Real,
) -> Fmi2Status {
    if kind != FMI2_LAST_SUCCESSFUL_TIME || value.is_null() {
        return FMI2_DISCARD;
    }
    unsafe {
        with(c, "fmi2GetRealStatus", |i| {
            // SAFETY: checked non-null; the importer passes one writable fmi2Real.
            *value = i.time_s();
            Ok(())
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetIntegerStatus(
    _c: Fmi2Component,
    _kind: Fmi2StatusKind,
    _value: *mut Fmi2Integer,
) -> Fmi2Status {
    FMI2_DISCARD
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetBooleanStatus(
    c: Fmi2Component,
    kind: Fmi2StatusKind,
    value: *mut Fmi2Boolean,
) -> Fmi2Status {
    if kind != FMI2_TERMINATED || value.is_null() {
        return FMI2_DISCARD;
    }
    unsafe {
        with(c, "fmi2GetBooleanStatus", |i| {
            // SAFETY: checked non-null; the importer passes one writable fmi2Boolean.
            *value = Fmi2Boolean::from(i.mode() == Mode::Terminated);
            Ok(())
        })
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetStringStatus(
    _c: Fmi2Component,
    _kind: Fmi2StatusKind,
    _value: *mut Fmi2String,
) -> Fmi2Status {
    FMI2_DISCARD
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resource_uris_become_folders() {
        for uri in [
            "file:///tmp/a%20b/resources",
            "file:/tmp/a%20b/resources",
            "file://localhost/tmp/a%20b/resources",
        ] {
            assert_eq!(
                resource_folder(uri).unwrap(),
                PathBuf::from("/tmp/a b/resources")
            );
        }
        assert!(resource_folder("http://x/resources").is_err());
        assert!(resource_folder("file:///tmp/%zz").is_err());
    }
}
