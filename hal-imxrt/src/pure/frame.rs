//! Edge-aligned whole-frame MT6816 decode (replaces the 1 ms duty window's
//! +-122-count phase error; see [`super::encoder`]).
//!
//! # Hardware arrangement (one QuadTimer channel per encoder, zero interrupts)
//!
//! The channel counts IPG/8 ticks (18.75 MHz, 32 CPU cycles) **while the pin
//! is high** (gated count, `CTRL[CM] = 0b011`, as the window decoder) and, in
//! addition, **captures the counter on every rising edge** of the pin
//! (`SCTRL[CAPTURE_MODE] = 0b01`, `SCTRL[IEF]` set on capture). A rising edge
//! is the start of an MT6816 frame, so `CAPT` holds the cumulative high ticks
//! at the start of the most recent frame, and
//!
//! ```text
//! high_ticks(frame f) = CAPT(start of f+1) - CAPT(start of f)     (wrapping u16)
//! ```
//!
//! is the high time of exactly one complete frame: no partial frames, so no
//! phase error and no wrap mixing. Once per control tick the firmware takes a
//! [`Snapshot`] (`SCTRL` before, `CAPT`, `CNTR`, `SCTRL` after, DWT CYCCNT)
//! and clears `IEF`.
//!
//! # Frame period
//!
//! The decode needs the MT6816's own frame period (its clock is an on-chip
//! oscillator, not the nominal 250 ns). When a snapshot is taken while the
//! pin is still high, `CNTR - CAPT` is the time since the frame's rising edge
//! (the counter has counted continuously since), which timestamps that edge
//! in CPU cycles. Two timestamped edges `n` frames apart give the period to
//! 32 cycles / n. The 1 kHz tick slides through the 971 Hz frame at the
//! 28.9 Hz beat, so edges are timestamped every few tens of ms whenever the
//! duty is not tiny; with a tiny duty (small count) the period error matters
//! little, because the count error is `(16 + count) * relative_period_error`.
//! Until the first measurement the nominal period ([`NOMINAL_PERIOD_CYCLES`])
//! is used.
//!
//! # Decode
//!
//! `count = round(4119 * high_cycles / period_cycles) - 16`, via
//! [`super::encoder::decode_window`] with a frame-sized [`FRAME_DECODE`]
//! config (it range-checks duty, stuck high/low).
//!
//! # Assumptions (bench-confirm; see the firmware README)
//!
//! * Capture works in gated-count mode on the secondary (gate) input and
//!   sets `IEF`; whether further captures overwrite `CAPT` while `IEF` is set
//!   or are inhibited does not matter here as long as at most one rising edge
//!   falls between two snapshots, which [`FrameDecoder`] enforces by refusing
//!   periods shorter than [`MIN_PERIOD_CYCLES`] (1 ms + 1 %). The MT6816
//!   oscillator must therefore be within -1.9 % / +10 % of nominal.
//! * `SCTRL[INPUT]` reflects the pin level (after `IPS`, which is 0).

use super::clock::CYCLES_PER_QTIMER_TICK;
use super::encoder::{decode_window, DecodeConfig, EncoderReading, LossReason, FRAME_CLOCKS};

/// Nominal frame period in CPU cycles (4119 * 250 ns at 600 MHz).
pub const NOMINAL_PERIOD_CYCLES: u32 = FRAME_CLOCKS * 150;
/// Shortest accepted period: above one control tick (600 000 cycles) plus
/// 1 %, so at most one rising edge can fall between two snapshots.
pub const MIN_PERIOD_CYCLES: u32 = 606_000;
/// Longest accepted period (nominal + 10 %).
pub const MAX_PERIOD_CYCLES: u32 = NOMINAL_PERIOD_CYCLES + NOMINAL_PERIOD_CYCLES / 10;
/// Snapshots without a new frame after which the reading is lost (a frame
/// starts in all but ~3 % of 1 ms ticks, never two ticks in a row).
pub const MAX_FRAME_AGE: u8 = 3;
/// Re-anchor the period measurement after this many frames.
pub const PERIOD_ANCHOR_FRAMES: u32 = 64;

/// Decoder limits for a window of exactly one frame.
pub const FRAME_DECODE: DecodeConfig = DecodeConfig {
    cycles_per_tick: CYCLES_PER_QTIMER_TICK,
    min_window_cycles: MIN_PERIOD_CYCLES,
    max_window_cycles: MAX_PERIOD_CYCLES,
    range_tolerance_clocks: 8,
    // one frame: one rising and one falling edge -> +-1 tick each
    edge_margin_ticks: 1,
};
const _: () = assert!(FRAME_DECODE.is_valid());

/// One per-tick read of a capture channel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Snapshot {
    /// `SCTRL[IEF]` at the first read: a rising edge was captured since the
    /// last snapshot (the firmware clears it after reading).
    pub ief: bool,
    /// `SCTRL[INPUT]` at the first read (pin level).
    pub input_high: bool,
    /// `CAPT`.
    pub capt: u16,
    /// `CNTR` (gated high ticks).
    pub cntr: u16,
    /// DWT CYCCNT at the `CNTR` read.
    pub cycles: u32,
    /// `SCTRL[INPUT]` and `SCTRL[IEF]` unchanged at the second read (no edge
    /// during the snapshot).
    pub consistent: bool,
}

/// Why [`FrameDecoder`] has no frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum NoFrame {
    Starting,
    Stale,
}

/// Per-channel whole-frame decoder (state for the period and the frame
/// chain). Feed one [`Snapshot`] per tick to [`FrameDecoder::update`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameDecoder {
    /// `CAPT` at the last rising edge seen, if the chain is unbroken.
    last_capt: Option<u16>,
    /// Rising edges seen since start (chain index).
    edges: u32,
    /// Edge timestamp anchor: (edge index, CPU cycles).
    anchor: Option<(u32, u32)>,
    /// Index of the edge last timestamped (to timestamp each edge once).
    stamped: Option<u32>,
    /// Frame period estimate, CPU cycles.
    period: u32,
    /// Whether `period` was measured (vs nominal).
    measured: bool,
    /// High ticks of the last complete frame.
    high: Option<u16>,
    /// Snapshots since `high` was updated.
    age: u8,
    state: NoFrame,
}

impl Default for FrameDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameDecoder {
    /// A decoder with no frame yet and the nominal period.
    pub const fn new() -> Self {
        Self {
            last_capt: None,
            edges: 0,
            anchor: None,
            stamped: None,
            period: NOMINAL_PERIOD_CYCLES,
            measured: false,
            high: None,
            age: 0,
            state: NoFrame::Starting,
        }
    }

    /// Current period estimate (CPU cycles) and whether it was measured.
    pub const fn period(&self) -> (u32, bool) {
        (self.period, self.measured)
    }

    fn break_chain(&mut self) {
        self.last_capt = None;
        self.anchor = None;
        self.stamped = None;
    }

    fn timestamp(&mut self, edge: u32, t: u32) {
        if self.stamped == Some(edge) {
            return;
        }
        self.stamped = Some(edge);
        match self.anchor {
            Some((n0, t0)) if edge > n0 => {
                let frames = edge - n0;
                let span = t.wrapping_sub(t0);
                let p = span / frames;
                // Shorter than MIN is recorded too (update() then refuses
                // every reading); implausibly short/long spans re-anchor.
                if (NOMINAL_PERIOD_CYCLES / 2..=MAX_PERIOD_CYCLES).contains(&p) {
                    // round to nearest
                    self.period = ((span as u64 + frames as u64 / 2) / frames as u64) as u32;
                    self.measured = true;
                    if frames >= PERIOD_ANCHOR_FRAMES {
                        self.anchor = Some((edge, t));
                    }
                } else {
                    // inconsistent (missed edge or glitch): start again
                    self.anchor = Some((edge, t));
                }
            }
            _ => self.anchor = Some((edge, t)),
        }
    }

    /// Process one snapshot; returns the reading for this tick (the count of
    /// the most recent complete frame, or why there is none).
    pub fn update(&mut self, s: Snapshot) -> EncoderReading {
        if !s.consistent {
            // An edge happened during the snapshot: we cannot tell whether
            // CAPT belongs to it. Break the chain; keep the last frame.
            self.break_chain();
        } else if s.ief {
            if let Some(prev) = self.last_capt {
                self.high = Some(s.capt.wrapping_sub(prev));
                self.age = 0;
            }
            self.last_capt = Some(s.capt);
            self.edges = self.edges.wrapping_add(1);
            if self.edges == 0 {
                // after 49 days: restart the period chain cleanly
                self.break_chain();
            }
        }
        if s.consistent && s.input_high && self.last_capt.is_some() {
            // Still high since the last captured rising edge: its time.
            let since = s.cntr.wrapping_sub(s.capt) as u32 * CYCLES_PER_QTIMER_TICK;
            if since < MIN_PERIOD_CYCLES {
                self.timestamp(self.edges, s.cycles.wrapping_sub(since));
            }
        }
        if !s.ief {
            self.age = self.age.saturating_add(1);
        }
        if self.period < MIN_PERIOD_CYCLES {
            return EncoderReading::Lost(LossReason::WindowTooShort);
        }
        match self.high {
            Some(_) if self.age > MAX_FRAME_AGE => {
                self.state = NoFrame::Stale;
                self.high = None;
                self.break_chain();
                EncoderReading::Lost(if s.input_high { LossReason::StuckHigh } else { LossReason::NoSignal })
            }
            Some(h) => decode_window(h as u32, self.period, &FRAME_DECODE),
            None => {
                if self.age > MAX_FRAME_AGE && self.state == NoFrame::Starting {
                    self.state = NoFrame::Stale;
                }
                match self.state {
                    NoFrame::Starting => EncoderReading::Lost(LossReason::Acquiring),
                    NoFrame::Stale => {
                        EncoderReading::Lost(if s.input_high { LossReason::StuckHigh } else { LossReason::NoSignal })
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::pure::encoder::{circular_distance, MAX_COUNT, START_CLOCKS};
    use std::{boxed::Box, vec::Vec};

    /// Simulated MT6816 + QuadTimer channel (gated count + capture on rising
    /// edge), sampled by a 1 kHz tick. Times in CPU cycles (f64).
    struct Sim {
        period: f64,
        phase: f64,
        count_at: Box<dyn Fn(u64) -> u16>,
        stuck: Option<bool>,
    }

    impl Sim {
        fn frame_of(&self, t: f64) -> (u64, f64) {
            let k = ((t - self.phase) / self.period).floor();
            (k as u64, self.phase + k * self.period)
        }
        fn high_len(&self, k: u64) -> f64 {
            (START_CLOCKS as f64 + (self.count_at)(k) as f64) * self.period / FRAME_CLOCKS as f64
        }
        fn is_high(&self, t: f64) -> bool {
            if let Some(s) = self.stuck {
                return s;
            }
            let (k, start) = self.frame_of(t);
            t - start < self.high_len(k)
        }
        /// Gated ticks counted in [0, t): ticks at multiples of 32 cycles.
        fn gated(&self, t: f64) -> u64 {
            let ticks_in = |a: f64, b: f64| ((b / 32.0).ceil() - (a / 32.0).ceil()).max(0.0) as u64;
            match self.stuck {
                Some(true) => return ticks_in(0.0, t),
                Some(false) => return 0,
                None => {}
            }
            let (kt, _) = self.frame_of(t);
            let mut n = 0;
            for k in 0..=kt {
                let s = self.phase + k as f64 * self.period;
                if s + 0.0 > t {
                    break;
                }
                let e = (s + self.high_len(k)).min(t);
                n += ticks_in(s.max(0.0), e);
            }
            n
        }
        /// Snapshot at tick time t (prev = previous tick time).
        fn snapshot(&self, prev: f64, t: f64) -> Snapshot {
            let (k, start) = self.frame_of(t);
            let edge_in = self.stuck.is_none() && start > prev && start >= 0.0;
            let capt = if self.stuck.is_none() && start >= 0.0 { self.gated(start) } else { 0 };
            let _ = k;
            Snapshot {
                ief: edge_in,
                input_high: self.is_high(t),
                capt: capt as u16,
                cntr: self.gated(t) as u16,
                cycles: t as u64 as u32,
                consistent: true,
            }
        }
    }

    fn run(sim: &Sim, ticks: usize) -> Vec<EncoderReading> {
        let mut d = FrameDecoder::new();
        let mut prev = 0.0;
        (1..=ticks)
            .map(|i| {
                let t = i as f64 * 600_000.0 + 1234.0;
                let r = d.update(sim.snapshot(prev, t));
                prev = t;
                r
            })
            .collect()
    }

    #[test]
    fn exact_at_rest_across_the_range_and_phases() {
        for count in (0..=MAX_COUNT).step_by(97).chain([0, 1, 4094, MAX_COUNT]) {
            for phase in [0.0, 111_111.0, 300_000.0, 617_000.0] {
                let sim = Sim {
                    period: NOMINAL_PERIOD_CYCLES as f64,
                    phase,
                    count_at: Box::new(move |_| count),
                    stuck: None,
                };
                let r = run(&sim, 60);
                for (i, x) in r.iter().enumerate().skip(4) {
                    assert_eq!(*x, EncoderReading::Count(count), "count {count} phase {phase} tick {i}");
                }
            }
        }
    }

    #[test]
    fn oscillator_off_nominal_is_measured() {
        for ppm in [-15_000.0, -5_000.0, 5_000.0, 30_000.0, 90_000.0] {
            let period = NOMINAL_PERIOD_CYCLES as f64 * (1.0 + ppm * 1e-6);
            for count in [100u16, 2048, 4000] {
                let sim = Sim { period, phase: 5000.0, count_at: Box::new(move |_| count), stuck: None };
                let r = run(&sim, 400);
                // after the period is measured (a beat period or two), exact
                for x in &r[200..] {
                    match x {
                        EncoderReading::Count(c) => assert!(circular_distance(*c, count) <= 1, "{ppm} {count} {c}"),
                        other => panic!("{ppm} {count} {other:?}"),
                    }
                }
            }
        }
    }

    #[test]
    fn moving_across_the_wrap_never_mixes_frames() {
        // 20 counts per frame through 4095 -> 0
        let sim = Sim {
            period: NOMINAL_PERIOD_CYCLES as f64,
            phase: 77.0,
            count_at: Box::new(|k| ((3900 + 20 * k) % 4096) as u16),
            stuck: None,
        };
        let r = run(&sim, 40);
        let counts: Vec<u16> = r.iter().filter_map(|x| x.count()).collect();
        assert!(counts.len() >= 30);
        assert!(counts.iter().any(|c| *c > 4000) && counts.iter().any(|c| *c < 300));
        for w in counts.windows(2) {
            assert!(circular_distance(w[0], w[1]) <= 41, "{w:?}");
        }
    }

    #[test]
    fn duty_extremes() {
        for count in [0u16, MAX_COUNT] {
            let sim = Sim {
                period: NOMINAL_PERIOD_CYCLES as f64,
                phase: 0.5,
                count_at: Box::new(move |_| count),
                stuck: None,
            };
            assert!(run(&sim, 50)[5..].iter().all(|x| *x == EncoderReading::Count(count)), "{count}");
        }
    }

    #[test]
    fn stuck_lines_are_lost() {
        for (stuck, why) in [(false, LossReason::NoSignal), (true, LossReason::StuckHigh)] {
            let sim =
                Sim { period: NOMINAL_PERIOD_CYCLES as f64, phase: 0.0, count_at: Box::new(|_| 0), stuck: Some(stuck) };
            let r = run(&sim, 10);
            assert_eq!(r[9], EncoderReading::Lost(why));
        }
    }

    #[test]
    fn signal_cut_after_tracking_goes_lost_within_four_ticks() {
        let mut d = FrameDecoder::new();
        let sim = Sim { period: NOMINAL_PERIOD_CYCLES as f64, phase: 0.0, count_at: Box::new(|_| 1000), stuck: None };
        let mut prev = 0.0;
        let mut last = EncoderReading::Lost(LossReason::Acquiring);
        for i in 1..=20 {
            let t = i as f64 * 600_000.0;
            last = d.update(sim.snapshot(prev, t));
            prev = t;
        }
        assert_eq!(last, EncoderReading::Count(1000));
        let cut = Snapshot { ief: false, input_high: false, capt: 0, cntr: 0, cycles: 0, consistent: true };
        let r: Vec<_> = (0..5).map(|_| d.update(cut)).collect();
        assert_eq!(r[4], EncoderReading::Lost(LossReason::NoSignal));
    }

    #[test]
    fn inconsistent_snapshot_breaks_the_chain_not_the_reading() {
        let mut d = FrameDecoder::new();
        let sim = Sim { period: NOMINAL_PERIOD_CYCLES as f64, phase: 0.0, count_at: Box::new(|_| 2500), stuck: None };
        let mut prev = 0.0;
        for i in 1..=30 {
            let t = i as f64 * 600_000.0;
            let mut s = sim.snapshot(prev, t);
            if i == 15 {
                s.consistent = false;
            }
            let r = d.update(s);
            if i > 5 {
                assert_eq!(r, EncoderReading::Count(2500), "tick {i}");
            }
            prev = t;
        }
    }

    #[test]
    fn period_shorter_than_a_tick_is_refused() {
        let period = 590_000.0;
        let sim = Sim { period, phase: 0.0, count_at: Box::new(|_| 1000), stuck: None };
        let r = run(&sim, 300);
        assert!(r[100..].iter().all(|x| x.count().is_none()), "{:?}", &r[100..110]);
    }
}
