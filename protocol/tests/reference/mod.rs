//! The reference parser (numbers converted from their text by
//! `Scalar::parse_decimal`): the straightforward form the shipped parser
//! must equal on every input: same verdict, same error, and
//! bit-identical values. Used by `tests/decimal_exhaustive.rs`,
//! `tests/parser_equivalence.rs` and the fuzz targets (included there by
//! `#[path]`).
#![allow(dead_code)]

use kernel::config::AXES;
use kernel::{Fx, MotionKind, MotionTarget, Scalar};
use protocol::parse::{Dialect, DialectLock, MOTION_FIELDS};
use protocol::{Command, ParseError, Parser};

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

/// The reference `Parser::parse`, with `p`'s limits and lock.
pub fn parse<S: Scalar>(p: &Parser<S>, line: &[u8]) -> Result<Command<S>, ParseError> {
    let rest = line.strip_prefix(b"<").ok_or(ParseError::MissingStart)?;
    let end = rest.iter().position(|&b| b == b'>').ok_or(ParseError::MissingEnd)?;
    let (body, tail) = rest.split_at_checked(end).ok_or(ParseError::MissingEnd)?;
    if tail.len() != 1 {
        return Err(ParseError::TrailingText);
    }
    match body.first() {
        None => Err(ParseError::EmptyFrame),
        Some(b) if b.is_ascii_alphabetic() => keyword(body),
        Some(_) => motion(p, body),
    }
}

fn keyword<S>(body: &[u8]) -> Result<Command<S>, ParseError> {
    match body {
        b"HOME" => Ok(Command::Home),
        b"ENABLE" => Ok(Command::Enable),
        [b'H', b'O', b'M', b'E', n @ b'1'..=b'6'] => Ok(Command::HomeJoint(n.saturating_sub(b'1'))),
        _ => Err(ParseError::UnknownKeyword),
    }
}

fn motion<S: Scalar>(p: &Parser<S>, body: &[u8]) -> Result<Command<S>, ParseError> {
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
    match (p.lock(), dialect) {
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
    let mut target = MotionTarget { position: [S::ZERO; AXES], velocity: [S::ZERO; AXES], kind: MotionKind::Stream };
    for ((pos, vel), &(pf, vf)) in target.position.iter_mut().zip(target.velocity.iter_mut()).zip(dialect.fields()) {
        *pos = value(pf)?;
        *vel = value(vf)?;
    }
    if dialect == Dialect::Configurator && target.velocity.iter().all(|v| *v == S::ZERO) {
        target.kind = MotionKind::GoTo;
    }
    p.limits().check(&target)?;
    Ok(Command::Motion { seq, dialect, target })
}

/// A scalar's bit pattern (so that -0.0 and 0.0 differ).
pub trait Bits: Scalar {
    /// The bits.
    fn bits(self) -> u32;
}
impl Bits for f32 {
    fn bits(self) -> u32 {
        self.to_bits()
    }
}
impl Bits for Fx {
    fn bits(self) -> u32 {
        self.to_bits() as u32
    }
}

/// True if `a` and `b` are the same outcome with bit-identical values.
pub fn same<S: Bits>(a: &Result<Command<S>, ParseError>, b: &Result<Command<S>, ParseError>) -> bool {
    match (a, b) {
        (
            Ok(Command::Motion { seq: s1, dialect: d1, target: t1 }),
            Ok(Command::Motion { seq: s2, dialect: d2, target: t2 }),
        ) => {
            let bits = |t: &MotionTarget<S>| (t.position.map(S::bits), t.velocity.map(S::bits));
            s1 == s2 && d1 == d2 && t1.kind == t2.kind && bits(t1) == bits(t2)
        }
        _ => a == b,
    }
}
