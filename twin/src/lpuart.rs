//! LPUART6 (Teensy Serial1): 4-entry TX and RX FIFOs, a transmit shifter
//! and a receive line that deliver one byte per frame time (10 bits at the
//! programmed baud rate), `STAT`/`DATA`/`FIFO` as the image polls them.

use std::collections::VecDeque;

use crate::board::CPU_HZ;

/// LPUART6 interrupt number (i.MXRT1062).
pub const IRQ_LPUART6: u32 = 25;

/// LPUART6 state.
#[derive(Clone, Debug, Default)]
pub struct Uart {
    /// Registers by offset/4.
    pub r: [u32; 12],
    /// TX FIFO.
    pub tx_fifo: VecDeque<u8>,
    /// Shifter busy until.
    pub tx_busy_until: u64,
    /// Bytes sent on the wire (with their completion time).
    pub tx_out: Vec<(u64, u8)>,
    /// RX FIFO.
    pub rx_fifo: VecDeque<u8>,
    /// Host bytes not yet on the wire.
    pub rx_pending: VecDeque<u8>,
    /// Next time a host byte can arrive.
    pub rx_next: u64,
    /// Overrun flag.
    pub or: bool,
}

impl Uart {
    /// Reset at `now`, keeping the wire's history (what a terminal saw):
    /// `PARAM` says 4-entry FIFOs.
    pub fn reset(&mut self, now: u64) {
        let out = std::mem::take(&mut self.tx_out);
        *self = Uart { tx_out: out, ..Uart::default() };
        self.r[1] = 0x0202;
        self.rx_next = now;
    }

    /// Cycles per byte on the wire (10 bits) for `CSCDR1` (the UART clock
    /// root: `UART_CLK_SEL` bit 6, 1 = OSC 24 MHz, else PLL3 80 MHz;
    /// `PODF` bits 5:0) and the programmed `BAUD`.
    pub fn byte_cycles(&self, cscdr1: u32) -> u64 {
        let baud = self.r[4];
        let sbr = u64::from(baud & 0x1FFF).max(1);
        let osr = u64::from((baud >> 24) & 0x1F) + 1;
        let osr = if osr < 4 { 16 } else { osr };
        let src = if cscdr1 & (1 << 6) != 0 { 24_000_000u64 } else { 80_000_000 };
        let clk = src / (u64::from(cscdr1 & 0x3F) + 1);
        10 * sbr * osr * CPU_HZ / clk
    }

    /// Brings the shifter and the receive line up to `now`.
    pub fn sync(&mut self, now: u64, byte: u64) {
        let te = self.r[6] & (1 << 19) != 0;
        let re = self.r[6] & (1 << 18) != 0;
        while te && !self.tx_fifo.is_empty() && self.tx_busy_until <= now {
            if let Some(b) = self.tx_fifo.pop_front() {
                let done = self.tx_busy_until + byte;
                self.tx_out.push((done, b));
                self.tx_busy_until = done;
            }
        }
        while re && !self.rx_pending.is_empty() && self.rx_next <= now {
            if let Some(b) = self.rx_pending.pop_front() {
                if self.rx_fifo.len() >= 4 {
                    self.or = true;
                } else {
                    self.rx_fifo.push_back(b);
                }
                self.rx_next += byte;
            }
        }
        if self.rx_pending.is_empty() && self.rx_next < now {
            self.rx_next = now;
        }
    }

    /// Bytes transmitted so far, as text.
    pub fn text(&self) -> String {
        let v: Vec<u8> = self.tx_out.iter().map(|&(_, b)| b).collect();
        String::from_utf8_lossy(&v).into_owned()
    }

    /// Queues host bytes onto the RX line.
    pub fn send(&mut self, bytes: &[u8]) {
        self.rx_pending.extend(bytes.iter().copied());
    }

    /// The interrupt is requested: `RIE` and a byte in the RX FIFO
    /// (`RDRF`, `RXWATER` 0), or `TIE` and an empty TX FIFO (`TDRE`,
    /// `TXWATER` 0).
    pub fn requesting(&self) -> bool {
        let ctrl = self.r[6];
        (ctrl & (1 << 21) != 0 && !self.rx_fifo.is_empty()) || (ctrl & (1 << 23) != 0 && self.tx_fifo.is_empty())
    }

    /// Nothing for the image to read now (RX FIFO empty).
    pub fn rx_quiet(&self) -> bool {
        self.rx_fifo.is_empty()
    }

    /// When the next host byte lands in the RX FIFO, if one is on its way.
    pub fn rx_next_event(&self, now: u64) -> Option<u64> {
        (!self.rx_pending.is_empty()).then_some(self.rx_next.max(now + 1))
    }

    /// When the transmitter next changes state (the shifter takes the next
    /// FIFO byte or finishes), if it is busy.
    pub fn tx_next_event(&self, now: u64) -> Option<u64> {
        (self.tx_busy_until > now || !self.tx_fifo.is_empty()).then_some(self.tx_busy_until.max(now + 1))
    }

    /// Register read at offset `off` (after [`Uart::sync`]).
    pub fn read(&mut self, off: u32, now: u64) -> u32 {
        match off {
            0x14 => {
                let mut s = self.r[5] & 0x3F00_0000;
                if self.tx_fifo.is_empty() {
                    s |= 1 << 23; // TDRE (TXWATER = 0)
                }
                if self.tx_fifo.is_empty() && self.tx_busy_until <= now {
                    s |= 1 << 22; // TC
                }
                if !self.rx_fifo.is_empty() {
                    s |= 1 << 21; // RDRF
                }
                if self.or {
                    s |= 1 << 19;
                }
                s
            }
            0x1C => match self.rx_fifo.pop_front() {
                Some(b) => u32::from(b),
                None => 1 << 12, // RXEMPT
            },
            0x28 => {
                let mut f = self.r[10] & !0x00C0_0000;
                if self.tx_fifo.is_empty() {
                    f |= 1 << 23; // TXEMPT
                }
                if self.rx_fifo.is_empty() {
                    f |= 1 << 22; // RXEMPT
                }
                f | 0x11 // TXFIFOSIZE / RXFIFOSIZE = 4
            }
            o => self.r.get((o / 4) as usize).copied().unwrap_or(0),
        }
    }

    /// Register write at offset `off` (after [`Uart::sync`]); `byte` is
    /// [`Uart::byte_cycles`].
    pub fn write(&mut self, off: u32, v: u32, now: u64, byte: u64) {
        match off {
            0x8 => {
                if v & 2 != 0 {
                    // software reset: the wire's history and the host's
                    // bytes still on the line survive
                    let param = self.r[1];
                    let out = std::mem::take(&mut self.tx_out);
                    let pend = std::mem::take(&mut self.rx_pending);
                    *self = Uart { tx_out: out, rx_pending: pend, rx_next: now, ..Uart::default() };
                    self.r[1] = param;
                }
                self.r[2] = v;
            }
            0x14 if v & (1 << 19) != 0 => self.or = false,
            0x14 => {}
            0x1C if self.r[6] & (1 << 19) != 0 => {
                if self.tx_fifo.is_empty() && self.tx_busy_until <= now {
                    let done = now + byte;
                    self.tx_out.push((done, v as u8));
                    self.tx_busy_until = done;
                } else if self.tx_fifo.len() < 4 {
                    self.tx_fifo.push_back(v as u8);
                }
            }
            0x1C => {}
            o if (o / 4) < 12 => self.r[(o / 4) as usize] = v,
            _ => {}
        }
    }
}
