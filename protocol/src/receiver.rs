//! Framer, parser and sequence filter chained: bytes in, at most one
//! [`Received`] per byte out.
//!
//! Module dependencies run one way: this module uses [`crate::report`] to
//! word its outcomes, and `report` does not use this module ([`Rejection`]
//! is defined at the crate root, next to the framer's and parser's errors).

use crate::framer::{Framer, FramerCounters};
use crate::parse::{Command, Parser};
use crate::report::{reject_line, resync_line, stale_line};
use crate::seq::{Resync, SeqCounters, SeqFilter, Stale, Verdict};
use crate::{Full, Line, ProtocolConfig, INPUT_LINE_CAP};
use kernel::config::Validated;
use kernel::Scalar;

pub use crate::Rejection;

/// What one line turned into.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Received<S> {
    /// A command to pass to the tick; `resync` is `Some` if the sequence
    /// filter resynchronised on this motion frame.
    Accepted {
        /// The command.
        command: Command<S>,
        /// The resynchronisation, if any.
        resync: Option<Resync>,
    },
    /// A line rejected whole; `count` is the running total of rejections.
    Rejected {
        /// Why.
        rejection: Rejection,
        /// Rejections so far (saturating), this one included.
        count: u32,
    },
    /// A well-formed motion frame dropped as stale or duplicate.
    Dropped(Stale),
}

impl<S> Received<S> {
    /// The report line for this outcome, if it needs one (every rejection,
    /// every drop, every resynchronisation; an accepted command without
    /// resynchronisation needs none). Returns whether `out` holds a line.
    pub fn report(&self, out: &mut Line) -> Result<bool, Full> {
        match self {
            Received::Accepted { resync: None, .. } => Ok(false),
            Received::Accepted { resync: Some(r), .. } => resync_line(out, r).map(|()| true),
            Received::Rejected { rejection, count } => reject_line(out, rejection, *count).map(|()| true),
            Received::Dropped(s) => stale_line(out, s).map(|()| true),
        }
    }
}

/// Counters of a [`Receiver`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counters {
    /// Framer counters.
    pub framer: FramerCounters,
    /// Sequence filter counters.
    pub seq: SeqCounters,
    /// Commands accepted.
    pub accepted: u32,
    /// Lines rejected (framer and parser).
    pub rejected: u32,
}

/// Bytes in, commands and reports out.
#[derive(Debug)]
pub struct Receiver<S, const N: usize = INPUT_LINE_CAP> {
    framer: Framer<N>,
    parser: Parser<S>,
    seq: SeqFilter,
    accepted: u32,
    rejected: u32,
}

impl<S: Scalar, const N: usize> Receiver<S, N> {
    /// A receiver for `arm`'s limits with protocol settings `cfg`.
    pub fn new(arm: &Validated, cfg: ProtocolConfig) -> Self {
        Receiver {
            framer: Framer::new(),
            parser: Parser::new(arm, cfg.lock),
            seq: SeqFilter::new(cfg.resync_gap_ms, cfg.resync_backward),
            accepted: 0,
            rejected: 0,
        }
    }

    /// SEQ of the last accepted motion frame (for the feedback's ACK; 0 if none).
    pub fn last_seq(&self) -> u32 {
        self.seq.last().unwrap_or(0)
    }

    /// The parser (limits and lock).
    pub fn parser(&self) -> &Parser<S> {
        &self.parser
    }

    /// All counters.
    pub fn counters(&self) -> Counters {
        Counters {
            framer: self.framer.counters(),
            seq: self.seq.counters(),
            accepted: self.accepted,
            rejected: self.rejected,
        }
    }

    /// Feeds one byte received at `now_ms` (a free-running millisecond
    /// clock; wrapping is fine).
    pub fn push(&mut self, byte: u8, now_ms: u32) -> Option<Received<S>> {
        let parsed = match self.framer.push(byte)? {
            Ok(line) => self.parser.parse(line).map_err(Rejection::Frame),
            Err(e) => Err(Rejection::Line(e)),
        };
        Some(match parsed {
            Err(rejection) => {
                self.rejected = self.rejected.saturating_add(1);
                Received::Rejected { rejection, count: self.rejected }
            }
            Ok(command) => {
                let resync = match command {
                    Command::Motion { seq, .. } => match self.seq.check(seq, now_ms) {
                        Verdict::Accept(r) => r,
                        Verdict::Drop(stale) => return Some(Received::Dropped(stale)),
                    },
                    Command::Home | Command::HomeJoint(_) | Command::Enable => {
                        self.seq.reset();
                        None
                    }
                };
                self.accepted = self.accepted.saturating_add(1);
                Received::Accepted { command, resync }
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kernel::config::PAROL6_VALIDATED;

    fn feed(rx: &mut Receiver<f32>, s: &[u8], now: u32) -> Vec<Received<f32>> {
        s.iter().filter_map(|&b| rx.push(b, now)).collect()
    }

    #[test]
    fn home_resets_sequence() {
        let mut rx: Receiver<f32> = Receiver::new(&PAROL6_VALIDATED, ProtocolConfig::DEFAULT);
        let z = b"<5,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000>\n";
        assert!(matches!(feed(&mut rx, z, 0)[..], [Received::Accepted { .. }]));
        assert!(matches!(feed(&mut rx, z, 1)[..], [Received::Dropped(_)]));
        assert!(matches!(feed(&mut rx, b"<HOME>\r\n", 2)[..], [Received::Accepted { command: Command::Home, .. }]));
        assert!(matches!(feed(&mut rx, z, 3)[..], [Received::Accepted { resync: None, .. }]));
        assert_eq!(rx.last_seq(), 5);
        let c = rx.counters();
        assert_eq!((c.accepted, c.rejected, c.seq.duplicates, c.seq.resets), (3, 0, 1, 1));
    }
}
