//! LPUART baud-rate divisor search.
//!
//! `baud = clock / (OSR + 1) / SBR` with the oversampling ratio `OSR + 1` in
//! 4..=32 and `SBR` in 1..=8191 (i.MXRT1060 RM, LPUART BAUD register). The
//! search is exhaustive over the 29 ratios (cheap, and done once at init), picks
//! the smallest absolute error and, on ties, the highest oversampling ratio.
//! Written by hand because no maintained `no_std` crate exposes this as a pure
//! function (imxrt-hal has it, but only behind its driver types).

/// Register values for `LPUART_BAUD`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BaudDivisor {
    /// `BAUD[OSR]` field value (oversampling ratio minus one), 3..=31.
    pub osr: u8,
    /// `BAUD[SBR]` field value, 1..=8191.
    pub sbr: u16,
    /// `BAUD[BOTHEDGE]` must be set for oversampling ratios 4..=7.
    pub both_edge: bool,
    /// Baud rate actually produced.
    pub achieved: u32,
    /// Signed error in parts per million, `(achieved - requested) / requested`.
    pub error_ppm: i32,
}

/// Baud search errors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BaudError {
    /// Zero baud or clock, or baud not reachable with any divisor.
    Unreachable,
    /// Best divisor is off by more than the allowed error.
    TooInaccurate,
}

/// Largest acceptable baud error, ppm (1 %, well inside the ~2 % UART budget
/// when both ends are off in opposite directions).
pub const MAX_BAUD_ERROR_PPM: u32 = 10_000;

/// Search `(OSR, SBR)` for `baud` from `clock_hz`.
// Cannot overflow: ratio is 4..=32 in the loop (so ratio - 1 and ratio -= 1
// stay positive), baud and clock_hz are u32 and non-zero (checked first):
// every product of two u32 values fits a u64, den > 0, sbr >= 1 at its
// division, and the ppm product is below 2^33 * 10^6 < 2^63.
#[allow(clippy::arithmetic_side_effects)]
pub const fn lpuart_divisor(clock_hz: u32, baud: u32) -> Result<BaudDivisor, BaudError> {
    if clock_hz == 0 || baud == 0 {
        return Err(BaudError::Unreachable);
    }
    let mut best: Option<BaudDivisor> = None;
    let mut best_err: u64 = u64::MAX;
    let mut ratio: u32 = 32;
    while ratio >= 4 {
        // nearest SBR: round(clock / (ratio * baud))
        let den = ratio as u64 * baud as u64;
        let sbr = (clock_hz as u64 + den / 2) / den;
        if sbr >= 1 && sbr <= 8191 {
            let achieved = clock_hz as u64 / (ratio as u64 * sbr);
            let err = achieved.abs_diff(baud as u64);
            if err < best_err {
                best_err = err;
                let ppm = (achieved as i64 - baud as i64) * 1_000_000 / baud as i64;
                best = Some(BaudDivisor {
                    osr: (ratio - 1) as u8,
                    sbr: sbr as u16,
                    both_edge: ratio < 8,
                    achieved: achieved as u32,
                    error_ppm: ppm as i32,
                });
            }
        }
        ratio -= 1;
    }
    match best {
        None => Err(BaudError::Unreachable),
        Some(b) => {
            if b.error_ppm.unsigned_abs() > MAX_BAUD_ERROR_PPM {
                Err(BaudError::TooInaccurate)
            } else {
                Ok(b)
            }
        }
    }
}

// Test code is built with overflow checks on: an overflow fails the test.
#[cfg(test)]
#[allow(clippy::arithmetic_side_effects)]
mod tests {
    use super::*;
    use crate::pure::clock::{OSC_HZ, PLL3_80M_HZ};

    #[test]
    fn baud_115200_from_24mhz() {
        let d = lpuart_divisor(OSC_HZ, 115_200).unwrap();
        // 24e6 / 208 = 115384.6 -> +0.16 %
        assert_eq!((d.osr as u32 + 1) * d.sbr as u32, 208);
        assert_eq!(d.osr, 25); // ratio 26 (highest ratio with error 0.16 %)
        assert_eq!(d.sbr, 8);
        assert!(!d.both_edge);
        assert!(d.error_ppm.unsigned_abs() < 2_000, "{}", d.error_ppm);
        let check = OSC_HZ / ((d.osr as u32 + 1) * d.sbr as u32);
        assert_eq!(check, d.achieved);
    }

    #[test]
    fn baud_115200_from_80mhz() {
        let d = lpuart_divisor(PLL3_80M_HZ, 115_200).unwrap();
        assert!(d.error_ppm.unsigned_abs() < 1_000, "{}", d.error_ppm);
        let ratio = d.osr as u32 + 1;
        assert!((4..=32).contains(&ratio));
        assert_eq!(d.both_edge, ratio < 8);
        assert_eq!(PLL3_80M_HZ / (ratio * d.sbr as u32), d.achieved);
    }

    #[test]
    fn other_rates_and_errors() {
        for baud in [9_600u32, 57_600, 230_400, 460_800, 1_000_000] {
            let d = lpuart_divisor(OSC_HZ, baud).unwrap();
            assert!(d.error_ppm.unsigned_abs() <= MAX_BAUD_ERROR_PPM);
        }
        assert_eq!(lpuart_divisor(OSC_HZ, 0), Err(BaudError::Unreachable));
        // 24 MHz / 4 / 1 = 6 Mbaud max; 7 Mbaud is unreachable within 1 %
        assert!(lpuart_divisor(OSC_HZ, 7_000_000).is_err());
        // too slow: 24e6 / 32 / 8191 = 91.6 baud minimum
        assert_eq!(lpuart_divisor(OSC_HZ, 50), Err(BaudError::Unreachable));
    }
}
