//! Effects that records of one output often cannot tell apart, and what would separate them.

use geared_servo::Effect;

/// Pairs of effects that records of one output at one amplitude often cannot tell apart,
/// with what would separate them: the one list the search and the report use. When one of
/// a pair is among the candidates refitted, so is the other, so that a tie is reported as a
/// tie, not decided by which of the two the projection happened to rank higher.
pub const KIN: [(Effect, Effect, &str); 10] = [
    (
        Effect::TachGain,
        Effect::MotorViscous,
        "log the armature current (viscous friction draws current, a sensor error does not), or record the load angle with an independent sensor",
    ),
    (
        Effect::TachGain,
        Effect::LoadViscous,
        "log the armature current (viscous friction draws current, a sensor error does not), or record the load angle with an independent sensor",
    ),
    (
        Effect::MotorViscous,
        Effect::LoadViscous,
        "a stepped sine with more periods through the anti-resonance, or a record of the load angle (the two damp different masses)",
    ),
    (
        Effect::MeshDamping,
        Effect::LoadViscous,
        "a stepped sine at two amplitudes through the resonance (mesh damping acts only in contact)",
    ),
    (
        Effect::MeshDamping,
        Effect::MotorViscous,
        "a stepped sine at two amplitudes through the resonance (mesh damping acts only in contact)",
    ),
    (
        Effect::HingeStiffness,
        Effect::GravityTorque,
        "a record with large load angles, or one that starts away from the hanging position (a spring is linear in the angle, gravity goes as its sine)",
    ),
    (
        Effect::InputDelay,
        Effect::TachLag,
        "a stepped sine well above 1/(2π τ) (a lag's phase stops at 90°, a delay's grows without bound), or a record of the load angle (a tachometer lag does not delay it)",
    ),
    (
        Effect::InputDelay,
        Effect::VoltageLimit,
        "records at two amplitudes (saturation depends on the amplitude, a delay or a gain error does not)",
    ),
    (
        Effect::VoltageLimit,
        Effect::TachGain,
        "records at two amplitudes (saturation depends on the amplitude, a delay or a gain error does not)",
    ),
    (
        Effect::StictionRatio,
        Effect::DriveDeadband,
        "log the armature current (a dead band cuts it off around zero voltage, stiction does not), or a slow voltage ramp through zero (the dead band holds the motor at the voltage's reversal, stiction at the speed's)",
    ),
];

/// The effects paired with `e` in [`KIN`].
pub fn kin(e: Effect) -> Vec<Effect> {
    KIN.iter()
        .filter_map(|&(a, b, _)| {
            if a == e {
                Some(b)
            } else if b == e {
                Some(a)
            } else {
                None
            }
        })
        .collect()
}

/// What would separate `a` from `b` when a record cannot ([`KIN`], or a general advice).
pub fn separating_measurement(a: Effect, b: Effect, output: &str) -> String {
    let found = KIN
        .iter()
        .find(|&&(x, y, _)| (a == x && b == y) || (a == y && b == x))
        .map(|&(_, _, m)| m.to_string());
    match found {
        // A record of the current already has it: the rest of the advice holds.
        Some(m) if output == "current_a" => m
            .replace("log the armature current (viscous friction draws current, a sensor error does not), or ", ""),
        Some(m) => m,
        None => "records at two amplitudes and of other outputs (current, load angle)".to_string(),
    }
}
