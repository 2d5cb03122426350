//! Serial1 = LPUART6 on Teensy pins 0 (RX) / 1 (TX), 8N1, polled; its
//! interrupt only wakes the main loop from WFI.
//!
//! (Not LPUART1: on the Teensy 4.1, LPUART1 is on pins 24/25, here limit
//! switches. Serial1 is LPUART6.)

use crate::pure::uart::BaudDivisor;
use imxrt_ral as ral;
use ral::lpuart;

/// Receive errors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RxError {
    /// Receiver overrun: bytes were lost.
    Overrun,
    /// Framing or noise error on this byte.
    Line,
}

/// The serial port.
pub struct Serial1 {
    uart: lpuart::LPUART6,
}

impl core::fmt::Debug for Serial1 {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Serial1").finish_non_exhaustive()
    }
}

impl Serial1 {
    /// Reset and configure with `div` (from
    /// [`crate::pure::uart::lpuart_divisor`] for the 24 MHz UART clock),
    /// enable the FIFOs, transmitter and receiver.
    pub fn new(uart: lpuart::LPUART6, div: BaudDivisor) -> Self {
        ral::write_reg!(ral::lpuart, uart, GLOBAL, RST: 1);
        ral::write_reg!(ral::lpuart, uart, GLOBAL, RST: 0);
        ral::write_reg!(
            ral::lpuart,
            uart,
            BAUD,
            OSR: div.osr as u32,
            SBR: div.sbr as u32,
            BOTHEDGE: div.both_edge as u32
        );
        ral::modify_reg!(ral::lpuart, uart, FIFO, TXFE: 1, RXFE: 1);
        ral::write_reg!(ral::lpuart, uart, WATER, 0);
        ral::write_reg!(ral::lpuart, uart, CTRL, TE: 1, RE: 1);
        Self { uart }
    }

    /// Queue one byte if there is room; `false` if the TX FIFO is full.
    pub fn try_write(&mut self, byte: u8) -> bool {
        if ral::read_reg!(ral::lpuart, self.uart, STAT, TDRE == 0) {
            return false;
        }
        ral::write_reg!(ral::lpuart, self.uart, DATA, byte as u32);
        true
    }

    /// Which states raise the LPUART6 interrupt: a received byte waiting
    /// (`RIE`, `RDRF` with `RXWATER` 0) and an empty transmit FIFO (`TIE`,
    /// `TDRE` with `TXWATER` 0). The main loop uses them only to wake from
    /// WFI; the handler masks the interrupt in the NVIC.
    pub fn set_interrupts(&mut self, rx: bool, tx: bool) {
        ral::modify_reg!(ral::lpuart, self.uart, CTRL, RIE: rx as u32, TIE: tx as u32);
    }

    /// Take one received byte, if any.
    pub fn try_read(&mut self) -> Option<Result<u8, RxError>> {
        let stat = ral::read_reg!(ral::lpuart, self.uart, STAT);
        if stat & lpuart::STAT::OR::mask != 0 {
            // w1c
            ral::write_reg!(ral::lpuart, self.uart, STAT, OR: 1);
            return Some(Err(RxError::Overrun));
        }
        if stat & lpuart::STAT::RDRF::mask == 0 {
            return None;
        }
        let data = ral::read_reg!(ral::lpuart, self.uart, DATA);
        if data & (lpuart::DATA::FRETSC::mask | lpuart::DATA::NOISY::mask) != 0 {
            return Some(Err(RxError::Line));
        }
        Some(Ok((data & 0xFF) as u8))
    }
}
