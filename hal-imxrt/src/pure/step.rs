//! Step-rate -> FlexPWM submodule programming (period, prescaler, pulse).
//!
//! A FlexPWM submodule counts the IPG clock (150 MHz) divided by
//! `2^prescaler_log2` (`SMCTRL[PRSC]`, 0..=7) from `INIT = 0` to
//! `VAL1 = period - 1`; the output goes high at `VAL2 = 0` (A) / `VAL4 = 0`
//! (B) and low at `VAL3` / `VAL5 = pulse`. One STEP pulse per period.
//!
//! Rates are signed milli-steps per second (`i32`, +-2.1 Msteps/s range) so the
//! sub-step/s resolution of slow moves is not lost; the sign is the direction.
//! The prescaler is the smallest that lets the period fit in 16 bits, which
//! maximises resolution: the rounding error of the period is at most half a
//! count, i.e. a relative rate error `<= 1 / (2 * period)`; with the smallest
//! prescaler `period >= 32768` unless the prescaler is 1, so the error is
//! `<= 15 ppm` below 2289 steps/s and `<= 0.5 / (150e6 / rate)` above (0.04 %
//! at 120 ksteps/s).

/// Step direction (what the DIR pin is set to; polarity per axis is the
/// kernel's configuration).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// Positive rate: DIR pin high.
    Positive,
    /// Negative rate: DIR pin low.
    Negative,
}

/// What to program into one axis' step generator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StepCommand {
    /// No pulses (output masked low).
    Stop,
    /// Generate pulses.
    Run(StepTiming),
}

/// Timer programming for a running axis.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StepTiming {
    /// Direction.
    pub dir: Direction,
    /// `SMCTRL[PRSC]`: timer clock = IPG / 2^prescaler_log2.
    pub prescaler_log2: u8,
    /// Period in timer counts (`VAL1 = period - 1`), 2..=65535... see config.
    pub period: u16,
    /// High time in timer counts (`VAL3`).
    pub pulse: u16,
}

/// Step generator configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StepConfig {
    /// Timer input clock (IPG), Hz.
    pub timer_hz: u32,
    /// STEP high time, ns (TMC5160 needs >= ~100 ns; 1 us is generous and
    /// also suits opto-isolated inputs).
    pub pulse_ns: u32,
    /// Minimum low time, ns.
    pub min_low_ns: u32,
    /// Rates with |rate| below this are `Stop`, milli-steps/s.
    pub min_rate_mhz: u32,
    /// A stopped output starts only at |rate| >= this, milli-steps/s
    /// (hysteresis above `min_rate_mhz`, see [`plan_update`]).
    pub start_rate_mhz: u32,
    /// Rates with |rate| above this are refused, milli-steps/s.
    pub max_rate_mhz: u32,
}

impl StepConfig {
    /// 150 MHz timer, 1 us pulses, 1 us minimum low time, stop below
    /// 20 steps/s (>= the 17.9 steps/s hardware minimum), start again only
    /// from 25 steps/s (a 5 steps/s hysteresis band: a rate dithering around
    /// the stop threshold by less than that stops and starts at most once),
    /// refuse above 200 ksteps/s. J3 needs 6 rad/s * 18431.6 = 110.6 ksteps/s.
    pub const DEFAULT: StepConfig = StepConfig {
        timer_hz: 150_000_000,
        pulse_ns: 1_000,
        min_low_ns: 1_000,
        min_rate_mhz: 20_000,
        start_rate_mhz: 25_000,
        max_rate_mhz: 200_000_000,
    };

    /// Lowest rate the hardware can generate (prescaler 128, period 65535),
    /// milli-steps/s, rounded up.
    // Cannot overflow: 1 000 times a u32 fits a u64; the divisor is a constant.
    #[allow(clippy::arithmetic_side_effects)]
    pub const fn hardware_min_rate_mhz(&self) -> u32 {
        let den = 128u64 * 65_535;
        ((self.timer_hz as u64 * 1000).div_ceil(den)) as u32
    }

    /// Highest rate that keeps the pulse and low times at prescaler 1,
    /// milli-steps/s.
    // Cannot overflow: the sum of two u32 values and 1 000 times a u32 fit a
    // u64; period is checked non-zero.
    #[allow(clippy::arithmetic_side_effects)]
    pub const fn hardware_max_rate_mhz(&self) -> u32 {
        let pulse = counts_ceil(self.pulse_ns, self.timer_hz) as u64;
        let low = counts_ceil(self.min_low_ns, self.timer_hz) as u64;
        let period = pulse + low;
        if period == 0 {
            return 0;
        }
        let r = self.timer_hz as u64 * 1000 / period;
        if r > u32::MAX as u64 {
            u32::MAX
        } else {
            r as u32
        }
    }

    /// Configured limits are inside what the hardware can do.
    pub const fn is_valid(&self) -> bool {
        self.timer_hz > 0
            && self.pulse_ns > 0
            && self.min_rate_mhz >= self.hardware_min_rate_mhz()
            && self.max_rate_mhz <= self.hardware_max_rate_mhz()
            && self.min_rate_mhz < self.max_rate_mhz
            && self.start_rate_mhz >= self.min_rate_mhz
            && self.start_rate_mhz <= self.max_rate_mhz
    }

    /// Longest period (timer-clock counts times the prescaler divisor) a
    /// stopped output may start with: the period of `start_rate_mhz`.
    // Cannot overflow: 1 000 times a u32 fits a u64; start_rate_mhz is checked
    // non-zero.
    #[allow(clippy::arithmetic_side_effects)]
    pub const fn start_max_ticks(&self) -> u64 {
        if self.start_rate_mhz == 0 {
            return u64::MAX;
        }
        self.timer_hz as u64 * 1000 / self.start_rate_mhz as u64
    }
}

const _: () = assert!(StepConfig::DEFAULT.is_valid());

// Cannot overflow: a u32 times a u32 fits a u64; the divisor is a constant.
#[allow(clippy::arithmetic_side_effects)]
const fn counts_ceil(ns: u32, hz: u32) -> u32 {
    let c = (ns as u64 * hz as u64).div_ceil(1_000_000_000);
    if c > u16::MAX as u64 {
        u16::MAX as u32
    } else {
        c as u32
    }
}

/// Step-rate errors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StepRateError {
    /// |rate| above the configured maximum; the kernel's limits are
    /// inconsistent with the HAL's (it must never ask for this).
    AboveMax,
    /// Configuration not valid (see [`StepConfig::is_valid`]).
    BadConfig,
}

/// Signed rate (milli-steps/s) -> step generator command: checks `cfg`
/// ([`StepPlan::new`]) and converts ([`StepPlan::command`]). The tick uses
/// a `StepPlan` built once, at compile time, and pays for no check and no
/// division.
pub const fn step_command(rate_mhz: i32, cfg: &StepConfig) -> Result<StepCommand, StepRateError> {
    match StepPlan::new(cfg) {
        Some(plan) => plan.command(rate_mhz),
        None => Err(StepRateError::BadConfig),
    }
}

/// Largest `max_rate_mhz` a [`StepPlan`] accepts: 2^28 milli-steps/s
/// (268 ksteps/s), so a divisor fits in 28 bits and the period's division
/// runs on the core's 32-bit divider (see [`StepPlan::command`]).
pub const PLAN_MAX_RATE_MHZ: u32 = 1 << 28;

/// A checked [`StepConfig`] with every constant the conversion of a rate
/// needs computed once: [`StepPlan::command`] runs in the tick interrupt
/// with no 64-bit division ([`reference_step_command`], like the C++
/// firmware, divides 64-bit numbers up to 8 times per axis per tick).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StepPlan {
    min_rate_mhz: u32,
    max_rate_mhz: u32,
    /// `timer_hz * 1000`: timer counts per second, times 1000 (the rates
    /// are in milli-steps per second).
    clk_x1000: u64,
    /// `fits[p]`: the smallest rate whose period at prescaler `2^p` fits in
    /// 16 bits (`round(clk_x1000 / (rate 2^p)) <= 65535`); `u32::MAX` if
    /// none does.
    fits: [u32; 8],
    /// STEP high time at each prescaler, timer counts (at least 1).
    pulse: [u16; 8],
}

impl StepPlan {
    /// The plan of the PAROL6 board ([`StepConfig::DEFAULT`]).
    pub const DEFAULT: StepPlan = match StepPlan::new(&StepConfig::DEFAULT) {
        Some(p) => p,
        None => panic!("StepConfig::DEFAULT is not valid"),
    };

    /// `None` if `cfg` is not valid ([`StepConfig::is_valid`]) or its
    /// maximum rate is not below [`PLAN_MAX_RATE_MHZ`].
    // Cannot overflow: clk_x1000 < 2^42; lo <= mid < hi <= PLAN_MAX_RATE_MHZ in
    // the binary search; p < 8.
    #[allow(clippy::arithmetic_side_effects)]
    pub const fn new(cfg: &StepConfig) -> Option<StepPlan> {
        if !cfg.is_valid() || cfg.max_rate_mhz >= PLAN_MAX_RATE_MHZ {
            return None;
        }
        let clk_x1000 = cfg.timer_hz as u64 * 1000;
        let mut fits = [u32::MAX; 8];
        let mut pulse = [1u16; 8];
        let mut p = 0;
        while p < 8 {
            // The period at prescaler 2^p fits iff
            // clk + den / 2 < den * 65536 with den = rate * 2^p, which is
            // monotone in the rate: binary search for the smallest rate.
            let (mut lo, mut hi) = (1u64, PLAN_MAX_RATE_MHZ as u64);
            if period_fits(clk_x1000, hi << p) {
                while lo < hi {
                    let mid = lo + (hi - lo) / 2;
                    if period_fits(clk_x1000, mid << p) {
                        hi = mid;
                    } else {
                        lo = mid + 1;
                    }
                }
                fits[p] = lo as u32;
            }
            let c = counts_ceil(cfg.pulse_ns, cfg.timer_hz >> p);
            pulse[p] = if c == 0 { 1 } else { c as u16 };
            p += 1;
        }
        Some(StepPlan { min_rate_mhz: cfg.min_rate_mhz, max_rate_mhz: cfg.max_rate_mhz, clk_x1000, fits, pulse })
    }

    /// Signed rate (milli-steps/s) -> step generator command; exactly
    /// [`reference_step_command`]'s result (checked for every rate by
    /// `proofs/exhaustive`), with the prescaler chosen by comparisons and
    /// the period divided on the 32-bit divider.
    // Cannot overflow: p and k count to at most 8; clk_x1000 < 2^42 and
    // den < 2^28 (stated at den).
    #[allow(clippy::arithmetic_side_effects)]
    pub const fn command(&self, rate_mhz: i32) -> Result<StepCommand, StepRateError> {
        let mag = rate_mhz.unsigned_abs();
        if mag < self.min_rate_mhz {
            return Ok(StepCommand::Stop);
        }
        if mag > self.max_rate_mhz {
            return Err(StepRateError::AboveMax);
        }
        let dir = if rate_mhz > 0 { Direction::Positive } else { Direction::Negative };
        // The smallest prescaler whose period fits: the number of those
        // that do not (the condition is monotone in the prescaler).
        let mut p = 0usize;
        let mut k = 0;
        while k < 8 {
            p += (mag < self.fits[k]) as usize;
            k += 1;
        }
        if p >= 8 {
            // below the hardware minimum: excluded by is_valid + min_rate
            return Ok(StepCommand::Stop);
        }
        // den = mag 2^p < 2^28: mag <= max < 2^28 at p = 0; for p > 0 the
        // period at 2^(p-1) did not fit, so den <= 2 clk / 65535.5 (4.6e6
        // for a 150 MHz timer, below 1.4e8 for any 32-bit timer clock).
        let den = (mag as u64) << p;
        let Some(period) = div_u16(self.clk_x1000 + den / 2, den) else {
            return Err(StepRateError::AboveMax);
        };
        let pulse = self.pulse[p];
        if period < 2 || pulse >= period {
            // cannot happen for a valid config and mag <= max
            return Err(StepRateError::AboveMax);
        }
        Ok(StepCommand::Run(StepTiming { dir, prescaler_log2: p as u8, period, pulse }))
    }
}

/// `clk + den / 2 < den * 65536`: the rounded period `(clk + den/2) / den`
/// is at most 65535.
// Cannot overflow for a StepPlan's arguments: clk < 2^42 and den is a rate
// up to PLAN_MAX_RATE_MHZ (2^28) times at most 2^7, so den << 16 <= 2^51.
#[allow(clippy::arithmetic_side_effects)]
const fn period_fits(clk: u64, den: u64) -> bool {
    clk + den / 2 < den << 16
}

/// `n / d` for a quotient below 2^16 and `d` below 2^28, on the 32-bit
/// divider: the high part `n >> 16` is below `d` (the quotient fits), and
/// each of four steps divides a 32-bit value (`r << 4`, `r < d < 2^28`) for
/// four more quotient bits. `None` if the preconditions do not hold (never
/// for a [`StepPlan`]'s arguments). Written by hand: no crate offers a
/// 64-by-32 division on ARMv7-M, and compiler-builtins' `__aeabi_uldivmod`
/// is a 64-by-64 loop.
// Cannot overflow: k counts down from 4 to 0; t = r << 4 | nibble with
// r < d < 2^28 fits a u32, qd * d <= t, and q gains four bits per step up
// to 16 (see the doc comment).
#[allow(clippy::arithmetic_side_effects)]
const fn div_u16(n: u64, d: u64) -> Option<u16> {
    if d == 0 || d >= 1 << 28 || (n >> 16) >= d {
        return None;
    }
    let d = d as u32;
    let lo = (n & 0xffff) as u32;
    let mut r = (n >> 16) as u32;
    let mut q = 0u32;
    let mut k = 4;
    while k > 0 {
        k -= 1;
        let t = (r << 4) | ((lo >> (4 * k)) & 0xf);
        let Some(qd) = t.checked_div(d) else {
            return None;
        };
        r = t - qd * d;
        q = (q << 4) | qd;
    }
    Some(q as u16)
}

/// The straightforward conversion (a 64-bit division per prescaler tried):
/// the reference [`StepPlan::command`] is checked against.
// Cannot overflow: mag < 2^31 times 2^p (p <= 7) and 1 000 times a u32 fit
// a u64; p counts to 8.
#[allow(clippy::arithmetic_side_effects)]
pub const fn reference_step_command(rate_mhz: i32, cfg: &StepConfig) -> Result<StepCommand, StepRateError> {
    if !cfg.is_valid() {
        return Err(StepRateError::BadConfig);
    }
    let mag = rate_mhz.unsigned_abs();
    if mag < cfg.min_rate_mhz {
        return Ok(StepCommand::Stop);
    }
    if mag > cfg.max_rate_mhz {
        return Err(StepRateError::AboveMax);
    }
    let dir = if rate_mhz > 0 { Direction::Positive } else { Direction::Negative };
    // ideal period in timer-clock counts, x1000 for milli-steps
    let clk_x1000 = cfg.timer_hz as u64 * 1000;
    let mut p: u8 = 0;
    while p <= 7 {
        let den = mag as u64 * (1u64 << p);
        let Some(period) = (clk_x1000 + den / 2).checked_div(den) else {
            return Ok(StepCommand::Stop);
        };
        if period <= 65_535 {
            let pulse = counts_ceil(cfg.pulse_ns, cfg.timer_hz >> p);
            let pulse = if pulse == 0 { 1 } else { pulse };
            if period < 2 || pulse as u64 >= period {
                return Err(StepRateError::AboveMax);
            }
            return Ok(StepCommand::Run(StepTiming {
                dir,
                prescaler_log2: p,
                period: period as u16,
                pulse: pulse as u16,
            }));
        }
        p += 1;
    }
    Ok(StepCommand::Stop)
}

/// Rate (milli-steps/s, signed) that a command actually produces.
// Cannot overflow: a u16 period times 2^7 and 1 000 times a u32 fit a u64;
// den is checked non-zero; the rate is below 2^42, so its negation fits an
// i64.
#[allow(clippy::arithmetic_side_effects)]
pub const fn achieved_rate_mhz(cmd: &StepCommand, cfg: &StepConfig) -> i64 {
    match cmd {
        StepCommand::Stop => 0,
        StepCommand::Run(t) => {
            let den = t.period as u64 * (1u64 << t.prescaler_log2);
            if den == 0 {
                return 0;
            }
            let r = ((cfg.timer_hz as u64 * 1000 + den / 2) / den) as i64;
            match t.dir {
                Direction::Positive => r,
                Direction::Negative => -r,
            }
        }
    }
}

/// Compare values of one period: the counter runs `0..=val1` and the
/// output is high from the `on` compare to the `off` compare.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Compares {
    /// `VAL1` (period - 1).
    pub val1: u16,
    /// `VAL2` / `VAL4`: rising edge.
    pub on: u16,
    /// `VAL3` / `VAL5`: falling edge.
    pub off: u16,
}

/// The pulse sits at the **end** of each period (twin defect 4): high
/// from count `period - 1 - pulse` to `period - 1`. A (re)started counter
/// therefore gives its first rising edge one period (minus the pulse) after
/// the start, never at once, and a Stop within the first period emits no
/// pulse at all. Each period still holds exactly one pulse of `pulse`
/// counts, and a retime loads `VAL1`/`on`/`off` together at a reload.
pub const fn compares(t: &StepTiming) -> Compares {
    let val1 = t.period.saturating_sub(1);
    Compares { val1, on: val1.saturating_sub(t.pulse), off: val1 }
}

/// Timer-clock counts of one period (`period * 2^prescaler`).
pub const fn period_ticks(t: &StepTiming) -> u64 {
    (t.period as u64) << (t.prescaler_log2 & 7)
}

/// What an axis' step output is doing (as last programmed).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AxisOutput {
    /// Pulses enabled.
    pub running: bool,
    /// Level last written to DIR (`None` before the first write).
    pub dir: Option<Direction>,
}

impl AxisOutput {
    /// Stopped, DIR never written.
    pub const INIT: AxisOutput = AxisOutput { running: false, dir: None };
}

/// How to get from the current output to a new command.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UpdatePlan {
    /// Stopped and stays stopped: nothing to do.
    Idle,
    /// Mask the output now (running -> stop).
    Halt,
    /// Same direction, already running: write the buffered period/pulse and
    /// set LDOK; takes effect at the next period boundary (no runt pulse).
    Retime(StepTiming),
    /// (Re)start from a masked output: if `dir_change`, write DIR and wait
    /// the settle time first; then restart the counter so the first rising
    /// edge comes after the settle time.
    Restart {
        /// New timing.
        timing: StepTiming,
        /// DIR must be written (and settled) before the first edge.
        dir_change: bool,
    },
}

/// Plan one axis update; returns the plan and the resulting state. A
/// direction reversal while running masks first (a pulse in flight may be
/// truncated: at most one step lost, which the encoder loop absorbs) and
/// then restarts, so no STEP edge ever follows a DIR change by less than the
/// settle time.
///
/// Stop/run hysteresis (twin defect 4): [`step_command`] stops below
/// `cfg.min_rate_mhz`; a **stopped** output starts only when the commanded
/// period is at most [`StepConfig::start_max_ticks`] (|rate| >=
/// `cfg.start_rate_mhz`), otherwise it stays stopped (`Idle`). A running
/// output keeps running down to `min_rate_mhz`.
pub const fn plan_update(state: AxisOutput, cmd: StepCommand, cfg: &StepConfig) -> (UpdatePlan, AxisOutput) {
    match cmd {
        StepCommand::Run(t) if !state.running && period_ticks(&t) > cfg.start_max_ticks() => {
            (UpdatePlan::Idle, AxisOutput { running: false, dir: state.dir })
        }
        StepCommand::Stop => {
            let plan = if state.running { UpdatePlan::Halt } else { UpdatePlan::Idle };
            (plan, AxisOutput { running: false, dir: state.dir })
        }
        StepCommand::Run(t) => {
            let same_dir = matches!(
                (state.dir, t.dir),
                (Some(Direction::Positive), Direction::Positive) | (Some(Direction::Negative), Direction::Negative)
            );
            let plan = if state.running && same_dir {
                UpdatePlan::Retime(t)
            } else {
                UpdatePlan::Restart { timing: t, dir_change: !same_dir }
            };
            (plan, AxisOutput { running: true, dir: Some(t.dir) })
        }
    }
}

// Test code is built with overflow checks on: an overflow fails the test.
#[cfg(test)]
#[allow(clippy::arithmetic_side_effects)]
mod tests {
    use super::*;
    const CFG: StepConfig = StepConfig::DEFAULT;

    fn rel_err_ppm(want: i32, got: i64) -> u64 {
        ((got - want as i64).unsigned_abs() * 1_000_000) / want.unsigned_abs() as u64
    }

    #[test]
    fn the_plan_equals_the_reference_near_every_prescaler_boundary() {
        extern crate std;
        use std::vec;
        use std::vec::Vec;
        // Sampled here (every rate is compared by `proofs/exhaustive`):
        // both sides of each prescaler's threshold, the limits, a stride.
        let plan = StepPlan::DEFAULT;
        let mut rates: Vec<i32> = vec![0, 1, -1, i32::MAX, i32::MIN, 19_999, 20_000, 200_000_000, 200_000_001];
        for f in plan.fits {
            if f < u32::MAX {
                for d in -3i64..=3 {
                    rates.push((i64::from(f) + d) as i32);
                }
            }
        }
        rates.extend((20_000..200_000_000).step_by(99_991));
        for r in rates.clone() {
            rates.push(r.saturating_neg());
        }
        for r in rates {
            assert_eq!(plan.command(r), reference_step_command(r, &CFG), "rate {r}");
        }
    }

    #[test]
    fn the_division_is_exact_or_refused() {
        assert_eq!(div_u16(150_000_000_000 + 2_500_000, 5_000_000), Some(30_000));
        assert_eq!(div_u16(150_000_000_000 + 1_000_000, 2_000_000), None); // 75,000 does not fit
        assert_eq!(div_u16(65_535 * 7 + 6, 7), Some(65_535));
        assert_eq!(div_u16(65_536 * 7, 7), None); // quotient does not fit
        assert_eq!(div_u16(5, 0), None);
        assert_eq!(div_u16(5, 1 << 28), None);
    }

    #[test]
    fn hardware_limits() {
        // 150e6 / 128 / 65535 = 17.88 steps/s
        assert_eq!(CFG.hardware_min_rate_mhz(), 17_882);
        // 1 us + 1 us at 150 MHz = 300 counts -> 500 ksteps/s
        assert_eq!(CFG.hardware_max_rate_mhz(), 500_000_000);
        assert!(CFG.is_valid());
    }

    #[test]
    fn stop_below_min_and_zero() {
        assert_eq!(step_command(0, &CFG), Ok(StepCommand::Stop));
        assert_eq!(step_command(19_999, &CFG), Ok(StepCommand::Stop));
        assert_eq!(step_command(-19_999, &CFG), Ok(StepCommand::Stop));
        assert!(matches!(step_command(20_000, &CFG), Ok(StepCommand::Run(_))));
    }

    #[test]
    fn refuses_above_max() {
        assert_eq!(step_command(200_000_001, &CFG), Err(StepRateError::AboveMax));
        assert_eq!(step_command(i32::MIN, &CFG), Err(StepRateError::AboveMax));
    }

    #[test]
    fn joint_max_rates_are_reachable() {
        // J2 3 rad/s * 20371.83, J3 6 rad/s * 18431.62 steps/rad
        for sps in [61_116i32, 110_590] {
            let cmd = step_command(sps * 1000, &CFG).unwrap();
            assert!(matches!(cmd, StepCommand::Run(_)));
        }
    }

    #[test]
    fn round_trip_error_bounded() {
        let mut rate: i64 = 20_000;
        while rate <= 200_000_000 {
            for sign in [1i64, -1] {
                let r = (rate * sign) as i32;
                let cmd = step_command(r, &CFG).unwrap();
                let StepCommand::Run(t) = cmd else { panic!("stop at {r}") };
                assert_eq!(t.dir == Direction::Positive, r > 0);
                let got = achieved_rate_mhz(&cmd, &CFG);
                // half a count of the period, plus rounding of the result
                // plus rounding of the achieved rate to whole milli-steps/s
                let bound = 1_000_000 / (2 * t.period as u64) + 500_000 / rate as u64 + 1;
                assert!(rel_err_ppm(r, got) <= bound, "rate {r} got {got}");
                // resolution: smallest prescaler => period > 32767 unless p=0
                assert!(t.prescaler_log2 == 0 || t.period > 32_767);
                assert!(t.pulse < t.period);
                // pulse >= 1 us
                let pulse_ns = t.pulse as u64 * (1u64 << t.prescaler_log2) * 1_000_000_000 / CFG.timer_hz as u64;
                assert!(pulse_ns >= 1_000 - 7);
            }
            rate = rate * 11 / 10 + 1;
        }
    }

    #[test]
    fn bad_config_refused() {
        let bad = StepConfig { min_rate_mhz: 1_000, ..CFG };
        assert_eq!(step_command(50_000, &bad), Err(StepRateError::BadConfig));
    }

    #[test]
    fn update_planning() {
        let t = |dir| StepTiming { dir, prescaler_log2: 0, period: 1500, pulse: 150 };
        use Direction::*;
        let (p, s) = plan_update(AxisOutput::INIT, StepCommand::Stop, &CFG);
        assert_eq!((p, s), (UpdatePlan::Idle, AxisOutput::INIT));
        // first start always writes DIR
        let (p, s) = plan_update(AxisOutput::INIT, StepCommand::Run(t(Positive)), &CFG);
        assert_eq!(p, UpdatePlan::Restart { timing: t(Positive), dir_change: true });
        // same direction while running: glitch-free retime
        let (p, s) = plan_update(s, StepCommand::Run(t(Positive)), &CFG);
        assert_eq!(p, UpdatePlan::Retime(t(Positive)));
        // reversal while running: restart with DIR settle
        let (p, s) = plan_update(s, StepCommand::Run(t(Negative)), &CFG);
        assert_eq!(p, UpdatePlan::Restart { timing: t(Negative), dir_change: true });
        // stop, then start the same way: no DIR write needed
        let (p, s) = plan_update(s, StepCommand::Stop, &CFG);
        assert_eq!(p, UpdatePlan::Halt);
        assert_eq!(s, AxisOutput { running: false, dir: Some(Negative) });
        let (p, _) = plan_update(s, StepCommand::Run(t(Negative)), &CFG);
        assert_eq!(p, UpdatePlan::Restart { timing: t(Negative), dir_change: false });
    }

    #[test]
    fn pulse_at_the_end_of_each_period() {
        for rate in [20_000i32, 25_000, 1_000_000, 10_000_000, 110_590_000] {
            let StepCommand::Run(t) = step_command(rate, &CFG).unwrap() else { panic!() };
            let c = compares(&t);
            assert_eq!(c.val1, t.period - 1);
            assert_eq!(c.off, c.val1, "falling edge at the reload");
            assert_eq!(c.off - c.on, t.pulse, "pulse width kept");
            // first rising edge no earlier than the minimum low time after a
            // counter start (here: at least half the period)
            assert!(u32::from(c.on) * 2 >= u32::from(t.period) - 2, "{rate}: {c:?}");
        }
    }

    #[test]
    fn stop_run_hysteresis() {
        use Direction::*;
        let run = |mhz: i32| step_command(mhz, &CFG).unwrap();
        assert_eq!(CFG.start_max_ticks(), 6_000_000);
        // stopped: 20..25 steps/s does not start
        for r in [20_000, 22_000, 24_900, -24_900] {
            let (p, s) = plan_update(AxisOutput::INIT, run(r), &CFG);
            assert_eq!(p, UpdatePlan::Idle, "{r}");
            assert!(!s.running);
        }
        // 25 steps/s starts
        let (p, s) = plan_update(AxisOutput::INIT, run(25_000), &CFG);
        assert!(matches!(p, UpdatePlan::Restart { .. }));
        // running: keeps running down to 20 steps/s
        let (p, s) = plan_update(s, run(20_000), &CFG);
        assert!(matches!(p, UpdatePlan::Retime(_)));
        // a rate dithering 19.9 / 20.1 steps/s: one halt, never a restart
        let mut st = s;
        let mut restarts = 0;
        let mut halts = 0;
        for k in 0..1000 {
            let r = if k % 2 == 0 { 19_900 } else { 20_100 };
            let (p, n) = plan_update(st, run(r), &CFG);
            match p {
                UpdatePlan::Restart { .. } => restarts += 1,
                UpdatePlan::Halt => halts += 1,
                _ => {}
            }
            st = n;
        }
        assert_eq!((halts, restarts), (1, 0));
        assert_eq!(st.dir, Some(Positive));
    }

    #[test]
    fn start_threshold_config_checked() {
        assert!(!StepConfig { start_rate_mhz: 19_000, ..CFG }.is_valid());
        assert!(StepConfig { start_rate_mhz: 20_000, ..CFG }.is_valid());
    }
}
