//! Scenarios: a line-based script format (documented in `sim/README.md`)
//! and the built-in set, which is written in the same format
//! (`sim/scenarios/*.scn`).

use std::fmt;
use std::path::Path;

use anyhow::{bail, Context, Result};
use kernel::config::AXES;

use crate::encoder::Line;

/// Something that marks a point in time once it happens.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Anchor {
    /// Homing status became H2 (complete).
    Homed,
    /// The kernel entered SOFT_ESTOP (ramp finished).
    Estop,
    /// The kernel entered FAULT.
    Fault,
    /// A latched stop or fault was cleared.
    Enabled,
    /// A homing run started (`HOMING_STARTED`).
    HomingStarted,
    /// Homing became H3 (a run failed).
    HomingFailed,
    /// A soft stop started (`SOFT_ESTOP`, any cause).
    SoftStop,
    /// A soft stop started for a lost link (`SOFT_ESTOP LINK_LOST`).
    LinkLost,
    /// A ramp ended latched (`STOPPED`).
    Stopped,
    /// The timeout held an arm at rest (`HOLDING`).
    Holding,
}

impl Anchor {
    /// All anchors.
    pub const ALL: [Anchor; 10] = [
        Anchor::Homed,
        Anchor::Estop,
        Anchor::Fault,
        Anchor::Enabled,
        Anchor::HomingStarted,
        Anchor::HomingFailed,
        Anchor::SoftStop,
        Anchor::LinkLost,
        Anchor::Stopped,
        Anchor::Holding,
    ];
    /// Name in scripts.
    pub fn name(self) -> &'static str {
        match self {
            Anchor::Homed => "homed",
            Anchor::Estop => "estop",
            Anchor::Fault => "fault",
            Anchor::Enabled => "enabled",
            Anchor::HomingStarted => "homing-started",
            Anchor::HomingFailed => "h3",
            Anchor::SoftStop => "soft-stop",
            Anchor::LinkLost => "link-lost",
            Anchor::Stopped => "stopped",
            Anchor::Holding => "holding",
        }
    }
    /// Index into per-anchor tables.
    pub fn index(self) -> usize {
        self as usize
    }
}

/// A time: milliseconds since power-on, or since the `n`-th occurrence of an
/// anchor.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct When {
    /// The anchor and its occurrence (1 = first), if any.
    pub anchor: Option<(Anchor, u32)>,
    /// Offset in ms.
    pub offset_ms: u64,
}

impl When {
    /// Resolves against the occurrence times recorded so far (indexed like
    /// [`Anchor::index`]; an anchor beyond the table never happens).
    pub fn resolve(&self, occurrences: &[Vec<u64>]) -> Option<u64> {
        match self.anchor {
            None => Some(self.offset_ms),
            Some((a, n)) => occurrences.get(a.index())?.get(n.saturating_sub(1) as usize).map(|t| t + self.offset_ms),
        }
    }
}

impl fmt::Display for When {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.anchor {
            None => write!(f, "{}ms", self.offset_ms),
            Some((a, 1)) => write!(f, "{}+{}ms", a.name(), self.offset_ms),
            Some((a, n)) => write!(f, "{}#{}+{}ms", a.name(), n, self.offset_ms),
        }
    }
}

/// Which host program a stream imitates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Client {
    /// The ROS 2 driver: interleaved, `%.3f`, SEQ never reset.
    Driver,
    /// The configurator: grouped, `:.4f`.
    Configurator,
}

/// The motion a stream sends.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Motion {
    /// From the pose at the start, `p = p0 + a (1 - cos(2 pi t / T)) / 2`.
    Cosine {
        /// Period (ms).
        period_ms: u64,
        /// Amplitude per joint (rad).
        amp: [f64; AXES],
    },
    /// Jog one joint (index 0..=5) at a constant velocity, then one final
    /// command with velocity 0.
    Jog {
        /// Joint index.
        joint: usize,
        /// Velocity (rad/s).
        vel: f64,
    },
}

impl Motion {
    /// The stream's reference pose and velocity at `t` (ms), for a stream
    /// from pose `p0` that runs from `start` to `end` (the jog's final pose,
    /// at velocity 0, after its end). One definition for the simulator's
    /// runner and the twin's, so both send the same frames.
    pub fn sample(&self, p0: &[f64; AXES], start: u64, end: u64, t: u64) -> ([f64; AXES], [f64; AXES]) {
        let el = (t.min(end).saturating_sub(start)) as f64 / 1000.0;
        match *self {
            Motion::Cosine { period_ms, amp } => {
                let w = std::f64::consts::TAU / (period_ms as f64 / 1000.0);
                (
                    std::array::from_fn(|i| p0[i] + amp[i] * (1.0 - (w * el).cos()) / 2.0),
                    std::array::from_fn(|i| amp[i] * w * (w * el).sin() / 2.0),
                )
            }
            Motion::Jog { joint, vel } => {
                let mut p = *p0;
                let mut v = [0.0; AXES];
                if let (Some(x), Some(y)) = (p.get_mut(joint), v.get_mut(joint)) {
                    *x += vel * el;
                    if t < end {
                        *y = vel;
                    }
                }
                (p, v)
            }
        }
    }
}

/// One scripted action.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    /// Bytes to the firmware.
    Send(Vec<u8>),
    /// A periodic command stream.
    Stream {
        /// Who sends.
        client: Client,
        /// Rate (Hz).
        rate_hz: f64,
        /// Duration (ms).
        duration_ms: u64,
        /// What it sends.
        motion: Motion,
        /// Frames are held and delivered this many at once (1: each when
        /// due), as a loaded host or a coalescing USB stack delivers them.
        burst: usize,
    },
    /// One motion frame to a pose with zero velocities.
    Goto {
        /// Who sends.
        client: Client,
        /// The pose (rad).
        pose: [f64; AXES],
    },
    /// Unplug (`false`) or plug (`true`) the cable: while unplugged no byte
    /// reaches the firmware, and over USB the port closes (the firmware
    /// reports the link lost to the kernel).
    Cable(bool),
    /// The bytes stop but the port stays open (a UART link, or a host that
    /// stops writing without closing the port): nothing tells the firmware.
    CableSilent,
    /// Add `offset` counts to `frames` frames of encoder `joint`.
    Glitch {
        /// Joint index.
        joint: usize,
        /// Offset (counts).
        offset: i32,
        /// Frames affected.
        frames: u32,
    },
    /// Set an encoder line's state (`Line::Ok` also ends a reversed or
    /// frozen reading).
    Encoder(usize, Line),
    /// A reversed encoder: from the next frame on, the count runs the other
    /// way (mirrored about that frame's count, so it does not jump).
    EncoderReversed(usize),
    /// A frozen but valid encoder reading: every later frame repeats the
    /// next frame's count.
    EncoderFrozen(usize),
    /// Force a switch closed (`Some(true)`), open, or back to its position.
    Switch(usize, Option<bool>),
    /// Uncommanded joint velocity (rad/s).
    Runaway(usize, f64),
    /// Fraction of steps lost.
    LostSteps(usize, f64),
    /// Invert (or restore) the DIR signal of a joint's driver: the motor
    /// turns the other way for every step command (a wiring fault).
    ReverseDir(usize, bool),
    /// Encoder noise (sigma, counts).
    Noise(f64),
    /// The next tick reports an overrun (the tick ran late).
    Overrun,
}

/// Fault kinds as written in scripts.
pub const FAULT_KINDS: [&str; 11] = [
    "encoder",
    "encoder-not-ready",
    "runaway",
    "limit-switch",
    "position-limit",
    "numeric",
    "homing-timeout",
    "homing-travel",
    "following-error",
    "hardware",
    "any",
];

/// One expectation, checked at the end of the run.
#[derive(Clone, Debug, PartialEq)]
pub enum Expect {
    /// No fault at all.
    NoFault,
    /// A fault of this kind (and joint index, if given) was raised.
    Fault(String, Option<usize>),
    /// The state at a time (name as on the wire: `OPERATIONAL`, `ESTOP_LATCHED`...).
    State(When, String),
    /// Homing completed (H2) by this time.
    HomedBy(When),
    /// Every stop after the last command of a burst reached standstill within this many ms.
    StopWithin(u64),
    /// Tracking error RMS below this (mrad), every joint.
    TrackingRmsBelow(f64),
    /// Tracking error max below this (mrad), every joint.
    TrackingMaxBelow(f64),
    /// Goal error at the end of the last motion burst below this (rad).
    GoalWithin(f64),
    /// At least this many frames/requests rejected.
    RejectedAtLeast(u64),
    /// Some line sent contains this text.
    Line(String),
    /// No line sent contains this text.
    NoLine(String),
    /// Some axis is commanded to move after this time.
    MovingAfter(When),
    /// A fault of this kind (and joint) was raised within `ms` after `from`.
    FaultWithin(When, u64, String, Option<usize>),
    /// A line containing the text was sent within `ms` after `from`.
    LineWithin(When, u64, String),
    /// Lines containing these texts were sent in this order.
    LineSequence(Vec<String>),
    /// The joint's true travel against its commanded direction, summed
    /// over the run, stays below this (rad).
    WrongWayBelow(usize, f64),
    /// From `from` to the end, the joint's true angle stays within this
    /// distance (rad) of its angle at `from`.
    ExcursionBelow(usize, When, f64),
    /// Every commanded speed (or joint J's, if given) is below the
    /// standstill threshold from `from` to `to`.
    StillBetween(When, When, Option<usize>),
    /// Exactly this many lines contain the text.
    LineCount(usize, String),
    /// No line containing the text was sent from `from` to `to`.
    NoLineBetween(When, When, String),
    /// At this time every joint's true angle is within this distance (rad)
    /// of the last accepted motion target.
    AtTargetWithin(When, f64),
    /// From `from` to `to`, every joint's commanded velocity changes by at
    /// most its acceleration limit per tick (1 % slack), in every state;
    /// the tick a fault zeroes the outputs and the stop at a homing switch
    /// are the only exceptions.
    AccelWithinLimits(When, When),
    /// An expectation that a known kernel defect (reported) makes fail: it
    /// is evaluated and shown but does not decide the outcome.
    Pending(Box<Expect>),
}

impl fmt::Display for Expect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Expect::NoFault => write!(f, "no fault"),
            Expect::Fault(k, None) => write!(f, "fault {k}"),
            Expect::Fault(k, Some(j)) => write!(f, "fault {k} J{}", j + 1),
            Expect::State(w, s) => write!(f, "state {s} at {w}"),
            Expect::HomedBy(w) => write!(f, "homed (H2) by {w}"),
            Expect::StopWithin(ms) => write!(f, "standstill within {ms} ms of the last command"),
            Expect::TrackingRmsBelow(m) => write!(f, "tracking RMS < {m} mrad"),
            Expect::TrackingMaxBelow(m) => write!(f, "tracking max < {m} mrad"),
            Expect::GoalWithin(r) => write!(f, "goal error < {r} rad"),
            Expect::RejectedAtLeast(n) => write!(f, "at least {n} rejections"),
            Expect::Line(t) => write!(f, "a line contains {t:?}"),
            Expect::NoLine(t) => write!(f, "no line contains {t:?}"),
            Expect::MovingAfter(w) => write!(f, "moving after {w}"),
            Expect::FaultWithin(w, ms, k, None) => write!(f, "fault {k} within {ms} ms after {w}"),
            Expect::FaultWithin(w, ms, k, Some(j)) => write!(f, "fault {k} J{} within {ms} ms after {w}", j + 1),
            Expect::LineWithin(w, ms, t) => write!(f, "a line contains {t:?} within {ms} ms after {w}"),
            Expect::LineSequence(ts) => write!(f, "lines in order: {}", ts.join(" ; ")),
            Expect::WrongWayBelow(j, r) => write!(f, "J{} travels < {r} rad against its command", j + 1),
            Expect::ExcursionBelow(j, w, r) => write!(f, "J{} stays within {r} rad of its angle at {w}", j + 1),
            Expect::StillBetween(a, b, None) => write!(f, "standstill from {a} to {b}"),
            Expect::StillBetween(a, b, Some(j)) => write!(f, "J{} at standstill from {a} to {b}", j + 1),
            Expect::LineCount(n, t) => write!(f, "exactly {n} line(s) contain {t:?}"),
            Expect::NoLineBetween(a, b, t) => write!(f, "no line contains {t:?} from {a} to {b}"),
            Expect::AtTargetWithin(w, r) => write!(f, "within {r} rad of the last target at {w}"),
            Expect::AccelWithinLimits(a, b) => write!(f, "acceleration within limits from {a} to {b}"),
            Expect::Pending(e) => write!(f, "PENDING (kernel defect, reported): {e}"),
        }
    }
}

/// A whole scenario.
#[derive(Clone, Debug, PartialEq)]
pub struct Scenario {
    /// Short name (file stem for reports).
    pub name: String,
    /// What it shows.
    pub description: String,
    /// When the run ends.
    pub end: When,
    /// Hard cap on simulated time (ms), for anchored ends that never come.
    pub max_ms: u64,
    /// Expectations failing here do not fail the run (safety still does).
    pub informational: bool,
    /// The scenario is about what USB can tell (the port closing): run
    /// with the Serial1 main loop, its expectations are informational.
    pub usb_only: bool,
    /// Plant settings.
    pub pose: Option<[f64; AXES]>,
    /// Encoder noise (sigma, counts).
    pub noise: Option<f64>,
    /// Switch angles overriding the configuration's.
    pub switch_at: Vec<(usize, f64)>,
    /// Step-rate limit (steps/s).
    pub max_step_rate: Option<f64>,
    /// Random seed.
    pub seed: u64,
    /// Timed actions.
    pub actions: Vec<(When, Action)>,
    /// Expectations.
    pub expects: Vec<Expect>,
}

impl Scenario {
    /// An empty scenario.
    pub fn new(name: &str) -> Self {
        Scenario {
            name: name.to_string(),
            description: String::new(),
            end: When { anchor: None, offset_ms: 10_000 },
            max_ms: 120_000,
            informational: false,
            usb_only: false,
            pose: None,
            noise: None,
            switch_at: Vec::new(),
            max_step_rate: None,
            seed: 1,
            actions: Vec::new(),
            expects: Vec::new(),
        }
    }

    /// Reads a scenario file.
    pub fn from_file(path: &Path) -> Result<Self> {
        let text = std::fs::read_to_string(path).with_context(|| format!("reading scenario {}", path.display()))?;
        let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("scenario");
        Scenario::parse(stem, &text).with_context(|| format!("in scenario file {}", path.display()))
    }

    /// Parses the script format; errors name the line.
    pub fn parse(default_name: &str, text: &str) -> Result<Self> {
        let mut s = Scenario::new(default_name);
        for (n, raw) in text.lines().enumerate() {
            let line = raw.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            parse_line(&mut s, line).with_context(|| format!("line {}: `{}`", n + 1, line))?;
        }
        Ok(s)
    }
}

fn parse_line(s: &mut Scenario, line: &str) -> Result<()> {
    let (kw, rest) = split1(line);
    let words: Vec<&str> = rest.split_whitespace().collect();
    match kw {
        "name" => s.name = rest.trim().to_string(),
        "description" => {
            if !s.description.is_empty() {
                s.description.push(' ');
            }
            s.description.push_str(rest.trim());
        }
        "end" => s.end = parse_when(one(&words)?)?,
        "max" => s.max_ms = parse_ms(one(&words)?)?,
        "informational" => s.informational = true,
        "usb-only" => s.usb_only = true,
        "pose" => s.pose = Some(six(&words)?),
        "noise" => s.noise = Some(num(one(&words)?)?),
        "seed" => s.seed = one(&words)?.parse().context("seed must be an integer")?,
        "decode" => bail!(
            "`decode` is no longer a scenario setting: the simulator always runs the firmware's shipped \
             frame-capture decoder (hal_imxrt::pure::channel)"
        ),
        "switch-at" => {
            let [j, a] = two(&words)?;
            s.switch_at.push((joint(j)?, num(a)?));
        }
        "max-step-rate" => s.max_step_rate = Some(num(one(&words)?)?),
        "at" => {
            let (when, action) = split1(rest);
            let when = parse_when(when)?;
            if let Some(chatter) = parse_chatter(action)? {
                // A chattering switch: forced closed and open in turn, then
                // back to its position (expanded here into plain actions).
                s.actions.extend(chatter.into_iter().map(|(dt, a)| (When { offset_ms: when.offset_ms + dt, ..when }, a)));
                return Ok(());
            }
            let action = parse_action(action)?;
            s.actions.push((when, action));
        }
        "expect" => s.expects.push(parse_expect(rest)?),
        other => bail!(
            "unknown keyword `{other}` (expected name, description, end, max, informational, usb-only, pose, noise, seed, \
             switch-at, max-step-rate, at, expect)"
        ),
    }
    Ok(())
}

/// `switch J chatter CLOSED_MS OPEN_MS DURATION`: the switch forced closed
/// for CLOSED_MS, open for OPEN_MS, repeated for DURATION, then back to its
/// position; as (offset ms, action) pairs. `None` for any other action.
fn parse_chatter(text: &str) -> Result<Option<Vec<(u64, Action)>>> {
    let (kw, rest) = split1(text);
    let w: Vec<&str> = rest.split_whitespace().collect();
    if kw != "switch" || w.get(1) != Some(&"chatter") {
        return Ok(None);
    }
    let [j, _, closed, open, duration] = w[..] else {
        bail!("usage: switch J chatter CLOSED_MS OPEN_MS DURATION");
    };
    let (j, closed, open, duration) = (joint(j)?, parse_ms(closed)?, parse_ms(open)?, parse_ms(duration)?);
    if closed == 0 || open == 0 {
        bail!("switch chatter: closed and open times must be at least 1 ms");
    }
    let mut out = Vec::new();
    let mut t = 0;
    while t < duration {
        out.push((t, Action::Switch(j, Some(true))));
        out.push((t + closed, Action::Switch(j, Some(false))));
        t += closed + open;
    }
    out.push((t, Action::Switch(j, None)));
    Ok(Some(out))
}

fn parse_action(text: &str) -> Result<Action> {
    let (kw, rest) = split1(text);
    let w: Vec<&str> = rest.split_whitespace().collect();
    Ok(match kw {
        "send" => {
            let mut b = unescape(rest.trim())?;
            b.push(b'\n');
            Action::Send(b)
        }
        "raw" => Action::Send(unescape(rest.trim())?),
        "stream" => {
            // stream CLIENT RATE_HZ DURATION cosine PERIOD A1..A6 [burst N]
            // stream CLIENT RATE_HZ DURATION jog J VEL [burst N]
            let (w, burst) = match w[..] {
                [ref head @ .., "burst", n] => {
                    let n: usize = n.parse().context("burst must be a whole number of frames")?;
                    if n == 0 {
                        bail!("burst must be at least 1 frame");
                    }
                    (head.to_vec(), n)
                }
                _ => (w.clone(), 1),
            };
            if w.len() < 4 {
                bail!("usage: stream driver|config RATE_HZ DURATION (cosine PERIOD A1..A6 | jog J VEL)");
            }
            let client = parse_client(w[0])?;
            let rate_hz = num(w[1])?;
            if !(rate_hz > 0.0 && rate_hz <= 1000.0) {
                bail!("stream rate must be in (0, 1000] Hz");
            }
            let duration_ms = parse_ms(w[2])?;
            let motion = match w[3] {
                "cosine" => {
                    if w.len() != 11 {
                        bail!("usage: ... cosine PERIOD A1 A2 A3 A4 A5 A6");
                    }
                    Motion::Cosine { period_ms: parse_ms(w[4])?.max(1), amp: six(&w[5..])? }
                }
                "jog" => {
                    if w.len() != 6 {
                        bail!("usage: ... jog J VEL");
                    }
                    Motion::Jog { joint: joint(w[4])?, vel: num(w[5])? }
                }
                m => bail!("unknown motion `{m}` (cosine or jog)"),
            };
            Action::Stream { client, rate_hz, duration_ms, motion, burst }
        }
        "goto" => {
            if w.len() != 7 {
                bail!("usage: goto driver|config P1 P2 P3 P4 P5 P6");
            }
            Action::Goto { client: parse_client(w[0])?, pose: six(&w[1..])? }
        }
        "cable" => match one(&w)? {
            "pull" => Action::Cable(false),
            "plug" => Action::Cable(true),
            "silent" => Action::CableSilent,
            o => bail!("cable takes `pull`, `silent` or `plug`, not `{o}`"),
        },
        "glitch" => {
            if !(w.len() == 2 || w.len() == 3) {
                bail!("usage: glitch J OFFSET_COUNTS [FRAMES]");
            }
            let frames = if w.len() == 3 { w[2].parse().context("frames must be an integer")? } else { 1 };
            Action::Glitch { joint: joint(w[0])?, offset: w[1].parse().context("offset must be an integer")?, frames }
        }
        "encoder" => {
            if let [j, "offset", c] = w[..] {
                // A lasting offset: every later frame reads C counts off.
                let offset = c.parse().context("offset must be an integer")?;
                return Ok(Action::Glitch { joint: joint(j)?, offset, frames: u32::MAX });
            }
            let [j, st] = two(&w)?;
            match st {
                "reversed" => return Ok(Action::EncoderReversed(joint(j)?)),
                "frozen" => return Ok(Action::EncoderFrozen(joint(j)?)),
                _ => {}
            }
            let line = match st {
                "ok" => Line::Ok,
                "lost" | "low" => Line::StuckLow,
                "high" => Line::StuckHigh,
                o => bail!("encoder state must be ok, lost (stuck low), high, reversed or frozen, not `{o}`"),
            };
            Action::Encoder(joint(j)?, line)
        }
        "switch" => {
            let [j, st] = two(&w)?;
            let f = match st {
                "press" => Some(true),
                "release" => Some(false),
                "auto" => None,
                o => bail!("switch state must be press, release or auto, not `{o}`"),
            };
            Action::Switch(joint(j)?, f)
        }
        "runaway" => {
            let [j, v] = two(&w)?;
            Action::Runaway(joint(j)?, num(v)?)
        }
        "lost-steps" => {
            let [j, f] = two(&w)?;
            let f = num(f)?;
            if !(0.0..=1.0).contains(&f) {
                bail!("lost-steps fraction must be within 0..=1");
            }
            Action::LostSteps(joint(j)?, f)
        }
        "noise" => Action::Noise(num(one(&w)?)?),
        "overrun" => {
            if !w.is_empty() {
                bail!("usage: overrun");
            }
            Action::Overrun
        }
        "reverse-dir" => match w[..] {
            [j] => Action::ReverseDir(joint(j)?, true),
            [j, "on"] => Action::ReverseDir(joint(j)?, true),
            [j, "off"] => Action::ReverseDir(joint(j)?, false),
            _ => bail!("usage: reverse-dir J [on|off]"),
        },
        o => bail!(
            "unknown action `{o}` (send, raw, stream, goto, cable, glitch, encoder, switch, runaway, lost-steps, \
             reverse-dir, noise, overrun)"
        ),
    })
}

fn parse_expect(text: &str) -> Result<Expect> {
    let (kw, rest) = split1(text);
    let w: Vec<&str> = rest.split_whitespace().collect();
    Ok(match kw {
        "no-fault" => Expect::NoFault,
        "fault" => {
            if w.is_empty() || w.len() > 2 {
                bail!("usage: expect fault KIND [J]");
            }
            if !FAULT_KINDS.contains(&w[0]) {
                bail!("unknown fault kind `{}` (one of {})", w[0], FAULT_KINDS.join(", "));
            }
            Expect::Fault(w[0].to_string(), w.get(1).map(|j| joint(j)).transpose()?)
        }
        "fault-within" => {
            if w.len() < 3 || w.len() > 4 {
                bail!("usage: expect fault-within FROM MS KIND [J]");
            }
            if !FAULT_KINDS.contains(&w[2]) {
                bail!("unknown fault kind `{}` (one of {})", w[2], FAULT_KINDS.join(", "));
            }
            Expect::FaultWithin(
                parse_when(w[0])?,
                parse_ms(w[1])?,
                w[2].to_string(),
                w.get(3).map(|j| joint(j)).transpose()?,
            )
        }
        "line-within" => {
            let (from, rest) = split1(rest);
            let (ms, text) = split1(rest);
            if text.trim().is_empty() {
                bail!("usage: expect line-within FROM MS TEXT");
            }
            Expect::LineWithin(parse_when(from)?, parse_ms(ms)?, text.trim().to_string())
        }
        "line-sequence" => {
            let ts: Vec<String> = rest.split(';').map(|t| t.trim().to_string()).collect();
            if ts.len() < 2 || ts.iter().any(String::is_empty) {
                bail!("usage: expect line-sequence TEXT ; TEXT [; TEXT ...]");
            }
            Expect::LineSequence(ts)
        }
        "max-travel-wrong-way" => {
            let [j, r] = two(&w)?;
            Expect::WrongWayBelow(joint(j)?, num(r)?)
        }
        "excursion-below" => match w[..] {
            [j, from, r] => Expect::ExcursionBelow(joint(j)?, parse_when(from)?, num(r)?),
            _ => bail!("usage: expect excursion-below J FROM RAD"),
        },
        "still-between" => match w[..] {
            [a, b] => Expect::StillBetween(parse_when(a)?, parse_when(b)?, None),
            [a, b, j] => Expect::StillBetween(parse_when(a)?, parse_when(b)?, Some(joint(j)?)),
            _ => bail!("usage: expect still-between FROM TO [J]"),
        },
        "line-count" => {
            let (n, text) = split1(rest.trim());
            let n = n.parse().context("line-count takes a whole number, then the text")?;
            Expect::LineCount(n, text.trim().to_string())
        }
        "no-line-between" => {
            let (a, r) = split1(rest.trim());
            let (b, text) = split1(r.trim());
            if text.trim().is_empty() {
                bail!("usage: expect no-line-between FROM TO TEXT");
            }
            Expect::NoLineBetween(parse_when(a)?, parse_when(b)?, text.trim().to_string())
        }
        "at-target-within" => {
            let [t, r] = two(&w)?;
            Expect::AtTargetWithin(parse_when(t)?, num(r)?)
        }
        "accel-within-limits" => {
            let [a, b] = two(&w)?;
            Expect::AccelWithinLimits(parse_when(a)?, parse_when(b)?)
        }
        "pending" => {
            let inner = parse_expect(rest)?;
            if matches!(inner, Expect::Pending(_)) {
                bail!("`pending pending` is one `pending`");
            }
            Expect::Pending(Box::new(inner))
        }
        "state" => {
            let [t, st] = two(&w)?;
            // The wire's names (`protocol::report::state_name`), one spelling
            // everywhere.
            use kernel::State as K;
            const STATES: [&str; 7] = [
                protocol::report::state_name(K::Boot),
                protocol::report::state_name(K::Unhomed),
                protocol::report::state_name(K::Homing),
                protocol::report::state_name(K::Operational),
                protocol::report::state_name(K::Stopping),
                protocol::report::state_name(K::SoftEstop),
                protocol::report::state_name(K::Fault),
            ];
            if !STATES.contains(&st) {
                bail!("unknown state `{st}` (one of {})", STATES.join(", "));
            }
            Expect::State(parse_when(t)?, st.to_string())
        }
        "homed-by" => Expect::HomedBy(parse_when(one(&w)?)?),
        "stop-within" => Expect::StopWithin(parse_ms(one(&w)?)?),
        "tracking-rms-below" => Expect::TrackingRmsBelow(num(one(&w)?)?),
        "tracking-max-below" => Expect::TrackingMaxBelow(num(one(&w)?)?),
        "goal-within" => Expect::GoalWithin(num(one(&w)?)?),
        "rejected-at-least" => Expect::RejectedAtLeast(one(&w)?.parse().context("count must be an integer")?),
        "line" => Expect::Line(rest.trim().to_string()),
        "no-line" => Expect::NoLine(rest.trim().to_string()),
        "moving-after" => Expect::MovingAfter(parse_when(one(&w)?)?),
        o => bail!(
            "unknown expectation `{o}` (no-fault, fault, fault-within, state, homed-by, stop-within, \
             tracking-rms-below, tracking-max-below, goal-within, rejected-at-least, line, no-line, line-within, \
             line-sequence, moving-after, still-between, max-travel-wrong-way, excursion-below, at-target-within, \
             accel-within-limits, pending)"
        ),
    })
}

fn split1(s: &str) -> (&str, &str) {
    let s = s.trim_start();
    match s.find(char::is_whitespace) {
        Some(i) => (&s[..i], &s[i..]),
        None => (s, ""),
    }
}

fn one<'a>(w: &[&'a str]) -> Result<&'a str> {
    match w {
        [x] => Ok(x),
        _ => bail!("expected exactly one value, got {}", w.len()),
    }
}

fn two<'a>(w: &[&'a str]) -> Result<[&'a str; 2]> {
    match w {
        [a, b] => Ok([a, b]),
        _ => bail!("expected exactly two values, got {}", w.len()),
    }
}

fn six(w: &[&str]) -> Result<[f64; AXES]> {
    if w.len() != AXES {
        bail!("expected {AXES} numbers, got {}", w.len());
    }
    let mut out = [0.0; AXES];
    for (o, x) in out.iter_mut().zip(w) {
        *o = num(x)?;
    }
    Ok(out)
}

fn num(s: &str) -> Result<f64> {
    let v: f64 = s.parse().with_context(|| format!("`{s}` is not a number"))?;
    if !v.is_finite() {
        bail!("`{s}` is not finite");
    }
    Ok(v)
}

fn joint(s: &str) -> Result<usize> {
    let j: usize = s.trim_start_matches(['J', 'j']).parse().with_context(|| format!("`{s}` is not a joint (1..6)"))?;
    if !(1..=AXES).contains(&j) {
        bail!("joint {j} out of range (1..6)");
    }
    Ok(j - 1)
}

fn parse_client(s: &str) -> Result<Client> {
    match s {
        "driver" => Ok(Client::Driver),
        "config" | "configurator" => Ok(Client::Configurator),
        o => bail!("client must be `driver` or `config`, not `{o}`"),
    }
}

/// `123`, `123ms`, `1.5s`.
pub fn parse_ms(s: &str) -> Result<u64> {
    let (v, scale) = if let Some(x) = s.strip_suffix("ms") {
        (x, 1.0)
    } else if let Some(x) = s.strip_suffix('s') {
        (x, 1000.0)
    } else {
        (s, 1.0)
    };
    let v = num(v).with_context(|| format!("bad time `{s}` (use 250, 250ms or 1.5s)"))?;
    if v < 0.0 {
        bail!("negative time `{s}`");
    }
    Ok((v * scale).round() as u64)
}

/// `TIME`, `ANCHOR`, `ANCHOR+TIME`, `ANCHOR#N+TIME`.
pub fn parse_when(s: &str) -> Result<When> {
    let first = s.chars().next().unwrap_or('0');
    if first.is_ascii_digit() || first == '.' {
        return Ok(When { anchor: None, offset_ms: parse_ms(s)? });
    }
    let (head, off) = match s.split_once('+') {
        Some((h, o)) => (h, parse_ms(o)?),
        None => (s, 0),
    };
    let (name, n) = match head.split_once('#') {
        Some((a, n)) => (a, n.parse::<u32>().with_context(|| format!("bad occurrence `{n}`"))?),
        None => (head, 1),
    };
    if n == 0 {
        bail!("occurrences count from 1");
    }
    let anchor = Anchor::ALL.into_iter().find(|a| a.name() == name).with_context(|| {
        format!(
            "unknown anchor `{name}` (homed, estop, fault, enabled, homing-started, h3, soft-stop, link-lost, \
             stopped, holding; e.g. homed+500 or estop#2+1s)"
        )
    })?;
    Ok(When { anchor: Some((anchor, n)), offset_ms: off })
}

/// `\n`, `\r`, `\t`, `\\`, `\xNN`; everything else literal.
pub fn unescape(s: &str) -> Result<Vec<u8>> {
    let mut out = Vec::new();
    let b = s.as_bytes();
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'\\' {
            match b.get(i + 1) {
                Some(b'n') => out.push(b'\n'),
                Some(b'r') => out.push(b'\r'),
                Some(b't') => out.push(b'\t'),
                Some(b'\\') => out.push(b'\\'),
                Some(b's') => out.push(b' '),
                Some(b'x') => {
                    let h = s.get(i + 2..i + 4).context("\\x needs two hex digits")?;
                    out.push(u8::from_str_radix(h, 16).with_context(|| format!("bad hex escape \\x{h}"))?);
                    i += 2;
                }
                _ => bail!("unknown escape at byte {i} (use \\n \\r \\t \\s \\\\ \\xNN)"),
            }
            i += 2;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    Ok(out)
}

/// The built-in scenarios, in the order they run.
pub const BUILTIN: [(&str, &str); 28] = [
    ("startup-homing", include_str!("../scenarios/startup-homing.scn")),
    ("driver-trajectory-100hz", include_str!("../scenarios/driver-trajectory-100hz.scn")),
    ("driver-stream-cut", include_str!("../scenarios/driver-stream-cut.scn")),
    ("configurator-jog-25hz", include_str!("../scenarios/configurator-jog-25hz.scn")),
    ("jog-release-jog", include_str!("../scenarios/jog-release-jog.scn")),
    ("configurator-goto", include_str!("../scenarios/configurator-goto.scn")),
    ("goto-then-driver-frame", include_str!("../scenarios/goto-then-driver-frame.scn")),
    ("leap-after-enable", include_str!("../scenarios/leap-after-enable.scn")),
    ("cable-pull", include_str!("../scenarios/cable-pull.scn")),
    ("cable-pull-goto", include_str!("../scenarios/cable-pull-goto.scn")),
    ("stream-resumes-after-silence", include_str!("../scenarios/stream-resumes-after-silence.scn")),
    ("home-mid-stream", include_str!("../scenarios/home-mid-stream.scn")),
    ("stale-h2-reactivation", include_str!("../scenarios/stale-h2-reactivation.scn")),
    ("limit-hit", include_str!("../scenarios/limit-hit.scn")),
    ("encoder-glitch", include_str!("../scenarios/encoder-glitch.scn")),
    ("encoder-loss", include_str!("../scenarios/encoder-loss.scn")),
    ("garbage", include_str!("../scenarios/garbage.scn")),
    ("runaway", include_str!("../scenarios/runaway.scn")),
    ("inverted-dir", include_str!("../scenarios/inverted-dir.scn")),
    ("dead-homing-switch", include_str!("../scenarios/dead-homing-switch.scn")),
    ("homing-link-loss", include_str!("../scenarios/homing-link-loss.scn")),
    ("homing-link-loss-seek", include_str!("../scenarios/homing-link-loss-seek.scn")),
    ("limit-chatter", include_str!("../scenarios/limit-chatter.scn")),
    ("stream-stop-at-speed", include_str!("../scenarios/stream-stop-at-speed.scn")),
    ("burst-stream", include_str!("../scenarios/burst-stream.scn")),
    ("tick-overrun", include_str!("../scenarios/tick-overrun.scn")),
    ("encoder-frozen", include_str!("../scenarios/encoder-frozen.scn")),
    ("encoder-reversed", include_str!("../scenarios/encoder-reversed.scn")),
];

/// Parses the built-in scenarios.
pub fn builtin() -> Result<Vec<Scenario>> {
    BUILTIN.iter().map(|(n, t)| Scenario::parse(n, t).with_context(|| format!("built-in scenario {n}"))).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtins_parse() {
        let all = builtin().unwrap();
        assert_eq!(all.len(), BUILTIN.len());
    }

    #[test]
    fn errors_name_the_line() {
        let e = Scenario::parse("x", "# c\nend 10s\nat 5 frobnicate 3\n").unwrap_err();
        let msg = format!("{e:#}");
        assert!(msg.contains("line 3"), "{msg}");
        assert!(msg.contains("unknown action"), "{msg}");
        let e = Scenario::parse("x", "pose 1 2 3\n").unwrap_err();
        assert!(format!("{e:#}").contains("line 1"));
        let e = Scenario::parse("x", "at homd+5 send <HOME>\n").unwrap_err();
        assert!(format!("{e:#}").contains("unknown anchor"));
    }

    #[test]
    fn new_expectations_and_injections_parse() {
        let s = Scenario::parse(
            "x",
            "at 5 reverse-dir J1\nat 6 reverse-dir 1 off\nexpect fault-within homed+500 150 following-error 1\n\
             expect line-sequence A ; B C ; D\nexpect max-travel-wrong-way J1 0.04\n\
             expect pending line-within homed 5 HOLDING at rest\nexpect still-between 1s 2s\n",
        )
        .unwrap();
        assert_eq!(s.actions[0].1, Action::ReverseDir(0, true));
        assert_eq!(s.actions[1].1, Action::ReverseDir(0, false));
        assert_eq!(
            s.expects[0],
            Expect::FaultWithin(
                When { anchor: Some((Anchor::Homed, 1)), offset_ms: 500 },
                150,
                "following-error".into(),
                Some(0)
            )
        );
        assert_eq!(s.expects[1], Expect::LineSequence(vec!["A".into(), "B C".into(), "D".into()]));
        assert_eq!(s.expects[2], Expect::WrongWayBelow(0, 0.04));
        let Expect::Pending(inner) = &s.expects[3] else { panic!("{:?}", s.expects[3]) };
        assert_eq!(
            **inner,
            Expect::LineWithin(When { anchor: Some((Anchor::Homed, 1)), offset_ms: 0 }, 5, "HOLDING at rest".into())
        );
        assert!(Scenario::parse("x", "expect line-sequence A\n").is_err());
        assert!(Scenario::parse("x", "expect fault-within 1 2 bogus\n").is_err());
    }

    #[test]
    fn times_and_escapes() {
        assert_eq!(parse_ms("1.5s").unwrap(), 1500);
        assert_eq!(parse_ms("20ms").unwrap(), 20);
        let w = parse_when("estop#2+1s").unwrap();
        assert_eq!(w, When { anchor: Some((Anchor::Estop, 2)), offset_ms: 1000 });
        assert_eq!(unescape("<a>\\x00\\r\\n").unwrap(), b"<a>\x00\r\n");
    }
}
