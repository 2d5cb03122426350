//! The transmit path of the protocol port: a fixed byte ring in front of the
//! hardware, with an admission rule per line class, every dropped line
//! counted and reported on the wire, and room reserved for the lines that
//! must never be lost.
//!
//! # Policy
//!
//! * A line is queued whole or not at all (a host never sees half a line).
//! * [`Class::Feedback`] (periodic status) is admitted only while at least
//!   [`FEEDBACK_HEADROOM`] bytes stay free after it; [`Class::Report`]
//!   (event and rejection lines) while [`CRITICAL_RESERVE`] bytes stay
//!   free; [`Class::Critical`] (fault, soft E-stop, stopped, enabled) while
//!   it fits at all. So a slow or absent reader loses feedback first, then
//!   reports, and a critical line always finds the reserve.
//! * A critical line that still does not fit (only if more than the reserve
//!   of critical lines arrive before the reader catches up) waits in a
//!   small pending list, sent before anything else as soon as there is
//!   room; only when that list is full is a critical line dropped (counted
//!   separately in [`TxCounters::critical_dropped`]; no test or scenario
//!   reaches it).
//! * Every dropped line is counted; the count goes out as a `TX_LOST n=<n>`
//!   line at the first opportunity (ahead of the next line that is queued).
//!   Lines produced while no host has the port open are counted apart and
//!   reported as `TX_LOST n=<n> reason=PORT_CLOSED` when a host opens it;
//!   critical lines are kept (pending) across a closed port.
//!
//! The composition root ([`crate::root::Host`]) and every board share this
//! one implementation; the board's [`Port`] only moves bytes.

use heapless::{Deque, Vec};
use protocol::report::tx_lost_line;
use protocol::Line;

use crate::board::Port;

/// Bytes of the transmit ring (the firmware's: about 20 feedback lines).
pub const TX_CAP: usize = 2048;
/// Bytes kept free for critical lines (at least 8 of the longest, 60 B).
pub const CRITICAL_RESERVE: usize = 512;
/// Bytes kept free after a feedback line (reports and critical lines first).
pub const FEEDBACK_HEADROOM: usize = 1024;
/// Critical lines that may wait for room.
pub const PENDING: usize = 4;

const _: () = assert!(CRITICAL_RESERVE < FEEDBACK_HEADROOM && FEEDBACK_HEADROOM < TX_CAP);
const _: () = assert!(CRITICAL_RESERVE >= 8 * 60);

/// How important a line is (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Class {
    /// A fault, soft E-stop, stopped or enabled line: never dropped.
    Critical,
    /// An event, rejection, resynchronisation or queue report.
    Report,
    /// A periodic feedback line.
    Feedback,
}

/// Counters of the transmit path (all saturating).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TxCounters {
    /// Lines queued.
    pub queued: u32,
    /// Lines dropped while a host had the port open.
    pub dropped: u32,
    /// Lines dropped while no host had the port open.
    pub dropped_closed: u32,
    /// Critical lines dropped (the pending list was full).
    pub critical_dropped: u32,
    /// `TX_LOST` lines queued.
    pub reports: u32,
}

/// The transmit ring with its policy.
#[derive(Debug)]
pub struct Tx {
    ring: Deque<u8, TX_CAP>,
    pending: Vec<Line, PENDING>,
    /// Dropped while open, not yet reported.
    unreported: u32,
    /// Dropped while closed, not yet reported.
    unreported_closed: u32,
    counters: TxCounters,
    scratch: Line,
}

impl Default for Tx {
    fn default() -> Self {
        Self::new()
    }
}

impl Tx {
    /// An empty ring.
    pub const fn new() -> Self {
        Tx {
            ring: Deque::new(),
            pending: Vec::new(),
            unreported: 0,
            unreported_closed: 0,
            counters: TxCounters { queued: 0, dropped: 0, dropped_closed: 0, critical_dropped: 0, reports: 0 },
            scratch: Line::new(),
        }
    }

    /// Counters so far.
    pub fn counters(&self) -> TxCounters {
        self.counters
    }

    /// Bytes free in the ring.
    pub fn free(&self) -> usize {
        TX_CAP.saturating_sub(self.ring.len())
    }

    /// Bytes waiting in the ring.
    pub fn queued_bytes(&self) -> usize {
        self.ring.len()
    }

    /// Critical lines waiting for room.
    pub fn pending(&self) -> usize {
        self.pending.len()
    }

    fn admits(&self, len: usize, class: Class) -> bool {
        let keep = match class {
            Class::Critical => 0,
            Class::Report => CRITICAL_RESERVE,
            Class::Feedback => FEEDBACK_HEADROOM,
        };
        self.free() >= len.saturating_add(keep)
    }

    fn put(&mut self, bytes: &[u8]) {
        for &b in bytes {
            // Cannot fail: callers checked `admits` for the whole line.
            let _ = self.ring.push_back(b);
        }
        self.counters.queued = self.counters.queued.saturating_add(1);
    }

    fn drop_line(&mut self, open: bool) {
        if open {
            self.counters.dropped = self.counters.dropped.saturating_add(1);
            self.unreported = self.unreported.saturating_add(1);
        } else {
            self.counters.dropped_closed = self.counters.dropped_closed.saturating_add(1);
            self.unreported_closed = self.unreported_closed.saturating_add(1);
        }
    }

    /// Moves pending critical lines into the ring while they fit.
    fn promote_pending(&mut self) {
        while let Some(first) = self.pending.first() {
            if !self.admits(first.len(), Class::Critical) {
                return;
            }
            let line = self.pending.remove(0);
            self.put(line.as_bytes());
        }
    }

    /// Queues the pending `TX_LOST` reports if they, and `then` more bytes
    /// of `class` after them, fit; true if nothing is left unreported.
    fn report_losses(&mut self, then: usize, class: Class) -> bool {
        for closed in [true, false] {
            let n = if closed { self.unreported_closed } else { self.unreported };
            if n == 0 {
                continue;
            }
            let mut line = core::mem::take(&mut self.scratch);
            let fits =
                tx_lost_line(&mut line, n, closed).is_ok() && self.admits(line.len().saturating_add(then), class);
            if fits {
                self.put(line.as_bytes());
                self.counters.reports = self.counters.reports.saturating_add(1);
                if closed {
                    self.unreported_closed = 0;
                } else {
                    self.unreported = 0;
                }
            }
            self.scratch = line;
        }
        self.unreported == 0 && self.unreported_closed == 0
    }

    /// Offers one line (terminator included). `open`: a host has the port
    /// open now. Returns whether the line was queued (a critical line that
    /// waits in the pending list counts as queued).
    pub fn push(&mut self, line: &Line, class: Class, open: bool) -> bool {
        if open {
            self.promote_pending();
        }
        if class == Class::Critical {
            if self.pending.is_empty() && open && self.admits(line.len(), Class::Critical) {
                self.put(line.as_bytes());
                return true;
            }
            if self.pending.push(line.clone()).is_ok() {
                return true;
            }
            self.counters.critical_dropped = self.counters.critical_dropped.saturating_add(1);
            self.drop_line(open);
            return false;
        }
        if !open {
            self.drop_line(false);
            return false;
        }
        // A line never overtakes an unreported loss: the host learns of the
        // gap before it sees what followed it, and the report goes in only
        // together with the line that follows it.
        if self.report_losses(line.len(), class) && self.admits(line.len(), class) {
            self.put(line.as_bytes());
            true
        } else {
            self.drop_line(true);
            false
        }
    }

    /// True if a line of `len` bytes of `class` would be admitted now.
    pub fn would_admit(&self, len: usize, class: Class) -> bool {
        self.admits(len, class)
    }

    /// The port closed: what is still queued will not be read by the host
    /// that opens it next (stale), so it is discarded and counted as lost
    /// while closed (critical lines excepted: they are kept pending, up to
    /// [`PENDING`]).
    pub fn on_close(&mut self) {
        let mut lines = 0u32;
        while let Some(b) = self.ring.pop_front() {
            if b == b'\n' {
                lines = lines.saturating_add(1);
            }
        }
        self.counters.dropped_closed = self.counters.dropped_closed.saturating_add(lines);
        self.unreported_closed = self.unreported_closed.saturating_add(lines);
    }

    /// A host opened the port: queues `banner` first, then the critical
    /// lines kept while the port was closed, then the report of what was
    /// lost meanwhile.
    pub fn on_open(&mut self, banner: &Line) {
        if self.admits(banner.len(), Class::Critical) {
            self.put(banner.as_bytes());
        } else {
            self.drop_line(true);
        }
        self.promote_pending();
        let _ = self.report_losses(0, Class::Report);
    }

    /// Moves queued bytes to the port as far as it takes them. Never blocks.
    pub fn flush<P: Port + ?Sized>(&mut self, port: &mut P) {
        if port.is_open() {
            self.promote_pending();
            // Once the reader has caught up (the ring is below the feedback
            // mark), losses are reported even if no other line follows.
            let _ = self.report_losses(0, Class::Feedback);
        }
        // Bounded: every pass either moves at least one byte or stops, and
        // the ring holds at most TX_CAP bytes; two slices per ring state.
        for _ in 0..=TX_CAP {
            let (a, _) = self.ring.as_slices();
            if a.is_empty() {
                break;
            }
            let n = port.write(a).min(a.len());
            if n == 0 {
                break;
            }
            for _ in 0..n {
                let _ = self.ring.pop_front();
            }
        }
    }
}

// Test code is built with overflow checks on: an overflow fails the test.
#[cfg(test)]
#[allow(clippy::arithmetic_side_effects)]
mod tests {
    use super::*;
    use core::fmt::Write as _;

    /// A port that takes at most `budget` bytes in total.
    struct Slow {
        out: std::vec::Vec<u8>,
        budget: usize,
        open: bool,
    }

    impl Port for Slow {
        fn is_open(&self) -> bool {
            self.open
        }
        fn read(&mut self) -> Option<u8> {
            None
        }
        fn write(&mut self, bytes: &[u8]) -> usize {
            let n = bytes.len().min(self.budget);
            self.out.extend_from_slice(&bytes[..n]);
            self.budget -= n;
            n
        }
    }

    fn line(s: &str) -> Line {
        let mut l = Line::new();
        l.write_str(s).unwrap();
        l
    }

    fn lines(b: &[u8]) -> std::vec::Vec<std::string::String> {
        std::string::String::from_utf8(b.to_vec()).unwrap().lines().map(|s| s.to_string()).collect()
    }

    #[test]
    fn feedback_is_dropped_first_counted_and_reported() {
        let mut tx = Tx::new();
        let fb = line(&format!("<ACK,{}>\n", "0".repeat(93)));
        let mut queued = 0;
        for _ in 0..30 {
            if tx.push(&fb, Class::Feedback, true) {
                queued += 1;
            }
        }
        // 2048 - 1024 headroom: ten 100-byte lines fit.
        assert_eq!(queued, 10);
        assert_eq!(tx.counters().dropped, 20);
        // A report still fits (the headroom is for it), but only after the
        // loss report.
        assert!(tx.push(&line("REFUSED MOTION NOT_HOMED\n"), Class::Report, true));
        let mut port = Slow { out: std::vec::Vec::new(), budget: usize::MAX, open: true };
        tx.flush(&mut port);
        let got = lines(&port.out);
        assert_eq!(got.len(), 12);
        assert_eq!(got[10], "TX_LOST n=20");
        assert_eq!(got[11], "REFUSED MOTION NOT_HOMED");
        assert_eq!(tx.counters().reports, 1);
    }

    #[test]
    fn critical_lines_use_the_reserve_and_then_wait() {
        let mut tx = Tx::new();
        let rep = line(&format!("REFUSED {}\n", "X".repeat(90)));
        while tx.push(&rep, Class::Report, true) {}
        // Reports stop at the reserve.
        assert!(tx.free() >= CRITICAL_RESERVE && tx.free() < CRITICAL_RESERVE + rep.len());
        let fault = line("FAULT LIMIT_SWITCH J3\n");
        for _ in 0..(tx.free() / fault.len()) {
            assert!(tx.push(&fault, Class::Critical, true));
        }
        // The ring is now full for this line: the next ones wait.
        for _ in 0..PENDING {
            assert!(tx.push(&fault, Class::Critical, true));
        }
        assert_eq!(tx.pending(), PENDING);
        assert_eq!(tx.counters().critical_dropped, 0);
        // A slow reader: pending critical lines go out before new reports.
        let mut port = Slow { out: std::vec::Vec::new(), budget: TX_CAP, open: true };
        tx.flush(&mut port);
        assert!(tx.push(&rep, Class::Report, true));
        tx.flush(&mut port);
        port.budget = usize::MAX;
        tx.flush(&mut port);
        let got = lines(&port.out);
        let faults = got.iter().filter(|l| l.starts_with("FAULT")).count();
        let last_fault = got.iter().rposition(|l| l.starts_with("FAULT")).unwrap();
        assert_eq!(tx.pending(), 0);
        // The one report refused at the reserve is reported, after every
        // critical line (pending ones included), before the next report.
        let tail: std::vec::Vec<&str> = got[last_fault + 1..].iter().map(|s| s.as_str()).collect();
        assert_eq!(tail.len(), 2, "{tail:?}");
        assert_eq!(tail[0], "TX_LOST n=1");
        assert!(tail[1].starts_with("REFUSED"));
        assert!(faults >= PENDING + 20);
        assert_eq!(tx.counters().dropped, 1);
        assert_eq!(got.len() as u32, tx.counters().queued, "{got:?}");
    }

    #[test]
    fn closed_port_counts_apart_and_keeps_critical_lines() {
        let mut tx = Tx::new();
        let fb = line("<ACK,1,0.000>\n");
        assert!(tx.push(&fb, Class::Feedback, true));
        tx.on_close();
        assert!(!tx.push(&fb, Class::Feedback, false));
        assert!(tx.push(&line("SOFT_ESTOP since_cmd_ms=101\n"), Class::Critical, false));
        let mut port = Slow { out: std::vec::Vec::new(), budget: usize::MAX, open: false };
        tx.flush(&mut port);
        assert!(port.out.is_empty());
        port.open = true;
        tx.on_open(&line("BOOT PAROL6\n"));
        tx.flush(&mut port);
        let got = lines(&port.out);
        assert_eq!(got, ["BOOT PAROL6", "SOFT_ESTOP since_cmd_ms=101", "TX_LOST n=2 reason=PORT_CLOSED"]);
    }
}
