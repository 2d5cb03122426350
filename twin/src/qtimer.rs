//! QuadTimer (TMR1..4) model, four channels each.
//!
//! Modelled (i.MXRT1060 RM, QTimer chapter): the primary clock source
//! `CTRL[PCS]` = 8..15 (IPG / 2^(PCS-8); IPG = 150 MHz = 4 CPU cycles: the
//! twin's own clock figure, independent of the HAL's on purpose), count
//! modes `CM` = 0 (stopped), 1 (count rising edges of the primary source),
//! 3 (count while the secondary input `SCS` is high: gated count); `ENBL`
//! gates every channel. Input capture `SCTRL[CAPTURE_MODE]` 1 (rising), 2
//! (falling), 3 (both) of the secondary input loads `CAPT` with the counter
//! and sets `SCTRL[IEF]`; while `IEF` is set **no further capture happens**
//! (IEF is cleared by writing 0). `SCTRL[INPUT]` reads the secondary input
//! (after `IPS` inversion). The counter is modelled only for the secondary
//! input = the channel's own pin (`SCS` = channel number, which is what a
//! gated count on a pin needs).
//!
//! Not modelled: compare/`TCF`/`TOF`, `LENGTH`, `DIR`, cascade, outputs,
//! the input filter (`FILT` is stored, not applied), DMA, interrupts.

/// The waveform on a channel's input pin.
pub trait InputWave {
    /// Level at time `t` and the next time (> t) the level changes.
    fn level_and_next(&mut self, ch: usize, t: u64) -> (bool, u64);
}

/// One channel.
#[derive(Clone, Debug, Default)]
pub struct Channel {
    /// Registers by offset/2 (COMP1, COMP2, CAPT, LOAD, HOLD, CNTR, CTRL,
    /// SCTRL, CMPLD1, CMPLD2, CSCTRL, FILT, DMA, -, -, ENBL).
    pub r: [u16; 16],
    /// Fractional counter progress in CPU cycles at `t`.
    pub t: u64,
    /// Input level at `t`.
    pub level: bool,
    /// Captures that happened.
    pub captures: u64,
    /// Edges seen while IEF was set (capture inhibited).
    pub inhibited: u64,
}

const CNTR: usize = 5;
const CTRL: usize = 6;
const SCTRL: usize = 7;
const CAPT: usize = 2;
/// Index of `FILT` in [`Channel::r`] (offset 0x16).
pub const FILT: usize = 11;

/// A QuadTimer module.
#[derive(Clone, Debug)]
pub struct QTimer {
    /// Channels 0..3.
    pub ch: [Channel; 4],
}

impl QTimer {
    /// Reset state.
    pub fn new() -> Self {
        let mut q = QTimer { ch: Default::default() };
        q.ch[0].r[15] = 0x000F; // ENBL reset: all channels enabled
        q
    }

    fn enabled(&self, c: usize) -> bool {
        self.ch[0].r[15] & (1 << c) != 0
    }

    /// Cycles per primary-source count, if the source is an IPG divider.
    fn cycles_per_count(ctrl: u16) -> Option<u64> {
        let pcs = (ctrl >> 9) & 0xF;
        if pcs >= 8 {
            Some(4u64 << (pcs - 8))
        } else {
            None
        }
    }

    /// Advance channel `c` to time `t` against the input waveform.
    pub fn advance(&mut self, c: usize, t: u64, wave: &mut dyn InputWave) {
        let en = self.enabled(c);
        let chn = &mut self.ch[c];
        if t <= chn.t {
            return;
        }
        let ctrl = chn.r[CTRL];
        let cm = ctrl >> 13;
        let scs = ((ctrl >> 7) & 3) as usize;
        let ips = chn.r[SCTRL] & (1 << 9) != 0;
        let cpc = Self::cycles_per_count(ctrl);
        let own_input = scs == c;
        let mut now = chn.t;
        while now < t {
            let (raw, next) = wave.level_and_next(c, now);
            let level = raw ^ ips;
            let seg_end = next.min(t);
            // edge at `now`?
            if level != chn.level {
                let mode = (chn.r[SCTRL] >> 6) & 3;
                let rising = level;
                let capture = en && own_input && ((mode == 1 && rising) || (mode == 2 && !rising) || mode == 3);
                if capture {
                    if chn.r[SCTRL] & (1 << 11) == 0 {
                        chn.r[CAPT] = chn.r[CNTR];
                        chn.r[SCTRL] |= 1 << 11;
                        chn.captures += 1;
                    } else {
                        chn.inhibited += 1;
                    }
                }
                chn.level = level;
            }
            // count over [now, seg_end)
            if en {
                if let Some(cpc) = cpc {
                    let ticks = seg_end / cpc - now / cpc;
                    let counting = match cm {
                        1 => true,
                        3 => own_input && level,
                        _ => false,
                    };
                    if counting {
                        chn.r[CNTR] = chn.r[CNTR].wrapping_add(ticks as u16);
                    }
                }
            }
            now = seg_end;
        }
        chn.t = t;
        // INPUT bit reflects the (inverted) pin
        let (raw, _) = wave.level_and_next(c, t);
        if raw ^ ips {
            chn.r[SCTRL] |= 1 << 8;
        } else {
            chn.r[SCTRL] &= !(1 << 8);
        }
    }

    /// Register read (module offset, 16-bit). Call `advance` first.
    pub fn read(&self, off: u32) -> u16 {
        let c = ((off >> 5) & 3) as usize;
        let r = ((off & 0x1F) / 2) as usize;
        if r == 15 {
            return self.ch[0].r[15];
        }
        self.ch[c].r[r]
    }

    /// Register write. Call `advance` first.
    pub fn write(&mut self, off: u32, v: u16) {
        let c = ((off >> 5) & 3) as usize;
        let r = ((off & 0x1F) / 2) as usize;
        match r {
            15 => self.ch[0].r[15] = v & 0xF,
            SCTRL => {
                let old = self.ch[c].r[SCTRL];
                // TCF (15), TOF (13), IEF (11): cleared by writing 0, not set by 1
                let flags = 0xA800u16;
                let keep = old & flags & v;
                let nv = (v & !flags & !(1 << 8)) | keep | (old & (1 << 8));
                self.ch[c].r[SCTRL] = nv;
            }
            CAPT => {}
            _ => self.ch[c].r[r] = v,
        }
    }
}

impl Default for QTimer {
    fn default() -> Self {
        Self::new()
    }
}
