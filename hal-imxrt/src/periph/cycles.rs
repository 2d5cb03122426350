//! DWT cycle counter (600 MHz), via the `cortex-m` crate.

use cortex_m::peripheral::{DCB, DWT};

/// Proof that the cycle counter runs.
#[derive(Debug)]
pub struct CycleCounter(());

impl CycleCounter {
    /// Enable trace and the cycle counter (Cortex-M7: also unlock the DWT
    /// lock-access register).
    pub fn enable(dcb: &mut DCB, dwt: &mut DWT) -> Self {
        dcb.enable_trace();
        DWT::unlock();
        dwt.enable_cycle_counter();
        CycleCounter(())
    }

    /// Current CYCCNT (wraps every 7.16 s; use wrapping differences).
    #[inline(always)]
    pub fn now(&self) -> u32 {
        DWT::cycle_count()
    }

    /// Busy-wait until `cycles` have passed since `start` (wrap-safe).
    #[inline]
    pub fn wait_since(&self, start: u32, cycles: u32) {
        while DWT::cycle_count().wrapping_sub(start) < cycles {
            core::hint::spin_loop();
        }
    }
}
