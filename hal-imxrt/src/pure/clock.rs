//! Clock-tree and divider arithmetic (no registers).
//!
//! The clock tree assumed by this crate (set up by the boot code, not by this
//! crate — see the crate docs):
//!
//! | clock            | frequency  | source                                   |
//! |------------------|------------|------------------------------------------|
//! | ARM core (AHB)   | 600 MHz    | ARM PLL, AHB_PODF = 1                     |
//! | IPG (bus)        | 150 MHz    | AHB / 4 (IPG_PODF = 3)                    |
//! | OSC              | 24 MHz     | crystal                                   |
//! | PERCLK (PIT)     | 24 MHz     | OSC, PERCLK_PODF = /1 (set by `periph::clocks`) |
//! | UART_CLK_ROOT    | 24 MHz     | OSC, UART_CLK_PODF = /1                   |
//! | FlexPWM counters | 150 MHz    | IPG                                       |
//! | QuadTimer        | 18.75 MHz  | IPG / 8 (PCS = 0b1011)                    |
//!
//! PERCLK from the 24 MHz crystal rather than from IPG: the 1 kHz tick then does
//! not depend on the ARM PLL setting, and 24 MHz divides exactly into 1 kHz.

/// Core clock (DWT CYCCNT rate), Hz.
pub const CPU_HZ: u32 = 600_000_000;
/// IPG bus clock, Hz (FlexPWM and QuadTimer source).
pub const IPG_HZ: u32 = 150_000_000;
/// Crystal oscillator, Hz.
pub const OSC_HZ: u32 = 24_000_000;
/// The 80 MHz PLL3 tap that can feed the UART clock root.
pub const PLL3_80M_HZ: u32 = 80_000_000;
/// Control tick rate, Hz.
pub const TICK_HZ: u32 = 1_000;
/// CPU cycles per microsecond (600).
pub const CYCLES_PER_US: u32 = CPU_HZ / 1_000_000;
/// CPU cycles per millisecond (600 000).
pub const CYCLES_PER_MS: u32 = CPU_HZ / 1_000;
/// CPU cycles per control tick (600 000).
pub const CYCLES_PER_TICK: u32 = CPU_HZ / TICK_HZ;
const _: () = assert!(CPU_HZ.is_multiple_of(1_000_000) && CPU_HZ.is_multiple_of(TICK_HZ));

/// Source of PERCLK_CLK_ROOT (CCM_CSCMR1\[PERCLK_CLK_SEL\]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PerclkSource {
    /// IPG clock root (`PERCLK_CLK_SEL = 0`).
    Ipg,
    /// 24 MHz oscillator (`PERCLK_CLK_SEL = 1`).
    Osc,
}

/// PERCLK configuration: source and divider (`PERCLK_PODF` = `divider - 1`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PerclkConfig {
    /// Clock source.
    pub source: PerclkSource,
    /// Divider 1..=64.
    pub divider: u8,
}

/// The PERCLK configuration this crate programs.
pub const PERCLK: PerclkConfig = PerclkConfig { source: PerclkSource::Osc, divider: 1 };

/// Errors of the divider arithmetic.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClockError {
    /// A divider is outside the range the hardware supports.
    DividerOutOfRange,
    /// The requested rate is zero or above the source clock.
    RateOutOfRange,
    /// The source clock is not an exact multiple of the requested rate.
    Inexact,
}

/// PERCLK frequency for a configuration, Hz.
// Cannot overflow: the divider is 1..=64 (checked first).
#[allow(clippy::arithmetic_side_effects)]
pub const fn perclk_hz(cfg: PerclkConfig, ipg_hz: u32, osc_hz: u32) -> Result<u32, ClockError> {
    if cfg.divider == 0 || cfg.divider > 64 {
        return Err(ClockError::DividerOutOfRange);
    }
    let src = match cfg.source {
        PerclkSource::Ipg => ipg_hz,
        PerclkSource::Osc => osc_hz,
    };
    Ok(src / cfg.divider as u32)
}

/// PIT `LDVAL` for an exact `tick_hz` from `timer_hz` (the PIT counts
/// `LDVAL + 1` clocks per period). Refuses rates that do not divide exactly, so
/// the tick period is exactly what the control law assumes.
// Cannot overflow: tick_hz is 1..=timer_hz (checked first), so the quotient
// is at least 1 and the subtraction does not wrap.
#[allow(clippy::arithmetic_side_effects)]
pub const fn pit_load_value(timer_hz: u32, tick_hz: u32) -> Result<u32, ClockError> {
    if tick_hz == 0 || tick_hz > timer_hz {
        return Err(ClockError::RateOutOfRange);
    }
    if !timer_hz.is_multiple_of(tick_hz) {
        return Err(ClockError::Inexact);
    }
    Ok(timer_hz / tick_hz - 1)
}

/// QuadTimer `CTRL[PCS]` value selecting "IP bus clock / `divider`"
/// (`divider` a power of two 1..=128 -> PCS 8..=15).
// Cannot overflow: a power of two up to 128 has at most 7 trailing zeros.
#[allow(clippy::arithmetic_side_effects)]
pub const fn qtimer_pcs_for_divider(divider: u32) -> Result<u16, ClockError> {
    if divider == 0 || divider > 128 || !divider.is_power_of_two() {
        return Err(ClockError::DividerOutOfRange);
    }
    Ok(8 + divider.trailing_zeros() as u16)
}

/// QuadTimer prescaler used for encoder capture (IPG / 8 = 18.75 MHz).
pub const QTIMER_DIVIDER: u32 = 8;
/// QuadTimer count rate, Hz.
pub const QTIMER_HZ: u32 = IPG_HZ / QTIMER_DIVIDER;

/// CPU cycles per QuadTimer tick; must be an integer so the duty ratio can be
/// computed exactly in integers.
// Cannot overflow: each divisor is checked non-zero before its division.
#[allow(clippy::arithmetic_side_effects)]
pub const fn cpu_cycles_per_qtimer_tick(cpu_hz: u32, ipg_hz: u32, divider: u32) -> Result<u32, ClockError> {
    if divider == 0 || ipg_hz == 0 {
        return Err(ClockError::DividerOutOfRange);
    }
    let qt = ipg_hz / divider;
    if qt == 0 || !ipg_hz.is_multiple_of(divider) || !cpu_hz.is_multiple_of(qt) {
        return Err(ClockError::Inexact);
    }
    Ok(cpu_hz / qt)
}

/// CPU cycles per QuadTimer tick for the configured clock tree (32).
pub const CYCLES_PER_QTIMER_TICK: u32 = match cpu_cycles_per_qtimer_tick(CPU_HZ, IPG_HZ, QTIMER_DIVIDER) {
    Ok(v) => v,
    Err(_) => panic!("CPU clock is not an integer multiple of the QuadTimer clock"),
};

/// Number of CPU cycles covering at least `ns` nanoseconds (rounded up).
// Cannot overflow: a u32 times a u32 fits a u64; the divisor is a constant.
#[allow(clippy::arithmetic_side_effects)]
pub const fn ns_to_cycles_ceil(ns: u32, cpu_hz: u32) -> u32 {
    let num = ns as u64 * cpu_hz as u64;
    let c = num.div_ceil(1_000_000_000);
    if c > u32::MAX as u64 {
        u32::MAX
    } else {
        c as u32
    }
}

/// DIR-to-STEP setup time required by the TMC5160 wiring, ns (spec: 1-2 us;
/// 1.5 us gives margin on both sides).
pub const DIR_SETTLE_NS: u32 = 1_500;

/// DIR settle time in CPU cycles (900 at 600 MHz).
pub const fn dir_settle_cycles(settle_ns: u32, cpu_hz: u32) -> u32 {
    ns_to_cycles_ceil(settle_ns, cpu_hz)
}

/// RTWDOG `TOVAL` for a timeout of `timeout_us` with a watchdog clock of
/// `wdog_clk_hz` and optional 256 prescaler. `None` if it does not fit 16 bits
/// or is zero.
// Cannot overflow: a u32 times at most a u32 fits a u64; the divisors are
// non-zero constants.
#[allow(clippy::arithmetic_side_effects)]
pub const fn rtwdog_toval(timeout_us: u32, wdog_clk_hz: u32, prescale_256: bool) -> Option<u16> {
    let clk = if prescale_256 { wdog_clk_hz as u64 / 256 } else { wdog_clk_hz as u64 };
    let t = timeout_us as u64 * clk / 1_000_000;
    if t == 0 || t > u16::MAX as u64 {
        None
    } else {
        Some(t as u16)
    }
}

/// LPO clock feeding RTWDOG when `CS[CLK] = 01`, Hz. The i.MXRT1060 reference
/// manual gives 32 kHz; needs bench confirmation (it is an RC oscillator).
pub const RTWDOG_LPO_HZ: u32 = 32_000;

/// Watchdog timeout: tick stopped for this long => reset (drive removed).
/// 20 ms: 20 missed ticks, well inside the 200 ms stop requirement.
pub const WATCHDOG_TIMEOUT_US: u32 = 20_000;

/// Watchdog window: a refresh earlier than this after the previous one
/// resets the chip (RTWDOG window mode). Half the 1 ms tick period: a tick
/// that runs at more than twice its rate, or a refresh from anywhere but the
/// end of the tick shortly after the tick's own, is caught; the tick's
/// refresh, 1 ms apart, stays valid with the LPO up to 50 % slow.
pub const WATCHDOG_WINDOW_US: u32 = 500;

/// RTWDOG `WIN` for a window of `window_us` (the same clock arithmetic as
/// [`rtwdog_toval`]).
pub const fn rtwdog_win(window_us: u32, wdog_clk_hz: u32, prescale_256: bool) -> Option<u16> {
    rtwdog_toval(window_us, wdog_clk_hz, prescale_256)
}

// The window opens before the next tick and closes (TOVAL) long after it.
const _: () = assert!(WATCHDOG_WINDOW_US < 1_000_000 / TICK_HZ && WATCHDOG_WINDOW_US < WATCHDOG_TIMEOUT_US);

// Test code is built with overflow checks on: an overflow fails the test.
#[cfg(test)]
#[allow(clippy::arithmetic_side_effects)]
mod tests {
    use super::*;

    #[test]
    fn pit_from_osc_is_exact_1khz() {
        let perclk = perclk_hz(PERCLK, IPG_HZ, OSC_HZ).unwrap();
        assert_eq!(perclk, 24_000_000);
        let ld = pit_load_value(perclk, TICK_HZ).unwrap();
        assert_eq!(ld, 23_999);
        // period in timer clocks = LDVAL + 1, exactly 1 ms
        assert_eq!((ld as u64 + 1) * 1_000_000_000 / perclk as u64, 1_000_000);
    }

    #[test]
    fn pit_from_ipg_div2() {
        let cfg = PerclkConfig { source: PerclkSource::Ipg, divider: 2 };
        let perclk = perclk_hz(cfg, IPG_HZ, OSC_HZ).unwrap();
        assert_eq!(pit_load_value(perclk, 1000), Ok(74_999));
    }

    #[test]
    fn pit_rejects_inexact_and_bad() {
        assert_eq!(pit_load_value(24_000_000, 7), Err(ClockError::Inexact));
        assert_eq!(pit_load_value(24_000_000, 0), Err(ClockError::RateOutOfRange));
        let bad = PerclkConfig { source: PerclkSource::Osc, divider: 0 };
        assert_eq!(perclk_hz(bad, IPG_HZ, OSC_HZ), Err(ClockError::DividerOutOfRange));
    }

    #[test]
    fn qtimer_prescaler() {
        assert_eq!(qtimer_pcs_for_divider(1), Ok(8));
        assert_eq!(qtimer_pcs_for_divider(8), Ok(0b1011));
        assert_eq!(qtimer_pcs_for_divider(128), Ok(15));
        assert!(qtimer_pcs_for_divider(3).is_err());
        assert!(qtimer_pcs_for_divider(256).is_err());
        assert_eq!(QTIMER_HZ, 18_750_000);
        assert_eq!(CYCLES_PER_QTIMER_TICK, 32);
    }

    #[test]
    fn dir_settle() {
        assert_eq!(dir_settle_cycles(DIR_SETTLE_NS, CPU_HZ), 900);
        // within the 1..2 us window
        let c = dir_settle_cycles(DIR_SETTLE_NS, CPU_HZ);
        assert!(c >= dir_settle_cycles(1_000, CPU_HZ) && c <= dir_settle_cycles(2_000, CPU_HZ));
        assert_eq!(ns_to_cycles_ceil(1, CPU_HZ), 1);
    }

    #[test]
    fn watchdog_toval() {
        assert_eq!(rtwdog_toval(WATCHDOG_TIMEOUT_US, RTWDOG_LPO_HZ, false), Some(640));
        assert_eq!(rtwdog_toval(10, RTWDOG_LPO_HZ, false), None);
        assert_eq!(rtwdog_toval(10_000_000, RTWDOG_LPO_HZ, false), None);
    }

    #[test]
    fn watchdog_window() {
        // 0.5 ms of the 32 kHz LPO = 16 counts; a 1 ms tick = 32 counts
        assert_eq!(rtwdog_win(WATCHDOG_WINDOW_US, RTWDOG_LPO_HZ, false), Some(16));
        let tick_counts = RTWDOG_LPO_HZ / TICK_HZ;
        assert!(u32::from(rtwdog_win(WATCHDOG_WINDOW_US, RTWDOG_LPO_HZ, false).unwrap_or(u16::MAX)) < tick_counts);
    }
}
