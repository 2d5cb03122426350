//! The last reset's cause, decoded from the SRC's reset status register
//! (`SRC_SRSR`, i.MXRT1062). The register's bits are sticky: the boot reads
//! it once and writes the value back (write-one-to-clear), so the next boot
//! sees only the causes of its own reset. A power-on reset resets the
//! register to `IPP_RESET_B` alone.

/// `IPP_RESET_B`: power-on reset (the power-up sequence or the `POR_B` pin).
pub const POWER_ON: u32 = 1 << 0;
/// `LOCKUP_SYSRESETREQ`: the core locked up, or software requested a
/// system reset (`SYSRESETREQ`); the SRC does not tell the two apart.
pub const LOCKUP_SYSRESETREQ: u32 = 1 << 1;
/// `CSU_RESET_B`: the central security unit's reset.
pub const CSU: u32 = 1 << 2;
/// `IPP_USER_RESET_B`: the qualified user reset input (`ipp_user_reset_b`).
pub const USER: u32 = 1 << 3;
/// `WDOG_RST_B`: WDOG1 or WDOG2 timed out.
pub const WDOG: u32 = 1 << 4;
/// `JTAG_RST_B`: JTAG's reset (`JTAG_TRST_B`).
pub const JTAG: u32 = 1 << 5;
/// `JTAG_SW_RST`: a software reset requested through JTAG.
pub const JTAG_SW: u32 = 1 << 6;
/// `WDOG3_RST_B`: the RTWDOG (WDOG3, the one the image runs) reset the chip.
pub const WDOG3: u32 = 1 << 7;
/// `TEMPSENSE_RST_B`: the temperature sensor's over-temperature reset.
pub const TEMPSENSE: u32 = 1 << 8;

/// Why the chip last reset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResetCause {
    /// Power-on (or `POR_B`), no later cause recorded.
    PowerOn,
    /// A watchdog: the RTWDOG (WDOG3) or WDOG1/WDOG2.
    Watchdog,
    /// A core lockup or a software system-reset request.
    Lockup,
    /// The over-temperature reset.
    Temperature,
    /// JTAG (its reset line or a software reset through it).
    Jtag,
    /// The user reset input.
    User,
    /// The central security unit.
    Security,
    /// No known bit set.
    Unknown,
}

impl ResetCause {
    /// The cause's name on the wire (the boot banner's `reset=` field).
    pub const fn name(self) -> &'static str {
        match self {
            ResetCause::PowerOn => "POWER_ON",
            ResetCause::Watchdog => "WATCHDOG",
            ResetCause::Lockup => "LOCKUP",
            ResetCause::Temperature => "TEMPERATURE",
            ResetCause::Jtag => "JTAG",
            ResetCause::User => "USER",
            ResetCause::Security => "SECURITY",
            ResetCause::Unknown => "UNKNOWN",
        }
    }
}

/// The cause of the last reset from `SRSR`'s value. When several bits are
/// set (a cause recorded on top of a power-on that nothing cleared), the
/// one that says most about a fault wins: a watchdog, then a lockup, then
/// over-temperature, JTAG, the user input, the security unit, and power-on
/// last.
pub const fn decode(srsr: u32) -> ResetCause {
    if srsr & (WDOG3 | WDOG) != 0 {
        ResetCause::Watchdog
    } else if srsr & LOCKUP_SYSRESETREQ != 0 {
        ResetCause::Lockup
    } else if srsr & TEMPSENSE != 0 {
        ResetCause::Temperature
    } else if srsr & (JTAG | JTAG_SW) != 0 {
        ResetCause::Jtag
    } else if srsr & USER != 0 {
        ResetCause::User
    } else if srsr & CSU != 0 {
        ResetCause::Security
    } else if srsr & POWER_ON != 0 {
        ResetCause::PowerOn
    } else {
        ResetCause::Unknown
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_bit_alone_names_its_cause() {
        let cases = [
            (POWER_ON, ResetCause::PowerOn),
            (LOCKUP_SYSRESETREQ, ResetCause::Lockup),
            (CSU, ResetCause::Security),
            (USER, ResetCause::User),
            (WDOG, ResetCause::Watchdog),
            (JTAG, ResetCause::Jtag),
            (JTAG_SW, ResetCause::Jtag),
            (WDOG3, ResetCause::Watchdog),
            (TEMPSENSE, ResetCause::Temperature),
        ];
        for (bit, cause) in cases {
            assert_eq!(decode(bit), cause, "{bit:#x}");
        }
        assert_eq!(decode(0), ResetCause::Unknown);
        // bits the register does not define are ignored
        assert_eq!(decode(0xFFFF_FE00), ResetCause::Unknown);
    }

    #[test]
    fn a_watchdog_beats_every_other_bit_and_power_on_loses_to_every_one() {
        for other in 0..(1u32 << 9) {
            assert_eq!(decode(other | WDOG3), ResetCause::Watchdog, "{other:#x}");
            if other & !POWER_ON != 0 {
                assert_ne!(decode(other | POWER_ON), ResetCause::PowerOn, "{other:#x}");
            }
        }
        assert_eq!(decode(POWER_ON | LOCKUP_SYSRESETREQ), ResetCause::Lockup);
        assert_eq!(decode(LOCKUP_SYSRESETREQ | TEMPSENSE), ResetCause::Lockup);
    }

    #[test]
    fn names_are_distinct_single_tokens() {
        let all = [
            ResetCause::PowerOn,
            ResetCause::Watchdog,
            ResetCause::Lockup,
            ResetCause::Temperature,
            ResetCause::Jtag,
            ResetCause::User,
            ResetCause::Security,
            ResetCause::Unknown,
        ];
        for (i, a) in all.iter().enumerate() {
            assert!(a.name().bytes().all(|b| b.is_ascii_uppercase() || b == b'_'), "{a:?}");
            for b in &all[i + 1..] {
                assert_ne!(a.name(), b.name());
            }
        }
    }
}
