//! Calibration starts from what the record says: the notch and peak of its own frequency
//! response (MODEL.md, "Calibrating against measured data").

use geared_servo::REFERENCE;
use geared_servo_host::calibrate::{self, frf_notch_peak, Param};
use geared_servo_host_tests::scenario::{perturbed, record};

#[test]
fn the_records_frequency_response_gives_the_notch_and_the_peak() {
    let truth = perturbed();
    let d = truth.derived().unwrap();
    let (rec, _) = record(&truth, false);
    let (f_ar, f_r) = frf_notch_peak(&rec).unwrap();
    eprintln!(
        "notch {f_ar:.1} Hz (closed form {:.1}), peak {f_r:.1} Hz (closed form {:.1})",
        d.f_ar_hz, d.f_r_hz
    );
    // The multisine has 40 log-spaced lines from 2 to 300 Hz (13.7 % apart): the estimate can
    // be off by up to half that spacing, plus the shift friction causes; 12 % allows both.
    assert!((f_ar / d.f_ar_hz - 1.0).abs() < 0.12, "{f_ar}");
    assert!((f_r / d.f_r_hz - 1.0).abs() < 0.12, "{f_r}");
}

#[test]
fn a_stiffness_off_by_a_factor_four_is_recovered() {
    // Beyond the coarse search's reach from the file alone (±0.7 in log per pass).
    let mut truth = perturbed();
    let k = calibrate::get(&truth, Param::StiffnessKeq);
    calibrate::set(&mut truth, Param::StiffnessKeq, 4.0 * k);
    let (rec, floor) = record(&truth, false);
    let p0 = calibrate::with_measured_stiffness(&REFERENCE).unwrap();
    let knobs = calibrate::default_knobs(&p0, rec.max_abs_v());
    let fit = calibrate::calibrate(&p0, &knobs, std::slice::from_ref(&rec));
    let k_fit = calibrate::get(&fit.params, Param::StiffnessKeq);
    eprintln!(
        "k {k_fit} (true {}), nrmse {} floor {floor}",
        4.0 * k,
        fit.cost.sqrt()
    );
    assert!((k_fit / (4.0 * k) - 1.0).abs() < 0.02);
    assert!(fit.cost.sqrt() < 1.05 * floor);
}
