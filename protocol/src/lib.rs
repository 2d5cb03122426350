//! The PAROL6 wire protocol, as the firmware and the simulator speak it.
//!
//! Bytes from the host go through:
//!
//! 1. [`framer::Framer`]: bytes in, complete lines out, from a fixed buffer;
//!    over-long lines and lines with non-printable bytes are rejected with a
//!    reason, never silently;
//! 2. [`parse::Parser`]: one line to one [`Command`], generic over
//!    [`kernel::Scalar`]; both host dialects, told apart by the *strict
//!    discriminator* (every number has exactly 3 decimals: driver; exactly 4:
//!    configurator; anything else is rejected whole), then range-checked
//!    against the arm's configuration;
//! 3. [`seq::SeqFilter`]: stale and duplicate motion frames are dropped and
//!    reported, with resynchronisation (HOME, ENABLE, a gap in traffic, a
//!    large backward jump).
//!
//! [`receiver::Receiver`] chains the three. Accepted commands travel to the
//! 1 kHz tick through [`queue::Link`] (two `heapless::spsc` queues); status
//! and [`kernel::Event`]s travel back the same way and are turned into text
//! by [`feedback`] and [`report`].
//!
//! The crate is `no_std`, allocates nothing, contains no `unsafe`, and has no
//! panicking operation outside tests (clippy denies `unwrap`, `expect`,
//! indexing, `panic!` and unchecked arithmetic). Every buffer has a fixed
//! capacity and every loop is bounded by a buffer length or a constant.
//!
//! The project's protocol reference is `docs/PROTOCOL.md`.
//!
//! ```
//! use kernel::config::{PAROL6, PAROL6_VALIDATED};
//! use protocol::{receiver::{Receiver, Received}, Command, ProtocolConfig};
//! let mut rx: Receiver<f32> = Receiver::new(&PAROL6_VALIDATED, ProtocolConfig::DEFAULT);
//! let mut got = None;
//! for &b in b"<HOME>\r\n" {
//!     if let Some(r) = rx.push(b, 0) {
//!         got = Some(r);
//!     }
//! }
//! assert!(matches!(got, Some(Received::Accepted { command: Command::Home, .. })));
//! ```
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![cfg_attr(
    not(test),
    deny(
        clippy::unwrap_used,
        clippy::expect_used,
        clippy::indexing_slicing,
        clippy::panic,
        clippy::arithmetic_side_effects
    )
)]

pub mod feedback;
pub mod framer;
pub mod parse;
pub mod queue;
pub mod receiver;
pub mod report;
pub mod seq;
mod text;

pub use parse::{Command, Dialect, DialectLock, ParseError, Parser};
pub use text::{Full, Line, LINE_CAP};

/// Why a line was rejected: by the framer or by the parser. Defined here,
/// beside the two error types it wraps, so that both [`receiver`] (which
/// produces it) and [`report`] (which words it) depend on it without
/// depending on each other; also reachable as `receiver::Rejection`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rejection {
    /// Over-long or non-printable line.
    Line(framer::LineError),
    /// Malformed, ambiguous or out-of-limits frame.
    Frame(ParseError),
}

/// Largest line the firmware accepts from a host, in bytes without the
/// terminator. A worst-case driver line is about 94 bytes (13 fields of up
/// to 10 characters and 12 separators); 128 leaves room for both dialects.
pub const INPUT_LINE_CAP: usize = 128;

/// Protocol settings chosen by the composition root.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ProtocolConfig {
    /// Which motion dialects are accepted.
    pub lock: DialectLock,
    /// Silence (ms since the last accepted motion frame) after which any
    /// sequence number is accepted as the start of a new stream.
    pub resync_gap_ms: u32,
    /// A frame more than this many numbers *behind* the last accepted one
    /// is taken as a restarted client and accepted (resynchronisation);
    /// a frame at most this far behind is dropped as stale.
    pub resync_backward: u32,
}

impl ProtocolConfig {
    /// Auto dialect (strict discriminator), 500 ms gap, 1000-frame backward jump.
    pub const DEFAULT: ProtocolConfig =
        ProtocolConfig { lock: DialectLock::Auto, resync_gap_ms: 500, resync_backward: 1000 };
}

impl Default for ProtocolConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}
