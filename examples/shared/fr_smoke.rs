//! The computation shared by the `fr_smoke` example (host and Cortex-M4F) and the host test
//! that compares both with `examples/expected/fr_smoke.txt` and with the host sweep.

use geared_servo::analyser::{self, Hold, SweepSettings};
use geared_servo::{describing, Plant, SineDrive, REFERENCE};

/// (backlash in deg, frequency in Hz) of the points measured at 10 V_pk. With backlash only
/// frequencies whose motion is not chaotic (MODEL.md, "Gear rattle"): host and target must
/// agree bit for bit.
pub const POINTS: [(f64, f64); 5] = [
    (0.0, 100.0),
    (0.0, 200.0),
    (0.08, 20.0),
    (0.08, 100.0),
    (0.08, 150.0),
];

/// Voltage amplitude, V.
pub const VPK: f64 = 10.0;

/// Measures every point of [`POINTS`] with the default sweep settings and a continuous sine,
/// from the describing-function warm start, and reports: backlash (deg), frequency (Hz), gain
/// (dB), phase (deg), settled, samples, then the `V_t/V_m` phasor's real and imaginary parts
/// (shortest exact representation). Returns false if anything cannot be built.
pub fn run(line: &mut dyn FnMut(core::fmt::Arguments)) -> bool {
    for (b, f) in POINTS {
        let p = REFERENCE.with_backlash_deg(b);
        let (Ok(plant), Ok(drive), Ok(an), Ok(warm)) = (
            Plant::new(&p),
            SineDrive::new(&p, f),
            analyser::for_sweep(f, p.sample_period_s, &SweepSettings::DEFAULT),
            describing::warm_start_model(&p, VPK),
        ) else {
            return false;
        };
        let m = analyser::measure(
            &plant,
            &drive,
            &an,
            VPK,
            Hold::Continuous,
            warm.steady_state(f, VPK),
        );
        let [t, _] = m.channels;
        line(format_args!(
            "{} {} {:.6} {:.4} {} {} {} {}",
            b,
            f,
            t.gain_db(),
            t.phase_deg(),
            u8::from(m.settled),
            m.samples,
            t.phasor.re,
            t.phasor.im
        ));
    }
    true
}
