//! The core clock checked against an independent clock: the DWT cycle
//! counter (the ARM PLL, 600 MHz nominal) against a counter on the
//! 32.768 kHz RTC crystal (GPT2 on `ipg_clk_32k`, a different oscillator
//! from the 24 MHz one the PLL multiplies). A PLL that locks at a wrong
//! frequency scales every time constant of the image (the step rates, the
//! encoder frame period in cycles, the cycle-based waits); a deviation above
//! [`TOLERANCE_PERCENT`] is a fault.
//!
//! [`ClockMonitor`] is the whole decision, host-tested: the first window
//! closes [`BOOT_WINDOW_CYCLES`] after the start (the boot self-test runs
//! meanwhile, so the first tick already knows), every later one
//! [`PERIOD_CYCLES`] (one second) after the previous one. A failure is
//! sticky until reset.

use super::clock::{CPU_HZ, CYCLES_PER_MS};

/// The independent reference: the RTC crystal.
pub const REF_HZ: u32 = 32_768;
/// Largest accepted deviation of the measured core clock from [`CPU_HZ`].
pub const TOLERANCE_PERCENT: u32 = 1;
/// The first (boot) window: 20 ms, 655 reference counts, so one count of
/// quantisation is 0.15 % of it, well inside the tolerance.
pub const BOOT_WINDOW_CYCLES: u32 = 20 * CYCLES_PER_MS;
/// Every later window: one second of CPU cycles (32 768 reference counts;
/// the 32-bit DWT counter wraps after 7.16 s, far beyond it).
pub const PERIOD_CYCLES: u32 = CPU_HZ;

const _: () = assert!(BOOT_WINDOW_CYCLES < PERIOD_CYCLES);
// one reference count must be a small fraction of the tolerance in the
// shortest window: counts in it x tolerance / 100 >= 4 counts
const _: () =
    assert!((BOOT_WINDOW_CYCLES as u64) * (REF_HZ as u64) * (TOLERANCE_PERCENT as u64) / (CPU_HZ as u64) / 100 >= 4);

/// The verdict over one window.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// The measured clock is within [`TOLERANCE_PERCENT`] of [`CPU_HZ`].
    Within,
    /// It is not (or the reference did not count at all).
    Deviates,
}

/// Compares `cycles` CPU cycles with `ref_counts` counts of the 32.768 kHz
/// reference over the same interval: the measured core clock
/// `cycles x REF_HZ / ref_counts` deviates if it is more than
/// [`TOLERANCE_PERCENT`] away from [`CPU_HZ`], i.e. if
/// `|cycles x REF_HZ - ref_counts x CPU_HZ| x 100 > ref_counts x CPU_HZ x TOLERANCE_PERCENT`.
/// No division; every product fits `u64` (`ref_counts x CPU_HZ < 2^62`), and
/// the left side saturates only when the deviation is far beyond the bound.
/// A reference that did not count (0) deviates.
pub const fn compare(cycles: u32, ref_counts: u32) -> Verdict {
    let measured = (cycles as u64).saturating_mul(REF_HZ as u64);
    let nominal = (ref_counts as u64).saturating_mul(CPU_HZ as u64);
    let lhs = measured.abs_diff(nominal).saturating_mul(100);
    let rhs = nominal.saturating_mul(TOLERANCE_PERCENT as u64);
    if ref_counts == 0 || lhs > rhs {
        Verdict::Deviates
    } else {
        Verdict::Within
    }
}

/// The running check: fed the DWT cycle count and the reference count once
/// per tick, it compares them over each closed window.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ClockMonitor {
    start_cycles: u32,
    start_ref: u32,
    window: u32,
    failed: bool,
    windows: u32,
}

impl ClockMonitor {
    /// Starts the first window at these readings.
    pub const fn new(cycles: u32, ref_count: u32) -> Self {
        Self { start_cycles: cycles, start_ref: ref_count, window: BOOT_WINDOW_CYCLES, failed: false, windows: 0 }
    }

    /// One reading of both counters (both free-running, wrapping). Closes
    /// the window when at least its length of CPU cycles has passed,
    /// compares, and starts the next one. Returns true once any window
    /// deviated (sticky: a clock that was wrong is not trusted again).
    pub fn update(&mut self, cycles: u32, ref_count: u32) -> bool {
        let d_cycles = cycles.wrapping_sub(self.start_cycles);
        if d_cycles >= self.window {
            let d_ref = ref_count.wrapping_sub(self.start_ref);
            if let Verdict::Deviates = compare(d_cycles, d_ref) {
                self.failed = true;
            }
            self.start_cycles = cycles;
            self.start_ref = ref_count;
            self.window = PERIOD_CYCLES;
            self.windows = self.windows.saturating_add(1);
        }
        self.failed
    }

    /// A window deviated.
    pub const fn failed(&self) -> bool {
        self.failed
    }

    /// Windows closed so far.
    pub const fn windows(&self) -> u32 {
        self.windows
    }
}

#[cfg(test)]
#[allow(clippy::arithmetic_side_effects)]
mod tests {
    use super::*;

    /// Reference counts for `cycles` at a core clock of `cpu_hz`.
    fn counts(cycles: u32, cpu_hz: f64) -> u32 {
        (f64::from(cycles) * f64::from(REF_HZ) / cpu_hz).floor() as u32
    }

    #[test]
    fn nominal_clock_is_within() {
        assert_eq!(compare(CPU_HZ, REF_HZ), Verdict::Within);
        assert_eq!(compare(BOOT_WINDOW_CYCLES, counts(BOOT_WINDOW_CYCLES, 600e6)), Verdict::Within);
    }

    #[test]
    fn the_boundary_is_one_percent_each_way() {
        for &w in &[BOOT_WINDOW_CYCLES, PERIOD_CYCLES] {
            for (pct, want) in [
                (0.9, Verdict::Within),
                (-0.9, Verdict::Within),
                (1.1, Verdict::Deviates),
                (-1.1, Verdict::Deviates),
                (2.0, Verdict::Deviates),
                (-2.0, Verdict::Deviates),
                (50.0, Verdict::Deviates),
            ] {
                let hz = 600e6 * (1.0 + pct / 100.0);
                assert_eq!(compare(w, counts(w, hz)), want, "window {w}, {pct} %");
            }
        }
    }

    #[test]
    fn exact_boundary_over_one_second() {
        // over 600 M cycles the measured clock 600 MHz x 32 768 / counts is
        // within 1 % for 32 443.56 <= counts <= 33 098.99
        assert_eq!(compare(CPU_HZ, 32_444), Verdict::Within);
        assert_eq!(compare(CPU_HZ, 32_443), Verdict::Deviates);
        assert_eq!(compare(CPU_HZ, 33_098), Verdict::Within);
        assert_eq!(compare(CPU_HZ, 33_099), Verdict::Deviates);
    }

    #[test]
    fn a_dead_reference_and_extreme_values_deviate() {
        assert_eq!(compare(CPU_HZ, 0), Verdict::Deviates);
        assert_eq!(compare(0, 0), Verdict::Deviates);
        assert_eq!(compare(u32::MAX, 1), Verdict::Deviates);
        assert_eq!(compare(1, u32::MAX), Verdict::Deviates);
        assert_eq!(compare(u32::MAX, u32::MAX), Verdict::Deviates);
    }

    /// Feeds the monitor one reading per millisecond tick of a core clock at
    /// `cpu_hz` from counter values near their wrap; returns the tick at
    /// which it first failed.
    fn run(cpu_hz: f64, ticks: u32) -> (Option<u32>, ClockMonitor) {
        let (c0, r0) = (u32::MAX - 1_000_000, u32::MAX - 100);
        let mut m = ClockMonitor::new(c0, r0);
        for k in 1..=ticks {
            let c = CYCLES_PER_MS * k; // CPU cycles of k ticks
            let r = counts(c, cpu_hz);
            if m.update(c0.wrapping_add(c), r0.wrapping_add(r)) {
                return (Some(k), m);
            }
        }
        (None, m)
    }

    #[test]
    fn a_wrong_pll_fails_at_the_first_window_and_stays_failed() {
        let (at, mut m) = run(612e6, 100);
        assert_eq!(at, Some(20), "fails when the boot window closes");
        assert!(m.update(0, 0) && m.failed(), "sticky");
        let (at, _) = run(588e6, 100);
        assert_eq!(at, Some(20));
    }

    #[test]
    fn a_nominal_clock_passes_every_window() {
        let (at, m) = run(600e6, 3_100);
        assert_eq!(at, None);
        assert_eq!(m.windows(), 4, "boot window then one per second");
        let (at, _) = run(600e6 * 1.009, 3_100);
        assert_eq!(at, None);
    }

    #[test]
    fn a_drift_after_boot_fails_within_one_period() {
        // nominal for 1.5 s, then 2 % fast
        let (c0, r0) = (5u32, 7u32);
        let mut m = ClockMonitor::new(c0, r0);
        let mut r = 0f64;
        let mut failed_at = None;
        for k in 1..=4_000u32 {
            let hz = if k <= 1_500 { 600e6 } else { 612e6 };
            r += f64::from(CYCLES_PER_MS) * f64::from(REF_HZ) / hz;
            if m.update(c0 + CYCLES_PER_MS * k, r0 + r as u32) {
                failed_at = Some(k);
                break;
            }
        }
        // windows close at 20, 1020, 2020, 3020 ms: 2020 holds 520 ms of the
        // drift (1.04 %), so it fails there
        assert_eq!(failed_at, Some(2_020));
    }
}
