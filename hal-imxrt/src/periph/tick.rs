//! PIT channel 0: the 1 kHz control tick, with overrun detection.

use imxrt_ral as ral;
use ral::pit;

/// Per-interrupt information.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TickInfo {
    /// Ticks since start (wrapping).
    pub count: u32,
    /// Interrupt latency in PIT clocks (`LDVAL - CVAL` at entry; 24 MHz ->
    /// 41.7 ns per count).
    pub latency_clocks: u32,
}

/// The 1 kHz tick. Owns the PIT (all four channels share `MCR`).
pub struct Tick {
    pit: pit::PIT,
    ldval: u32,
    count: u32,
    overruns: u32,
}

impl core::fmt::Debug for Tick {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Tick")
            .field("ldval", &self.ldval)
            .field("count", &self.count)
            .field("overruns", &self.overruns)
            .finish_non_exhaustive()
    }
}

impl Tick {
    /// Configure channel 0 with `ldval` (from
    /// [`crate::pure::clock::pit_load_value`], 23 999 for 1 kHz at 24 MHz)
    /// and start it with its interrupt enabled. The caller unmasks
    /// `PIT` in the NVIC.
    pub fn start(pit: pit::PIT, ldval: u32) -> Self {
        // MDIS = 0 (module clock on), FRZ = 1 (stop in debug halt)
        ral::write_reg!(ral::pit, pit, MCR, FRZ: 1, MDIS: 0);
        let ch = &pit.TIMER[0];
        ral::write_reg!(ral::pit::timer, ch, TCTRL, 0);
        ral::write_reg!(ral::pit::timer, ch, LDVAL, ldval);
        ral::write_reg!(ral::pit::timer, ch, TFLG, TIF: 1); // w1c
        ral::write_reg!(ral::pit::timer, ch, TCTRL, TIE: 1, TEN: 1);
        Self { pit, ldval, count: 0, overruns: 0 }
    }

    /// Restart the period from now: the counter reloads from `LDVAL` and a
    /// pending flag is cleared, so the first interrupt after this comes one
    /// full period later (used after the boot self-test, so that the first
    /// tick's watchdog refresh is a period after the boot's last one and
    /// not inside the watchdog's window).
    pub fn restart(&mut self) {
        let ch = &self.pit.TIMER[0];
        ral::write_reg!(ral::pit::timer, ch, TCTRL, 0);
        ral::write_reg!(ral::pit::timer, ch, TFLG, TIF: 1); // w1c
        ral::write_reg!(ral::pit::timer, ch, TCTRL, TIE: 1, TEN: 1);
    }

    /// Call first in the PIT interrupt handler: clears the flag.
    pub fn on_interrupt(&mut self) -> TickInfo {
        let ch = &self.pit.TIMER[0];
        let cval = ral::read_reg!(ral::pit::timer, ch, CVAL);
        ral::write_reg!(ral::pit::timer, ch, TFLG, TIF: 1);
        self.count = self.count.wrapping_add(1);
        TickInfo { count: self.count, latency_clocks: self.ldval.saturating_sub(cval) }
    }

    /// Call last in the handler. If the flag is already set again, the next
    /// period elapsed while this one was being handled: an overrun, counted
    /// and returned as `true`. (The pending interrupt still runs, late; more
    /// than one missed period is counted once.)
    pub fn end_of_handler(&mut self) -> bool {
        let ch = &self.pit.TIMER[0];
        let late = ral::read_reg!(ral::pit::timer, ch, TFLG, TIF == 1);
        if late {
            self.overruns = self.overruns.wrapping_add(1);
        }
        late
    }

    /// Overruns since start.
    pub fn overruns(&self) -> u32 {
        self.overruns
    }

    /// Stop the tick (the watchdog will then expire).
    pub fn stop(&mut self) {
        let ch = &self.pit.TIMER[0];
        ral::write_reg!(ral::pit::timer, ch, TCTRL, 0);
    }
}
