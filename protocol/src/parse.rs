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
//! Numbers are converted only after their syntax above is validated here
//! (so `+1.000`, `1e3`, `nan`, `inf`, spaces never reach a conversion).
//! Each number's digits are gathered into an integer mantissa; the value,
//! `mantissa / 10^decimals`, is then converted by [`Scalar::from_decimal`]
//! with integer arithmetic (one exactly rounded division for `f32`), giving
//! exactly what [`Scalar::parse_decimal`] gives for the text (checked for
//! every mantissa below 2^24 in `protocol/tests/decimal_exhaustive.rs`). A
//! number with more digits than a `u32` holds is converted from its text by
//! `parse_decimal`. `None` (does not fit the scalar) is a rejection.
//!
//! Two paths, one result. A *well-formed* frame (SEQ and twelve numbers of
//! at most 9 digits, all with 3 or all with 4 decimals, every number
//! converting) is read in one pass that checks each byte once, at the place
//! the grammar expects it, and converts each number as soon as it is read
//! (`well_formed`); that is every frame a host sends. Anything else goes to
//! the general path, which runs the checks one after the other (framing,
//! field count, empty fields, SEQ, each number's syntax and decimals, the
//! dialect, the lock, each conversion) and so reports the first error. Both
//! end in the same limit check. That the two paths give what the reference
//! parser (`tests/reference`, numbers converted from their text) gives, on every input, is checked by
//! `tests/parser_equivalence.rs`, `tests/decimal_exhaustive.rs` and the fuzz
//! targets.
//!
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

/// A number: its sign and its digits as one integer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Number {
    /// A leading `-`.
    negative: bool,
    /// Its digits (integer and fraction) as one integer; `u32::MAX` when it
    /// has more than 9 digits (then the text is converted instead, by
    /// `parse_decimal`; only the general path has such numbers).
    mantissa: u32,
}

/// What the single pass over a motion frame's body learns about one
/// comma-separated field (the general path).
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

    /// The number and its decimals (digits after the point, 0 without a
    /// point) if the field is `-?[0-9]+(\.[0-9]*)?`, else `None`.
    fn number(&self, body: &[u8]) -> Option<(Number, usize)> {
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
        Some((Number { negative, mantissa }, decimals))
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

/// The decimal digits at the start of `s` gathered into `acc` (`acc = 10
/// acc + digit`, wrapping: exact while the digits in all are at most
/// [`MAX_DIGITS`]), how many there are, and what follows them.
#[inline(always)]
fn take_digits(s: &[u8], mut acc: u32) -> (u32, usize, &[u8]) {
    let mut rest = s;
    while let [b, tail @ ..] = rest {
        let d = u32::from(*b).wrapping_sub(u32::from(b'0'));
        if d > 9 {
            break;
        }
        acc = acc.wrapping_mul(10).wrapping_add(d);
        rest = tail;
    }
    (acc, s.len().wrapping_sub(rest.len()), rest)
}

/// A leading `-` of `s`, and what follows it.
#[inline(always)]
fn take_sign(s: &[u8]) -> (bool, &[u8]) {
    let negative = s.first() == Some(&b'-');
    (negative, if negative { s.get(1..).unwrap_or_default() } else { s })
}

/// The number at the start of `s` if it is `-?[0-9]+\.[0-9]*` with at most
/// [`MAX_DIGITS`] digits, followed by `end`: the number, its decimals, and
/// what follows `end`.
#[inline(always)]
fn well_formed_number(s: &[u8], end: u8) -> Option<(Number, usize, &[u8])> {
    let (negative, s) = take_sign(s);
    let (int, int_digits, s) = take_digits(s, 0);
    let [b'.', s @ ..] = s else { return None };
    let (mantissa, decimals, s) = take_digits(s, int);
    let [b, s @ ..] = s else { return None };
    let fits = int_digits > 0 && int_digits.saturating_add(decimals) <= MAX_DIGITS;
    (*b == end && fits).then_some((Number { negative, mantissa }, decimals, s))
}

/// [`well_formed_number`] for a number with exactly `K` decimals: the same
/// reading, with the `K` decimals and `end` checked at fixed places.
#[inline(always)]
fn number_of<const K: usize>(s: &[u8], end: u8) -> Option<(Number, &[u8])> {
    let (negative, s) = take_sign(s);
    let (int, int_digits, s) = take_digits(s, 0);
    if int_digits.wrapping_sub(1) >= MAX_DIGITS.saturating_sub(K) {
        return None; // no integer digit (0 - 1 wraps), or more than 9 - K
    }
    let [b'.', s @ ..] = s else { return None };
    let (fraction, s) = s.split_first_chunk::<K>()?;
    let mut mantissa = int;
    for &b in fraction {
        let d = u32::from(b).wrapping_sub(u32::from(b'0'));
        if d > 9 {
            return None;
        }
        mantissa = mantissa.wrapping_mul(10).wrapping_add(d);
    }
    match s {
        [b, s @ ..] if *b == end => Some((Number { negative, mantissa }, s)),
        _ => None,
    }
}

/// A number's value, or `None` if it is not a finite value of `S`.
#[inline(always)]
fn value_of<S: Scalar, const K: u32>(n: Number) -> Option<S> {
    S::from_decimal(n.negative, n.mantissa, K).filter(|v| v.is_finite())
}

/// The values of fields 2..=12 of a well-formed frame whose first number
/// has `K` (= `KU`) decimals; `s` is the text after field 1's `,`. Each
/// number read and converted in one go; `None` if anything is not as
/// [`well_formed`] requires.
#[inline(always)]
fn other_values<S: Scalar, const K: usize, const KU: u32>(
    mut s: &[u8],
    values: &mut [S; MOTION_FIELDS - 2],
) -> Option<()> {
    let [middle @ .., last] = values;
    for v in middle {
        let (n, tail) = number_of::<K>(s, b',')?;
        *v = value_of::<S, KU>(n)?;
        s = tail;
    }
    let (n, tail) = number_of::<K>(s, b'>')?;
    *last = value_of::<S, KU>(n)?;
    tail.is_empty().then_some(())
}

/// The fast path: SEQ, the dialect and the twelve values (in field order)
/// of `rest` (the line after `<`) if it is a well-formed motion frame whose
/// numbers all convert; `None` for anything else, which the general path
/// then reads (and reports exactly). Well formed: SEQ of 1 to
/// [`MAX_DIGITS`] digits, twelve numbers `-?[0-9]+\.[0-9]+` of at most
/// [`MAX_DIGITS`] digits each, all with 3 or all with 4 decimals, separated
/// by `,`, then `>` and the end of the line. One pass: each byte is looked
/// at once, as what the grammar expects at its place, and each number is
/// converted as soon as it is read.
///
/// On such a frame the general path finds 13 non-empty fields, a valid SEQ
/// of the same value, twelve numbers with these signs, mantissas and
/// decimals, so the same dialect, and converts each number with the same
/// [`Scalar::from_decimal`] call; every other line (a 10-digit SEQ or
/// number, a number that does not convert, included) gets `None` here.
#[inline(always)]
fn well_formed<S: Scalar>(rest: &[u8]) -> Option<(u32, Dialect, [S; MOTION_FIELDS - 1])> {
    let (seq, seq_digits, s) = take_digits(rest, 0);
    let [b',', s @ ..] = s else { return None };
    if seq_digits == 0 || seq_digits > MAX_DIGITS {
        return None;
    }
    let (first, decimals, s) = well_formed_number(s, b',')?;
    let mut values = [S::ZERO; MOTION_FIELDS - 1];
    let [value, others @ ..] = &mut values;
    let dialect = match decimals {
        3 => {
            *value = value_of::<S, 3>(first)?;
            other_values::<S, 3, 3>(s, others)?;
            Dialect::Driver
        }
        4 => {
            *value = value_of::<S, 4>(first)?;
            other_values::<S, 4, 4>(s, others)?;
            Dialect::Configurator
        }
        _ => return None,
    };
    Some((seq, dialect, values))
}

/// `f32`'s overflow threshold, `2^128 - 2^103` (half way from `f32::MAX` to
/// `2^128`, which rounds up): a decimal at least this large is not finite
/// in `f32` (core's parser gives infinity) and beyond [`kernel::Fx`] too.
const OVERFLOW: &[u8; 39] = b"340282356779733661637539395458142568448";

/// The value of a number of more than [`MAX_DIGITS`] digits, `text` =
/// `-?[0-9]+\.[0-9]{3,4}` (its syntax and decimals checked), as
/// [`Scalar::parse_decimal`] of the text decides it, without a text parser:
///
/// - leading zeros of the integer part do not count: with at most
///   [`MAX_DIGITS`] digits left, the number goes to [`Scalar::from_decimal`]
///   like any other (exact);
/// - otherwise the integer part has at least 6 significant digits, so
///   `|value| >= 10^5`: at or beyond [`OVERFLOW`] it fits no scalar
///   (`None`, as `parse_decimal` gives); below it `from_decimal` of
///   `±99999.9999` stands in for it. Both are beyond every joint limit a
///   [`Validated`] configuration can hold (`kernel::config::check`:
///   positions within `POSITION_ABS_MAX - 2` = 30 rad, asserted below at
///   compile time; velocities at most 16 rad/s), so the target is rejected
///   with the same error as with the exact value: the value itself is
///   never part of an accepted command. (For [`kernel::Fx`], range
///   [-128, 128), both are `None`.)
fn long_number<S: Scalar>(text: &[u8]) -> Option<S> {
    let (negative, digits) = take_sign(text);
    let mut parts = digits.splitn(2, |&b| b == b'.');
    let int = parts.next().unwrap_or_default();
    let fraction = parts.next().unwrap_or_default();
    let significant = int.iter().position(|&b| b != b'0').and_then(|i| int.get(i..)).unwrap_or_default();
    let decimals = fraction.len() as u32;
    if significant.len().saturating_add(fraction.len()) <= MAX_DIGITS {
        let (mantissa, _, _) = take_digits(significant, 0);
        let (mantissa, _, _) = take_digits(fraction, mantissa);
        return S::from_decimal(negative, mantissa, decimals);
    }
    if significant.len() > OVERFLOW.len() || (significant.len() == OVERFLOW.len() && significant >= OVERFLOW.as_slice())
    {
        return None;
    }
    S::from_decimal(negative, 999_999_999, 4)
}

// The stand-in of `long_number` is beyond every joint limit of a validated
// configuration (`kernel::config::check`: limits within
// `POSITION_ABS_MAX - 2`, velocities at most 16 rad/s).
const _: () = assert!(kernel::config::POSITION_ABS_MAX < 99_999.0);

/// A converted value, or why it is rejected.
#[inline(always)]
fn checked<S: Scalar>(field: usize, v: Option<S>) -> Result<S, ParseError> {
    let v = v.ok_or_else(|| ParseError::OutOfRange { field: sat_u8(field) })?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(ParseError::NonFinite { field: sat_u8(field) })
    }
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
            // A motion frame (or junk).
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
    /// letter nor `>`. A well-formed frame (every frame a host sends) takes
    /// the fast path; anything else the general one, which finds the exact
    /// error.
    fn motion(&self, rest: &[u8]) -> Result<Command<S>, ParseError> {
        match well_formed::<S>(rest) {
            Some((seq, dialect, values)) if self.allows(dialect) => {
                let mut target =
                    MotionTarget { position: [S::ZERO; AXES], velocity: [S::ZERO; AXES], kind: MotionKind::Stream };
                match dialect {
                    // p1, v1, ..., p6, v6
                    Dialect::Driver => {
                        let pairs = values.chunks_exact(2);
                        for ((p, v), pair) in target.position.iter_mut().zip(&mut target.velocity).zip(pairs) {
                            if let [pv, vv] = pair {
                                (*p, *v) = (*pv, *vv);
                            }
                        }
                    }
                    // p1..p6, v1..v6
                    Dialect::Configurator => {
                        let [p @ .., _, _, _, _, _, _] = values;
                        let [_, _, _, _, _, _, v @ ..] = values;
                        (target.position, target.velocity) = (p, v);
                    }
                }
                self.command(seq, dialect, target)
            }
            _ => self.general(rest),
        }
    }

    /// The general path: any line after `<` (see [`Self::motion`]), with the
    /// checks in the documented order.
    fn general(&self, rest: &[u8]) -> Result<Command<S>, ParseError> {
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
            let (number, decimals) = f.number(body).ok_or(ParseError::NonNumeric { field: i })?;
            *n = number;
            match decimals {
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
        if !self.allows(dialect) {
            return Err(ParseError::DialectLocked { found: dialect });
        }
        let value = |field: usize| {
            let n = nums.get(field).copied().unwrap_or_default();
            let v = if n.mantissa == u32::MAX {
                long_number(fields.get(field).map_or(&[][..], |f| f.text(body)))
            } else {
                // Exactly `parse_decimal` of the text (`Scalar::from_decimal`).
                S::from_decimal(n.negative, n.mantissa, dialect.decimals() as u32)
            };
            checked(field, v)
        };
        let mut target =
            MotionTarget { position: [S::ZERO; AXES], velocity: [S::ZERO; AXES], kind: MotionKind::Stream };
        for ((p, v), &(pf, vf)) in target.position.iter_mut().zip(target.velocity.iter_mut()).zip(dialect.fields()) {
            *p = value(pf)?;
            *v = value(vf)?;
        }
        self.command(seq, dialect, target)
    }

    /// True if the lock lets `dialect` through.
    fn allows(&self, dialect: Dialect) -> bool {
        !matches!(
            (self.lock, dialect),
            (DialectLock::DriverOnly, Dialect::Configurator) | (DialectLock::ConfiguratorOnly, Dialect::Driver)
        )
    }

    /// The command for a frame whose values are all read: its kind, then
    /// the joint limits.
    #[inline(always)]
    fn command(&self, seq: u32, dialect: Dialect, mut target: MotionTarget<S>) -> Result<Command<S>, ParseError> {
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
    fn number(text: &[u8]) -> Option<(Number, usize)> {
        let mut rest = text.to_vec();
        rest.push(b'>');
        let mut fields = [Field::default(); MOTION_FIELDS];
        assert_eq!(scan_fields(&rest, &mut fields), (1, Some(text.len())));
        fields[0].number(&rest[..text.len()])
    }

    #[test]
    fn number_syntax() {
        let n = |negative, mantissa, decimals| Some((Number { negative, mantissa }, decimals));
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
        // verdict and decimals are `number_decimals`'s, the mantissa the digits';
        // the fast path's reading ([`well_formed_number`], [`number_of`]) is
        // the general one's wherever it accepts, and it accepts exactly the
        // numbers with a point and at most 9 digits (and `K` decimals).
        let alphabet = b"-.0159x";
        for len in 0..=7 {
            let mut idx = vec![0usize; len];
            loop {
                let t: Vec<u8> = idx.iter().map(|&i| alphabet[i]).collect();
                let got = number(&t);
                assert_eq!(got.map(|n| n.1), number_decimals(&t), "{}", String::from_utf8_lossy(&t));
                if let Some((n, _)) = got {
                    let digits: String = t.iter().filter(|b| b.is_ascii_digit()).map(|&b| b as char).collect();
                    assert_eq!(n.mantissa, digits.parse::<u32>().unwrap());
                    assert_eq!(n.negative, t[0] == b'-');
                }
                for end in [b',', b'>'] {
                    let mut line = t.clone();
                    line.extend_from_slice(&[end, b'x']);
                    let fast = well_formed_number(&line, end);
                    let want = got.filter(|(n, _)| t.contains(&b'.') && n.mantissa != u32::MAX);
                    assert_eq!(
                        fast.map(|(n, d, rest)| (n, d, rest.to_vec())),
                        want.map(|(n, d)| (n, d, b"x".to_vec()))
                    );
                    // With the decimals fixed: the same reading, for that count.
                    let with = |k: usize| fast.filter(|f| f.1 == k).map(|(n, _, rest)| (n, rest));
                    assert_eq!(number_of::<3>(&line, end), with(3));
                    assert_eq!(number_of::<4>(&line, end), with(4));
                }
                let Some(p) = idx.iter().rposition(|&i| i + 1 < alphabet.len()) else { break };
                idx[p] += 1;
                idx[p + 1..].iter_mut().for_each(|i| *i = 0);
            }
        }
        // The fast path's digit bound: at most 9 digits in all.
        let m = |negative, mantissa| Number { negative, mantissa };
        assert_eq!(well_formed_number(b"-999999.999,", b','), Some((m(true, 999_999_999), 3, &b""[..])));
        assert_eq!(number_of::<3>(b"-999999.999,", b','), Some((m(true, 999_999_999), &b""[..])));
        assert_eq!(number_of::<4>(b"99999.9999>", b'>'), Some((m(false, 999_999_999), &b""[..])));
        for long in [&b"9999999.999,"[..], b"0000000.000,", b"999999.9999,", b"1.000000000,"] {
            assert_eq!(well_formed_number(long, b','), None);
            assert_eq!(number_of::<3>(long, b','), None);
            assert_eq!(number_of::<4>(long, b','), None);
        }
        assert_eq!(parse_seq(b"4294967295"), Ok(u32::MAX));
        assert_eq!(parse_seq(b"4294967296"), Err(ParseError::SeqOverflow));
        assert_eq!(parse_seq(b"-1"), Err(ParseError::BadSeq));
        assert_eq!(parse_seq(b"+1"), Err(ParseError::BadSeq));
    }
}
