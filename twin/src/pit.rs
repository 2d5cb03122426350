//! The periodic interrupt timer (PIT): four channels counting down from
//! `LDVAL` at the PIT clock, `TIF` at each expiry. Time is the board's
//! `now` in CPU cycles; the channels are computed from it when read, not
//! stepped.

/// PIT interrupt number (i.MXRT1062).
pub const IRQ_PIT: u32 = 122;

/// One PIT channel.
#[derive(Clone, Debug, Default)]
pub struct PitCh {
    /// LDVAL.
    pub ldval: u32,
    /// TCTRL.
    pub tctrl: u32,
    /// TIF.
    pub tif: bool,
    /// Time the counter was (re)loaded.
    pub start: u64,
    /// Expiries counted so far since `start`.
    pub expiries: u64,
}

impl PitCh {
    /// One period in CPU cycles at `clk` cycles per PIT clock.
    fn period(&self, clk: u64) -> u64 {
        (u64::from(self.ldval) + 1) * clk
    }
}

/// The PIT: its channels and `MCR`.
#[derive(Clone, Debug)]
pub struct Pit {
    /// Channels 0..3.
    pub ch: [PitCh; 4],
    /// MCR.
    pub mcr: u32,
}

impl Default for Pit {
    /// Reset: `MDIS` = 1, every channel off.
    fn default() -> Self {
        Pit { ch: Default::default(), mcr: 0x2 }
    }
}

impl Pit {
    /// The module is disabled (`MCR[MDIS]`).
    fn disabled(&self) -> bool {
        self.mcr & 2 != 0
    }

    /// Sets `TIF` on every running channel that expired by `now`.
    pub fn update(&mut self, now: u64, clk: u64) {
        if self.disabled() {
            return;
        }
        for ch in self.ch.iter_mut().filter(|ch| ch.tctrl & 1 != 0) {
            let n = now.saturating_sub(ch.start) / ch.period(clk);
            if n > ch.expiries {
                ch.tif = true;
                ch.expiries = n;
            }
        }
    }

    /// Register read at offset `off` (after [`Pit::update`]).
    pub fn read(&self, off: u32, now: u64, clk: u64) -> u32 {
        if off == 0 {
            return self.mcr;
        }
        if !(0x100..0x140).contains(&off) {
            return 0;
        }
        let ch = &self.ch[((off - 0x100) / 0x10) as usize];
        match off & 0xF {
            0x0 => ch.ldval,
            0x4 => {
                if ch.tctrl & 1 == 0 || self.disabled() {
                    ch.ldval
                } else {
                    let in_p = (now - ch.start) % ch.period(clk);
                    ch.ldval - (in_p / clk) as u32
                }
            }
            0x8 => ch.tctrl,
            _ => u32::from(ch.tif),
        }
    }

    /// Register write at offset `off` (after [`Pit::update`]).
    pub fn write(&mut self, off: u32, v: u32, now: u64) {
        if off == 0 {
            self.mcr = v;
            for ch in self.ch.iter_mut() {
                ch.start = now;
                ch.expiries = 0;
            }
        } else if (0x100..0x140).contains(&off) {
            let ch = &mut self.ch[((off - 0x100) / 0x10) as usize];
            match off & 0xF {
                0x0 => ch.ldval = v,
                0x8 => {
                    if v & 1 != 0 && ch.tctrl & 1 == 0 {
                        ch.start = now;
                        ch.expiries = 0;
                    }
                    ch.tctrl = v & 7;
                }
                0xC if v & 1 != 0 => ch.tif = false,
                _ => {}
            }
        }
    }

    /// The next expiry of a running channel (cycles), if one runs.
    pub fn next_expiry(&self, clk: u64) -> Option<u64> {
        if self.disabled() {
            return None;
        }
        self.ch.iter().filter(|ch| ch.tctrl & 1 != 0).map(|ch| ch.start + (ch.expiries + 1) * ch.period(clk)).min()
    }

    /// When the pending interrupt was raised: the latest expiry of a
    /// channel whose `TIF` and `TIE` are set (the earliest such channel if
    /// several), or `None` if none is pending.
    pub fn raised_at(&self, clk: u64) -> Option<u64> {
        self.ch
            .iter()
            .filter(|c| c.tif && c.tctrl & 2 != 0 && c.expiries > 0)
            .map(|c| c.start + c.expiries * c.period(clk))
            .min()
    }

    /// A channel with `TIF` and `TIE` set requests the interrupt.
    pub fn requesting(&self) -> bool {
        self.ch.iter().any(|c| c.tif && c.tctrl & 2 != 0)
    }

    /// After a debug halt of `cycles`: with `MCR[FRZ]` the channels resume
    /// where they stopped.
    pub fn debug_halt(&mut self, cycles: u64) {
        if self.mcr & 1 != 0 {
            for ch in self.ch.iter_mut() {
                ch.start += cycles;
            }
        }
    }
}
