//! QuadTimer gated-count capture of the six MT6816 PWM inputs.
//!
//! Each channel: `CTRL[CM] = 0b011` (count primary while secondary high),
//! `PCS = 0b1011` (IPG/8 = 18.75 MHz), `SCS` = the channel's own input pin,
//! `LENGTH = 0` (free-running 16-bit, wraps at 65536). Once per tick
//! [`EncoderCapture::sample`] reads every `CNTR` and the DWT CYCCNT; the
//! arithmetic is in [`crate::pure::encoder`].
//!
//! *Bench*: that the QuadTimer3 select-input values route pins 14/15/19
//! (see [`crate::pure::pins`]); that no input filter (`FILT = 0`) is needed
//! against ringing on the encoder cable.

use super::cycles::CycleCounter;
use crate::pure::clock::{qtimer_pcs_for_divider, QTIMER_DIVIDER};
use crate::pure::encoder::RawSample;
use crate::pure::pins::{encoder_fn, PinMap, PinMapError, QtimerFn};
use imxrt_ral as ral;
use ral::tmr;

/// Gated count mode ("count rising edges of primary source while secondary
/// input high active").
const CM_GATED: u16 = 0b011;

/// PCS for IPG/8, checked at compile time.
const PCS: u16 = match qtimer_pcs_for_divider(QTIMER_DIVIDER) {
    Ok(v) => v,
    Err(_) => panic!("bad QuadTimer divider"),
};

/// The encoder capture hardware: TMR1 and TMR3 (the default map uses only
/// these two modules; maps on TMR2/TMR4 are rejected).
pub struct EncoderCapture {
    tmr1: tmr::TMR1,
    tmr3: tmr::TMR3,
    channels: [QtimerFn; 6],
}

impl core::fmt::Debug for EncoderCapture {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("EncoderCapture").field("channels", &self.channels).finish_non_exhaustive()
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

impl EncoderCapture {
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
        // LENGTH = 0, DIR = 0 (up), ONCE = 0
        let ctrl = (CM_GATED << 13) | (PCS << 9);
        for f in channels {
            let rb = this.block(f.module);
            let ch = f.channel;
            let ctrl = ctrl | (((ch & 3) as u16) << 7); // SCS = own input pin
            per_channel!(rb, ch, write_reg, [CTRL0, CTRL1, CTRL2, CTRL3], 0);
            per_channel!(rb, ch, write_reg, [SCTRL0, SCTRL1, SCTRL2, SCTRL3], 0);
            per_channel!(rb, ch, write_reg, [CSCTRL0, CSCTRL1, CSCTRL2, CSCTRL3], 0);
            per_channel!(rb, ch, write_reg, [FILT0, FILT1, FILT2, FILT3], 0);
            per_channel!(rb, ch, write_reg, [LOAD0, LOAD1, LOAD2, LOAD3], 0);
            per_channel!(rb, ch, write_reg, [COMP10, COMP11, COMP12, COMP13], 0xFFFF);
            per_channel!(rb, ch, write_reg, [CMPLD10, CMPLD11, CMPLD12, CMPLD13], 0xFFFF);
            per_channel!(rb, ch, write_reg, [CNTR0, CNTR1, CNTR2, CNTR3], 0);
            per_channel!(rb, ch, write_reg, [CTRL0, CTRL1, CTRL2, CTRL3], ctrl);
        }
        // Channel enables (ENBL resets to 0xF; make sure ours are on).
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

    /// Read all six counters and the cycle counter (J1..J6).
    ///
    /// One CYCCNT read for all six: the counters are read within ~20 bus
    /// cycles of it, and the skew is the same every tick, so it cancels in
    /// window differences.
    pub fn sample(&self, cycles: &CycleCounter) -> [RawSample; 6] {
        let now = cycles.now();
        let mut out = [RawSample { counter: 0, cycles: now }; 6];
        for (o, f) in out.iter_mut().zip(self.channels) {
            let rb = self.block(f.module);
            o.counter = per_channel!(rb, f.channel, read_reg, [CNTR0, CNTR1, CNTR2, CNTR3]);
        }
        out
    }
}
