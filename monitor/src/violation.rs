//! A violated requirement ([`Violation`]) and the requirement's number ([`Sr`]).

use core::fmt;

use kernel::State;

/// The result of one check: the first violation, if any.
pub(crate) type Checked = Result<(), Violation>;

/// A safety requirement of `SAFETY.md`, by number: `Display` gives its
/// name as the document writes it (`Sr::Sr7` is "SR-7").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[allow(missing_docs)] // Each variant is the requirement its name numbers.
pub enum Sr {
    Sr1 = 1,
    Sr2,
    Sr3,
    Sr4,
    Sr5,
    Sr6,
    Sr7,
    Sr8,
    Sr9,
    Sr10,
    Sr11,
    Sr12,
    Sr13,
    Sr14,
    Sr15,
    Sr16,
    Sr17,
    Sr18,
    Sr19,
    Sr20,
    Sr21,
    Sr22,
    Sr23,
    Sr24,
    Sr25,
    Sr26,
    Sr27,
    Sr28,
    Sr29,
    Sr30,
    Sr31,
}

impl Sr {
    /// The requirement's number (`Sr::Sr7.number() == 7`).
    pub const fn number(self) -> u8 {
        self as u8
    }
}

impl fmt::Display for Sr {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "SR-{}", self.number())
    }
}

/// A violated requirement: which one, on which axis, what, and the numbers.
/// `Display` formats it on one line.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Violation {
    /// The requirement, e.g. `Sr::Sr7` (displayed "SR-7").
    pub sr: Sr,
    /// The axis (0..=5), if the check is per axis.
    pub axis: Option<u8>,
    /// What was wrong.
    pub what: &'static str,
    /// The offending value, where there is one.
    pub got: Option<f64>,
    /// The bound it broke, where there is one.
    pub bound: Option<f64>,
    /// The kernel's tick count (`status.tick`).
    pub tick: u32,
    /// The kernel's state after the tick.
    pub state: State,
}

impl Violation {
    pub(crate) fn on(mut self, axis: usize) -> Self {
        self.axis = u8::try_from(axis).ok();
        self
    }
    pub(crate) fn got(mut self, x: f64) -> Self {
        self.got = Some(x);
        self
    }
    pub(crate) fn bound(mut self, x: f64) -> Self {
        self.bound = Some(x);
        self
    }
}

impl fmt::Display for Violation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.sr)?;
        if let Some(a) = self.axis {
            write!(f, " J{}", u16::from(a).saturating_add(1))?;
        }
        write!(f, ": {}", self.what)?;
        if let Some(g) = self.got {
            write!(f, ": got {g}")?;
        }
        if let Some(b) = self.bound {
            write!(f, ", bound {b}")?;
        }
        write!(f, " (tick {}, {:?})", self.tick, self.state)
    }
}

/// `Err(v())` unless `ok` (the violation is built only when it is one).
#[inline(always)]
pub(crate) fn ensure_ok(ok: bool, v: impl FnOnce() -> Violation) -> Checked {
    if ok {
        Ok(())
    } else {
        Err(v())
    }
}
