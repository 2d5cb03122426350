//! RTWDOG (WDOG3): resets the chip if the control tick stops feeding it,
//! or feeds it too early (window mode), and cannot be reconfigured or
//! disabled once started (`CS[UPDATE] = 0`: only a chip reset unlocks it).
//!
//! After the reset every pad returns to its reset state (input, keeper), so
//! no STEP edges are produced and the firmware reboots into its unhomed,
//! non-moving state. Note: this stops *stepping*; the TMC5160 drivers stay
//! energised (holding torque) because no driver-enable pin is wired in the
//! pin map. Cutting motor current needs an EN line (open item).
//!
//! Clock: LPO (`CS[CLK] = 01`), nominally 32 kHz (*bench*: measure; it is an
//! RC oscillator). Timeout from [`crate::pure::clock::rtwdog_toval`].

use imxrt_ral as ral;
use ral::rtwdog;

/// 32-bit unlock key (CMD32EN = 1).
const UNLOCK: u32 = 0xD928_C520;
/// 32-bit refresh key.
const REFRESH: u32 = 0xB480_A602;

/// The running watchdog.
pub struct Watchdog {
    wd: rtwdog::RTWDOG,
}

impl core::fmt::Debug for Watchdog {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Watchdog").finish_non_exhaustive()
    }
}

impl Watchdog {
    /// Unlock, program a timeout of `toval` LPO clocks and a window of `win`
    /// LPO clocks (a refresh while the counter is below `win` resets the
    /// chip), enable with updates forbidden (`UPDATE = 0`: the configuration
    /// is locked until the next reset, so no later code can widen, stretch
    /// or disable it), and wait for the configuration to take effect. Runs
    /// with interrupts masked because the unlock window is 255 bus clocks.
    pub fn start(wd: rtwdog::RTWDOG, toval: u16, win: u16) -> Self {
        cortex_m::interrupt::free(|_| {
            ral::write_reg!(ral::rtwdog, wd, CNT, UNLOCK);
            while ral::read_reg!(ral::rtwdog, wd, CS, ULK == 0) {}
            ral::write_reg!(ral::rtwdog, wd, TOVAL, toval as u32);
            ral::write_reg!(ral::rtwdog, wd, WIN, win as u32);
            ral::write_reg!(
                ral::rtwdog,
                wd,
                CS,
                EN: 1,
                CLK: 1,
                UPDATE: 0,
                CMD32EN: 1,
                PRES: 0,
                WIN: 1,
                INT: 0,
                TST: 0,
                DBG: 0,
                WAIT: 0,
                STOP: 0
            );
            while ral::read_reg!(ral::rtwdog, wd, CS, RCS == 0) {}
        });
        Self { wd }
    }

    /// Refresh. Call from the tick handler only, after the tick's work, and
    /// only once per tick: a second refresh within the window resets.
    #[inline]
    pub fn feed(&self) {
        ral::write_reg!(ral::rtwdog, self.wd, CNT, REFRESH);
    }
}
