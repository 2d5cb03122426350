//! Whole-frame MT6816 capture: QuadTimer gated count **plus** capture of the
//! counter on each rising edge (see [`crate::pure::frame`] for the method and
//! the decode). Zero interrupts: the tick calls [`FrameCapture::sample`].
//!
//! Per channel: `CTRL[CM] = 0b011` (count IPG/8 while the pin is high),
//! `PCS = IPG/8`, `SCS` = own input, `SCTRL[CAPTURE_MODE] = 0b01` (rising
//! edge), `IPS = 0`, no interrupt enables, and the input filter on
//! ([`FILT`]).
//!
//! *Bench*: that `CAPT` is loaded on the rising edge in gated-count mode and
//! `IEF` set; that `SCTRL[INPUT]` follows the pin; the QuadTimer3 select
//! inputs for pins 14/15/19 (see [`crate::pure::pins`]).

use super::cycles::CycleCounter;
use crate::pure::clock::{qtimer_pcs_for_divider, QTIMER_DIVIDER};
use crate::pure::frame::Snapshot;
use crate::pure::pins::{encoder_fn, PinMap, PinMapError, QtimerFn};
use imxrt_ral as ral;
use ral::tmr;

const CM_GATED: u16 = 0b011;
const PCS: u16 = match qtimer_pcs_for_divider(QTIMER_DIVIDER) {
    Ok(v) => v,
    Err(_) => panic!("bad QuadTimer divider"),
};
/// SCTRL bits (imxrt-ral `tmr::SCTRL0` field offsets).
const SCTRL_IEF: u16 = 1 << 11;
const SCTRL_INPUT: u16 = 1 << 8;
const SCTRL_CAPTURE_RISING: u16 = 0b01 << 6;
/// Input filter: `FILT_CNT = 7` (the input must hold a level for
/// 7 + 3 = 10 consecutive samples), `FILT_PER = 2` (a sample every 2 IPG
/// clocks, 13.3 ns): glitches up to 133 ns are rejected and both edges are
/// delayed alike by ~147 ns (so the high time, the decoded quantity, is
/// unchanged). The MT6816's shortest high or low time is 16 of its 250 ns
/// clocks (4 us), 30 times longer than the rejected glitch.
const FILT: u16 = (7 << 8) | 2;

/// The capture hardware for six encoders on TMR1 and TMR3.
pub struct FrameCapture {
    tmr1: tmr::TMR1,
    tmr3: tmr::TMR3,
    channels: [QtimerFn; 6],
}

impl core::fmt::Debug for FrameCapture {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("FrameCapture").field("channels", &self.channels).finish_non_exhaustive()
    }
}

macro_rules! per_channel {
    ($rb:expr, $ch:expr, $mac:ident, [$r0:ident, $r1:ident, $r2:ident, $r3:ident] $(, $val:expr)?) => {
        match $ch & 3 {
            0 => ral::$mac!(ral::tmr, $rb, $r0 $(, $val)?),
            1 => ral::$mac!(ral::tmr, $rb, $r1 $(, $val)?),
            2 => ral::$mac!(ral::tmr, $rb, $r2 $(, $val)?),
            _ => ral::$mac!(ral::tmr, $rb, $r3 $(, $val)?),
        }
    };
}

impl FrameCapture {
    /// Configure the six channels of `map.encoder` (J1..J6) and start them.
    pub fn new(tmr1: tmr::TMR1, tmr3: tmr::TMR3, map: &PinMap) -> Result<Self, PinMapError> {
        let mut channels = [QtimerFn { module: 1, channel: 0, alt: 1, daisy: None }; 6];
        for (slot, &p) in channels.iter_mut().zip(map.encoder.iter()) {
            match encoder_fn(p) {
                Some(f) if f.module == 1 || f.module == 3 => *slot = f,
                _ => return Err(PinMapError::NotEncoderCapable(p)),
            }
        }
        let this = Self { tmr1, tmr3, channels };
        let ctrl = (CM_GATED << 13) | (PCS << 9);
        for f in channels {
            let rb = this.block(f.module);
            let ch = f.channel;
            let ctrl = ctrl | (((ch & 3) as u16) << 7); // SCS = own input pin
            per_channel!(rb, ch, write_reg, [CTRL0, CTRL1, CTRL2, CTRL3], 0);
            per_channel!(rb, ch, write_reg, [SCTRL0, SCTRL1, SCTRL2, SCTRL3], SCTRL_CAPTURE_RISING);
            per_channel!(rb, ch, write_reg, [CSCTRL0, CSCTRL1, CSCTRL2, CSCTRL3], 0);
            per_channel!(rb, ch, write_reg, [FILT0, FILT1, FILT2, FILT3], FILT);
            per_channel!(rb, ch, write_reg, [LOAD0, LOAD1, LOAD2, LOAD3], 0);
            per_channel!(rb, ch, write_reg, [COMP10, COMP11, COMP12, COMP13], 0xFFFF);
            per_channel!(rb, ch, write_reg, [CMPLD10, CMPLD11, CMPLD12, CMPLD13], 0xFFFF);
            per_channel!(rb, ch, write_reg, [CNTR0, CNTR1, CNTR2, CNTR3], 0);
            per_channel!(rb, ch, write_reg, [CTRL0, CTRL1, CTRL2, CTRL3], ctrl);
        }
        for f in channels {
            let rb = this.block(f.module);
            let bit = 1u16 << (f.channel & 3);
            ral::modify_reg!(ral::tmr, rb, ENBL, |v| v | bit);
        }
        Ok(this)
    }

    fn block(&self, module: u8) -> &tmr::RegisterBlock {
        if module == 1 {
            &self.tmr1
        } else {
            &self.tmr3
        }
    }

    /// One snapshot per channel (J1..J6): `SCTRL`, `CAPT`, `CNTR` + CYCCNT,
    /// clear `IEF` if it was set, `SCTRL` again for the consistency check.
    /// About 6 x 6 bus accesses; no waiting.
    pub fn sample(&self, cycles: &CycleCounter) -> [Snapshot; 6] {
        let mut out = [Snapshot { ief: false, input_high: false, capt: 0, cntr: 0, cycles: 0, consistent: false }; 6];
        for (o, f) in out.iter_mut().zip(self.channels.iter()) {
            let rb = self.block(f.module);
            let ch = f.channel;
            let s1: u16 = per_channel!(rb, ch, read_reg, [SCTRL0, SCTRL1, SCTRL2, SCTRL3]);
            let capt: u16 = per_channel!(rb, ch, read_reg, [CAPT0, CAPT1, CAPT2, CAPT3]);
            let now = cycles.now();
            let cntr: u16 = per_channel!(rb, ch, read_reg, [CNTR0, CNTR1, CNTR2, CNTR3]);
            if s1 & SCTRL_IEF != 0 {
                // IEF is cleared by writing 0; keep the configuration bits.
                per_channel!(rb, ch, write_reg, [SCTRL0, SCTRL1, SCTRL2, SCTRL3], s1 & !SCTRL_IEF);
            }
            let s2: u16 = per_channel!(rb, ch, read_reg, [SCTRL0, SCTRL1, SCTRL2, SCTRL3]);
            // An edge during the snapshot changes INPUT, or sets IEF again
            // (a rising edge after the clear).
            let consistent = (s1 & SCTRL_INPUT) == (s2 & SCTRL_INPUT) && (s2 & SCTRL_IEF) == 0;
            *o = Snapshot {
                ief: s1 & SCTRL_IEF != 0,
                input_high: s1 & SCTRL_INPUT != 0,
                capt,
                cntr,
                cycles: now,
                consistent,
            };
        }
        out
    }
}
