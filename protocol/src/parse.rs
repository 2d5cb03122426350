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
//! Numbers are converted only after the syntax above is validated here (so
//! `+1.000`, `1e3`, `nan`, `inf`, spaces never reach a conversion). One pass
//! over each number checks its syntax and gathers its digits into an integer
//! mantissa; the value, `mantissa / 10^decimals`, is then converted by
//! [`Scalar::from_decimal`] with integer arithmetic (one exactly rounded
//! division for `f32`), giving exactly what [`Scalar::parse_decimal`] gives
//! for the text (checked for every mantissa below 2^24 in
//! `protocol/tests/decimal_exhaustive.rs`). A number with more digits than a
//! `u32` holds is converted from its text by `parse_decimal`. `None` (does
//! not fit the scalar) is a rejection.
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

/// A number: its sign, its digits as one integer and its decimals.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Number {
    /// A leading `-`.
    negative: bool,
    /// Its digits (integer and fraction) as one integer; `u32::MAX` when it
    /// has more than 9 digits (then the text is converted instead, by
    /// `parse_decimal`).
    mantissa: u32,
    /// Digits after the point (0 without a point).
    decimals: usize,
}

/// What the single pass over a motion frame's body learns about one
/// comma-separated field.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Field {
    /// Its bytes are `body[start..end]`.
    start: usize,
    end: usize,
    /// Its digits gathered as `m = 10 m + d` (wrapping; meaningful for at
    /// most 9 digits).
    mantissa: u32,
    /// Points seen, and where the last one is.
    dots: usize,
    dot: usize,
    /// A byte other than a digit, a point, or a `-` in first place.
    bad: bool,
}

/// Largest digit count whose mantissa fits a `u32` for sure.
const MAX_DIGITS: usize = 9;

impl Field {
    fn text<'a>(&self, body: &'a [u8]) -> &'a [u8] {
        body.get(self.start..self.end).unwrap_or_default()
    }

    /// The number if the field is `-?[0-9]+(\.[0-9]*)?`, else `None`.
    fn number(&self, body: &[u8]) -> Option<Number> {
        let negative = body.get(self.start) == Some(&b'-');
        let digits_start = self.start.saturating_add(usize::from(negative));
        if self.bad || self.dots > 1 {
            return None;
        }
        let (int_end, decimals) = match self.dots {
            1 => (self.dot, self.end.saturating_sub(self.dot).saturating_sub(1)),
            _ => (self.end, 0),
        };
        if int_end <= digits_start {
            return None; // no integer digit (`.5`, `-`, `-.5`)
        }
        let digits = self.end.saturating_sub(digits_start).saturating_sub(self.dots);
        let mantissa = if digits <= MAX_DIGITS { self.mantissa } else { u32::MAX };
        Some(Number { negative, mantissa, decimals })
    }
}

/// One pass over a motion frame's text after `<`, up to the first `>`:
/// field boundaries, and for each field its digits (as an integer), points
/// and stray bytes; the first [`MOTION_FIELDS`] fields are stored. Returns
/// the number of fields and where the `>` is (`None`: no `>`). The parser's
/// checks then run in the documented order on these summaries.
#[inline]
fn scan_fields(rest: &[u8], fields: &mut [Field; MOTION_FIELDS]) -> (usize, Option<usize>) {
    let mut found = 0usize;
    let mut f = Field::default();
    for (i, &b) in rest.iter().enumerate() {
        let d = b.wrapping_sub(b'0');
        if d < 10 {
            f.mantissa = f.mantissa.wrapping_mul(10).wrapping_add(u32::from(d));
            continue;
        }
        match b {
            b',' | b'>' => {
                f.end = i;
                if let Some(slot) = fields.get_mut(found) {
                    *slot = f;
                }
                found = found.saturating_add(1);
                if b == b'>' {
                    return (found, Some(i));
                }
                f = Field { start: i.saturating_add(1), ..Field::default() };
            }
            b'.' => {
                f.dots = f.dots.saturating_add(1);
                f.dot = i;
            }
            b'-' if i == f.start => {}
            _ => f.bad = true,
        }
    }
    (found, None)
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
        if rest.first().is_some_and(|b| !b.is_ascii_alphabetic() && *b != b'>') {
            // A motion frame (or junk): one pass finds the end too.
            return self.motion(rest);
        }
        let end = rest.iter().position(|&b| b == b'>').ok_or(ParseError::MissingEnd)?;
        let (body, tail) = rest.split_at_checked(end).ok_or(ParseError::MissingEnd)?;
        if tail.len() != 1 {
            return Err(ParseError::TrailingText);
        }
        match body.first() {
            None => Err(ParseError::EmptyFrame),
            _ => Self::keyword(body),
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

    /// A motion frame: `rest` is the line after `<`, starting with neither a
    /// letter nor `>`.
    fn motion(&self, rest: &[u8]) -> Result<Command<S>, ParseError> {
        let mut fields = [Field::default(); MOTION_FIELDS];
        let (found, end) = scan_fields(rest, &mut fields);
        let end = end.ok_or(ParseError::MissingEnd)?;
        if rest.len() != end.saturating_add(1) {
            return Err(ParseError::TrailingText);
        }
        let body = rest.get(..end).unwrap_or_default();
        if found != MOTION_FIELDS {
            return Err(ParseError::WrongFieldCount { found: sat_u8(found) });
        }
        if let Some(i) = fields.iter().position(|f| f.start == f.end) {
            return Err(ParseError::EmptyField { field: sat_u8(i) });
        }
        let seq = parse_seq(fields.first().map_or(&[][..], |f| f.text(body)))?;

        // Syntax and decimals of every number before any conversion.
        let mut nums = [Number::default(); MOTION_FIELDS];
        let mut threes = 0usize;
        for ((i, f), n) in (1u8..).zip(fields.iter().skip(1)).zip(nums.iter_mut().skip(1)) {
            *n = f.number(body).ok_or(ParseError::NonNumeric { field: i })?;
            match n.decimals {
                3 => threes = threes.saturating_add(1),
                4 => {}
                d => return Err(ParseError::BadDecimals { field: i, decimals: sat_u8(d) }),
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
            let n = nums.get(field).ok_or(ParseError::OutOfRange { field: idx })?;
            let v = if n.mantissa == u32::MAX {
                // More than 9 digits (beyond every limit unless padded with
                // zeros): the text parser's verdict, whatever it is.
                let text = fields.get(field).ok_or(ParseError::OutOfRange { field: idx })?.text(body);
                let text = core::str::from_utf8(text).map_err(|_| ParseError::NonNumeric { field: idx })?;
                S::parse_decimal(text)
            } else {
                // Exactly `parse_decimal` of the text (`Scalar::from_decimal`).
                S::from_decimal(n.negative, n.mantissa, dialect.decimals() as u32)
            };
            let v = v.ok_or(ParseError::OutOfRange { field: idx })?;
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

    /// The syntax check as it was (`-?[0-9]+(\.[0-9]*)?`, decimals), the
    /// specification of [`Field::number`].
    fn number_decimals(field: &[u8]) -> Option<usize> {
        let digits = field.strip_prefix(b"-").unwrap_or(field);
        let (int, frac) = match digits.iter().position(|&b| b == b'.') {
            Some(dot) => (&digits[..dot], &digits[dot + 1..]),
            None => (digits, &[][..]),
        };
        let all_digits = |s: &[u8]| s.iter().all(u8::is_ascii_digit);
        (!int.is_empty() && all_digits(int) && all_digits(frac)).then_some(frac.len())
    }

    /// [`Field::number`] of `text` scanned as the first field of a frame.
    fn number(text: &[u8]) -> Option<Number> {
        let mut rest = text.to_vec();
        rest.push(b'>');
        let mut fields = [Field::default(); MOTION_FIELDS];
        assert_eq!(scan_fields(&rest, &mut fields), (1, Some(text.len())));
        fields[0].number(&rest[..text.len()])
    }

    #[test]
    fn number_syntax() {
        let n = |negative, mantissa, decimals| Some(Number { negative, mantissa, decimals });
        assert_eq!(number(b"0.000"), n(false, 0, 3));
        assert_eq!(number(b"-12.3456"), n(true, 123_456, 4));
        assert_eq!(number(b"-0.000"), n(true, 0, 3));
        assert_eq!(number(b"1"), n(false, 1, 0));
        assert_eq!(number(b"1."), n(false, 1, 0));
        assert_eq!(number(b"999999.999"), n(false, 999_999_999, 3));
        assert_eq!(number(b"0000001.000"), n(false, u32::MAX, 3));
        assert_eq!(number(b"99999999999999999999.000"), n(false, u32::MAX, 3));
        for bad in [&b"+1.000"[..], b"1e3", b"nan", b"inf", b" 1.000", b".500", b"-", b"--1.000", b"1.0.0", b"1-0.0"] {
            assert_eq!(number(bad), None, "{}", String::from_utf8_lossy(bad));
        }
        // Every string of up to 7 characters over a small alphabet: the
        // verdict and decimals are the old check's, the mantissa the digits'.
        let alphabet = b"-.0159x";
        for len in 0..=7 {
            let mut idx = vec![0usize; len];
            loop {
                let t: Vec<u8> = idx.iter().map(|&i| alphabet[i]).collect();
                let got = number(&t);
                assert_eq!(got.map(|n| n.decimals), number_decimals(&t), "{}", String::from_utf8_lossy(&t));
                if let Some(n) = got {
                    let digits: String = t.iter().filter(|b| b.is_ascii_digit()).map(|&b| b as char).collect();
                    assert_eq!(n.mantissa, digits.parse::<u32>().unwrap());
                    assert_eq!(n.negative, t[0] == b'-');
                }
                let Some(p) = idx.iter().rposition(|&i| i + 1 < alphabet.len()) else { break };
                idx[p] += 1;
                idx[p + 1..].iter_mut().for_each(|i| *i = 0);
            }
        }
        assert_eq!(parse_seq(b"4294967295"), Ok(u32::MAX));
        assert_eq!(parse_seq(b"4294967296"), Err(ParseError::SeqOverflow));
        assert_eq!(parse_seq(b"-1"), Err(ParseError::BadSeq));
        assert_eq!(parse_seq(b"+1"), Err(ParseError::BadSeq));
    }
}
