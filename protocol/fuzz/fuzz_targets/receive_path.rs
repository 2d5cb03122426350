//! The whole receive path on arbitrary bytes: framer, parser, sequence
//! filter (`Receiver`) and the command queue to the tick (`queue::Link`),
//! with the tick taking commands and sending telemetry on a schedule drawn
//! from the input, and the millisecond clock advancing the same way.
//!
//! Input: byte 0 picks the dialect lock and the sequence filter's settings
//! (gap, backward window, including 0 and `u32::MAX`), bytes 1..=4 seed the
//! schedule, the rest are the bytes received. Panics (the fuzzer's findings)
//! on any panic in the crate or any departure from the rules of
//! docs/PROTOCOL.md sections 2, 3 and 5, checked against a model written
//! here from the document:
//! - an accepted motion frame outside the joint limits or not finite;
//! - a sequence verdict (accept, resync with its reason and figures, drop
//!   with its reason, last SEQ and count) other than section 3's rule;
//! - counters (accepted, rejected, each report's count) that do not add up;
//! - a report line that is not printable text;
//! - the command queue refusing a command that fits or taking one that
//!   does not (a motion frame needs more than the two reserved slots free),
//!   or the tick receiving anything but the queued commands in order;
//! - telemetry: elements out of order, or dropped ones not accounted for
//!   exactly by the `Lost(n)` reports and the pending count.
#![no_main]

use std::collections::VecDeque;

use kernel::config::{PAROL6, PAROL6_VALIDATED};
use kernel::{Fx, MotionTarget, Scalar};
use libfuzzer_sys::fuzz_target;
use protocol::queue::{Link, Telemetry, CONTROL_RESERVE};
use protocol::receiver::{Received, Receiver};
use protocol::seq::{Resync, ResyncReason, Stale, StaleReason};
use protocol::{Command, DialectLock, Line, ProtocolConfig};

/// Command slots of the link (holds `C - 1`) and telemetry slots.
const C: usize = 8;
const T: usize = 6;

fn finite_within_limits<S: Scalar>(t: &MotionTarget<S>) -> bool {
    PAROL6.joints.iter().zip(t.position.iter().zip(&t.velocity)).all(|(j, (p, v))| {
        let (p, v) = (p.to_f32() as f64, v.to_f32() as f64);
        p.is_finite()
            && v.is_finite()
            && p >= j.limit_min as f64 - 1e-7
            && p <= j.limit_max as f64 + 1e-7
            && v.abs() <= j.max_velocity as f64 + 1e-7
    })
}

/// Section 3's rule, written from the document.
enum Expect {
    Accept(Option<Resync>),
    Drop { reason: StaleReason, last: u32 },
}

fn expect(last: Option<(u32, u32)>, seq: u32, now: u32, cfg: &ProtocolConfig) -> Expect {
    let Some((l, l_ms)) = last else { return Expect::Accept(None) };
    let elapsed = now.wrapping_sub(l_ms);
    let d = seq.wrapping_sub(l) as i32;
    if elapsed > cfg.resync_gap_ms {
        Expect::Accept(Some(Resync { reason: ResyncReason::Gap { ms: elapsed }, seq, last: l }))
    } else if d > 0 {
        Expect::Accept(None)
    } else if d == 0 {
        Expect::Drop { reason: StaleReason::Duplicate, last: l }
    } else if d.unsigned_abs() > cfg.resync_backward {
        Expect::Accept(Some(Resync { reason: ResyncReason::BackwardJump, seq, last: l }))
    } else {
        Expect::Drop { reason: StaleReason::Behind, last: l }
    }
}

/// xorshift32: the schedule.
struct Rng(u32);
impl Rng {
    fn next(&mut self) -> u32 {
        let mut x = self.0;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        self.0 = x;
        x
    }
}

fn run<S: Scalar>(cfg: ProtocolConfig, seed: u32, bytes: &[u8]) {
    let mut rx: Receiver<S> = Receiver::new(&PAROL6_VALIDATED, cfg);
    let mut link: Link<S, C, T> = Link::new();
    let (mut host, mut tick) = link.split();
    let mut rng = Rng(seed | 1);
    let mut now = 0u32;
    let mut out = Line::new();
    // The model.
    let mut queued: VecDeque<Command<S>> = VecDeque::new();
    let mut last: Option<(u32, u32)> = None;
    let (mut accepted, mut rejected, mut dropped, mut refused) = (0u32, 0u32, 0u32, 0u32);
    let (mut tel_sent, mut tel_next, mut tel_got, mut tel_lost_reported) = (0u32, 0u32, 0u32, 0u32);

    for &b in bytes {
        let r = rng.next();
        now = now.wrapping_add(match r & 0xF {
            0 => (r >> 8) & 0x3FF,
            1 => (r >> 8).wrapping_mul(0x10001),
            2..=5 => 1,
            _ => 0,
        });
        if let Some(got) = rx.push(b, now) {
            if got.report(&mut out).expect("a report fits its line") {
                let body = out.strip_suffix('\n').expect("terminated");
                assert!(!body.starts_with('<') && body.bytes().all(|b| (0x20..=0x7E).contains(&b)), "{body:?}");
            }
            match got {
                Received::Accepted { command, resync } => {
                    accepted += 1;
                    match command {
                        Command::Motion { seq, target, .. } => {
                            assert!(finite_within_limits(&target), "{target:?}");
                            match expect(last, seq, now, &cfg) {
                                Expect::Accept(want) => assert_eq!(resync, want, "seq {seq} last {last:?} now {now}"),
                                Expect::Drop { .. } => panic!("seq {seq} accepted, last {last:?} now {now}"),
                            }
                            last = Some((seq, now));
                        }
                        Command::Home | Command::HomeJoint(_) | Command::Enable => {
                            assert_eq!(resync, None);
                            last = None;
                        }
                    }
                    let free = C - 1 - queued.len();
                    let fits = if command.is_motion() { free > CONTROL_RESERVE } else { free > 0 };
                    match host.send(command) {
                        Ok(()) => {
                            assert!(fits, "queued with {free} free");
                            queued.push_back(command);
                        }
                        Err(full) => {
                            refused += 1;
                            assert!(!fits, "refused with {free} free");
                            assert_eq!((full.command, full.count), (command, refused));
                        }
                    }
                }
                Received::Rejected { count, .. } => {
                    rejected += 1;
                    assert_eq!(count, rejected);
                }
                Received::Dropped(Stale { seq, last: l, reason, count }) => {
                    dropped += 1;
                    assert_eq!(count, dropped);
                    match expect(last, seq, now, &cfg) {
                        Expect::Drop { reason: want, last: want_last } => assert_eq!((reason, l), (want, want_last)),
                        Expect::Accept(_) => panic!("seq {seq} dropped, last {last:?} now {now}"),
                    }
                }
            }
            let c = rx.counters();
            assert_eq!((c.accepted, c.rejected), (accepted, rejected));
            assert_eq!(rx.last_seq(), last.map_or(0, |(s, _)| s));
        }

        // The tick's side: take a command, send telemetry; the host reads.
        if r & 0x300 == 0 {
            assert_eq!(tick.recv(), queued.pop_front());
        }
        if r & 0xC00 == 0 {
            tel_sent += 1;
            let delivered = tick.send(Telemetry::EventsLost(tel_next as u8));
            tel_next += u32::from(delivered);
        }
        if r & 0x3000 == 0 {
            while let Some(t) = host.recv() {
                match t {
                    Telemetry::Lost(n) => tel_lost_reported += n,
                    Telemetry::EventsLost(i) => {
                        assert_eq!(i, tel_got as u8, "telemetry out of order");
                        tel_got += 1;
                    }
                    other => panic!("never sent: {other:?}"),
                }
            }
        }
    }
    // Everything queued arrives, in order; telemetry adds up.
    while let Some(c) = tick.recv() {
        assert_eq!(Some(c), queued.pop_front());
    }
    assert!(queued.is_empty());
    while let Some(t) = host.recv() {
        match t {
            Telemetry::Lost(n) => tel_lost_reported += n,
            Telemetry::EventsLost(i) => {
                assert_eq!(i, tel_got as u8);
                tel_got += 1;
            }
            other => panic!("never sent: {other:?}"),
        }
    }
    assert_eq!(tel_got, tel_next);
    assert_eq!(tel_sent, tel_got + tel_lost_reported + tick.lost(), "telemetry not accounted for");
    assert_eq!(host.refused(), refused);
}

fuzz_target!(|data: &[u8]| {
    let (&head, rest) = match data.split_first() {
        Some(x) => x,
        None => return,
    };
    let (seed, bytes) = match rest.split_first_chunk::<4>() {
        Some((s, b)) => (u32::from_le_bytes(*s), b),
        None => (0x9e37_79b9, rest),
    };
    let lock = match head % 3 {
        0 => DialectLock::Auto,
        1 => DialectLock::DriverOnly,
        _ => DialectLock::ConfiguratorOnly,
    };
    let gaps = [500, 0, 50, u32::MAX];
    let backs = [1000, 0, 5, u32::MAX];
    let cfg = ProtocolConfig {
        lock,
        resync_gap_ms: gaps[usize::from(head >> 2) % 4],
        resync_backward: backs[usize::from(head >> 4) % 4],
    };
    if head & 0x40 == 0 {
        run::<f32>(cfg, seed, bytes);
    } else {
        run::<Fx>(cfg, seed, bytes);
    }
});
