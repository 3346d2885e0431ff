//! Cortex-M helpers (feature `cortex-m`): time `step()` with the DWT cycle counter or SysTick,
//! and share the actuator between an interrupt and the main loop.
//!
//! These compile on any target (so feature combinations build on the host), but the
//! register accesses only mean something on a Cortex-M.

use core::cell::RefCell;

use cortex_m::peripheral::{syst::SystClkSource, DCB, DWT, SYST};
use critical_section::Mutex;

/// Starts the DWT cycle counter (Cortex-M3 and up). QEMU does not model it (it reads 0):
/// use [`SysTickStopwatch`] there.
pub fn enable_cycle_counter(dcb: &mut DCB, dwt: &mut DWT) {
    dcb.enable_trace();
    dwt.enable_cycle_counter();
}

/// Core clock cycles of `f` by the DWT counter (wrapping difference, so valid for runs under
/// 2^32 cycles), with `f`'s result. Needs [`enable_cycle_counter`] first.
#[inline]
pub fn time_cycles<R>(f: impl FnOnce() -> R) -> (R, u32) {
    let start = DWT::cycle_count();
    let r = f();
    (r, DWT::cycle_count().wrapping_sub(start))
}

/// SysTick as a free-running 24-bit down-counter on the core clock. Under QEMU with
/// `-icount shift=0` one tick is 40 instructions; on silicon one tick is one core cycle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SysTickStopwatch;

impl SysTickStopwatch {
    /// Counter span, ticks (2^24).
    pub const SPAN: u32 = 1 << 24;

    /// Configures `syst` to count down from 2^24 − 1 on the core clock, without interrupt.
    pub fn start(syst: &mut SYST) -> SysTickStopwatch {
        syst.disable_interrupt();
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(Self::SPAN - 1);
        syst.clear_current();
        syst.enable_counter();
        SysTickStopwatch
    }

    /// The counter now, ticks (counts down).
    #[inline(always)]
    pub fn now(&self) -> u32 {
        SYST::get_current()
    }

    /// Ticks from `earlier` to `later` (both from [`SysTickStopwatch::now`]), valid for
    /// intervals under 2^24 ticks.
    #[inline(always)]
    pub fn ticks_between(&self, earlier: u32, later: u32) -> u32 {
        earlier.wrapping_sub(later) & (Self::SPAN - 1)
    }
}

/// A value shared between interrupt handlers and the main loop:
/// `critical_section::Mutex<RefCell<Option<T>>>` whose accessors never panic — a re-entrant
/// access (e.g. from a closure that reaches the same `Shared` again) gets `None`/`Err`
/// instead of a `BorrowMutError` panic.
///
/// ```
/// # use geared_servo::cortex_m::Shared;
/// static COUNTER: Shared<u32> = Shared::new();
/// # fn main() {
/// COUNTER.put(0).ok();
/// // in the control-tick interrupt:
/// let ticks = COUNTER.with_mut(|c| { *c += 1; *c });
/// assert_eq!(ticks, Some(1));
/// // re-entry is refused, not a panic:
/// assert_eq!(COUNTER.with_mut(|_| COUNTER.with_mut(|c| *c)), Some(None));
/// # }
/// ```
pub struct Shared<T> {
    inner: Mutex<RefCell<Option<T>>>,
}

impl<T> Shared<T> {
    /// Empty; `const`, for a `static`.
    pub const fn new() -> Shared<T> {
        Shared {
            inner: Mutex::new(RefCell::new(None)),
        }
    }

    /// Stores `value`, returning the previous one; `Err(value)` if it is in use right now.
    pub fn put(&self, value: T) -> Result<Option<T>, T> {
        critical_section::with(|cs| match self.inner.borrow(cs).try_borrow_mut() {
            Ok(mut slot) => Ok(slot.replace(value)),
            Err(_) => Err(value),
        })
    }

    /// Removes and returns the value; `None` if empty or in use right now.
    pub fn take(&self) -> Option<T> {
        critical_section::with(|cs| {
            self.inner
                .borrow(cs)
                .try_borrow_mut()
                .ok()
                .and_then(|mut slot| slot.take())
        })
    }

    /// Runs `f` on the value inside a critical section; `None` if empty or already borrowed
    /// (re-entry).
    pub fn with_mut<R>(&self, f: impl FnOnce(&mut T) -> R) -> Option<R> {
        critical_section::with(|cs| {
            let mut slot = self.inner.borrow(cs).try_borrow_mut().ok()?;
            slot.as_mut().map(f)
        })
    }
}

impl<T> Default for Shared<T> {
    fn default() -> Self {
        Shared::new()
    }
}
