//! A TMC5160 stepper driver's SPI side (written from the driver's datasheet,
//! independently of `hal_imxrt::pure::tmc5160`): a register file with
//! `GSTAT`, `IOIN` and `DRV_STATUS`, the 40-bit datagram, the status byte
//! sent with every answer, and the one-datagram delay of read data: a read
//! request is acted on when its chip select rises, and its register goes out
//! with the **next** datagram. Tests inject the driver's faults by changing
//! its registers ([`Tmc5160::inject`]).

/// `GSTAT` bits.
pub const GSTAT_RESET: u32 = 1;
/// `GSTAT.drv_err`.
pub const GSTAT_DRV_ERR: u32 = 2;
/// `GSTAT.uv_cp`.
pub const GSTAT_UV_CP: u32 = 4;

/// A condition a test can put a driver in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Condition {
    /// Overtemperature shutdown: `DRV_STATUS.ot` (and `otpw`), `GSTAT.drv_err`.
    Overtemperature,
    /// Phase A shorted to ground: `DRV_STATUS.s2ga`, `GSTAT.drv_err`.
    ShortToGround,
    /// Phase B shorted to the supply: `DRV_STATUS.s2vsb`, `GSTAT.drv_err`.
    ShortToSupply,
    /// Phase A open: `DRV_STATUS.ola` (no shutdown, no `drv_err`).
    OpenLoad,
    /// `GSTAT.drv_err` latched with no `DRV_STATUS` flag left (a shutdown
    /// that has cleared).
    DrvErrLatched,
}

/// One driver.
#[derive(Clone, Debug)]
pub struct Tmc5160 {
    /// Fitted and powered: answers on the bus. Not: its SDO stays
    /// high-impedance.
    pub present: bool,
    /// `GSTAT` (write 1 to clear).
    pub gstat: u32,
    /// `IOIN` (`VERSION` in bits 31:24).
    pub ioin: u32,
    /// `DRV_STATUS`.
    pub drv_status: u32,
    /// The datagram shifted in while selected, waiting for the chip select
    /// to rise.
    received: Option<u64>,
    /// The data the next answer carries.
    out_data: u32,
    /// The register `out_data` was read from.
    last_read: Option<u8>,
    /// Datagrams acted on (chip select rose after a complete datagram).
    pub datagrams: u64,
    /// When (cycles) an answer first carried a `DRV_STATUS` fault flag
    /// (ot, s2g, s2vs, ol) in its data: the image collects it in the next
    /// tick (test instrumentation, not hardware).
    pub fault_answer_at: Option<u64>,
}

/// `DRV_STATUS` fault flags: ot, s2ga/b, s2vsa/b, ola/b.
pub const DRV_FAULT_FLAGS: u32 = (1 << 25) | (3 << 27) | (3 << 12) | (3 << 29);

impl Default for Tmc5160 {
    fn default() -> Self {
        Self {
            present: true,
            gstat: GSTAT_RESET,
            // VERSION 0x30; DRV_ENN high and SD_MODE high among the inputs
            ioin: 0x3000_0050,
            // standstill, some motor current
            drv_status: (1 << 31) | (16 << 16),
            received: None,
            out_data: 0,
            last_read: None,
            datagrams: 0,
            fault_answer_at: None,
        }
    }
}

impl Tmc5160 {
    /// A read of register `addr` (7 bits).
    fn reg(&self, addr: u8) -> u32 {
        match addr {
            0x01 => self.gstat,
            0x04 => self.ioin,
            0x6F => self.drv_status,
            _ => 0,
        }
    }

    /// `SPI_STATUS`: reset_flag, driver_error, sg2, standstill.
    pub fn status(&self) -> u8 {
        let mut s = (self.gstat & 3) as u8;
        if self.drv_status & (1 << 24) != 0 {
            s |= 1 << 2;
        }
        if self.drv_status & (1 << 31) != 0 {
            s |= 1 << 3;
        }
        s
    }

    /// A whole 40-bit datagram shifted in while selected at `now`; returns
    /// the 40 bits shifted out (status byte, then the previous read's data).
    pub fn shift(&mut self, bits_in: u64, now: u64) -> u64 {
        self.received = Some(bits_in);
        if self.out_data & DRV_FAULT_FLAGS != 0 && self.last_read == Some(0x6F) && self.fault_answer_at.is_none() {
            self.fault_answer_at = Some(now);
        }
        (u64::from(self.status()) << 32) | u64::from(self.out_data)
    }

    /// The chip select rose: act on a complete datagram.
    pub fn deselect(&mut self) {
        let Some(bits) = self.received.take() else { return };
        self.datagrams += 1;
        let addr = ((bits >> 32) & 0xFF) as u8;
        let data = bits as u32;
        if addr & 0x80 != 0 {
            if addr & 0x7F == 0x01 {
                self.gstat &= !(data & 7);
            }
        } else {
            self.out_data = self.reg(addr & 0x7F);
            self.last_read = Some(addr & 0x7F);
        }
    }

    /// Put the driver in `c`.
    pub fn inject(&mut self, c: Condition) {
        match c {
            Condition::Overtemperature => {
                self.drv_status |= (1 << 25) | (1 << 26);
                self.gstat |= GSTAT_DRV_ERR;
            }
            Condition::ShortToGround => {
                self.drv_status |= 1 << 27;
                self.gstat |= GSTAT_DRV_ERR;
            }
            Condition::ShortToSupply => {
                self.drv_status |= 1 << 13;
                self.gstat |= GSTAT_DRV_ERR;
            }
            Condition::OpenLoad => self.drv_status |= 1 << 29,
            Condition::DrvErrLatched => self.gstat |= GSTAT_DRV_ERR,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn read_data_comes_with_the_next_datagram() {
        let mut t = Tmc5160::default();
        let a = t.shift(0x04_0000_0000, 0);
        assert_eq!(a >> 32, 0x09, "reset flag and standstill");
        t.deselect();
        let b = t.shift(0x01_0000_0000, 0);
        assert_eq!(b as u32, 0x3000_0050, "IOIN");
        t.deselect();
        let c = t.shift(0x81_0000_0007, 0);
        assert_eq!(c as u32, GSTAT_RESET, "GSTAT");
        t.deselect();
        assert_eq!(t.gstat, 0, "cleared by the write");
        // a datagram not followed by a deselect is not acted on
        let _ = t.shift(0x6F_0000_0000, 0);
        assert_eq!(t.datagrams, 3);
    }
}
