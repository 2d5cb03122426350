//! GPT1/GPT2: `CR`, `PR` and the free-running `CNT` clocked from
//! `ipg_clk_32k`, the 32.768 kHz RTC crystal, which is independent of the
//! core clock. The twin's time is CPU cycles; the crystal counts emulated
//! real time, i.e. cycles divided by the core's actual frequency
//! ([`crate::Board::cpu_hz`], nominally [`crate::CPU_HZ`]): a PLL locked at
//! a wrong frequency shows as a different number of CPU cycles per
//! reference count, which is what the image's clock check measures. (The
//! other peripheral models keep counting in nominal cycles: only this
//! reference is modelled as a second clock domain.) Other clock sources
//! than `ipg_clk_32k` are not modelled (the counter stays at 0).

/// Reference frequency (Hz).
pub const REF_HZ: f64 = 32_768.0;

/// One GPT.
#[derive(Clone, Debug, Default)]
pub struct Gpt {
    /// CR (SWR reads back 0).
    pub cr: u32,
    /// PR.
    pub pr: u32,
    /// Reference counts (before the prescaler) accumulated up to `base_at`.
    base_counts: f64,
    /// Time (cycles) up to which `base_counts` is accumulated.
    base_at: u64,
}

impl Gpt {
    fn counting(&self) -> bool {
        self.cr & 1 != 0 && (self.cr >> 6) & 7 == 4
    }

    /// Reference counts since the counter was enabled, at `now` for a core
    /// clock of `cpu_hz`.
    fn counts(&self, now: u64, cpu_hz: f64) -> f64 {
        if !self.counting() {
            return self.base_counts;
        }
        self.base_counts + now.saturating_sub(self.base_at) as f64 * REF_HZ / cpu_hz
    }

    /// Fold the counts so far into the base (before the core frequency or
    /// the configuration changes).
    pub fn rebase(&mut self, now: u64, cpu_hz: f64) {
        self.base_counts = self.counts(now, cpu_hz);
        self.base_at = now;
    }

    /// A debug halt of `cycles`: with `CR[DBGEN] = 0` the counter stops.
    pub fn debug_halt(&mut self, cycles: u64) {
        if self.cr & (1 << 2) == 0 {
            self.base_at += cycles;
        }
    }

    /// Register read.
    pub fn read(&self, off: u32, now: u64, cpu_hz: f64) -> u32 {
        match off {
            0x00 => self.cr,
            0x04 => self.pr,
            0x24 => {
                let pres = f64::from((self.pr & 0xFFF) + 1);
                (self.counts(now, cpu_hz) / pres).floor() as u64 as u32
            }
            _ => 0,
        }
    }

    /// Register write.
    pub fn write(&mut self, off: u32, v: u32, now: u64, cpu_hz: f64) {
        match off {
            0x00 => {
                if v & (1 << 15) != 0 {
                    // SWR: every register to reset, the bit self-clears
                    *self = Gpt { base_at: now, ..Gpt::default() };
                    return;
                }
                self.rebase(now, cpu_hz);
                let enabling = v & 1 != 0 && self.cr & 1 == 0;
                if enabling && v & 2 != 0 {
                    // ENMOD: the counter starts from 0
                    self.base_counts = 0.0;
                }
                self.cr = v;
            }
            0x04 => {
                self.rebase(now, cpu_hz);
                self.pr = v;
            }
            _ => {}
        }
    }
}
