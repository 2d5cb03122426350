//! Shared by the host tool and the emulated Cortex-M7: the recorded scenario
//! format, the replay loop, and the text of one trace line.
//!
//! Both sides run [`replay`] on the same bytes and print what it hands to
//! [`Hooks::line`]; the two outputs are compared byte for byte. Every number
//! in a trace line is printed as its bit pattern (`f32::to_bits`, the raw
//! `I8F24` word), so equal text means bit-identical values.
//!
//! # Scenario format (little endian)
//!
//! ```text
//! header  = "EMUSCN1\0" ticks:u32
//! tick    = enc:6*u16 limits:u8 hw:u8 len:u8 frame:len*u8
//! enc     = 0..=4095 a count, 0xFFFF no valid reading (EncoderSample::Lost)
//! hw      = 0 none, 1 TickOverrun, 0x10+axis Driver, 0x80+code SelfTest
//! frame   = one host line without terminator ("<HOME>", "<17,0.100,...>"),
//!           parsed by protocol::Parser<S> and, if accepted, turned into the
//!           tick's request; len 0 = no request this tick
//! ```
#![no_std]
#![forbid(unsafe_code)]

use core::fmt::{self, Write};

use kernel::config::{Validated, AXES};
use kernel::{Actuation, DriverCause, EncoderSample, Events, Fx, HardwareFault, Kernel, Scalar, Sense, TickOutput};
use protocol::{Command, DialectLock, ParseError, Parser};

/// Magic bytes at the start of a scenario.
pub const MAGIC: &[u8; 8] = b"EMUSCN1\0";
/// Encoder value meaning [`EncoderSample::Lost`].
pub const LOST: u16 = 0xFFFF;

/// The bit pattern of a scalar, for exact comparison.
pub trait Bits: Scalar {
    /// Name of the variant in trace headers.
    const NAME: &'static str;
    /// The raw bits.
    fn bits(self) -> u32;
}

impl Bits for f32 {
    const NAME: &'static str = "f32";
    fn bits(self) -> u32 {
        self.to_bits()
    }
}

impl Bits for Fx {
    const NAME: &'static str = "fx";
    fn bits(self) -> u32 {
        self.to_bits() as u32
    }
}

/// One tick of input, decoded.
#[derive(Clone, Copy, Debug)]
pub struct TickInput<'a> {
    /// Sensors.
    pub sense: Sense,
    /// The host line delivered this tick, if any.
    pub frame: Option<&'a [u8]>,
}

/// Malformed scenario bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScenarioError {
    /// Wrong magic.
    Magic,
    /// Truncated at this byte offset.
    Truncated(usize),
    /// Bytes left after the last tick.
    Trailing(usize),
}

/// Reads a scenario tick by tick.
#[derive(Clone, Debug)]
pub struct Reader<'a> {
    data: &'a [u8],
    pos: usize,
    /// Number of ticks announced by the header.
    pub ticks: u32,
    read: u32,
}

impl<'a> Reader<'a> {
    /// Checks the header.
    pub fn new(data: &'a [u8]) -> Result<Self, ScenarioError> {
        if data.get(..8) != Some(&MAGIC[..]) {
            return Err(ScenarioError::Magic);
        }
        let t = data.get(8..12).ok_or(ScenarioError::Truncated(8))?;
        let ticks = u32::from_le_bytes([t[0], t[1], t[2], t[3]]);
        Ok(Reader { data, pos: 12, ticks, read: 0 })
    }

    fn take(&mut self, n: usize) -> Result<&'a [u8], ScenarioError> {
        let s = self.data.get(self.pos..self.pos + n).ok_or(ScenarioError::Truncated(self.pos))?;
        self.pos += n;
        Ok(s)
    }

    /// The next tick, `Ok(None)` after the last.
    pub fn next_tick(&mut self) -> Result<Option<TickInput<'a>>, ScenarioError> {
        if self.read == self.ticks {
            return if self.pos == self.data.len() { Ok(None) } else { Err(ScenarioError::Trailing(self.pos)) };
        }
        self.read += 1;
        let e = self.take(12)?;
        let mut encoders = [EncoderSample::Lost; AXES];
        for (i, s) in encoders.iter_mut().enumerate() {
            let v = u16::from_le_bytes([e[2 * i], e[2 * i + 1]]);
            *s = if v == LOST { EncoderSample::Lost } else { EncoderSample::Count(v) };
        }
        let b = self.take(3)?;
        let hardware_fault = decode_hw(b[1]);
        let len = usize::from(b[2]);
        let frame = if len == 0 { None } else { Some(self.take(len)?) };
        Ok(Some(TickInput { sense: Sense { encoders, limits: b[0], hardware_fault, link_lost: false }, frame }))
    }
}

/// The driver diagnostics' causes in their scenario encoding's order
/// (`0x20 + 10 axis + index`).
const DRIVER_CAUSES: [DriverCause; 9] = [
    DriverCause::Missing,
    DriverCause::WrongVersion,
    DriverCause::Reset,
    DriverCause::DriverError,
    DriverCause::ChargePump,
    DriverCause::Overtemperature,
    DriverCause::ShortToGround,
    DriverCause::ShortToSupply,
    DriverCause::OpenLoad,
];

fn decode_hw(b: u8) -> Option<HardwareFault> {
    let diagnostic = b.checked_sub(0x20).and_then(|v| {
        let cause = *DRIVER_CAUSES.get(usize::from(v % 10))?;
        Some(HardwareFault::DriverDiagnostic { axis: v / 10, cause })
    });
    match b {
        0 => None,
        1 => Some(HardwareFault::TickOverrun),
        0x10..=0x1F => Some(HardwareFault::Driver { axis: b - 0x10 }),
        0x20..=0x6F if diagnostic.is_some() => diagnostic,
        0x80..=0xFF => Some(HardwareFault::SelfTest(b - 0x80)),
        _ => Some(HardwareFault::SelfTest(0x7F)),
    }
}

/// Encodes a hardware fault for the scenario.
pub fn encode_hw(f: Option<HardwareFault>) -> u8 {
    match f {
        None => 0,
        Some(HardwareFault::TickOverrun) => 1,
        Some(HardwareFault::Driver { axis }) => 0x10 | (axis & 0x0F),
        Some(HardwareFault::SelfTest(c)) => 0x80 | (c & 0x7F),
        Some(HardwareFault::DriverDiagnostic { axis, cause }) => {
            let i = DRIVER_CAUSES.iter().position(|c| *c == cause).unwrap_or(0) as u8;
            0x20 + (axis % 8) * 10 + i
        }
    }
}

/// Appends one tick to a scenario being written (the caller owns the buffer
/// and patches the tick count with [`set_ticks`]).
pub fn encode_tick(out: &mut impl Extend<u8>, sense: &Sense, frame: Option<&[u8]>) {
    for s in &sense.encoders {
        let v = match s {
            EncoderSample::Count(c) => *c,
            EncoderSample::Lost => LOST,
        };
        out.extend(v.to_le_bytes());
    }
    let frame = frame.unwrap_or(&[]);
    assert!(frame.len() <= 255, "frame too long for the scenario format");
    out.extend([sense.limits, encode_hw(sense.hardware_fault), frame.len() as u8]);
    out.extend(frame.iter().copied());
}

/// The header of a scenario with `ticks` ticks.
pub fn header(ticks: u32) -> [u8; 12] {
    let mut h = [0u8; 12];
    h[..8].copy_from_slice(MAGIC);
    h[8..].copy_from_slice(&ticks.to_le_bytes());
    h
}

/// Where the replay loop hands control to its caller. The target uses the
/// `before_*`/`after_*` pairs to place its instruction-count markers tightly
/// around the parser and the tick.
pub trait Hooks {
    /// Called with each finished line of output (no newline).
    fn line(&mut self, text: &str);
    /// Just before `Parser::parse`.
    fn before_parse(&mut self) {}
    /// Just after `Parser::parse`.
    fn after_parse(&mut self) {}
    /// Just before `Kernel::tick`.
    fn before_tick(&mut self) {}
    /// Just after `Kernel::tick`.
    fn after_tick(&mut self) {}
}

/// A fixed text buffer for one line; overflow truncates and is flagged.
#[derive(Debug)]
pub struct LineBuf {
    buf: [u8; 1024],
    len: usize,
    /// Set if text was cut.
    pub overflow: bool,
}

impl LineBuf {
    /// Empty buffer.
    pub const fn new() -> Self {
        LineBuf { buf: [0; 1024], len: 0, overflow: false }
    }
    /// Empties it.
    pub fn clear(&mut self) {
        self.len = 0;
        self.overflow = false;
    }
    /// The text so far.
    pub fn as_str(&self) -> &str {
        // Only `write_str` fills the buffer, with whole `str`s (cut at a
        // char boundary below), so this is valid UTF-8.
        core::str::from_utf8(&self.buf[..self.len]).unwrap_or("<utf8?>")
    }
}

impl Default for LineBuf {
    fn default() -> Self {
        Self::new()
    }
}

impl Write for LineBuf {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        let room = self.buf.len() - self.len;
        let mut n = s.len().min(room);
        while !s.is_char_boundary(n) {
            n -= 1;
        }
        self.buf[self.len..self.len + n].copy_from_slice(&s.as_bytes()[..n]);
        self.len += n;
        if n < s.len() {
            self.overflow = true;
        }
        Ok(())
    }
}

fn hex6<S: Bits>(w: &mut LineBuf, tag: &str, v: &[S; AXES]) -> fmt::Result {
    write!(w, " {tag}=")?;
    for (i, x) in v.iter().enumerate() {
        write!(w, "{}{:08x}", if i == 0 { "" } else { "," }, x.bits())?;
    }
    Ok(())
}

/// Writes the trace line of one tick.
pub fn format_tick<S: Bits>(w: &mut LineBuf, n: u32, o: &TickOutput<S>) -> fmt::Result {
    let s = &o.status;
    write!(w, "{n} {:?} {:?} L{:02x} H{:02x} A{}", s.state, s.homing, s.limits, s.homed, u8::from(s.timeout_armed))?;
    write!(w, " t{}", s.tick)?;
    hex6(w, "v", &o.act.velocity)?;
    write!(w, " r=")?;
    for (i, r) in o.act.step_rate.iter().enumerate() {
        write!(w, "{}{r}", if i == 0 { "" } else { "," })?;
    }
    hex6(w, "p", &s.position)?;
    hex6(w, "w", &s.velocity)?;
    hex6(w, "s", &s.setpoint)?;
    if let Some(f) = s.fault {
        write!(w, " F={:?}@{}", f.reason, f.tick)?;
    }
    for e in o.events.iter() {
        write!(w, " E={e:?}")?;
    }
    if o.events.dropped() != 0 {
        write!(w, " dropped={}", o.events.dropped())?;
    }
    Ok(())
}

fn format_parse<S: Bits>(w: &mut LineBuf, r: &Result<Command<S>, ParseError>) -> fmt::Result {
    match r {
        Ok(Command::Motion { seq, dialect, target }) => {
            write!(w, " cmd=Motion#{seq}/{dialect:?}")?;
            hex6(w, "tp", &target.position)?;
            hex6(w, "tv", &target.velocity)
        }
        Ok(c) => write!(w, " cmd={c:?}"),
        Err(e) => write!(w, " cmd=Err({e:?})"),
    }
}

/// `Kernel::tick_into` (the call the firmware makes: outputs and events
/// into caller-owned storage, no status), kept out of line so its stack
/// frame is its own (the target measures the stack used below the caller)
/// and the measured region is one call.
#[inline(never)]
pub fn tick<S: Scalar>(
    k: &mut Kernel<S>,
    sense: &Sense,
    request: Option<kernel::Request<S>>,
    act: &mut Actuation<S>,
    events: &mut Events,
) {
    k.tick_into(sense, request, act, events)
}

/// Replays `scenario` through a fresh `Kernel<S>` built from `config`, and a
/// `Parser<S>` (auto dialect), handing one line per tick to `hooks`, framed
/// by a header line and a summary line. Returns the number of ticks.
pub fn replay<S: Bits, H: Hooks>(config: &Validated, scenario: &[u8], hooks: &mut H) -> Result<u32, ScenarioError> {
    let mut rd = Reader::new(scenario)?;
    let (mut kernel, authority) = Kernel::<S>::new(config);
    let parser = Parser::<S>::new(config, DialectLock::Auto);
    let mut w = LineBuf::new();
    let _ = write!(w, "== {} ticks={}", S::NAME, rd.ticks);
    hooks.line(w.as_str());
    // Running checksum (FNV-1a over every line) for a one-line summary.
    let mut fnv: u32 = 0x811c_9dc5;
    let mut n = 0u32;
    let mut act = Actuation::zero();
    let mut events = Events::new();
    while let Some(input) = rd.next_tick()? {
        w.clear();
        let request = match input.frame {
            None => None,
            Some(frame) => {
                hooks.before_parse();
                let parsed = core::hint::black_box(parser.parse(core::hint::black_box(frame)));
                hooks.after_parse();
                let _ = format_parse(&mut w, &parsed);
                parsed.ok().map(|c| c.into_request(&authority))
            }
        };
        let mut head = LineBuf::new();
        hooks.before_tick();
        tick(&mut kernel, core::hint::black_box(&input.sense), request, &mut act, &mut events);
        hooks.after_tick();
        // The status is built outside the measured region, as the firmware
        // builds it only when telemetry is due.
        let out = TickOutput { act, status: kernel.status(input.sense.limits), events };
        let out = core::hint::black_box(out);
        let _ = format_tick(&mut head, n, &out);
        let _ = head.write_str(w.as_str());
        if head.overflow {
            let _ = head.write_str(" <overflow>");
        }
        for b in head.as_str().bytes() {
            fnv = (fnv ^ u32::from(b)).wrapping_mul(0x0100_0193);
        }
        hooks.line(head.as_str());
        n += 1;
    }
    w.clear();
    let _ = write!(w, "== {} end ticks={n} fnv1a={fnv:08x}", S::NAME);
    hooks.line(w.as_str());
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every hardware fault a scenario can carry decodes to itself.
    #[test]
    fn hardware_faults_round_trip() {
        let check = |f: Option<HardwareFault>| assert_eq!(decode_hw(encode_hw(f)), f, "{f:?}");
        check(None);
        check(Some(HardwareFault::TickOverrun));
        check(Some(HardwareFault::SelfTest(5)));
        for axis in 0..AXES as u8 {
            check(Some(HardwareFault::Driver { axis }));
            for cause in DRIVER_CAUSES {
                check(Some(HardwareFault::DriverDiagnostic { axis, cause }));
            }
        }
    }
}
