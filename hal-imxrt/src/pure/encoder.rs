//! MT6816 PWM-output decoding, integer-only and wrap-safe.
//!
//! # Signal
//!
//! One frame is [`FRAME_CLOCKS`] = 4119 PWM clocks of 250 ns (1029.75 us,
//! 971.1 Hz). The output is HIGH for [`START_CLOCKS`] = 16 clocks plus `count`
//! (0..=4095) clocks, then LOW to the end of the frame. So the duty is
//! `(16 + count) / 4119`, in `[16/4119, 4111/4119]`.
//!
//! # Measurement
//!
//! A QuadTimer channel in gated-count mode (`CTRL[CM] = 0b011`, "count rising
//! edges of primary source while secondary input high") counts IPG/8 =
//! 18.75 MHz ticks (53.33 ns = 32 CPU cycles) while the encoder pin is high.
//! Once per control tick the firmware samples the 16-bit counter and the 32-bit
//! DWT CYCCNT. [`WindowSampler`] turns two samples into a window
//! (`high_ticks`, `elapsed_cycles`) with explicit wrap handling of both
//! counters, and [`decode_window`] turns a window into a count:
//!
//! ```text
//! high_clocks = 4119 * high_ticks * 32 / elapsed_cycles   (PWM clocks per frame)
//! count       = round(high_clocks) - 16
//! ```
//!
//! # Why a duty average is not wrap-safe, and what this module does about it
//!
//! A window that contains parts of two frames measures a weighted mix of their
//! duties. If the two frames are on either side of the 0/4095 wrap (e.g. 4090
//! then 3), the mix is anywhere in between (near 2048 = pi for an even mix):
//! a *valid-looking* duty. No range check on a single window can detect it;
//! the C++ firmware's 10 ms average had exactly this defect.
//!
//! Protection is therefore in two layers:
//!
//! 1. [`decode_window`] (stateless) rejects what one window can prove wrong:
//!    too short/too long windows (the 16-bit counter can wrap unobservably
//!    after 65536 ticks = 3.495 ms), no high time (stuck low / no signal), no
//!    low time (stuck high), and duty outside `[16, 4111]` clocks by more than
//!    a tolerance.
//! 2. [`Tracker`] (per axis) accepts a count only if it is physically reachable
//!    from the last accepted count: circular distance at most
//!    `max_step_counts` per elapsed tick. A wrap-mixed window lands far from
//!    both neighbours and is reported as `Lost(Inconsistent)`; the unwrapper
//!    downstream therefore never sees a jump larger than `max_step_counts`
//!    (< 2048), so it cannot lose a turn. An outage longer than
//!    `max_lost_ticks` latches `Lost(Unrecoverable)` until [`Tracker::reset`]
//!    (re-home), so a long stream of self-consistent but wrong readings can
//!    never be adopted silently.
//!
//! # Error budget (1 ms window, 250 ns PWM clock)
//!
//! * Quantisation: the gate is sampled by the 53.33 ns tick, so each high pulse
//!   is measured to +-1 tick; a 1 ms window holds at most 2 pulse ends:
//!   +-2 ticks = +-107 ns = +-0.43 PWM clock = +-0.43 count. CYCCNT (1.67 ns)
//!   and the read skew between CNTR and CYCCNT (a few bus cycles, < 1 tick)
//!   add well under 0.5 count. Total quantisation: < +-1 count.
//! * **Phase (dominant)**: a 1 ms window covers 0.971 of a 1029.75 us frame.
//!   The uncovered 29.75 us may be high or low depending on where the window
//!   falls in the frame, so a single window's count is off by up to
//!   `4119 * 29.75 / 1000 * max(d, 1-d)` ~ +-61 counts at mid-scale and
//!   ~ +-122 counts near the ends, beating at |1000 - 971.1| = 28.9 Hz. This
//!   is intrinsic to a sub-frame (or any non-integer-frame) duty window, the
//!   C++ 10 ms window had the same magnitude. It is bounded, not a wrap error;
//!   it is the reason `max_step_counts` defaults to 256. Near the ends of the
//!   range a 1 ms window can also miss the whole 4 us start pulse (count ~ 0)
//!   or the whole 2 us low gap (count ~ 4095) in about 3 % of windows; those
//!   windows are reported as `Lost(NoSignal)` / `Lost(StuckHigh)`.
//! * Removing the phase error needs edge-aligned measurement (QuadTimer input
//!   capture on the falling edge gives the exact high time of one pulse) plus
//!   a frame-period estimate; [`decode_window`] is already the right decoder
//!   for a window of exactly one frame. Not implemented here: it needs bench
//!   work on the capture/IEF behaviour.

use super::clock::CYCLES_PER_QTIMER_TICK;

/// PWM clocks per MT6816 frame.
pub const FRAME_CLOCKS: u32 = 4119;
/// HIGH start clocks preceding the count.
pub const START_CLOCKS: u32 = 16;
/// Largest 12-bit count.
pub const MAX_COUNT: u16 = 4095;
/// Counts per revolution.
pub const COUNTS_PER_REV: u32 = 4096;

/// Why a reading is not a count.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LossReason {
    /// No high time in the window: pin stuck low, encoder unpowered or
    /// disconnected (input pad has a pull-down).
    NoSignal,
    /// No low time in the window: pin stuck high.
    StuckHigh,
    /// Duty outside the range an MT6816 can produce.
    DutyOutOfRange,
    /// Window too short to contain a meaningful part of a frame.
    WindowTooShort,
    /// Window longer than the 16-bit counter can span unambiguously (a missed
    /// tick): the high-tick count may have wrapped.
    WindowTooLong,
    /// Counter advanced more than time allows: sampling error.
    Implausible,
    /// A valid-looking count that is not physically reachable from the last
    /// accepted count (typically a window straddling the 0/2pi wrap).
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

/// Stateless decoder parameters.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DecodeConfig {
    /// CPU cycles per QuadTimer tick (32 at 600 MHz / 18.75 MHz).
    pub cycles_per_tick: u32,
    /// Shortest accepted window, CPU cycles.
    pub min_window_cycles: u32,
    /// Longest accepted window, CPU cycles; must stay below 65536 ticks.
    pub max_window_cycles: u32,
    /// Tolerance on the duty range, PWM clocks.
    pub range_tolerance_clocks: u32,
    /// High (or low) time at or below this many ticks counts as none.
    pub edge_margin_ticks: u32,
}

impl DecodeConfig {
    /// Defaults for a 1 ms window at 600 MHz: accept 0.5 ms ..= 3 ms windows
    /// (3 ms < 65536 ticks * 53.3 ns = 3.495 ms), 8-clock range tolerance,
    /// 2-tick edge margin (quantisation of two pulse ends).
    pub const DEFAULT: DecodeConfig = DecodeConfig {
        cycles_per_tick: CYCLES_PER_QTIMER_TICK,
        min_window_cycles: 300_000,
        max_window_cycles: 1_800_000,
        range_tolerance_clocks: 8,
        edge_margin_ticks: 2,
    };

    /// True if the window limits are consistent with a 16-bit counter.
    pub const fn is_valid(&self) -> bool {
        self.cycles_per_tick > 0
            && self.min_window_cycles > 0
            && self.min_window_cycles < self.max_window_cycles
            && (self.max_window_cycles as u64) < 65_536u64 * self.cycles_per_tick as u64
    }
}

const _: () = assert!(DecodeConfig::DEFAULT.is_valid());

/// Decode one window: `high_ticks` QuadTimer ticks of HIGH over
/// `elapsed_cycles` CPU cycles.
///
/// For any config (one `u64` division). The tick decodes its whole frames
/// with [`super::frame::decode_frame`], this function with
/// [`super::frame::FRAME_DECODE`] on 32-bit arithmetic (equal for every
/// input; `proofs/exhaustive`).
pub const fn decode_window(high_ticks: u32, elapsed_cycles: u32, cfg: &DecodeConfig) -> EncoderReading {
    if cfg.cycles_per_tick == 0 || elapsed_cycles < cfg.min_window_cycles {
        return EncoderReading::Lost(LossReason::WindowTooShort);
    }
    if elapsed_cycles > cfg.max_window_cycles {
        return EncoderReading::Lost(LossReason::WindowTooLong);
    }
    let window_ticks = elapsed_cycles / cfg.cycles_per_tick;
    // At most one tick of read skew plus one per gated edge.
    if high_ticks > window_ticks + cfg.edge_margin_ticks {
        return EncoderReading::Lost(LossReason::Implausible);
    }
    if high_ticks <= cfg.edge_margin_ticks {
        return EncoderReading::Lost(LossReason::NoSignal);
    }
    if high_ticks + cfg.edge_margin_ticks >= window_ticks {
        return EncoderReading::Lost(LossReason::StuckHigh);
    }
    // high clocks per frame in 1/16 clock: 4119*16 * H * cpt / E, rounded.
    // Max numerator: 4119*16*65536*cpt(<=2^16) < 2^49: no u64 overflow.
    let num = FRAME_CLOCKS as u64 * 16 * high_ticks as u64 * cfg.cycles_per_tick as u64;
    let den = elapsed_cycles as u64;
    let high_x16 = (num + den / 2) / den;
    let lo = ((START_CLOCKS.saturating_sub(cfg.range_tolerance_clocks)) as u64) * 16;
    let hi = ((START_CLOCKS + MAX_COUNT as u32 + cfg.range_tolerance_clocks) as u64) * 16;
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

/// Wrap-safe difference of two samples of a free-running 16-bit counter
/// (QuadTimer CNTR). Correct if fewer than 65536 ticks elapsed; the decoder's
/// `max_window_cycles` guarantees that for accepted windows.
pub const fn counter_delta_u16(prev: u16, now: u16) -> u16 {
    now.wrapping_sub(prev)
}

/// Wrap-safe difference of two samples of the 32-bit DWT CYCCNT (wraps every
/// 7.16 s at 600 MHz; correct for any window shorter than that).
pub const fn cycles_delta(prev: u32, now: u32) -> u32 {
    now.wrapping_sub(prev)
}

/// Circular distance between two counts on the 4096-count circle (0..=2048).
pub const fn circular_distance(a: u16, b: u16) -> u16 {
    let d = (a as i32 - b as i32).rem_euclid(COUNTS_PER_REV as i32) as u16;
    if d > 2048 {
        4096 - d
    } else {
        d
    }
}

/// One raw sample of an encoder channel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RawSample {
    /// QuadTimer CNTR (gated high ticks, free running, wraps at 65536).
    pub counter: u16,
    /// DWT CYCCNT at the time of the read.
    pub cycles: u32,
}

/// Turns consecutive [`RawSample`]s into windows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WindowSampler {
    prev: Option<RawSample>,
}

impl WindowSampler {
    /// A sampler with no previous sample.
    pub const fn new() -> Self {
        Self { prev: None }
    }

    /// Feed a sample; returns `(high_ticks, elapsed_cycles)` of the window
    /// since the previous sample, or `None` for the first sample.
    pub fn push(&mut self, s: RawSample) -> Option<(u32, u32)> {
        let out = self.prev.map(|p| (counter_delta_u16(p.counter, s.counter) as u32, cycles_delta(p.cycles, s.cycles)));
        self.prev = Some(s);
        out
    }
}

/// Per-axis continuity tracker (see module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TrackerConfig {
    /// Largest physically possible change between two consecutive 1 ms
    /// windows, counts: motor speed (J3: 6 rad/s * 18.1 = 109 rad/s = 71
    /// counts/ms) plus the phase error swing (up to ~122). Must be < 2048.
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

/// Continuity tracker: wraps [`decode_window`] results.
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

/// Exact window (CPU cycles, QuadTimer high ticks) that an ideal MT6816 at
/// `count` produces over `frames` whole frames with the nominal 250 ns clock.
/// Test/bench helper: a 250 ns clock is 150 CPU cycles.
pub const fn ideal_window(count: u16, frames: u32) -> (u32, u32) {
    let cycles = FRAME_CLOCKS * 150 * frames;
    let high_cycles = (START_CLOCKS + count as u32) * 150 * frames;
    (high_cycles / CYCLES_PER_QTIMER_TICK, cycles)
}

#[cfg(test)]
mod tests {
    use super::*;

    const CFG: DecodeConfig = DecodeConfig::DEFAULT;

    /// Simulated MT6816 + gated counter: high ticks in [t0, t0 + w) (CPU
    /// cycles), with per-frame counts given by `count_of(frame_index)`.
    fn simulate(t0: u64, w: u64, count_of: &dyn Fn(u64) -> u16) -> u32 {
        let frame = FRAME_CLOCKS as u64 * 150;
        let mut high = 0u64;
        let mut f = t0 / frame;
        while f * frame < t0 + w {
            let start = f * frame;
            let end = start + (START_CLOCKS as u64 + count_of(f) as u64) * 150;
            let a = start.max(t0);
            let b = end.min(t0 + w);
            if b > a {
                high += b - a;
            }
            f += 1;
        }
        (high / CYCLES_PER_QTIMER_TICK as u64) as u32
    }

    #[test]
    fn whole_frame_windows_decode_exactly_every_count() {
        for count in 0..=MAX_COUNT {
            let (h, e) = ideal_window(count, 1);
            let got = decode_window(h, e, &CFG);
            // quantisation of one 53 ns tick < 0.25 count
            assert_eq!(got, EncoderReading::Count(count), "count {count}");
        }
    }

    #[test]
    fn duty_extremes() {
        let (h, e) = ideal_window(0, 1);
        assert_eq!(decode_window(h, e, &CFG), EncoderReading::Count(0));
        let (h, e) = ideal_window(4095, 1);
        assert_eq!(decode_window(h, e, &CFG), EncoderReading::Count(4095));
        // 1 ms window fully inside a count-0 frame's pulse+low: +-122 bound
        for start_us in (0..1029).step_by(7) {
            let t0 = start_us * 600;
            let h = simulate(t0, 600_000, &|_| 0);
            match decode_window(h, 600_000, &CFG) {
                EncoderReading::Count(c) => assert!(c <= 125, "{c}"),
                EncoderReading::Lost(r) => assert_eq!(r, LossReason::NoSignal),
            }
            let h = simulate(t0, 600_000, &|_| 4095);
            match decode_window(h, 600_000, &CFG) {
                EncoderReading::Count(c) => assert!(c >= 4095 - 125, "{c}"),
                EncoderReading::Lost(r) => assert_eq!(r, LossReason::StuckHigh),
            }
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
        // ~1 clock of high per frame (below the 16-clock start pulse - 8)
        let e = FRAME_CLOCKS * 150;
        let h = 5 * 150 / 32;
        assert_eq!(decode_window(h, e, &CFG), EncoderReading::Lost(LossReason::DutyOutOfRange));
        // 4118 of 4119 clocks high: above 4111 + 8? no: 4118 < 4119 -> range
        let h = (4118 * 150 - 4 * 32) / 32; // just inside
        assert!(matches!(decode_window(h, e, &CFG), EncoderReading::Count(4095)));
    }

    #[test]
    fn phase_error_bounded_for_1ms_windows() {
        for count in (0..=MAX_COUNT).step_by(97) {
            for start_us in (0..1030).step_by(13) {
                let h = simulate(start_us * 600, 600_000, &|_| count);
                if let EncoderReading::Count(c) = decode_window(h, 600_000, &CFG) {
                    assert!(circular_distance(c, count) <= 125, "count {count} got {c}");
                }
            }
        }
    }

    #[test]
    fn counter_wraparound() {
        assert_eq!(counter_delta_u16(65_000, 500), 1_036);
        assert_eq!(cycles_delta(u32::MAX - 99, 500), 600);
        let mut s = WindowSampler::new();
        assert_eq!(s.push(RawSample { counter: 65_530, cycles: u32::MAX - 299_999 }), None);
        let (h, e) = ideal_window(2000, 1);
        let got = s.push(RawSample {
            counter: 65_530u16.wrapping_add(h as u16),
            cycles: (u32::MAX - 299_999).wrapping_add(e),
        });
        assert_eq!(got, Some((h, e)));
        let (h, e) = got.unwrap();
        assert_eq!(decode_window(h, e, &CFG), EncoderReading::Count(2000));
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

    /// The C++ failure: a window straddling the wrap averages to ~pi.
    #[test]
    fn window_straddling_wrap_is_never_reported_as_a_bogus_angle() {
        // Motor creeping forward across the wrap: frames ..4090, 4093, then 1, 4
        let counts = |f: u64| -> u16 { ((4080 + 3 * f) % 4096) as u16 };
        let frame = FRAME_CLOCKS as u64 * 150;
        let mut t = acquired(counts(0));
        let mut prev_ok = counts(0);
        // 1 ms windows, run across the wrap
        let mut t0 = frame; // start of frame 1
        for _ in 0..20 {
            let h = simulate(t0, 600_000, &counts);
            let raw = decode_window(h, 600_000, &CFG);
            let out = t.update(raw);
            if let EncoderReading::Count(c) = out {
                // never further than the physical motion + phase error
                assert!(circular_distance(c, prev_ok) <= 256, "jump {prev_ok} -> {c}");
                // and never near pi
                assert!(circular_distance(c, 0) < 400, "bogus {c}");
                prev_ok = c;
            }
            t0 += 600_000;
        }
        // ended up past the wrap
        assert!(t.last_count().unwrap() < 200);
    }

    #[test]
    fn mixed_window_alone_is_rejected_as_inconsistent() {
        let mut t = acquired(4090);
        // an even mix of 4090 and 3: ~2046
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
