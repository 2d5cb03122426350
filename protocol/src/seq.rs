//! Sequence handling: stale and duplicate motion frames are dropped and
//! reported; the filter resynchronises so a restarted client is never locked
//! out for long.
//!
//! # Rule
//!
//! Sequence numbers are compared with serial-number arithmetic (RFC 1982 on
//! u32): `d = seq.wrapping_sub(last) as i32`, so `0` follows `4294967295`.
//! For each well-formed motion frame, with `last` the SEQ of the last
//! *accepted* motion frame and `now_ms` the caller's millisecond clock:
//!
//! 1. no `last` (boot, or after `<HOME>`, `<HOMEn>` or `<ENABLE>`, which call
//!    [`SeqFilter::reset`]): accept;
//! 2. more than `resync_gap_ms` since the last accepted motion frame: accept
//!    and report a [`ResyncReason::Gap`];
//! 3. `d > 0` (newer, including forward jumps and wrap-around): accept;
//! 4. `d == 0`: drop as [`StaleReason::Duplicate`];
//! 5. `d < 0` and `|d| > resync_backward`: accept and report a
//!    [`ResyncReason::BackwardJump`] (a restarted client counting from 0);
//! 6. otherwise (`d < 0`, at most `resync_backward` behind): drop as
//!    [`StaleReason::Behind`].
//!
//! Because rule 2 measures time since the last *accepted* frame, a client
//! whose numbers are behind can be locked out for at most `resync_gap_ms`.
//! Every drop is reported with the running count of drops.

/// Why a frame was dropped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StaleReason {
    /// Same SEQ as the last accepted frame.
    Duplicate,
    /// Older than the last accepted frame (within the backward window).
    Behind,
}

/// A dropped frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stale {
    /// Its SEQ.
    pub seq: u32,
    /// SEQ of the last accepted frame.
    pub last: u32,
    /// Why.
    pub reason: StaleReason,
    /// Frames dropped so far (saturating), this one included.
    pub count: u32,
}

/// Why the filter resynchronised on an accepted frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResyncReason {
    /// No accepted motion frame for `ms` milliseconds.
    Gap {
        /// Milliseconds since the last accepted motion frame.
        ms: u32,
    },
    /// SEQ jumped back by more than the configured window.
    BackwardJump,
}

/// A resynchronisation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Resync {
    /// Why.
    pub reason: ResyncReason,
    /// SEQ of the new frame.
    pub seq: u32,
    /// SEQ of the last frame accepted before it.
    pub last: u32,
}

/// Verdict on one motion frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Apply it; `Some` if the filter resynchronised.
    Accept(Option<Resync>),
    /// Drop it.
    Drop(Stale),
}

/// Counters, saturating.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SeqCounters {
    /// Duplicates dropped.
    pub duplicates: u32,
    /// Older frames dropped.
    pub behind: u32,
    /// Resynchronisations after a gap.
    pub gap_resyncs: u32,
    /// Resynchronisations after a backward jump.
    pub jump_resyncs: u32,
    /// Explicit resets (HOME, HOMEn, ENABLE).
    pub resets: u32,
}

/// The stale-frame filter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SeqFilter {
    last: Option<u32>,
    last_ms: u32,
    gap_ms: u32,
    backward: u32,
    counters: SeqCounters,
}

impl SeqFilter {
    /// A filter with the given gap (ms) and backward window (frames).
    pub const fn new(resync_gap_ms: u32, resync_backward: u32) -> Self {
        SeqFilter {
            last: None,
            last_ms: 0,
            gap_ms: resync_gap_ms,
            backward: resync_backward,
            counters: SeqCounters { duplicates: 0, behind: 0, gap_resyncs: 0, jump_resyncs: 0, resets: 0 },
        }
    }

    /// SEQ of the last accepted motion frame.
    pub fn last(&self) -> Option<u32> {
        self.last
    }

    /// Counters.
    pub fn counters(&self) -> SeqCounters {
        self.counters
    }

    /// Forgets the last SEQ (on HOME, HOMEn, ENABLE): the next frame is accepted.
    pub fn reset(&mut self) {
        self.last = None;
        self.counters.resets = self.counters.resets.saturating_add(1);
    }

    /// Judges a motion frame with sequence number `seq` received at `now_ms`.
    pub fn check(&mut self, seq: u32, now_ms: u32) -> Verdict {
        let c = &mut self.counters;
        let verdict = match self.last {
            None => Verdict::Accept(None),
            Some(last) => {
                let elapsed = now_ms.wrapping_sub(self.last_ms);
                let d = seq.wrapping_sub(last) as i32;
                if elapsed > self.gap_ms {
                    c.gap_resyncs = c.gap_resyncs.saturating_add(1);
                    Verdict::Accept(Some(Resync { reason: ResyncReason::Gap { ms: elapsed }, seq, last }))
                } else if d > 0 {
                    Verdict::Accept(None)
                } else if d.unsigned_abs() > self.backward {
                    c.jump_resyncs = c.jump_resyncs.saturating_add(1);
                    Verdict::Accept(Some(Resync { reason: ResyncReason::BackwardJump, seq, last }))
                } else {
                    let reason = if d == 0 {
                        c.duplicates = c.duplicates.saturating_add(1);
                        StaleReason::Duplicate
                    } else {
                        c.behind = c.behind.saturating_add(1);
                        StaleReason::Behind
                    };
                    let count = c.duplicates.saturating_add(c.behind);
                    Verdict::Drop(Stale { seq, last, reason, count })
                }
            }
        };
        if let Verdict::Accept(_) = verdict {
            self.last = Some(seq);
            self.last_ms = now_ms;
        }
        verdict
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f() -> SeqFilter {
        SeqFilter::new(500, 1000)
    }

    #[test]
    fn newer_accepted_older_and_duplicate_dropped() {
        let mut s = f();
        assert_eq!(s.check(10, 0), Verdict::Accept(None));
        assert_eq!(s.check(11, 10), Verdict::Accept(None));
        assert_eq!(s.check(15, 20), Verdict::Accept(None));
        assert_eq!(
            s.check(15, 30),
            Verdict::Drop(Stale { seq: 15, last: 15, reason: StaleReason::Duplicate, count: 1 })
        );
        assert_eq!(s.check(12, 40), Verdict::Drop(Stale { seq: 12, last: 15, reason: StaleReason::Behind, count: 2 }));
        assert_eq!(s.last(), Some(15));
    }

    #[test]
    fn wraps_with_serial_arithmetic() {
        let mut s = f();
        assert_eq!(s.check(u32::MAX - 1, 0), Verdict::Accept(None));
        assert_eq!(s.check(u32::MAX, 10), Verdict::Accept(None));
        assert_eq!(s.check(0, 20), Verdict::Accept(None));
        assert_eq!(s.check(1, 30), Verdict::Accept(None));
        assert!(matches!(s.check(u32::MAX, 40), Verdict::Drop(Stale { reason: StaleReason::Behind, .. })));
    }

    #[test]
    fn resync_on_gap_jump_and_reset() {
        let mut s = f();
        let _ = s.check(500, 0);
        // restarted client, small backward distance: dropped until the gap
        assert!(matches!(s.check(0, 10), Verdict::Drop(_)));
        assert!(matches!(s.check(1, 500), Verdict::Drop(_)));
        assert_eq!(
            s.check(2, 501),
            Verdict::Accept(Some(Resync { reason: ResyncReason::Gap { ms: 501 }, seq: 2, last: 500 }))
        );
        assert_eq!(s.check(3, 502), Verdict::Accept(None));
        // large backward jump
        let _ = s.check(100_000, 503);
        assert_eq!(
            s.check(0, 504),
            Verdict::Accept(Some(Resync { reason: ResyncReason::BackwardJump, seq: 0, last: 100_000 }))
        );
        // explicit reset
        let _ = s.check(50, 505);
        s.reset();
        assert_eq!(s.check(0, 506), Verdict::Accept(None));
        // clock wrap
        let mut s = f();
        let _ = s.check(7, u32::MAX - 5);
        assert!(matches!(s.check(7, 3), Verdict::Drop(_)));
        assert!(matches!(s.check(7, 600), Verdict::Accept(Some(_))));
    }
}
