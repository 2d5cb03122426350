//! The TMC5160 stepper drivers' SPI link: datagram framing, decoding of
//! `SPI_STATUS`, `GSTAT`, `IOIN` and `DRV_STATUS`, the boot check and the
//! run-time round-robin monitor. Pure and host-tested; the register
//! driver is `periph::lpspi`.
//!
//! # The datagram
//!
//! 40 bits, most significant bit first, SPI mode 3: an address byte (bit 7
//! set = write) and 32 data bits. The driver answers every datagram with its
//! `SPI_STATUS` byte (bit 0 `reset_flag` = `GSTAT.reset`, bit 1
//! `driver_error` = `GSTAT.drv_err`, ...) followed by 32 data bits that are
//! the register addressed by the **previous** datagram (a read request is
//! answered one datagram later). LPSPI3 sends it as one 40-bit frame
//! (`TCR[FRAMESZ]` = 39): the transmit FIFO takes two words, the first 32
//! bits (address, data 31:8), then the remaining 8 (data 7:0); the receive
//! FIFO returns the answer the same way ([`Datagram::words`],
//! [`Reply::from_words`]).
//!
//! # Boot
//!
//! [`BOOT_SEQUENCE`] per driver: read `IOIN`, read `GSTAT` (answer: `IOIN`),
//! write `GSTAT` = 7 (answer: `GSTAT`; the write clears the power-on
//! `reset` flag and a latched `drv_err`), read `DRV_STATUS`, read
//! `DRV_STATUS` again (answer: `DRV_STATUS`). [`boot_verdict`] names the
//! first problem: no answer ([`Finding::Missing`]), a `VERSION` other than
//! 0x30 ([`Finding::WrongVersion`]), `GSTAT.drv_err` or `GSTAT.uv_cp`, a
//! `DRV_STATUS` fault flag, or a `reset_flag` that the clear did not clear.
//!
//! # Run time
//!
//! [`Monitor`]: one `DRV_STATUS` read per tick, round-robin over the six
//! drivers (each every [`DRIVERS`] ticks). Every answer carries the driver's
//! current `SPI_STATUS` and the `DRV_STATUS` latched by the previous read of
//! that driver. A `driver_error` that the `DRV_STATUS` data does not explain
//! (it is older) is followed up by reading the same driver again on the next
//! tick, so overtemperature and shorts are named, not only flagged.

/// Register `GSTAT` (read, write 1 to clear).
pub const REG_GSTAT: u8 = 0x01;
/// Register `IOIN` (read): input levels and `VERSION` in bits 31:24.
pub const REG_IOIN: u8 = 0x04;
/// Register `DRV_STATUS` (read).
pub const REG_DRV_STATUS: u8 = 0x6F;
/// Address bit 7: write access.
pub const WRITE: u8 = 0x80;
/// `IOIN.VERSION` of a TMC5160.
pub const VERSION: u8 = 0x30;
/// Bits per datagram.
pub const DATAGRAM_BITS: u32 = 40;
/// `LPSPI_TCR[FRAMESZ]` for one datagram (frame size - 1).
pub const FRAMESZ: u32 = DATAGRAM_BITS - 1;
/// Drivers on the link (J1..J6).
pub const DRIVERS: usize = 6;

/// `SPI_STATUS` bit 0: `GSTAT.reset` (the driver was reset since the flag
/// was last cleared).
pub const STATUS_RESET: u8 = 1 << 0;
/// `SPI_STATUS` bit 1: `GSTAT.drv_err` (the bridge was switched off for
/// overtemperature or a short since the flag was last cleared).
pub const STATUS_DRIVER_ERROR: u8 = 1 << 1;

/// `GSTAT` bit 0: reset.
pub const GSTAT_RESET: u32 = 1 << 0;
/// `GSTAT` bit 1: drv_err.
pub const GSTAT_DRV_ERR: u32 = 1 << 1;
/// `GSTAT` bit 2: uv_cp (charge pump undervoltage, driver disabled).
pub const GSTAT_UV_CP: u32 = 1 << 2;

/// `DRV_STATUS` bit 12: short to supply, bridge A.
pub const DRV_S2VSA: u32 = 1 << 12;
/// `DRV_STATUS` bit 13: short to supply, bridge B.
pub const DRV_S2VSB: u32 = 1 << 13;
/// `DRV_STATUS` bit 24: stallGuard (not a fault here: it depends on tuning).
pub const DRV_STALLGUARD: u32 = 1 << 24;
/// `DRV_STATUS` bit 25: overtemperature shutdown.
pub const DRV_OT: u32 = 1 << 25;
/// `DRV_STATUS` bit 26: overtemperature prewarning (not a fault here).
pub const DRV_OTPW: u32 = 1 << 26;
/// `DRV_STATUS` bit 27: short to ground, bridge A.
pub const DRV_S2GA: u32 = 1 << 27;
/// `DRV_STATUS` bit 28: short to ground, bridge B.
pub const DRV_S2GB: u32 = 1 << 28;
/// `DRV_STATUS` bit 29: open load, bridge A.
pub const DRV_OLA: u32 = 1 << 29;
/// `DRV_STATUS` bit 30: open load, bridge B.
pub const DRV_OLB: u32 = 1 << 30;
/// `DRV_STATUS` bits that are always 0 on a TMC5160 (11:10, 23:21): set
/// in an answer, the line is not a driver talking.
pub const DRV_RESERVED: u32 = (0b11 << 10) | (0b111 << 21);

/// What a check found wrong with one driver.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Finding {
    /// No driver answers (the data line reads all ones or all zeros, or an
    /// impossible `DRV_STATUS`), or the transfer did not complete.
    Missing,
    /// `IOIN.VERSION` is not a TMC5160's.
    WrongVersion,
    /// `SPI_STATUS.reset_flag` after boot cleared it: the driver reset
    /// (lost its supply) while running.
    Reset,
    /// `GSTAT.drv_err`: the driver switched its bridges off, reason not in
    /// `DRV_STATUS` (any more).
    DriverError,
    /// `GSTAT.uv_cp`: charge pump undervoltage, the driver is disabled.
    ChargePump,
    /// `DRV_STATUS.ot`: overtemperature shutdown.
    Overtemperature,
    /// `DRV_STATUS.s2ga`/`s2gb`: a motor phase shorted to ground.
    ShortToGround,
    /// `DRV_STATUS.s2vsa`/`s2vsb`: a motor phase shorted to the supply.
    ShortToSupply,
    /// `DRV_STATUS.ola`/`olb`: a motor phase open (a coil not connected).
    OpenLoad,
}

/// One request to a driver.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Datagram {
    /// Address byte (bit 7 = write).
    pub addr: u8,
    /// Data (ignored by the driver for a read).
    pub data: u32,
}

impl Datagram {
    /// A read request of `reg`.
    pub const fn read(reg: u8) -> Self {
        Self { addr: reg & !WRITE, data: 0 }
    }
    /// A write of `data` to `reg`.
    pub const fn write(reg: u8, data: u32) -> Self {
        Self { addr: reg | WRITE, data }
    }
    /// The 40 bits, most significant first, in the low bits.
    pub const fn bits(self) -> u64 {
        ((self.addr as u64) << 32) | self.data as u64
    }
    /// The two LPSPI transmit FIFO words of the 40-bit frame: bits 39..8,
    /// then bits 7..0.
    pub const fn words(self) -> [u32; 2] {
        let b = self.bits();
        [(b >> 8) as u32, (b & 0xFF) as u32]
    }
}

/// One answer of a driver.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Reply {
    /// `SPI_STATUS`, current at the transfer.
    pub status: u8,
    /// The register the previous datagram addressed.
    pub data: u32,
}

impl Reply {
    /// The answer from the two LPSPI receive FIFO words of a 40-bit frame
    /// (bits 39..8, then bits 7..0 in the low byte).
    pub const fn from_words(w: [u32; 2]) -> Self {
        let [hi, lo] = w;
        Self { status: (hi >> 24) as u8, data: (hi << 8) | (lo & 0xFF) }
    }
    /// The 40 bits as received, in the low bits.
    pub const fn bits(self) -> u64 {
        ((self.status as u64) << 32) | self.data as u64
    }
    /// No driver drove the data line: every bit one (the line's pull-up)
    /// or every bit zero (held low).
    pub const fn is_silent(self) -> bool {
        let b = self.bits();
        b == 0 || b == (1u64 << DATAGRAM_BITS) - 1
    }
}

/// The datagrams of the boot check, per driver (see the module docs).
pub const BOOT_SEQUENCE: [Datagram; 5] = [
    Datagram::read(REG_IOIN),
    Datagram::read(REG_GSTAT),
    Datagram::write(REG_GSTAT, GSTAT_RESET | GSTAT_DRV_ERR | GSTAT_UV_CP),
    Datagram::read(REG_DRV_STATUS),
    Datagram::read(REG_DRV_STATUS),
];

/// The problem an `IOIN` answer shows, if any.
pub const fn check_ioin(r: Reply) -> Option<Finding> {
    if r.is_silent() {
        Some(Finding::Missing)
    } else if (r.data >> 24) as u8 != VERSION {
        Some(Finding::WrongVersion)
    } else {
        None
    }
}

/// The problem a `GSTAT` value shows, if any (`reset` is expected after
/// power-on and is not one).
pub const fn check_gstat(gstat: u32) -> Option<Finding> {
    if gstat & GSTAT_DRV_ERR != 0 {
        Some(Finding::DriverError)
    } else if gstat & GSTAT_UV_CP != 0 {
        Some(Finding::ChargePump)
    } else {
        None
    }
}

/// The fault a `DRV_STATUS` value shows, if any: overtemperature, then a
/// short to ground, a short to the supply, an open load. Prewarning and
/// stallGuard are not faults.
pub const fn check_drv_status(d: u32) -> Option<Finding> {
    if d & DRV_RESERVED != 0 {
        Some(Finding::Missing)
    } else if d & DRV_OT != 0 {
        Some(Finding::Overtemperature)
    } else if d & (DRV_S2GA | DRV_S2GB) != 0 {
        Some(Finding::ShortToGround)
    } else if d & (DRV_S2VSA | DRV_S2VSB) != 0 {
        Some(Finding::ShortToSupply)
    } else if d & (DRV_OLA | DRV_OLB) != 0 {
        Some(Finding::OpenLoad)
    } else {
        None
    }
}

/// The boot check's verdict from the five answers to [`BOOT_SEQUENCE`]
/// (answer `i` belongs to datagram `i`, and carries the data of datagram
/// `i - 1`).
pub const fn boot_verdict(r: &[Reply; 5]) -> Option<Finding> {
    let [_, ioin, gstat, _, drv] = *r;
    if let Some(f) = check_ioin(ioin) {
        return Some(f);
    }
    if gstat.is_silent() || drv.is_silent() {
        return Some(Finding::Missing);
    }
    if let Some(f) = check_gstat(gstat.data) {
        return Some(f);
    }
    if let Some(f) = check_drv_status(drv.data) {
        return Some(f);
    }
    if drv.status & STATUS_RESET != 0 {
        return Some(Finding::Reset);
    }
    if drv.status & STATUS_DRIVER_ERROR != 0 {
        return Some(Finding::DriverError);
    }
    None
}

/// The run-time monitor: which driver to read next, and what each driver's
/// latest answer showed (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Monitor {
    next: u8,
    follow_up: bool,
    /// Per driver: a problem its latest answer showed.
    active: [Option<Finding>; DRIVERS],
    /// Per driver: the boot check failed (kept for the whole run: its
    /// answers are not trusted).
    failed_boot: [bool; DRIVERS],
}

impl Monitor {
    /// After the boot check, with its verdict per driver.
    pub const fn after_boot(verdicts: [Option<Finding>; DRIVERS]) -> Self {
        let [v0, v1, v2, v3, v4, v5] = verdicts;
        let failed_boot = [v0.is_some(), v1.is_some(), v2.is_some(), v3.is_some(), v4.is_some(), v5.is_some()];
        Self { next: 0, follow_up: false, active: verdicts, failed_boot }
    }

    /// The driver (0..=5) the next `DRV_STATUS` read goes to.
    pub const fn driver(&self) -> usize {
        self.next as usize % DRIVERS
    }

    /// The answer to the `DRV_STATUS` read just sent to [`Monitor::driver`],
    /// or `None` if the transfer did not complete. Chooses the next driver.
    pub fn on_reply(&mut self, reply: Option<Reply>) {
        let d = self.driver();
        let finding = match reply {
            None => Some(Finding::Missing),
            Some(r) if r.is_silent() => Some(Finding::Missing),
            Some(r) => match check_drv_status(r.data) {
                Some(f) => Some(f),
                None if r.status & STATUS_RESET != 0 => Some(Finding::Reset),
                None if r.status & STATUS_DRIVER_ERROR != 0 && !self.follow_up => {
                    // the data predates the error: read this driver again
                    self.follow_up = true;
                    return;
                }
                None if r.status & STATUS_DRIVER_ERROR != 0 => Some(Finding::DriverError),
                None => None,
            },
        };
        self.follow_up = false;
        if let Some(slot) = self.active.get_mut(d) {
            if !self.failed_boot.get(d).copied().unwrap_or(false) {
                *slot = finding;
            }
        }
        self.next = match d.checked_add(1) {
            Some(n) if n < DRIVERS => n as u8,
            _ => 0,
        };
    }

    /// The first driver (J1 first) whose latest answer (or boot check)
    /// showed a problem, and the problem.
    pub fn fault(&self) -> Option<(u8, Finding)> {
        self.active.iter().enumerate().find_map(|(i, f)| f.map(|f| (i as u8, f)))
    }
}

/// `LPSPI_CCR[SCKDIV]` for an SCK of `sck_hz` from a functional clock of
/// `clk_hz` with the prescaler at /1: SCK = clk / (SCKDIV + 2). The
/// division must be exact and SCKDIV fit its 8 bits.
pub const fn lpspi_sckdiv(clk_hz: u32, sck_hz: u32) -> Option<u8> {
    let (Some(div), Some(0)) = (clk_hz.checked_div(sck_hz), clk_hz.checked_rem(sck_hz)) else {
        return None;
    };
    match div.checked_sub(2) {
        Some(v) if v <= 255 => Some(v as u8),
        _ => None,
    }
}

/// LPSPI functional clock (teensy4-bsp: PLL2 528 MHz / 4).
pub const LPSPI_CLK_HZ: u32 = 132_000_000;
/// SCK: 2 MHz, half the TMC5160's limit with its internal clock, for
/// margin on the cable to the drivers.
pub const SCK_HZ: u32 = 2_000_000;
/// `CCR[SCKDIV]` for [`SCK_HZ`].
pub const SCKDIV: u8 = match lpspi_sckdiv(LPSPI_CLK_HZ, SCK_HZ) {
    Some(v) => v,
    None => panic!("LPSPI SCK divider"),
};
/// One datagram on the wire, in nanoseconds (40 SCK periods).
pub const DATAGRAM_NS: u32 = match DATAGRAM_BITS.checked_mul(1_000_000_000 / SCK_HZ) {
    Some(v) => v,
    None => panic!("datagram time"),
};

#[cfg(test)]
#[allow(clippy::arithmetic_side_effects)]
mod tests {
    use super::*;

    fn reply(status: u8, data: u32) -> Reply {
        Reply { status, data }
    }

    #[test]
    fn datagram_framing_round_trips_through_the_two_fifo_words() {
        let d = Datagram::write(REG_GSTAT, 0xA1B2_C3D4);
        assert_eq!(d.addr, 0x81);
        assert_eq!(d.bits(), 0x81_A1B2_C3D4);
        assert_eq!(d.words(), [0x81A1_B2C3, 0xD4]);
        assert_eq!(Datagram::read(REG_DRV_STATUS).words(), [0x6F00_0000, 0]);
        // a read never sets the write bit, whatever the register byte
        assert_eq!(Datagram::read(0xEF).addr, 0x6F);
        let r = Reply::from_words([0x0330_0000, 0x5A]);
        assert_eq!(r, reply(0x03, 0x3000_005A));
        // upper bits of the second word (not part of the frame) are ignored
        assert_eq!(Reply::from_words([0x0330_0000, 0xFFFF_FF5A]), r);
        for bits in [0u64, 1, 0xFF_FFFF_FFFF, 0x12_3456_789A, 0x80_0000_0001] {
            let d = Datagram { addr: (bits >> 32) as u8, data: bits as u32 };
            let back = Reply::from_words(d.words());
            assert_eq!(back.bits(), bits);
        }
        assert_eq!(FRAMESZ, 39);
    }

    #[test]
    fn silent_line_and_version() {
        assert!(reply(0xFF, 0xFFFF_FFFF).is_silent());
        assert!(reply(0, 0).is_silent());
        assert!(!reply(0x01, 0x3000_0000).is_silent());
        assert_eq!(check_ioin(reply(0xFF, 0xFFFF_FFFF)), Some(Finding::Missing));
        assert_eq!(check_ioin(reply(0, 0)), Some(Finding::Missing));
        assert_eq!(check_ioin(reply(0x01, 0x3000_0051)), None);
        // a TMC5130 (VERSION 0x11), a TMC2130 (0x11) or a TMC2160 (0x30 is
        // shared with the TMC2160: the datagram cannot tell them apart)
        assert_eq!(check_ioin(reply(0x01, 0x1100_0051)), Some(Finding::WrongVersion));
        assert_eq!(check_ioin(reply(0x01, 0x3100_0000)), Some(Finding::WrongVersion));
    }

    #[test]
    fn gstat_and_drv_status_decode() {
        assert_eq!(check_gstat(GSTAT_RESET), None);
        assert_eq!(check_gstat(GSTAT_RESET | GSTAT_DRV_ERR), Some(Finding::DriverError));
        assert_eq!(check_gstat(GSTAT_UV_CP), Some(Finding::ChargePump));
        assert_eq!(check_drv_status(0), None);
        // standstill, stallGuard, prewarning, current and SG_RESULT bits are
        // not faults
        assert_eq!(check_drv_status((1 << 31) | DRV_STALLGUARD | DRV_OTPW | (31 << 16) | 0x3FF), None);
        assert_eq!(check_drv_status(DRV_OT | DRV_OTPW), Some(Finding::Overtemperature));
        assert_eq!(check_drv_status(DRV_S2GA), Some(Finding::ShortToGround));
        assert_eq!(check_drv_status(DRV_S2GB), Some(Finding::ShortToGround));
        assert_eq!(check_drv_status(DRV_S2VSA), Some(Finding::ShortToSupply));
        assert_eq!(check_drv_status(DRV_S2VSB), Some(Finding::ShortToSupply));
        assert_eq!(check_drv_status(DRV_OLA), Some(Finding::OpenLoad));
        assert_eq!(check_drv_status(DRV_OLB), Some(Finding::OpenLoad));
        // priority: overtemperature names the shutdown even with a short
        assert_eq!(check_drv_status(DRV_OT | DRV_S2GA | DRV_OLA), Some(Finding::Overtemperature));
        assert_eq!(check_drv_status(DRV_S2GA | DRV_OLB), Some(Finding::ShortToGround));
        // reserved bits: not a driver
        assert_eq!(check_drv_status(1 << 10), Some(Finding::Missing));
        assert_eq!(check_drv_status(1 << 22), Some(Finding::Missing));
    }

    /// The answers a healthy TMC5160 gives to the boot sequence.
    fn healthy() -> [Reply; 5] {
        [
            reply(0x01, 0),                 // whatever was asked before
            reply(0x01, 0x3000_0051),       // IOIN
            reply(0x01, GSTAT_RESET),       // GSTAT (power-on reset flag)
            reply(0x00, 0x07),              // (the write)
            reply(0x08, (1 << 31) | 0x123), // DRV_STATUS: standstill
        ]
    }

    #[test]
    fn boot_verdict_names_each_problem() {
        assert_eq!(boot_verdict(&healthy()), None);
        assert_eq!(boot_verdict(&[reply(0xFF, 0xFFFF_FFFF); 5]), Some(Finding::Missing));
        assert_eq!(boot_verdict(&[reply(0, 0); 5]), Some(Finding::Missing));
        let mut r = healthy();
        r[1].data = 0x1100_0051;
        assert_eq!(boot_verdict(&r), Some(Finding::WrongVersion));
        let mut r = healthy();
        r[2].data = GSTAT_RESET | GSTAT_DRV_ERR;
        assert_eq!(boot_verdict(&r), Some(Finding::DriverError));
        let mut r = healthy();
        r[2].data = GSTAT_UV_CP;
        assert_eq!(boot_verdict(&r), Some(Finding::ChargePump));
        let mut r = healthy();
        r[4].data |= DRV_OT;
        assert_eq!(boot_verdict(&r), Some(Finding::Overtemperature));
        let mut r = healthy();
        r[4].data |= DRV_OLA;
        assert_eq!(boot_verdict(&r), Some(Finding::OpenLoad));
        let mut r = healthy();
        r[4].status |= STATUS_RESET;
        assert_eq!(boot_verdict(&r), Some(Finding::Reset));
        let mut r = healthy();
        r[4].status |= STATUS_DRIVER_ERROR;
        assert_eq!(boot_verdict(&r), Some(Finding::DriverError));
        // the line fell silent after IOIN
        let mut r = healthy();
        r[4] = reply(0xFF, 0xFFFF_FFFF);
        assert_eq!(boot_verdict(&r), Some(Finding::Missing));
    }

    #[test]
    fn boot_sequence_reads_ioin_gstat_and_drv_status() {
        let addrs = BOOT_SEQUENCE.map(|d| d.addr);
        assert_eq!(addrs, [0x04, 0x01, 0x81, 0x6F, 0x6F]);
        assert_eq!(BOOT_SEQUENCE[2].data, 7);
    }

    const OK: Reply = Reply { status: 0x08, data: 1 << 31 };

    #[test]
    fn monitor_visits_every_driver_in_turn() {
        let mut m = Monitor::after_boot([None; DRIVERS]);
        let mut seen = [0usize; 12];
        for s in seen.iter_mut() {
            *s = m.driver();
            m.on_reply(Some(OK));
        }
        assert_eq!(seen, [0, 1, 2, 3, 4, 5, 0, 1, 2, 3, 4, 5]);
        assert_eq!(m.fault(), None);
    }

    #[test]
    fn monitor_latches_a_drv_status_fault_until_a_clean_answer() {
        let mut m = Monitor::after_boot([None; DRIVERS]);
        m.on_reply(Some(OK)); // J1
        m.on_reply(Some(OK)); // J2
        m.on_reply(Some(reply(0x00, DRV_OLB))); // J3
        assert_eq!(m.fault(), Some((2, Finding::OpenLoad)));
        for _ in 0..5 {
            m.on_reply(Some(OK));
            assert_eq!(m.fault(), Some((2, Finding::OpenLoad)));
        }
        assert_eq!(m.driver(), 2);
        m.on_reply(Some(OK));
        assert_eq!(m.fault(), None);
    }

    #[test]
    fn monitor_follows_up_a_driver_error_to_name_it() {
        let mut m = Monitor::after_boot([None; DRIVERS]);
        for _ in 0..3 {
            m.on_reply(Some(OK));
        }
        // J4: the status flags the error, the (older) data does not say why
        m.on_reply(Some(reply(STATUS_DRIVER_ERROR, 0)));
        assert_eq!(m.fault(), None);
        assert_eq!(m.driver(), 3, "the same driver is read again");
        m.on_reply(Some(reply(STATUS_DRIVER_ERROR, DRV_OT)));
        assert_eq!(m.fault(), Some((3, Finding::Overtemperature)));
        assert_eq!(m.driver(), 4);
        // an error the fresh data does not explain either is DRV_ERR
        let mut m = Monitor::after_boot([None; DRIVERS]);
        m.on_reply(Some(reply(STATUS_DRIVER_ERROR, 0)));
        m.on_reply(Some(reply(STATUS_DRIVER_ERROR, 0)));
        assert_eq!(m.fault(), Some((0, Finding::DriverError)));
    }

    #[test]
    fn monitor_reports_silence_reset_and_incomplete_transfers() {
        let mut m = Monitor::after_boot([None; DRIVERS]);
        m.on_reply(Some(reply(0xFF, 0xFFFF_FFFF)));
        assert_eq!(m.fault(), Some((0, Finding::Missing)));
        m.on_reply(None);
        assert_eq!(m.fault(), Some((0, Finding::Missing)));
        let mut m = Monitor::after_boot([None; DRIVERS]);
        m.on_reply(Some(OK));
        m.on_reply(Some(reply(STATUS_RESET, 0)));
        assert_eq!(m.fault(), Some((1, Finding::Reset)));
    }

    #[test]
    fn a_failed_boot_check_stays_reported_for_the_run() {
        let mut v = [None; DRIVERS];
        v[5] = Some(Finding::WrongVersion);
        let mut m = Monitor::after_boot(v);
        assert_eq!(m.fault(), Some((5, Finding::WrongVersion)));
        for _ in 0..12 {
            m.on_reply(Some(OK));
        }
        assert_eq!(m.fault(), Some((5, Finding::WrongVersion)));
    }

    #[test]
    fn sck_divider() {
        assert_eq!(SCKDIV, 64);
        assert_eq!(LPSPI_CLK_HZ / (u32::from(SCKDIV) + 2), SCK_HZ);
        assert_eq!(lpspi_sckdiv(132_000_000, 4_000_000), Some(31));
        assert_eq!(lpspi_sckdiv(132_000_000, 5_000_000), None, "not exact");
        assert_eq!(lpspi_sckdiv(132_000_000, 100_000), None, "beyond 8 bits");
        assert_eq!(lpspi_sckdiv(132_000_000, 0), None);
        assert_eq!(DATAGRAM_NS, 20_000);
    }
}
