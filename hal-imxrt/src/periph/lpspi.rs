//! LPSPI3 as the TMC5160 drivers' link: SPI mode 3, 40-bit frames at
//! [`SCK_HZ`], one GPIO chip select per driver (active low). The framing,
//! the decoding and the polling policy are `crate::pure::tmc5160`; the pins
//! are `crate::pure::pins::TMC_WIRING` (configured by
//! [`crate::periph::iomux::configure_tmc_pins`]).
//!
//! A transfer is started ([`TmcLink::start`]: chip select low, the two
//! transmit words into the FIFO) and collected later ([`TmcLink::finish`]:
//! the two receive words, chip select high, which is when the driver acts on
//! the datagram). The tick starts one and collects it on the next tick, so
//! the 20 us on the wire never hold up the CPU; the boot check waits for
//! each ([`TmcLink::transfer`], bounded).
//!
//! Hand-written over `imxrt-ral` although `imxrt-hal`'s `Lpspi` (in the
//! image through teensy4-bsp) offers the same FIFO access
//! (`without_pins`, `enqueue_transaction`, `enqueue_data`, `read_data`):
//! this crate drives every peripheral through `imxrt-ral` with the numbers
//! of `pure`, and the SCK divider here is a compile-time constant checked
//! to divide the clock exactly (`pure::tmc5160::SCKDIV`), where
//! `imxrt-hal` derives its divider at run time. The 40-bit frame's split
//! into FIFO words (32 bits, then the remaining 8) is the LPSPI's rule for
//! frames over 32 bits, the one `imxrt-hal`'s `Transaction` also states
//! (its last word must hold at least 2 bits).

use crate::periph::cycles::CycleCounter;
use crate::periph::gpio::Gpios;
use crate::pure::pins::{teensy41_pin, GpioBit, TmcWiring};
use crate::pure::tmc5160::{Datagram, Reply, DRIVERS, FRAMESZ, SCKDIV, SCK_HZ};
use imxrt_ral as ral;
use ral::{ccm, lpspi};

/// Longest wait for one datagram at boot: five times its 20 us.
const TRANSFER_TIMEOUT_CYCLES: u32 = 60_000;
const _: () = assert!(SCK_HZ == 2_000_000);

/// LPSPI3 and the six chip selects.
pub struct TmcLink {
    spi: lpspi::LPSPI3,
    cs: [GpioBit; DRIVERS],
    /// The driver whose transfer is on the wire (chip select low).
    in_flight: Option<usize>,
}

impl core::fmt::Debug for TmcLink {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("TmcLink").field("in_flight", &self.in_flight).finish_non_exhaustive()
    }
}

impl TmcLink {
    /// Open LPSPI3's clock gate (its root is teensy4-bsp's 132 MHz), reset
    /// and configure it as controller, mode 3, 40-bit frames; chip selects
    /// high and outputs (their pads are GPIO from `configure_tmc_pins`).
    pub fn new(spi: lpspi::LPSPI3, ccm: &ccm::CCM, gpios: &Gpios, wiring: &TmcWiring) -> Self {
        // lpspi3 = CCGR1 CG2
        ral::modify_reg!(ral::ccm, ccm, CCGR1, CG2: 0b11);
        let mut cs = [GpioBit { port: 1, bit: 0 }; DRIVERS];
        for (slot, &pin) in cs.iter_mut().zip(wiring.cs.iter()) {
            if let Some(tp) = teensy41_pin(pin) {
                gpios.write(tp.gpio, true);
                gpios.make_output(tp.gpio);
                *slot = tp.gpio;
            }
        }
        ral::write_reg!(ral::lpspi, spi, CR, RST: 1);
        ral::write_reg!(ral::lpspi, spi, CR, 0);
        ral::write_reg!(ral::lpspi, spi, CFGR1, MASTER: 1);
        ral::write_reg!(ral::lpspi, spi, CCR, SCKDIV: u32::from(SCKDIV), DBT: 8, PCSSCK: 8, SCKPCS: 8);
        ral::write_reg!(ral::lpspi, spi, FCR, 0);
        ral::write_reg!(ral::lpspi, spi, CR, MEN: 1, RTF: 1, RRF: 1);
        ral::write_reg!(ral::lpspi, spi, TCR, CPOL: 1, CPHA: 1, PRESCALE: 0, FRAMESZ: FRAMESZ);
        Self { spi, cs, in_flight: None }
    }

    /// Select `driver` and queue `d` (non-blocking). A transfer still in
    /// flight is abandoned first.
    pub fn start(&mut self, gpios: &Gpios, driver: usize, d: Datagram) {
        if self.in_flight.is_some() {
            self.abandon(gpios);
        }
        let Some(&cs) = self.cs.get(driver) else { return };
        gpios.write(cs, false);
        let [w0, w1] = d.words();
        ral::write_reg!(ral::lpspi, self.spi, TDR, w0);
        ral::write_reg!(ral::lpspi, self.spi, TDR, w1);
        self.in_flight = Some(driver);
    }

    /// Collect the transfer started by [`TmcLink::start`] (non-blocking):
    /// its answer if both receive words are there, `None` if not (the
    /// transfer is abandoned, the FIFOs flushed). Deselects the driver.
    pub fn finish(&mut self, gpios: &Gpios) -> Option<Reply> {
        let driver = self.in_flight.take()?;
        let rx = ral::read_reg!(ral::lpspi, self.spi, FSR, RXCOUNT);
        let reply = if rx >= 2 {
            let w0 = ral::read_reg!(ral::lpspi, self.spi, RDR);
            let w1 = ral::read_reg!(ral::lpspi, self.spi, RDR);
            Some(Reply::from_words([w0, w1]))
        } else {
            None
        };
        if let Some(&cs) = self.cs.get(driver) {
            gpios.write(cs, true);
        }
        if reply.is_none() || rx > 2 {
            ral::modify_reg!(ral::lpspi, self.spi, CR, RTF: 1, RRF: 1);
        }
        reply
    }

    /// One datagram, waiting (at most [`TRANSFER_TIMEOUT_CYCLES`]) for its
    /// answer: boot only.
    pub fn transfer(&mut self, gpios: &Gpios, cycles: &CycleCounter, driver: usize, d: Datagram) -> Option<Reply> {
        self.start(gpios, driver, d);
        let t0 = cycles.now();
        while ral::read_reg!(ral::lpspi, self.spi, FSR, RXCOUNT) < 2 {
            if cycles.now().wrapping_sub(t0) > TRANSFER_TIMEOUT_CYCLES {
                break;
            }
        }
        self.finish(gpios)
    }

    fn abandon(&mut self, gpios: &Gpios) {
        if let Some(driver) = self.in_flight.take() {
            if let Some(&cs) = self.cs.get(driver) {
                gpios.write(cs, true);
            }
        }
        ral::modify_reg!(ral::lpspi, self.spi, CR, RTF: 1, RRF: 1);
    }
}
