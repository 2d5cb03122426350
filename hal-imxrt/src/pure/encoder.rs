//! MT6816 PWM readings: what a reading is, the decode of a measured high
//! time over a measured frame period, and the per-axis continuity tracker.
//!
//! # Signal
//!
//! [`super::mt6816`]: one frame is 4119 PWM clocks of 250 ns, HIGH for
//! 16 + `count` (0..=4095) clocks, then LOW to the end of the frame.
//!
//! # Measurement: whole frames, edge-aligned
//!
//! A QuadTimer channel counts IPG/8 = 18.75 MHz ticks (53.33 ns = 32 CPU
//! cycles) while the encoder pin is high and captures that counter on every
//! rising edge, the start of a frame; the difference of two captures is the
//! high time of exactly one complete frame ([`super::frame`] has the method,
//! the frame-period measurement and the decoder the tick runs,
//! `periph::frame_capture` the register side). A reading never mixes two
//! frames, so it has no phase error, and a frame on one side of the
//! 0/4095 wrap cannot blend with one on the other side into a
//! valid-looking angle near 2048 (the defect of a duty average over a
//! fixed window, which a range check cannot detect).
//!
//! # Protection in two layers
//!
//! 1. [`decode_window`] (stateless; the tick runs its 32-bit equal
//!    [`super::frame::decode_frame`]) rejects what one frame can prove
//!    wrong: a period outside the accepted range, no high time (stuck low /
//!    no signal), no low time (stuck high), and a duty outside `[16, 4111]`
//!    clocks by more than a tolerance.
//! 2. [`Tracker`] (per axis) accepts a count only if it is physically
//!    reachable from the last accepted count: circular distance at most
//!    `max_step_counts` per elapsed tick. A reading that is not (a glitch, a
//!    corrupted capture) is reported as `Lost(Inconsistent)`; the unwrapper
//!    downstream therefore never sees a jump larger than `max_step_counts`
//!    (< 2048), so it cannot lose a turn. An outage longer than
//!    `max_lost_ticks` latches `Lost(Unrecoverable)` until [`Tracker::reset`]
//!    (re-home), so a long stream of self-consistent but wrong readings can
//!    never be adopted silently.
//!
//! # Error budget (one frame, 250 ns PWM clock)
//!
//! The gate is sampled by the 53.33 ns tick, so each of the frame's two
//! pulse ends is measured to +-1 tick: +-107 ns = +-0.43 PWM clock =
//! +-0.43 count; the frame period is measured to 32 cycles over up to 64
//! frames. Once the period is measured a reading is exact to +-1 count
//! (`frame::tests`). Before that, the nominal period stands in for the
//! sensor's own, and a reading is off by the relative period error times
//! `16 + count` (see [`super::frame`], "Frame period").

use super::mt6816::{COUNTS_PER_REV, FRAME_CLOCKS, MAX_COUNT, START_CLOCKS};

/// Why a reading is not a count.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LossReason {
    /// No high time in the frame: pin stuck low, encoder unpowered or
    /// disconnected (input pad has a pull-down).
    NoSignal,
    /// No low time in the frame: pin stuck high.
    StuckHigh,
    /// Duty outside the range an MT6816 can produce.
    DutyOutOfRange,
    /// Frame period (the measured window) shorter than the accepted range.
    WindowTooShort,
    /// Frame period longer than the accepted range.
    WindowTooLong,
    /// Counter advanced more than time allows: sampling error.
    Implausible,
    /// A valid-looking count that is not physically reachable from the last
    /// accepted count (a glitch, a corrupted capture).
    Inconsistent,
    /// No accepted count yet (start-up / after reset): collecting agreeing
    /// readings.
    Acquiring,
    /// Lost for longer than allowed; latched until [`Tracker::reset`].
    Unrecoverable,
}

/// One decoded encoder reading.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EncoderReading {
    /// 12-bit angle count, `angle = count / 4096 * 2 pi`.
    Count(u16),
    /// No trustworthy count this tick.
    Lost(LossReason),
}

impl EncoderReading {
    /// The count, if valid.
    pub const fn count(self) -> Option<u16> {
        match self {
            EncoderReading::Count(c) => Some(c),
            EncoderReading::Lost(_) => None,
        }
    }
}

/// Stateless decoder parameters (the tick's are
/// [`super::frame::FRAME_DECODE`]: a window of exactly one frame).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DecodeConfig {
    /// CPU cycles per QuadTimer tick (32 at 600 MHz / 18.75 MHz).
    pub cycles_per_tick: u32,
    /// Shortest accepted window (frame period), CPU cycles.
    pub min_window_cycles: u32,
    /// Longest accepted window, CPU cycles; must stay below 65536 ticks.
    pub max_window_cycles: u32,
    /// Tolerance on the duty range, PWM clocks.
    pub range_tolerance_clocks: u32,
    /// High (or low) time at or below this many ticks counts as none.
    pub edge_margin_ticks: u32,
}

impl DecodeConfig {
    /// True if the window limits are consistent with a 16-bit counter.
    // Cannot overflow: 65 536 times a u32 fits a u64.
    #[allow(clippy::arithmetic_side_effects)]
    pub const fn is_valid(&self) -> bool {
        self.cycles_per_tick > 0
            && self.min_window_cycles > 0
            && self.min_window_cycles < self.max_window_cycles
            && (self.max_window_cycles as u64) < 65_536u64 * self.cycles_per_tick as u64
    }
}

/// Decode one window: `high_ticks` QuadTimer ticks of HIGH over
/// `elapsed_cycles` CPU cycles (for the tick, one frame over its period).
///
/// For any config, with one `u64` division: the definition of the decode.
/// The tick runs [`super::frame::decode_frame`], this function with
/// [`super::frame::FRAME_DECODE`] on 32-bit arithmetic (equal for every
/// input: `proofs/exhaustive`, `hal-imxrt/tests/frame_reference.rs`).
// Cannot overflow: the divisor cfg.cycles_per_tick is checked non-zero, the
// bounds of the u64 numerator and of E are stated where they are used, and
// high_clocks - 16 only runs when high_clocks > 16.
#[allow(clippy::arithmetic_side_effects)]
pub const fn decode_window(high_ticks: u32, elapsed_cycles: u32, cfg: &DecodeConfig) -> EncoderReading {
    if cfg.cycles_per_tick == 0 || elapsed_cycles < cfg.min_window_cycles {
        return EncoderReading::Lost(LossReason::WindowTooShort);
    }
    if elapsed_cycles > cfg.max_window_cycles {
        return EncoderReading::Lost(LossReason::WindowTooLong);
    }
    let window_ticks = elapsed_cycles / cfg.cycles_per_tick;
    // At most one tick of read skew plus one per gated edge.
    if high_ticks > window_ticks.saturating_add(cfg.edge_margin_ticks) {
        return EncoderReading::Lost(LossReason::Implausible);
    }
    if high_ticks <= cfg.edge_margin_ticks {
        return EncoderReading::Lost(LossReason::NoSignal);
    }
    if high_ticks.saturating_add(cfg.edge_margin_ticks) >= window_ticks {
        return EncoderReading::Lost(LossReason::StuckHigh);
    }
    // high clocks per frame in 1/16 clock: 4119*16 * H * cpt / E, rounded.
    // Past the checks H < window_ticks = E / cpt, so H * cpt < E < 2^32 and
    // the numerator is below 4119 * 16 * 2^32 < 2^49; E >= 1.
    let num = FRAME_CLOCKS as u64 * 16 * high_ticks as u64 * cfg.cycles_per_tick as u64;
    let den = elapsed_cycles as u64;
    let high_x16 = (num + den / 2) / den;
    let lo = ((START_CLOCKS.saturating_sub(cfg.range_tolerance_clocks)) as u64) * 16;
    let hi = (START_CLOCKS as u64 + MAX_COUNT as u64 + cfg.range_tolerance_clocks as u64) * 16;
    if high_x16 < lo || high_x16 > hi {
        return EncoderReading::Lost(LossReason::DutyOutOfRange);
    }
    // count = round(high/16) - 16, clamped into 0..=4095 (the tolerance band).
    let high_clocks = (high_x16 + 8) / 16;
    let count = if high_clocks <= START_CLOCKS as u64 {
        0
    } else if high_clocks - START_CLOCKS as u64 >= MAX_COUNT as u64 {
        MAX_COUNT
    } else {
        (high_clocks - START_CLOCKS as u64) as u16
    };
    EncoderReading::Count(count)
}

/// Circular distance between two counts on the 4096-count circle (0..=2048).
// Cannot overflow: the difference of two u16 values fits an i32, and
// 0 <= d < REV, so REV - d and d fit a u16.
#[allow(clippy::arithmetic_side_effects)]
pub const fn circular_distance(a: u16, b: u16) -> u16 {
    const REV: i32 = COUNTS_PER_REV as i32;
    // 0 <= d < REV: the results fit a u16
    let d = (a as i32 - b as i32).rem_euclid(REV);
    (if d > REV / 2 { REV - d } else { d }) as u16
}

/// Per-axis continuity tracker (see module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TrackerConfig {
    /// Largest accepted change per elapsed tick, counts: the fastest motor
    /// (J3: 6 rad/s * 18.1 = 109 rad/s) turns 71 counts per 1 ms tick, and a
    /// fresh frame after a repeated one carries two ticks of motion (142);
    /// 256 leaves margin for both. Must be < 2048.
    pub max_step_counts: u16,
    /// Agreeing consecutive readings needed to (re)acquire.
    pub acquire_readings: u8,
    /// Lost ticks tolerated before latching `Unrecoverable`.
    pub max_lost_ticks: u16,
}

impl TrackerConfig {
    /// 256 counts/tick, 3 agreeing readings, 20 ticks (20 ms) of outage.
    pub const DEFAULT: TrackerConfig = TrackerConfig { max_step_counts: 256, acquire_readings: 3, max_lost_ticks: 20 };

    /// `max_step_counts` must leave the unwrapper's half-turn margin.
    pub const fn is_valid(&self) -> bool {
        self.max_step_counts > 0 && self.max_step_counts < 1024 && self.acquire_readings >= 2
    }
}

const _: () = assert!(TrackerConfig::DEFAULT.is_valid());

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum TrackState {
    /// Collecting `agree` consecutive agreeing readings, last one `last`.
    Acquiring {
        last: Option<u16>,
        agree: u8,
    },
    /// Tracking; `since` ticks since `last` was accepted (1 = previous tick).
    Tracking {
        last: u16,
        since: u16,
    },
    Latched,
}

/// Continuity tracker: filters the decoder's per-tick readings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tracker {
    cfg: TrackerConfig,
    state: TrackState,
}

impl Tracker {
    /// A tracker in the acquiring state.
    pub const fn new(cfg: TrackerConfig) -> Self {
        Self { cfg, state: TrackState::Acquiring { last: None, agree: 0 } }
    }

    /// Forget everything and re-acquire (after re-homing / fault reset).
    pub fn reset(&mut self) {
        self.state = TrackState::Acquiring { last: None, agree: 0 };
    }

    /// True once the tracker has latched `Unrecoverable` (it answers every
    /// reading with that until [`Tracker::reset`]).
    pub const fn is_latched(&self) -> bool {
        matches!(self.state, TrackState::Latched)
    }

    /// Last accepted count, if tracking.
    pub const fn last_count(&self) -> Option<u16> {
        match self.state {
            TrackState::Tracking { last, .. } => Some(last),
            _ => None,
        }
    }

    /// Feed one per-tick decoded reading; returns the filtered reading.
    pub fn update(&mut self, raw: EncoderReading) -> EncoderReading {
        let cfg = self.cfg;
        match self.state {
            TrackState::Latched => EncoderReading::Lost(LossReason::Unrecoverable),
            TrackState::Acquiring { last, agree } => match raw {
                EncoderReading::Lost(r) => {
                    self.state = TrackState::Acquiring { last: None, agree: 0 };
                    EncoderReading::Lost(r)
                }
                EncoderReading::Count(c) => {
                    let agree = match last {
                        Some(l) if circular_distance(l, c) <= cfg.max_step_counts => agree.saturating_add(1),
                        _ => 1,
                    };
                    if agree >= cfg.acquire_readings {
                        self.state = TrackState::Tracking { last: c, since: 1 };
                        EncoderReading::Count(c)
                    } else {
                        self.state = TrackState::Acquiring { last: Some(c), agree };
                        EncoderReading::Lost(LossReason::Acquiring)
                    }
                }
            },
            TrackState::Tracking { since, .. } if since > cfg.max_lost_ticks => {
                self.state = TrackState::Latched;
                EncoderReading::Lost(LossReason::Unrecoverable)
            }
            TrackState::Tracking { last, since } => {
                let allowed = (cfg.max_step_counts as u32).saturating_mul(since as u32);
                match raw {
                    EncoderReading::Count(c) if (circular_distance(last, c) as u32) <= allowed => {
                        self.state = TrackState::Tracking { last: c, since: 1 };
                        EncoderReading::Count(c)
                    }
                    other => {
                        let reason = match other {
                            EncoderReading::Lost(r) => r,
                            EncoderReading::Count(_) => LossReason::Inconsistent,
                        };
                        self.state = TrackState::Tracking { last, since: since.saturating_add(1) };
                        EncoderReading::Lost(reason)
                    }
                }
            }
        }
    }
}

// Test code is built with overflow checks on: an overflow fails the test.
#[cfg(test)]
#[allow(clippy::arithmetic_side_effects)]
mod tests {
    use super::*;
    use crate::pure::clock::CYCLES_PER_QTIMER_TICK;
    use crate::pure::frame::FRAME_DECODE;
    use crate::pure::mt6816::{CYCLES_PER_PWM_CLOCK, NOMINAL_FRAME_CYCLES};

    const CFG: DecodeConfig = FRAME_DECODE;

    /// Exact window (QuadTimer high ticks, CPU cycles) of one frame of an
    /// ideal MT6816 at `count` with the nominal 250 ns clock.
    const fn ideal_frame(count: u16) -> (u32, u32) {
        let cycles = NOMINAL_FRAME_CYCLES;
        let high_cycles = (START_CLOCKS + count as u32) * CYCLES_PER_PWM_CLOCK;
        (high_cycles / CYCLES_PER_QTIMER_TICK, cycles)
    }

    #[test]
    fn whole_frames_decode_exactly_every_count() {
        for count in 0..=MAX_COUNT {
            let (h, e) = ideal_frame(count);
            let got = decode_window(h, e, &CFG);
            // quantisation of one 53 ns tick < 0.25 count
            assert_eq!(got, EncoderReading::Count(count), "count {count}");
        }
    }

    #[test]
    fn stuck_low_high_and_no_signal() {
        assert_eq!(decode_window(0, 600_000, &CFG), EncoderReading::Lost(LossReason::NoSignal));
        assert_eq!(decode_window(600_000 / 32, 600_000, &CFG), EncoderReading::Lost(LossReason::StuckHigh));
        assert_eq!(decode_window(600_000 / 32 + 100, 600_000, &CFG), EncoderReading::Lost(LossReason::Implausible));
        assert_eq!(decode_window(100, 1_000, &CFG), EncoderReading::Lost(LossReason::WindowTooShort));
        assert_eq!(decode_window(100, 2_000_000, &CFG), EncoderReading::Lost(LossReason::WindowTooLong));
    }

    #[test]
    fn out_of_range_duty() {
        // ~5 clocks of high per frame (below the 16-clock start pulse - 8)
        let e = NOMINAL_FRAME_CYCLES;
        let h = 5 * CYCLES_PER_PWM_CLOCK / CYCLES_PER_QTIMER_TICK;
        assert_eq!(decode_window(h, e, &CFG), EncoderReading::Lost(LossReason::DutyOutOfRange));
        // 4118 of 4119 clocks high, less two ticks: inside the tolerance
        // band above 16 + 4095, clamped to the largest count
        let h = (4118 * CYCLES_PER_PWM_CLOCK - 4 * CYCLES_PER_QTIMER_TICK) / CYCLES_PER_QTIMER_TICK;
        assert_eq!(decode_window(h, e, &CFG), EncoderReading::Count(MAX_COUNT));
    }

    #[test]
    fn circular_distance_props() {
        assert_eq!(circular_distance(0, 4095), 1);
        assert_eq!(circular_distance(4095, 0), 1);
        assert_eq!(circular_distance(0, 2048), 2048);
        assert_eq!(circular_distance(100, 300), 200);
    }

    fn acquired(c: u16) -> Tracker {
        let mut t = Tracker::new(TrackerConfig::DEFAULT);
        assert_eq!(t.update(EncoderReading::Count(c)), EncoderReading::Lost(LossReason::Acquiring));
        assert_eq!(t.update(EncoderReading::Count(c)), EncoderReading::Lost(LossReason::Acquiring));
        assert_eq!(t.update(EncoderReading::Count(c)), EncoderReading::Count(c));
        t
    }

    #[test]
    fn unreachable_count_alone_is_rejected_as_inconsistent() {
        let mut t = acquired(4090);
        // half a turn away in one tick (a corrupted capture)
        assert_eq!(t.update(EncoderReading::Count(2046)), EncoderReading::Lost(LossReason::Inconsistent));
        // next clean frame is accepted (within 2 * 256 after one lost tick)
        assert_eq!(t.update(EncoderReading::Count(5)), EncoderReading::Count(5));
    }

    #[test]
    fn long_outage_latches() {
        let mut t = acquired(100);
        for _ in 0..20 {
            assert!(matches!(
                t.update(EncoderReading::Lost(LossReason::NoSignal)),
                EncoderReading::Lost(LossReason::NoSignal)
            ));
        }
        assert_eq!(t.update(EncoderReading::Count(100)), EncoderReading::Lost(LossReason::Unrecoverable));
        assert_eq!(t.update(EncoderReading::Count(100)), EncoderReading::Lost(LossReason::Unrecoverable));
        t.reset();
        assert_eq!(t.update(EncoderReading::Count(100)), EncoderReading::Lost(LossReason::Acquiring));
    }

    #[test]
    fn acquisition_needs_agreeing_readings() {
        let mut t = Tracker::new(TrackerConfig::DEFAULT);
        assert_eq!(t.update(EncoderReading::Count(10)), EncoderReading::Lost(LossReason::Acquiring));
        assert_eq!(t.update(EncoderReading::Count(2000)), EncoderReading::Lost(LossReason::Acquiring));
        assert_eq!(t.update(EncoderReading::Count(2010)), EncoderReading::Lost(LossReason::Acquiring));
        assert_eq!(t.update(EncoderReading::Count(2020)), EncoderReading::Count(2020));
        // a start-up zero is not a count: Lost until acquired (C++ defect 1)
        let mut t = Tracker::new(TrackerConfig::DEFAULT);
        assert!(t.update(EncoderReading::Lost(LossReason::NoSignal)).count().is_none());
    }
}
