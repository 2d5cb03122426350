//! The RTWDOG watchdog: unlock and refresh sequences, `CS`/`TOVAL`/`WIN`,
//! its counter from the LPO (32 kHz) or the bus clock, the deadline that
//! resets the chip, window mode (`CS[WIN]`: a refresh while the counter is
//! below `WIN` resets the chip) and the configuration lock (`CS[UPDATE] =
//! 0` written: the unlock key no longer unlocks, so `CS`, `TOVAL` and `WIN`
//! keep their values until the chip resets).

use crate::board::CPU_HZ;

/// LPO clock of the RTWDOG (32 kHz nominal), cycles per LPO tick.
pub const LPO_CYCLES: f64 = CPU_HZ as f64 / 32_000.0;

/// The unlock key written to `CNT`.
const UNLOCK: u32 = 0xD928_C520;
/// The refresh key written to `CNT`.
const REFRESH: u32 = 0xB480_A602;

/// RTWDOG state.
#[derive(Clone, Debug, Default)]
pub struct Wdog {
    /// CS.
    pub cs: u32,
    /// TOVAL.
    pub toval: u32,
    /// WIN.
    pub win: u32,
    /// Time of the last refresh/configuration.
    pub since: u64,
    /// Unlocked (ULK) until this time.
    pub unlocked_until: u64,
    /// Refreshes seen.
    pub refreshes: u64,
    /// Refreshes inside the closed window (each one resets the chip).
    pub early_refreshes: u64,
    /// Configured with `UPDATE = 0`: locked until the chip resets.
    pub locked: bool,
    /// Unlock attempts ignored because the configuration was locked.
    pub locked_unlocks: u64,
    /// A refresh inside the closed window asks for a chip reset.
    pub reset_request: bool,
}

impl Wdog {
    /// After the boot ROM: disabled (the twin's assumption), `TOVAL` at its
    /// reset value.
    pub fn after_boot_rom() -> Self {
        Wdog { cs: 0x2120, toval: 0x0400, ..Wdog::default() }
    }

    /// Cycles per counter tick: the LPO or the bus clock (4 cycles).
    fn tick_cycles(&self) -> f64 {
        if (self.cs >> 8) & 3 == 1 {
            LPO_CYCLES
        } else {
            4.0
        }
    }

    /// When the watchdog resets the chip unless refreshed, if it is enabled.
    pub fn deadline(&self) -> Option<u64> {
        if self.cs & (1 << 7) == 0 {
            return None;
        }
        let pres = if self.cs & (1 << 12) != 0 { 256.0 } else { 1.0 };
        Some(self.since + (f64::from(self.toval) * pres * self.tick_cycles()) as u64)
    }

    /// Register read at offset `off`.
    pub fn read(&self, off: u32, now: u64) -> u32 {
        match off {
            0x0 => {
                let mut cs = self.cs;
                if now < self.unlocked_until {
                    cs |= 1 << 11;
                }
                cs | (1 << 10) // RCS: reconfiguration done at once
            }
            0x4 => ((now - self.since) as f64 / self.tick_cycles()) as u32 & 0xFFFF,
            0x8 => self.toval,
            _ => self.win,
        }
    }

    /// The counter, in watchdog clocks since the last refresh or
    /// configuration.
    fn counter(&self, now: u64) -> u64 {
        (now.saturating_sub(self.since) as f64 / self.tick_cycles()) as u64
    }

    /// Register write at offset `off`.
    pub fn write(&mut self, off: u32, v: u32, now: u64) {
        let unlocked = now < self.unlocked_until;
        match off {
            0x4 => {
                if v == UNLOCK {
                    if self.locked {
                        // UPDATE = 0: no reconfiguration until reset (the
                        // unlock is not granted; whether the silicon also
                        // resets on the attempt is not modelled)
                        self.locked_unlocks += 1;
                    } else {
                        // unlock window: 255 bus clocks (IPG = 4 cycles)
                        self.unlocked_until = now + 255 * 4;
                    }
                } else if v == REFRESH {
                    let enabled = self.cs & (1 << 7) != 0;
                    let window = self.cs & (1 << 15) != 0;
                    if enabled && window && self.counter(now) < u64::from(self.win) {
                        self.early_refreshes += 1;
                        self.reset_request = true;
                    }
                    self.since = now;
                    self.refreshes += 1;
                }
            }
            0x0 if unlocked => {
                self.cs = v & !(1 << 14);
                self.since = now;
                self.unlocked_until = 0;
                self.locked = v & (1 << 5) == 0;
            }
            0x8 if unlocked => self.toval = v & 0xFFFF,
            0xC if unlocked => self.win = v & 0xFFFF,
            _ => {}
        }
    }
}
