//! The frame decoder's 32-bit arithmetic against the `u64` / `i64`
//! reference decoder (`reference/mod.rs`), end to end.
//!
//! * [`decode_frame`] equals `decode_window(h, p, &FRAME_DECODE)` for every
//!   `u16` high time at sampled periods (every period is swept in release
//!   mode by `proofs/exhaustive`).
//! * [`FrameDecoder::update`] and the reference's `update` (the same control
//!   flow on `u64` / `i64` divisions) give the same reading and leave the
//!   same state (equal `Debug` renderings) on every tick of simulated MT6816
//!   streams (periods across and beyond the accepted +-10 %, moving counts,
//!   CYCCNT wraps, glitches: missed and spurious captures, inconsistent
//!   snapshots, skipped ticks, jitter), half of them from the boot
//!   calibration's period and phase, and of fully random snapshots.
//! * [`EncoderChannel`] (decoder + tracker) reads what the reference decodes,
//!   through its public API.

use hal_imxrt as hal;

mod reference;

use hal_imxrt::pure::channel::EncoderChannel;
use hal_imxrt::pure::clock::{CYCLES_PER_QTIMER_TICK, CYCLES_PER_TICK};
use hal_imxrt::pure::encoder::{decode_window, EncoderReading};
use hal_imxrt::pure::frame::{
    decode_frame, FrameDecoder, Snapshot, FRAME_DECODE, MAX_PERIOD_CYCLES, MIN_PERIOD_CYCLES, NOMINAL_PERIOD_CYCLES,
};
use hal_imxrt::pure::mt6816::{COUNTS_PER_REV, FRAME_CLOCKS, START_CLOCKS};

/// splitmix64.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: u64) -> u64 {
        ((self.next() >> 32) * n) >> 32
    }
    fn chance(&mut self, per_mille: u64) -> bool {
        self.below(1000) < per_mille
    }
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

#[test]
fn decode_frame_equals_decode_window_for_every_high_time() {
    let mut rng = Rng(11);
    let mut periods: Vec<u32> = vec![
        0,
        1,
        MIN_PERIOD_CYCLES - 1,
        MIN_PERIOD_CYCLES,
        MIN_PERIOD_CYCLES + 1,
        NOMINAL_PERIOD_CYCLES,
        MAX_PERIOD_CYCLES - 1,
        MAX_PERIOD_CYCLES,
        MAX_PERIOD_CYCLES + 1,
        u32::MAX,
    ];
    periods.extend(
        (0..40).map(|_| MIN_PERIOD_CYCLES + rng.below((MAX_PERIOD_CYCLES - MIN_PERIOD_CYCLES + 1) as u64) as u32),
    );
    let mut counts = 0u32;
    for p in periods {
        for h in 0..=u16::MAX {
            let got = decode_frame(h, p);
            assert_eq!(got, decode_window(h as u32, p, &FRAME_DECODE), "high {h} period {p}");
            counts += u32::from(got.count().is_some());
        }
    }
    assert!(counts > 500_000, "{counts}");
}

/// An MT6816 on a gated-count + capture QuadTimer channel, sampled by a
/// jittered 1 kHz tick, with optional glitches. Times in CPU cycles.
struct Stream {
    period: f64,
    phase: f64,
    /// count of frame k: `(base + speed * k) mod 4096`.
    base: u64,
    speed: u64,
    stuck: Option<bool>,
    /// per-mille probability of each glitch kind per tick
    glitch: u64,
    /// CYCCNT at t = 0 (wraps during the run)
    cyc0: u64,
    /// Both decoders start with the boot calibration's period and phase.
    calibrated: bool,
}

impl Stream {
    fn count(&self, k: u64) -> u64 {
        (self.base + self.speed * k) % u64::from(COUNTS_PER_REV)
    }
    fn start(&self, k: u64) -> f64 {
        self.phase + k as f64 * self.period
    }
    fn high_len(&self, k: u64) -> f64 {
        (START_CLOCKS as f64 + self.count(k) as f64) * self.period / FRAME_CLOCKS as f64
    }
    /// Frame in progress at t (t >= phase).
    fn frame_of(&self, t: f64) -> u64 {
        let k = ((t - self.phase) / self.period).floor().max(0.0) as u64;
        // guard the float floor at a frame start
        if self.start(k + 1) <= t {
            k + 1
        } else {
            k
        }
    }
    /// Ticks of the 32-cycle counter clock in [a, b).
    fn ticks(a: f64, b: f64) -> u64 {
        let tick = f64::from(CYCLES_PER_QTIMER_TICK);
        ((b / tick).ceil() - (a / tick).ceil()).max(0.0) as u64
    }
}

/// Cumulative gated ticks, advanced frame by frame as time goes on.
struct Gated {
    k: u64,
    at_k: u64,
}

impl Gated {
    fn at(&mut self, s: &Stream, t: f64) -> u64 {
        if t < s.phase {
            return self.at_k;
        }
        let kt = s.frame_of(t);
        while self.k < kt {
            let a = s.start(self.k);
            self.at_k += Stream::ticks(a, a + s.high_len(self.k));
            self.k += 1;
        }
        let a = s.start(kt);
        self.at_k + Stream::ticks(a, (a + s.high_len(kt)).min(t))
    }
}

/// Runs `ticks` snapshots of `s` through a decoder pair and a channel pair;
/// returns (ticks with a count, ticks with a measured period, fast ticks).
fn run(s: &Stream, ticks: usize, rng: &mut Rng) -> (usize, usize, usize) {
    let (mut new, mut reference) = (FrameDecoder::new(), reference::FrameDecoder::new());
    let mut channel = EncoderChannel::new();
    if s.calibrated {
        // the boot calibration's result: the period to a few cycles, a
        // rising edge's time to 32
        let p = (s.period + rng.below(9) as f64 - 4.0) as u32;
        let edge = (s.cyc0 as f64 + s.start(0) + rng.below(33) as f64) as u64 as u32;
        new.calibrate(p, edge);
        reference.calibrate(p, edge);
        channel.calibrate(p, edge);
    }
    let mut gated = Gated { k: 0, at_k: 0 };
    let mut prev = 0.0f64;
    let mut stats = (0, 0, 0);
    for i in 1..=ticks {
        let mut t = i as f64 * f64::from(CYCLES_PER_TICK) + rng.below(600) as f64;
        if rng.chance(s.glitch) {
            // a late or early snapshot (interrupt latency)
            t += rng.below(20_000) as f64 - 10_000.0;
        }
        if t <= prev {
            t = prev + 1.0;
        }
        let mut snap = match s.stuck {
            Some(high) => Snapshot {
                ief: false,
                input_high: high,
                capt: 0,
                cntr: if high { Stream::ticks(0.0, t) as u16 } else { 0 },
                cycles: (s.cyc0 + t as u64) as u32,
                consistent: true,
            },
            None => {
                let k = s.frame_of(t);
                let start = s.start(k);
                let started = t >= s.phase;
                let capt = if started { gated.at(s, start) } else { 0 };
                let cntr = gated.at(s, t);
                Snapshot {
                    ief: started && start > prev,
                    input_high: started && t - start < s.high_len(k),
                    capt: capt as u16,
                    cntr: cntr as u16,
                    cycles: (s.cyc0 + t as u64) as u32,
                    consistent: true,
                }
            }
        };
        prev = t;
        if rng.chance(s.glitch) {
            match rng.below(6) {
                0 => snap.consistent = false,
                1 => snap.ief = !snap.ief,
                2 => snap.capt = rng.next() as u16,
                3 => snap.cntr = snap.cntr.wrapping_add(rng.below(64) as u16),
                4 => snap.input_high = !snap.input_high,
                _ => continue, // a skipped tick
            }
        }
        let a = new.update(snap);
        let b = reference.update(snap);
        assert_eq!(a, b, "tick {i}: {snap:?}");
        assert_eq!(format!("{new:?}"), format!("{reference:?}"), "tick {i}: {snap:?}");
        let _ = channel.update(snap);
        assert_eq!(channel.raw(), b, "tick {i}");
        stats.0 += usize::from(matches!(a, EncoderReading::Count(_)));
        stats.1 += usize::from(new.period().1);
        stats.2 += usize::from(new.fast());
    }
    stats
}

#[test]
fn decoder_equals_the_reference_on_simulated_streams() {
    let mut rng = Rng(12);
    let mut totals = (0, 0, 0, 0);
    for n in 0..72u64 {
        // periods from 13 % fast to 13 % slow, a third of them nominal +- 0.5 %
        let rel = if n % 3 == 0 { 1.0 + (rng.unit() - 0.5) * 0.01 } else { 0.87 + rng.unit() * 0.26 };
        let s = Stream {
            period: NOMINAL_PERIOD_CYCLES as f64 * rel,
            phase: rng.unit() * 700_000.0,
            base: rng.below(u64::from(COUNTS_PER_REV)),
            speed: [0, 1, 13, 40, 300][rng.below(5) as usize],
            stuck: match n % 24 {
                5 => Some(false),
                17 => Some(true),
                _ => None,
            },
            glitch: [0, 0, 2, 10, 50][rng.below(5) as usize],
            cyc0: (u32::MAX - rng.below(1 << 31) as u32) as u64,
            calibrated: n % 2 == 1,
        };
        let (counts, measured, fast) = run(&s, 2500, &mut rng);
        totals = (totals.0 + 2500, totals.1 + counts, totals.2 + measured, totals.3 + fast);
    }
    // the streams reach every regime of the decoder
    let (ticks, counts, measured, fast) = totals;
    assert!(counts > ticks / 2 && measured > ticks / 2 && fast > ticks / 10, "{totals:?}");
}

#[test]
fn decoder_equals_the_reference_on_random_snapshots() {
    let mut rng = Rng(13);
    for _ in 0..40 {
        let (mut new, mut reference) = (FrameDecoder::new(), reference::FrameDecoder::new());
        let mut cycles = rng.next() as u32;
        for i in 0..5_000 {
            cycles = cycles.wrapping_add(match rng.below(4) {
                0 => rng.next() as u32,
                _ => 550_000 + rng.below(150_000) as u32,
            });
            let bits = rng.next();
            let snap = Snapshot {
                ief: bits & 1 != 0,
                input_high: bits & 2 != 0,
                capt: (bits >> 8) as u16,
                cntr: (bits >> 24) as u16,
                cycles,
                consistent: bits & 4 != 0 || bits & 8 != 0,
            };
            assert_eq!(new.update(snap), reference.update(snap), "tick {i}: {snap:?}");
            assert_eq!(format!("{new:?}"), format!("{reference:?}"), "tick {i}: {snap:?}");
        }
    }
}
