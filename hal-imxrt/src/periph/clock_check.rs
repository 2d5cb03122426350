//! The independent reference for the clock check
//! ([`crate::pure::clock_check`]): GPT2 free-running on `ipg_clk_32k`, the
//! 32.768 kHz RTC crystal (not derived from the 24 MHz oscillator the ARM
//! PLL multiplies). `DBGEN = 0`: the counter stops while a debugger halts
//! the core, as the DWT cycle counter does, so a debug halt is no deviation.
//!
//! *bench*: confirm that `ipg_clk_32k` runs from the crystal on the board
//! (firmware/README.md's checklist measures the check's verdict with a
//! deliberately detuned PLL).

use imxrt_ral as ral;
use ral::{ccm, gpt};

use crate::pure::clock_check::ClockMonitor;

/// GPT2 counting the 32.768 kHz reference, and the monitor fed from it.
pub struct ClockCheck {
    gpt: gpt::GPT2,
    monitor: ClockMonitor,
}

impl core::fmt::Debug for ClockCheck {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("ClockCheck").field("monitor", &self.monitor).finish_non_exhaustive()
    }
}

impl ClockCheck {
    /// Gates GPT2 on (CCGR0 CG12 bus, CG13 serial), resets it and starts it
    /// free-running from `ipg_clk_32k` without prescaler; the first window
    /// starts at `cycles_now` (DWT).
    pub fn start(gpt: gpt::GPT2, ccm: &ccm::CCM, cycles_now: impl Fn() -> u32) -> Self {
        ral::modify_reg!(ral::ccm, ccm, CCGR0, CG12: 0b11, CG13: 0b11);
        ral::write_reg!(ral::gpt, gpt, CR, 0);
        ral::write_reg!(ral::gpt, gpt, CR, SWR: 1);
        while ral::read_reg!(ral::gpt, gpt, CR, SWR == 1) {}
        ral::write_reg!(ral::gpt, gpt, IR, 0);
        ral::write_reg!(ral::gpt, gpt, PR, 0);
        // CLKSRC 4 = ipg_clk_32k; FRR: free-run; ENMOD: the count starts at 0
        ral::write_reg!(ral::gpt, gpt, CR, CLKSRC: 4, FRR: 1, ENMOD: 1, DBGEN: 0);
        ral::modify_reg!(ral::gpt, gpt, CR, EN: 1);
        let r0 = ral::read_reg!(ral::gpt, gpt, CNT);
        let monitor = ClockMonitor::new(cycles_now(), r0);
        Self { gpt, monitor }
    }

    /// One reading (the tick, once per tick): true once a window deviated.
    #[inline(always)]
    pub fn poll(&mut self, cycles_now: u32) -> bool {
        let r = ral::read_reg!(ral::gpt, self.gpt, CNT);
        self.monitor.update(cycles_now, r)
    }
}
