//! Command parser: one line to one [`Command`], accepted whole or rejected
//! whole with a [`ParseError`].
//!
//! # Grammar (exact; keywords are case-sensitive)
//!
//! ```text
//! line    = "<" body ">"                       (nothing before "<" or after ">")
//! body    = "HOME" | "ENABLE" | "HOME" ("1".."6") | motion
//! motion  = seq 12*("," number)
//! seq     = 1*DIGIT                            (decimal u32, no sign, overflow rejected)
//! number  = ["-"] 1*DIGIT "." 3DIGIT           (driver: 12 x interleaved p,v)
//!         | ["-"] 1*DIGIT "." 4DIGIT           (configurator: p1..p6 then v1..v6)
//! ```
//!
//! # Dialect rule (strict discriminator)
//!
//! A motion frame is read as the driver's (interleaved) only if *all twelve*
//! numbers have exactly 3 decimals, and as the configurator's (grouped) only
//! if all twelve have exactly 4. Anything else (a mix, 2 or 5 decimals, no
//! decimal point) is rejected whole. A velocity can therefore never be read
//! as a position: the two layouts are distinguished by a property every
//! number of the frame must share, never by a guess. [`DialectLock`] can
//! further restrict the accepted dialect.
//!
//! Numbers are converted with [`Scalar::parse_decimal`] only after the
//! syntax above is validated here (so `+1.000`, `1e3`, `nan`, `inf`, spaces
//! never reach it); `None` from it (does not fit the scalar) is a rejection.
//! Every accepted target is then checked against the arm's configuration:
//! `limit_min <= p <= limit_max` and `|v| <= max_velocity`, with the limits
//! checked by the kernel's own [`kernel::TargetLimits`].

use kernel::config::{Validated, AXES};
use kernel::{Authority, EnableCapability, MotionKind, MotionTarget, Request, Scalar};

/// Number of comma-separated fields of a motion frame (SEQ + 12 numbers).
pub const MOTION_FIELDS: usize = 13;

/// The two host dialects.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dialect {
    /// ROS 2 driver: interleaved `p1,v1,...,p6,v6`, 3 decimals.
    Driver,
    /// Configurator: grouped `p1..p6,v1..v6`, 4 decimals.
    Configurator,
}

impl Dialect {
    /// Decimals every number of this dialect has.
    pub const fn decimals(self) -> usize {
        match self {
            Dialect::Driver => 3,
            Dialect::Configurator => 4,
        }
    }
    /// `10^decimals`.
    pub const fn scale(self) -> i64 {
        match self {
            Dialect::Driver => 1_000,
            Dialect::Configurator => 10_000,
        }
    }
    /// Field indices (1..=12) of each joint's position and velocity.
    pub const fn fields(self) -> &'static [(usize, usize); AXES] {
        match self {
            Dialect::Driver => &[(1, 2), (3, 4), (5, 6), (7, 8), (9, 10), (11, 12)],
            Dialect::Configurator => &[(1, 7), (2, 8), (3, 9), (4, 10), (5, 11), (6, 12)],
        }
    }
}

/// Which motion dialects are accepted. Keywords (`<HOME>`, `<ENABLE>`,
/// `<HOME1>`..`<HOME6>`) cannot be misread and are accepted in every mode.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DialectLock {
    /// Only the driver's 3-decimal interleaved frames.
    DriverOnly,
    /// Only the configurator's 4-decimal grouped frames.
    ConfiguratorOnly,
    /// Either, by the strict discriminator (the default).
    #[default]
    Auto,
}

/// A command accepted from the host. `Enable` is a protocol value: only the
/// composition root holding the kernel's [`Authority`] can turn it into
/// [`Request::Enable`] (see [`Command::into_request`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command<S> {
    /// A motion frame.
    Motion {
        /// The host's sequence number.
        seq: u32,
        /// Which dialect it was read as.
        dialect: Dialect,
        /// Positions and velocities, within the joint limits.
        target: MotionTarget<S>,
    },
    /// `<HOME>`.
    Home,
    /// `<HOMEn>`: joint index `n - 1` (0..=5).
    HomeJoint(u8),
    /// `<ENABLE>`.
    Enable,
}

impl<S> Command<S> {
    /// The kernel request for this command; `enable` is called only for
    /// [`Command::Enable`] and must mint the capability (e.g.
    /// `|| authority.enable()`), which is the caller's decision.
    pub fn into_request_with(self, enable: impl FnOnce() -> EnableCapability) -> Request<S> {
        match self {
            Command::Motion { target, .. } => Request::Motion(target),
            Command::Home => Request::Home,
            Command::HomeJoint(j) => Request::HomeJoint(j),
            Command::Enable => Request::Enable(enable()),
        }
    }
    /// [`Self::into_request_with`] using `authority` for `<ENABLE>`.
    pub fn into_request(self, authority: &Authority) -> Request<S> {
        self.into_request_with(|| authority.enable())
    }
    /// True for motion frames.
    pub const fn is_motion(&self) -> bool {
        matches!(self, Command::Motion { .. })
    }
}

/// Why a frame was rejected. Field indices count from 0 (SEQ) to 12.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ParseError {
    /// The line does not start with `<`.
    MissingStart,
    /// No `>` in the line.
    MissingEnd,
    /// Text after the first `>`.
    TrailingText,
    /// `<>`.
    EmptyFrame,
    /// A body starting with a letter that is not exactly `HOME`, `ENABLE` or
    /// `HOME1`..`HOME6` (case-sensitive).
    UnknownKeyword,
    /// Not 13 comma-separated fields (`found`, saturating at 255).
    WrongFieldCount {
        /// Fields found.
        found: u8,
    },
    /// An empty field.
    EmptyField {
        /// Field index.
        field: u8,
    },
    /// SEQ is not a plain decimal number.
    BadSeq,
    /// SEQ does not fit in a u32.
    SeqOverflow,
    /// A number is not `-?digits[.digits]` (sign `+`, exponent, `nan`,
    /// `inf`, spaces, other characters).
    NonNumeric {
        /// Field index.
        field: u8,
    },
    /// A number whose decimals are neither 3 nor 4.
    BadDecimals {
        /// Field index.
        field: u8,
        /// Decimals found (saturating at 255).
        decimals: u8,
    },
    /// Some numbers with 3 decimals, some with 4: neither dialect.
    MixedDialect,
    /// A well-formed frame of a dialect the [`DialectLock`] excludes.
    DialectLocked {
        /// The dialect of the frame.
        found: Dialect,
    },
    /// A number that does not fit the scalar type (`parse_decimal` gave `None`).
    OutOfRange {
        /// Field index.
        field: u8,
    },
    /// A NaN or infinite value.
    NonFinite {
        /// Field index.
        field: u8,
    },
    /// A position outside the joint's limits.
    PositionOutOfLimits {
        /// Axis index 0..=5.
        axis: u8,
    },
    /// A velocity above the joint's limit.
    VelocityTooHigh {
        /// Axis index 0..=5.
        axis: u8,
    },
}

/// Joint limits in the scalar type: the kernel's [`kernel::TargetLimits`],
/// with its refusals mapped to parse errors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits<S> {
    inner: kernel::TargetLimits<S>,
}

impl<S: Scalar> Limits<S> {
    /// The limits of `config`: the kernel's own [`kernel::TargetLimits`], so
    /// the parser and the kernel can never disagree on a target.
    pub fn new(config: &Validated) -> Self {
        Limits { inner: kernel::TargetLimits::new(config) }
    }

    /// Checks a target: finite, every position within its joint's limits,
    /// every |velocity| at most its joint's limit.
    pub fn check(&self, t: &MotionTarget<S>) -> Result<(), ParseError> {
        self.inner.check(t).map_err(|r| match r {
            kernel::Reject::PositionOutOfLimits { axis } => ParseError::PositionOutOfLimits { axis },
            kernel::Reject::VelocityTooHigh { axis } => ParseError::VelocityTooHigh { axis },
            _ => ParseError::NonFinite { field: 0 },
        })
    }
}

/// The parser: limits and the dialect lock.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Parser<S> {
    limits: Limits<S>,
    lock: DialectLock,
}

/// Checks `-?[0-9]+(\.[0-9]*)?`; returns the number of decimals.
fn number_decimals(field: &[u8]) -> Option<usize> {
    let digits = field.strip_prefix(b"-").unwrap_or(field);
    let (int, frac) = match digits.iter().position(|&b| b == b'.') {
        Some(dot) => (digits.get(..dot)?, digits.get(dot.saturating_add(1)..)?),
        None => (digits, &[][..]),
    };
    let all_digits = |s: &[u8]| s.iter().all(u8::is_ascii_digit);
    if int.is_empty() || !all_digits(int) || !all_digits(frac) {
        return None;
    }
    Some(frac.len())
}

fn parse_seq(field: &[u8]) -> Result<u32, ParseError> {
    if field.is_empty() || !field.iter().all(u8::is_ascii_digit) {
        return Err(ParseError::BadSeq);
    }
    field.iter().try_fold(0u32, |acc, &b| {
        acc.checked_mul(10).and_then(|a| a.checked_add(u32::from(b & 0x0F))).ok_or(ParseError::SeqOverflow)
    })
}

fn sat_u8(n: usize) -> u8 {
    u8::try_from(n).unwrap_or(u8::MAX)
}

impl<S: Scalar> Parser<S> {
    /// A parser for `config`'s limits with the given lock.
    pub fn new(config: &Validated, lock: DialectLock) -> Self {
        Parser { limits: Limits::new(config), lock }
    }

    /// The limits used.
    pub fn limits(&self) -> &Limits<S> {
        &self.limits
    }

    /// The dialect lock.
    pub fn lock(&self) -> DialectLock {
        self.lock
    }

    /// Parses one line (without terminator).
    pub fn parse(&self, line: &[u8]) -> Result<Command<S>, ParseError> {
        let rest = line.strip_prefix(b"<").ok_or(ParseError::MissingStart)?;
        let end = rest.iter().position(|&b| b == b'>').ok_or(ParseError::MissingEnd)?;
        let (body, tail) = rest.split_at_checked(end).ok_or(ParseError::MissingEnd)?;
        if tail.len() != 1 {
            return Err(ParseError::TrailingText);
        }
        match body.first() {
            None => Err(ParseError::EmptyFrame),
            Some(b) if b.is_ascii_alphabetic() => Self::keyword(body),
            Some(_) => self.motion(body),
        }
    }

    fn keyword(body: &[u8]) -> Result<Command<S>, ParseError> {
        match body {
            b"HOME" => Ok(Command::Home),
            b"ENABLE" => Ok(Command::Enable),
            [b'H', b'O', b'M', b'E', n @ b'1'..=b'6'] => Ok(Command::HomeJoint(n.saturating_sub(b'1'))),
            _ => Err(ParseError::UnknownKeyword),
        }
    }

    fn motion(&self, body: &[u8]) -> Result<Command<S>, ParseError> {
        // Split into exactly 13 fields; count any extra.
        let mut fields: [&[u8]; MOTION_FIELDS] = [&[]; MOTION_FIELDS];
        let mut found = 0usize;
        for part in body.split(|&b| b == b',') {
            if let Some(slot) = fields.get_mut(found) {
                *slot = part;
            }
            found = found.saturating_add(1);
        }
        if found != MOTION_FIELDS {
            return Err(ParseError::WrongFieldCount { found: sat_u8(found) });
        }
        if let Some(i) = fields.iter().position(|f| f.is_empty()) {
            return Err(ParseError::EmptyField { field: sat_u8(i) });
        }
        let [seq_field, numbers @ ..] = fields;
        let seq = parse_seq(seq_field)?;

        // Syntax and decimals of every number before any conversion.
        let mut threes = 0usize;
        for (i, f) in (1u8..).zip(numbers.iter()) {
            match number_decimals(f) {
                None => return Err(ParseError::NonNumeric { field: i }),
                Some(3) => threes = threes.saturating_add(1),
                Some(4) => {}
                Some(d) => return Err(ParseError::BadDecimals { field: i, decimals: sat_u8(d) }),
            }
        }
        let dialect = match threes {
            12 => Dialect::Driver,
            0 => Dialect::Configurator,
            _ => return Err(ParseError::MixedDialect),
        };
        match (self.lock, dialect) {
            (DialectLock::DriverOnly, Dialect::Configurator) | (DialectLock::ConfiguratorOnly, Dialect::Driver) => {
                return Err(ParseError::DialectLocked { found: dialect })
            }
            _ => {}
        }

        let value = |field: usize| -> Result<S, ParseError> {
            let idx = sat_u8(field);
            let text = fields.get(field).ok_or(ParseError::OutOfRange { field: idx })?;
            let text = core::str::from_utf8(text).map_err(|_| ParseError::NonNumeric { field: idx })?;
            let v = S::parse_decimal(text).ok_or(ParseError::OutOfRange { field: idx })?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(ParseError::NonFinite { field: idx })
            }
        };
        let mut target =
            MotionTarget { position: [S::ZERO; AXES], velocity: [S::ZERO; AXES], kind: MotionKind::Stream };
        for ((p, v), &(pf, vf)) in target.position.iter_mut().zip(target.velocity.iter_mut()).zip(dialect.fields()) {
            *p = value(pf)?;
            *v = value(vf)?;
        }
        // The configurator's "go to" is one frame with every velocity zero
        // (docs/PROTOCOL.md section 6): a point-to-point move. Every driver
        // frame, and a configurator frame with a velocity, is a stream
        // sample.
        if dialect == Dialect::Configurator && target.velocity.iter().all(|v| *v == S::ZERO) {
            target.kind = MotionKind::GoTo;
        }
        self.limits.check(&target)?;
        Ok(Command::Motion { seq, dialect, target })
    }
}

/// Formats a motion command as `dialect` sends it (for test clients, the
/// simulator and round-trip tests), terminated by `\n`.
pub fn format_motion<S: Scalar>(
    out: &mut crate::Line,
    seq: u32,
    dialect: Dialect,
    target: &MotionTarget<S>,
) -> Result<(), crate::Full> {
    use crate::text::{push_byte, push_scaled, push_u32};
    out.clear();
    push_byte(out, b'<')?;
    push_u32(out, seq)?;
    let mut values = [S::ZERO; MOTION_FIELDS];
    for ((p, v), &(pf, vf)) in target.position.iter().zip(&target.velocity).zip(dialect.fields()) {
        if let Some(slot) = values.get_mut(pf) {
            *slot = *p;
        }
        if let Some(slot) = values.get_mut(vf) {
            *slot = *v;
        }
    }
    for v in values.iter().skip(1) {
        push_byte(out, b',')?;
        push_scaled(out, v.to_scaled_int(dialect.scale()), dialect.decimals())?;
    }
    push_byte(out, b'>')?;
    push_byte(out, b'\n')
}

#[cfg(test)]
mod tests {
    use super::*;
    use kernel::config::PAROL6_VALIDATED;

    fn p() -> Parser<f32> {
        Parser::new(&PAROL6_VALIDATED, DialectLock::Auto)
    }

    #[test]
    fn keywords() {
        assert_eq!(p().parse(b"<HOME>"), Ok(Command::Home));
        assert_eq!(p().parse(b"<ENABLE>"), Ok(Command::Enable));
        assert_eq!(p().parse(b"<HOME1>"), Ok(Command::HomeJoint(0)));
        assert_eq!(p().parse(b"<HOME6>"), Ok(Command::HomeJoint(5)));
        for bad in [&b"<HOME0>"[..], b"<HOME7>", b"<home>", b"<Home>", b"<HOME >", b"<HOMEX>", b"<HOME12>"] {
            assert_eq!(p().parse(bad), Err(ParseError::UnknownKeyword), "{}", String::from_utf8_lossy(bad));
        }
    }

    #[test]
    fn framing_errors() {
        assert_eq!(p().parse(b"HOME>"), Err(ParseError::MissingStart));
        assert_eq!(p().parse(b" <HOME>"), Err(ParseError::MissingStart));
        assert_eq!(p().parse(b"<HOME"), Err(ParseError::MissingEnd));
        assert_eq!(p().parse(b"<HOME>x"), Err(ParseError::TrailingText));
        assert_eq!(p().parse(b"<HOME><HOME>"), Err(ParseError::TrailingText));
        assert_eq!(p().parse(b"<>"), Err(ParseError::EmptyFrame));
    }

    #[test]
    fn number_syntax() {
        assert_eq!(number_decimals(b"0.000"), Some(3));
        assert_eq!(number_decimals(b"-12.3456"), Some(4));
        assert_eq!(number_decimals(b"1"), Some(0));
        assert_eq!(number_decimals(b"1."), Some(0));
        for bad in [&b"+1.000"[..], b"1e3", b"nan", b"inf", b" 1.000", b".500", b"-", b"--1.000", b"1.0.0", b"1-0.0"] {
            assert_eq!(number_decimals(bad), None, "{}", String::from_utf8_lossy(bad));
        }
        assert_eq!(parse_seq(b"4294967295"), Ok(u32::MAX));
        assert_eq!(parse_seq(b"4294967296"), Err(ParseError::SeqOverflow));
        assert_eq!(parse_seq(b"-1"), Err(ParseError::BadSeq));
        assert_eq!(parse_seq(b"+1"), Err(ParseError::BadSeq));
    }
}
