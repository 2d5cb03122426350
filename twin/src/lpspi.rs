//! LPSPI3 as a controller (i.MXRT1062 reference manual, LPSPI chapter):
//! `CR` (`MEN`, `RST`, `RTF`/`RRF` flush), `CFGR1[MASTER]`, `CCR[SCKDIV]`,
//! `TCR` (`FRAMESZ`, `PRESCALE`; written directly, not through the FIFO),
//! `FSR` counts, `TDR` and `RDR`, `SR[MBF]`. A frame is taken from the
//! transmit words when enough are queued for its size (32-bit words, the
//! last one the remainder, most significant bit first), shifted through the
//! selected devices at once ([`crate::Board`] routes it), and its receive
//! words land in the FIFO when the frame's time on the wire has passed:
//! `FRAMESZ + 1` SCK periods of `(SCKDIV + 2) << PRESCALE` functional
//! clocks. Only the 528 MHz PLL2 source of the LPSPI clock root is modelled
//! (the one the image selects). Interrupts, DMA, the PCS outputs, match
//! logic and continuous transfers are not modelled.

use std::collections::VecDeque;

/// FIFO depth (words) of the i.MXRT1062's LPSPI.
pub const FIFO: usize = 16;

/// One LPSPI.
#[derive(Clone, Debug, Default)]
pub struct Lpspi {
    /// CR (RST, RTF, RRF read back 0).
    pub cr: u32,
    /// CFGR1.
    pub cfgr1: u32,
    /// CCR.
    pub ccr: u32,
    /// FCR.
    pub fcr: u32,
    /// TCR.
    pub tcr: u32,
    /// Transmit words not yet making up a whole frame.
    tx: Vec<u32>,
    /// Receive FIFO.
    rx: VecDeque<u32>,
    /// Frames on the wire: (time their receive words land, the words).
    pending: VecDeque<(u64, Vec<u32>)>,
    /// The wire is busy until then (cycles).
    busy_until: u64,
    /// Frames shifted since reset.
    pub frames: u64,
}

/// A frame the controller shifts out now: its bits (most significant
/// first, in the low `bits` bits) and its size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Frame {
    /// Bits.
    pub data: u64,
    /// Frame size in bits (8..=64 modelled).
    pub bits: u32,
}

impl Lpspi {
    /// Chip reset: every register and FIFO to reset (the frame count kept).
    pub fn reset(&mut self) {
        *self = Lpspi { frames: self.frames, ..Lpspi::default() };
    }

    fn frame_bits(&self) -> u32 {
        (self.tcr & 0xFFF) + 1
    }

    fn words_per_frame(&self) -> usize {
        self.frame_bits().div_ceil(32) as usize
    }

    /// Cycles (600 MHz) one frame takes on the wire, with a functional
    /// clock of `clk_hz`.
    pub fn frame_cycles(&self, clk_hz: f64) -> u64 {
        let sckdiv = f64::from(self.ccr & 0xFF) + 2.0;
        let prescale = f64::from(1u32 << ((self.tcr >> 27) & 7));
        let sck_hz = clk_hz / (sckdiv * prescale);
        (f64::from(self.frame_bits()) * crate::CPU_HZ as f64 / sck_hz).ceil() as u64
    }

    fn settle(&mut self, now: u64) {
        while self.pending.front().is_some_and(|(t, _)| *t <= now) {
            if let Some((_, words)) = self.pending.pop_front() {
                for w in words {
                    if self.rx.len() < FIFO {
                        self.rx.push_back(w);
                    }
                }
            }
        }
    }

    /// Register read.
    pub fn read(&mut self, off: u32, now: u64) -> u32 {
        self.settle(now);
        match off {
            0x00 => 0x0102_0004, // VERID
            0x04 => 0x0004_0404, // PARAM: 16-word FIFOs, 4 PCS
            0x10 => self.cr,
            0x14 => {
                let busy = !self.pending.is_empty() || now < self.busy_until;
                let tdf = u32::from(self.tx.len() <= (self.fcr & 0xF) as usize);
                let rdf = u32::from(self.rx.len() > ((self.fcr >> 16) & 0xF) as usize) << 1;
                tdf | rdf | (u32::from(busy) << 24)
            }
            0x24 => self.cfgr1,
            0x40 => self.ccr,
            0x58 => self.fcr,
            0x5C => (self.tx.len() as u32) | ((self.rx.len() as u32) << 16),
            0x60 => self.tcr,
            0x74 => self.rx.pop_front().unwrap_or(0),
            _ => 0,
        }
    }

    /// Register write; a frame that becomes complete is returned for the
    /// board to shift through the devices, with the time it starts.
    pub fn write(&mut self, off: u32, v: u32, now: u64) -> Option<Frame> {
        self.settle(now);
        match off {
            0x10 => {
                if v & 2 != 0 {
                    self.reset();
                    return None;
                }
                if v & (1 << 8) != 0 {
                    self.tx.clear();
                }
                if v & (1 << 9) != 0 {
                    self.rx.clear();
                    self.pending.clear();
                }
                self.cr = v & 0xF;
            }
            0x24 => self.cfgr1 = v,
            0x40 => self.ccr = v,
            0x58 => self.fcr = v,
            0x60 => self.tcr = v,
            0x64 => {
                if self.cr & 1 == 0 || self.cfgr1 & 1 == 0 || self.tx.len() >= FIFO {
                    return None;
                }
                self.tx.push(v);
                if self.tx.len() >= self.words_per_frame() {
                    let words: Vec<u32> = self.tx.drain(..self.words_per_frame()).collect();
                    return Some(self.assemble(&words));
                }
            }
            _ => {}
        }
        None
    }

    fn assemble(&self, words: &[u32]) -> Frame {
        let bits = self.frame_bits().min(64);
        let mut data = 0u64;
        let mut left = bits;
        for &w in words {
            let n = left.min(32);
            let mask = if n == 32 { u32::MAX } else { (1u32 << n) - 1 };
            data = (data << n) | u64::from(w & mask);
            left -= n;
        }
        Frame { data, bits }
    }

    /// The answer to the frame just returned by [`Lpspi::write`]: split
    /// into receive words like the transmit side, landing after the frame's
    /// `cycles` on the wire (frames queue behind each other).
    pub fn complete(&mut self, frame: Frame, answer: u64, now: u64, cycles: u64) {
        let mut words = Vec::new();
        let mut left = frame.bits;
        while left > 0 {
            let n = left.min(32);
            left -= n;
            let mask = if n == 32 { u64::from(u32::MAX) } else { (1u64 << n) - 1 };
            words.push(((answer >> left) & mask) as u32);
        }
        let start = now.max(self.busy_until);
        self.busy_until = start + cycles;
        self.pending.push_back((self.busy_until, words));
        self.frames += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_forty_bit_frame_is_two_words_each_way() {
        let mut s = Lpspi::default();
        assert_eq!(s.write(0x10, 1, 0), None);
        s.write(0x24, 1, 0);
        s.write(0x40, 64, 0);
        s.write(0x60, (3 << 30) | 39, 0);
        assert_eq!(s.write(0x64, 0x81A1_B2C3, 0), None);
        let f = s.write(0x64, 0xD4, 0).expect("frame");
        assert_eq!(f, Frame { data: 0x81_A1B2_C3D4, bits: 40 });
        // 40 bits at 132 MHz / 66 = 2 MHz: 20 us
        let cycles = s.frame_cycles(132e6);
        assert_eq!(cycles, 12_000);
        s.complete(f, 0x09_3000_0050, 0, cycles);
        assert_eq!(s.read(0x5C, 11_999) >> 16, 0, "still on the wire");
        assert_eq!(s.read(0x5C, 12_000) >> 16, 2);
        assert_eq!(s.read(0x74, 12_000), 0x0930_0000);
        assert_eq!(s.read(0x74, 12_000), 0x50);
    }
}
