//! Fin position loop at 2 kHz on the virtual actuator, driven only through `embedded_hal`
//! traits and read only through the emulated sensors: a 5° step then a 20 Hz sine. Prints rise
//! time, overshoot, steady-state and tracking error (compared with
//! `examples/expected/fin_loop.txt`) and, on the target only, `cost:` lines: instructions per
//! `step()` (SysTick under QEMU `-icount shift=0`, 40 instructions a tick) and RAM sizes.
//! Then the same controller meets a fault scenario (tachometer dropout, gust, jam) and the
//! tracking error and current per window are printed (`examples/expected/fin_faults.txt`).
//! Exits non-zero if a figure is outside its bound.
//!
//! Target: `cargo run --release --example fin_loop --target thumbv7em-none-eabihf`
//! Host:   `cargo run --release --example fin_loop`
#![cfg_attr(target_os = "none", no_std)]
#![cfg_attr(target_os = "none", no_main)]

#[path = "shared/harness.rs"]
mod harness;
#[cfg(not(target_os = "none"))]
use harness::main;

#[path = "shared/fin_loop.rs"]
mod fin_loop;

#[path = "shared/fin_faults.rs"]
mod fin_faults;

/// The run the harness starts on the host: the nominal loop, then the fault scenario, which
/// runs even when the nominal figures fail so that both are reported.
#[cfg(not(target_os = "none"))]
fn program() -> bool {
    let nominal = matches!(fin_loop::run(&mut harness::line, None), Some((fig, _)) if fig.ok());
    let faults = fin_faults::run(&mut harness::line);
    nominal && faults
}

/// The run the harness starts on the target: the nominal loop timed by SysTick, its `cost:`
/// lines, then the fault scenario. The timed replay must have followed the run's trajectory.
#[cfg(target_os = "none")]
fn program() -> bool {
    use geared_servo::cortex_m::SysTickStopwatch;
    let Some(mut p) = cortex_m::Peripherals::take() else {
        return false;
    };
    let sw = SysTickStopwatch::start(&mut p.SYST);
    let Some((fig, c)) = fin_loop::run(&mut harness::line, Some(&sw)) else {
        return false;
    };
    cost::report(&c);
    let faults_ok = fin_faults::run(&mut harness::line);
    fig.ok() && c.replay_identical && faults_ok
}

/// The target's cost figures: SysTick as the loop's step clock, and the `cost:` lines.
#[cfg(target_os = "none")]
mod cost {
    use super::fin_loop::{StepClock, StepCost};
    use super::harness::line;
    use geared_servo::cortex_m::SysTickStopwatch;
    use geared_servo::{Plant, PlantState, VirtualActuator};

    /// QEMU mps2-an386 under `-icount shift=0`: SysTick on the core clock ticks once per
    /// 40 instructions.
    const INSTRUCTIONS_PER_TICK: u64 = 40;

    impl StepClock for SysTickStopwatch {
        fn now(&self) -> u32 {
            SysTickStopwatch::now(self)
        }
        fn ticks_between(&self, earlier: u32, later: u32) -> u32 {
            SysTickStopwatch::ticks_between(self, earlier, later)
        }
    }

    /// Prints the `cost:` lines (CI filters them out before diffing with the host's figures).
    pub fn report(c: &StepCost) {
        let n = u64::from(c.steps.max(1));
        let net = c.ticks.saturating_sub(c.overhead_ticks);
        line(format_args!(
            "cost: VirtualActuator::step() (plant + sensors) instructions per call {} (gross {}, timer overhead {} subtracted; {} steps, {} in the backlash gap; 1 SysTick = {} instructions)",
            net * INSTRUCTIONS_PER_TICK / n,
            c.ticks * INSTRUCTIONS_PER_TICK / n,
            c.overhead_ticks * INSTRUCTIONS_PER_TICK / n,
            c.steps,
            c.steps_in_gap,
            INSTRUCTIONS_PER_TICK
        ));
        let plant_net = c.plant_ticks.saturating_sub(c.overhead_ticks);
        line(format_args!(
            "cost: Plant::step() instructions per call {} (gross {}, timer overhead subtracted; same {} steps replayed, replay identical: {})",
            plant_net * INSTRUCTIONS_PER_TICK / n,
            c.plant_ticks * INSTRUCTIONS_PER_TICK / n,
            c.steps,
            c.replay_identical
        ));
        let ev = u64::from(c.plant_event_steps.max(1));
        let quiet = u64::from((c.steps - c.plant_event_steps).max(1));
        line(format_args!(
            "cost: Plant::step() by kind: {} steps with a contact change average {} instructions, the other {} average {}",
            c.plant_event_steps,
            c.plant_event_ticks * INSTRUCTIONS_PER_TICK / ev,
            c.steps - c.plant_event_steps,
            (c.plant_ticks - c.plant_event_ticks) * INSTRUCTIONS_PER_TICK / quiet
        ));
        line(format_args!(
            "cost: RAM size_of Plant {} B, PlantState {} B, VirtualActuator {} B",
            core::mem::size_of::<Plant>(),
            core::mem::size_of::<PlantState>(),
            core::mem::size_of::<VirtualActuator>()
        ));
    }
}
