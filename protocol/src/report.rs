//! Plain-text report lines (not starting with `<`): every kernel
//! [`Event`], every rejected or dropped frame, sequence resynchronisations,
//! queue overflow, and the boot banner with the configuration fingerprint.
//!
//! The ROS 2 driver ignores these lines; the configurator shows them and
//! puts every line containing `FAULT` or `SOFT_ESTOP` in its fault log. Only
//! faults and soft E-stops use those words (a test checks that no other line
//! contains them). Every line is printable ASCII and ends with `\n`.

use crate::feedback::FeedbackMode;
use crate::framer::LineError;
use crate::parse::{Dialect, DialectLock, ParseError};
use crate::queue::QueueFull;
use crate::seq::{Resync, ResyncReason, Stale, StaleReason};
use crate::text::{push_byte, push_hex64, push_hex8, push_i64, push_str, push_u32};
use crate::{Command, Full, Line, Rejection};
use kernel::config::{ArmConfig, HomingConfig, JointConfig};
use kernel::homing::Phase;
use kernel::{DriverCause, Event, FaultReason, HardwareFault, Reject, RequestKind, State, StopCause};

/// Protocol revision printed in the banner.
pub const PROTOCOL_REVISION: u32 = 1;

fn joint(out: &mut Line, axis: u8) -> Result<(), Full> {
    push_byte(out, b'J')?;
    push_u32(out, u32::from(axis).saturating_add(1))
}

fn kv(out: &mut Line, key: &str, v: u32) -> Result<(), Full> {
    push_byte(out, b' ')?;
    push_str(out, key)?;
    push_byte(out, b'=')?;
    push_u32(out, v)
}

fn field(out: &mut Line, name: &str, field: u8) -> Result<(), Full> {
    push_str(out, name)?;
    kv(out, "field", u32::from(field))
}

fn named_joint(out: &mut Line, name: &str, axis: u8) -> Result<(), Full> {
    push_str(out, name)?;
    push_byte(out, b' ')?;
    joint(out, axis)
}

/// The wire token of a driver's diagnostic (`docs/PROTOCOL.md` section 4.2).
pub const fn driver_cause_name(c: DriverCause) -> &'static str {
    match c {
        DriverCause::Missing => "MISSING",
        DriverCause::WrongVersion => "WRONG_VERSION",
        DriverCause::Reset => "RESET",
        DriverCause::DriverError => "DRV_ERR",
        DriverCause::ChargePump => "UV_CP",
        DriverCause::Overtemperature => "OVERTEMP",
        DriverCause::ShortToGround => "SHORT_TO_GROUND",
        DriverCause::ShortToSupply => "SHORT_TO_SUPPLY",
        DriverCause::OpenLoad => "OPEN_LOAD",
    }
}

const fn phase_name(p: Phase) -> &'static str {
    match p {
        Phase::Idle => "IDLE",
        Phase::Waiting => "WAITING",
        Phase::FastSeek => "FAST_SEEK",
        Phase::BackOff => "BACK_OFF",
        Phase::SlowSeek => "SLOW_SEEK",
        Phase::Release => "RELEASE",
        Phase::Settle => "SETTLE",
        Phase::Done => "DONE",
    }
}

/// Name of a state (used in `ENABLED state=...`).
pub const fn state_name(s: State) -> &'static str {
    match s {
        State::Boot => "BOOT",
        State::Unhomed => "UNHOMED",
        State::Homing => "HOMING",
        State::Operational => "OPERATIONAL",
        State::Stopping => "STOPPING",
        State::SoftEstop => "ESTOP_LATCHED",
        State::Fault => "FAULT_LATCHED",
    }
}

const fn dialect_name(d: Dialect) -> &'static str {
    match d {
        Dialect::Driver => "DRIVER",
        Dialect::Configurator => "CONFIGURATOR",
    }
}

const fn lock_name(l: DialectLock) -> &'static str {
    match l {
        DialectLock::DriverOnly => "DRIVER_ONLY",
        DialectLock::ConfiguratorOnly => "CONFIGURATOR_ONLY",
        DialectLock::Auto => "AUTO",
    }
}

/// Text of a fault reason, e.g. `LIMIT_SWITCH J3` (without the `FAULT` word).
fn fault_reason(out: &mut Line, r: &FaultReason) -> Result<(), Full> {
    match *r {
        FaultReason::EncoderLost { axis } => named_joint(out, "ENCODER_LOST", axis),
        FaultReason::EncoderJump { axis, delta } => {
            named_joint(out, "ENCODER_JUMP", axis)?;
            push_str(out, " delta=")?;
            push_i64(out, i64::from(delta))
        }
        FaultReason::EncoderNotReady { axis } => named_joint(out, "ENCODER_NOT_READY", axis),
        FaultReason::Runaway { axis } => named_joint(out, "RUNAWAY", axis),
        FaultReason::LimitSwitch { axis } => named_joint(out, "LIMIT_SWITCH", axis),
        FaultReason::PositionLimit { axis } => named_joint(out, "POSITION_LIMIT", axis),
        FaultReason::Numeric { axis } => named_joint(out, "NUMERIC", axis),
        FaultReason::HomingTimeout { axis, phase } => {
            named_joint(out, "HOMING_TIMEOUT", axis)?;
            push_str(out, " phase=")?;
            push_str(out, phase_name(phase))
        }
        FaultReason::HomingTravel { axis, phase } => {
            named_joint(out, "HOMING_TRAVEL", axis)?;
            push_str(out, " phase=")?;
            push_str(out, phase_name(phase))
        }
        FaultReason::FollowingError { axis } => named_joint(out, "FOLLOWING_ERROR", axis),
        FaultReason::Hardware(h) => {
            push_str(out, "HARDWARE ")?;
            match h {
                HardwareFault::TickOverrun => push_str(out, "TICK_OVERRUN"),
                HardwareFault::Driver { axis } => named_joint(out, "DRIVER", axis),
                HardwareFault::SelfTest(code) => {
                    push_str(out, "SELF_TEST")?;
                    kv(out, "code", u32::from(code))
                }
                HardwareFault::DriverDiagnostic { axis, cause } => {
                    named_joint(out, "DRIVER_DIAG", axis)?;
                    push_byte(out, b' ')?;
                    push_str(out, driver_cause_name(cause))
                }
            }
        }
    }
}

fn request_name(out: &mut Line, r: RequestKind) -> Result<(), Full> {
    match r {
        RequestKind::Motion => push_str(out, "MOTION"),
        RequestKind::Home => push_str(out, "HOME"),
        RequestKind::HomeJoint(j) => {
            push_str(out, "HOME")?;
            push_u32(out, u32::from(j).saturating_add(1))
        }
        RequestKind::Enable => push_str(out, "ENABLE"),
    }
}

fn kernel_reject(out: &mut Line, r: &Reject) -> Result<(), Full> {
    match *r {
        Reject::Booting => push_str(out, "BOOTING"),
        Reject::NotHomed => push_str(out, "NOT_HOMED"),
        Reject::Homing => push_str(out, "HOMING_IN_PROGRESS"),
        Reject::Latched => push_str(out, "LATCHED_ENABLE_FIRST"),
        Reject::Stopping => push_str(out, "STOPPING"),
        Reject::PositionOutOfLimits { axis } => named_joint(out, "POSITION_LIMIT", axis),
        Reject::VelocityTooHigh { axis } => named_joint(out, "VELOCITY_LIMIT", axis),
        Reject::NonFinite { axis } => named_joint(out, "NON_FINITE", axis),
        Reject::NoSuchJoint => push_str(out, "NO_SUCH_JOINT"),
        Reject::DependencyNotHomed { needs } => {
            push_str(out, "DEPENDENCY_NOT_HOMED needs=")?;
            push_hex8(out, needs)
        }
        Reject::NothingToClear => push_str(out, "NOTHING_TO_CLEAR"),
        Reject::CauseActive(reason) => {
            push_str(out, "CAUSE_ACTIVE ")?;
            fault_reason(out, &reason)
        }
        Reject::ForeignCapability => push_str(out, "FOREIGN_CAPABILITY"),
        Reject::TargetJump { axis } => named_joint(out, "TARGET_JUMP", axis),
        Reject::Internal => push_str(out, "INTERNAL"),
    }
}

/// The line for one kernel event.
///
/// `READY`, `REFUSED <request> <reason>`, `HOMING_QUEUED ...`, `HOMING_STARTED mask=0x..`,
/// `HOMING_DONE mask=0x..`, `HOMING_FAULT <reason>` (homing timeouts),
/// `FAULT <reason>` (every other fault), `SOFT_ESTOP since_cmd_ms=<n>`,
/// `SOFT_ESTOP LINK_LOST`, `HOLDING ...`, `STOPPED`, `ENABLED state=<state>`.
pub fn event_line(out: &mut Line, e: &Event) -> Result<(), Full> {
    out.clear();
    match e {
        Event::Ready => push_str(out, "READY")?,
        Event::Rejected { request, reason } => {
            push_str(out, "REFUSED ")?;
            request_name(out, *request)?;
            push_byte(out, b' ')?;
            kernel_reject(out, reason)?;
        }
        Event::HomingQueued => push_str(out, "HOMING_QUEUED waiting for every encoder")?,
        Event::HomingStarted { mask } => {
            push_str(out, "HOMING_STARTED mask=")?;
            push_hex8(out, *mask)?;
        }
        Event::HomingDone { mask } => {
            push_str(out, "HOMING_DONE mask=")?;
            push_hex8(out, *mask)?;
        }
        Event::Fault(r @ (FaultReason::HomingTimeout { .. } | FaultReason::HomingTravel { .. })) => {
            push_str(out, "HOMING_FAULT ")?;
            fault_reason(out, r)?;
        }
        Event::Fault(r) => {
            push_str(out, "FAULT ")?;
            fault_reason(out, r)?;
        }
        Event::SoftEstop { cause: StopCause::CommandTimeout { since_command_ms } } => {
            push_str(out, "SOFT_ESTOP")?;
            kv(out, "since_cmd_ms", *since_command_ms)?;
        }
        Event::SoftEstop { cause: StopCause::LinkLost } => push_str(out, "SOFT_ESTOP LINK_LOST")?,
        Event::Holding => push_str(out, "HOLDING at rest, timeout disarmed")?,
        Event::HomingAfterStop => push_str(out, "HOMING_QUEUED stopping first")?,
        Event::Stopped => push_str(out, "STOPPED")?,
        Event::Enabled(s) => {
            push_str(out, "ENABLED state=")?;
            push_str(out, state_name(*s))?;
        }
    }
    push_byte(out, b'\n')
}

/// `EVENTS_LOST n=<n>`: the kernel's per-tick event list overflowed.
pub fn events_lost_line(out: &mut Line, n: u32) -> Result<(), Full> {
    out.clear();
    push_str(out, "EVENTS_LOST")?;
    kv(out, "n", n)?;
    push_byte(out, b'\n')
}

fn parse_error(out: &mut Line, e: &ParseError) -> Result<(), Full> {
    match *e {
        ParseError::MissingStart => push_str(out, "MISSING_START"),
        ParseError::MissingEnd => push_str(out, "MISSING_END"),
        ParseError::TrailingText => push_str(out, "TRAILING_TEXT"),
        ParseError::EmptyFrame => push_str(out, "EMPTY_FRAME"),
        ParseError::UnknownKeyword => push_str(out, "UNKNOWN_KEYWORD"),
        ParseError::WrongFieldCount { found } => {
            push_str(out, "FIELD_COUNT")?;
            kv(out, "found", u32::from(found))?;
            kv(out, "want", 13)
        }
        ParseError::EmptyField { field: f } => field(out, "EMPTY_FIELD", f),
        ParseError::BadSeq => push_str(out, "BAD_SEQ"),
        ParseError::SeqOverflow => push_str(out, "SEQ_OVERFLOW"),
        ParseError::NonNumeric { field: f } => field(out, "NON_NUMERIC", f),
        ParseError::BadDecimals { field: f, decimals } => {
            field(out, "BAD_DECIMALS", f)?;
            kv(out, "decimals", u32::from(decimals))
        }
        ParseError::MixedDialect => push_str(out, "MIXED_DIALECT"),
        ParseError::DialectLocked { found } => {
            push_str(out, "DIALECT_LOCKED found=")?;
            push_str(out, dialect_name(found))
        }
        ParseError::OutOfRange { field: f } => field(out, "OUT_OF_RANGE", f),
        ParseError::NonFinite { field: f } => field(out, "NON_FINITE", f),
        ParseError::PositionOutOfLimits { axis } => named_joint(out, "POSITION_LIMIT", axis),
        ParseError::VelocityTooHigh { axis } => named_joint(out, "VELOCITY_LIMIT", axis),
    }
}

/// `REJECT <reason> count=<n>` for a rejected line or frame; `count` is the
/// running total of rejections.
pub fn reject_line(out: &mut Line, r: &Rejection, count: u32) -> Result<(), Full> {
    out.clear();
    push_str(out, "REJECT ")?;
    match r {
        Rejection::Line(LineError::TooLong { len }) => {
            push_str(out, "LINE_TOO_LONG")?;
            kv(out, "len", *len)?;
        }
        Rejection::Line(LineError::NonPrintable { byte, at }) => {
            push_str(out, "NON_PRINTABLE byte=")?;
            push_hex8(out, *byte)?;
            kv(out, "at", *at)?;
        }
        Rejection::Frame(e) => parse_error(out, e)?,
    }
    kv(out, "count", count)?;
    push_byte(out, b'\n')
}

/// `STALE_CMD seq=<s> last=<l> reason=<DUPLICATE|BEHIND> count=<n>`.
pub fn stale_line(out: &mut Line, s: &Stale) -> Result<(), Full> {
    out.clear();
    push_str(out, "STALE_CMD")?;
    kv(out, "seq", s.seq)?;
    kv(out, "last", s.last)?;
    push_str(
        out,
        match s.reason {
            StaleReason::Duplicate => " reason=DUPLICATE",
            StaleReason::Behind => " reason=BEHIND",
        },
    )?;
    kv(out, "count", s.count)?;
    push_byte(out, b'\n')
}

/// `SEQ_RESYNC reason=GAP ms=<ms> seq=<s> last=<l>` or
/// `SEQ_RESYNC reason=BACKWARD_JUMP seq=<s> last=<l>`.
pub fn resync_line(out: &mut Line, r: &Resync) -> Result<(), Full> {
    out.clear();
    push_str(out, "SEQ_RESYNC")?;
    match r.reason {
        ResyncReason::Gap { ms } => {
            push_str(out, " reason=GAP")?;
            kv(out, "ms", ms)?;
        }
        ResyncReason::BackwardJump => push_str(out, " reason=BACKWARD_JUMP")?,
    }
    kv(out, "seq", r.seq)?;
    kv(out, "last", r.last)?;
    push_byte(out, b'\n')
}

/// `QUEUE_FULL <command> count=<n>`: an accepted command could not be
/// queued to the tick (see [`crate::queue`] for the policy).
pub fn queue_full_line<S>(out: &mut Line, q: &QueueFull<S>) -> Result<(), Full> {
    out.clear();
    push_str(out, "QUEUE_FULL ")?;
    match q.command {
        Command::Motion { seq, .. } => {
            push_str(out, "MOTION")?;
            kv(out, "seq", seq)?;
        }
        Command::Home => push_str(out, "HOME")?,
        Command::HomeJoint(j) => request_name(out, RequestKind::HomeJoint(j))?,
        Command::Enable => push_str(out, "ENABLE")?,
    }
    kv(out, "count", q.count)?;
    push_byte(out, b'\n')
}

/// `TELEMETRY_LOST n=<n>`: status or events the tick could not queue.
pub fn telemetry_lost_line(out: &mut Line, n: u32) -> Result<(), Full> {
    out.clear();
    push_str(out, "TELEMETRY_LOST")?;
    kv(out, "n", n)?;
    push_byte(out, b'\n')
}

/// Boot banner: `BOOT PAROL6 fw=<version> protocol=1 config=<16 hex>
/// dialect=<lock> feedback=<mode> reset=<cause>`. Bytes of `version` and
/// `reset` outside 0x21..=0x7E are printed as `?`; at most 32 of the
/// version and 16 of the cause are printed. `reset` names why the chip
/// last reset (`POWER_ON`, `WATCHDOG`, `LOCKUP`, ...).
pub fn banner_line(
    out: &mut Line,
    version: &str,
    fingerprint: u64,
    lock: DialectLock,
    mode: FeedbackMode,
    reset: &str,
) -> Result<(), Full> {
    out.clear();
    push_str(out, "BOOT PAROL6 fw=")?;
    for &b in version.as_bytes().iter().take(32) {
        push_byte(out, if (0x21..=0x7E).contains(&b) { b } else { b'?' })?;
    }
    kv(out, "protocol", PROTOCOL_REVISION)?;
    push_str(out, " config=")?;
    push_hex64(out, fingerprint)?;
    push_str(out, " dialect=")?;
    push_str(out, lock_name(lock))?;
    push_str(
        out,
        match mode {
            FeedbackMode::Driver => " feedback=DRIVER",
            FeedbackMode::Configurator => " feedback=CONFIGURATOR",
            FeedbackMode::Both => " feedback=BOTH",
        },
    )?;
    push_str(out, " reset=")?;
    for &b in reset.as_bytes().iter().take(16) {
        push_byte(out, if (0x21..=0x7E).contains(&b) { b } else { b'?' })?;
    }
    push_byte(out, b'\n')
}

/// Turns one telemetry element into its output lines (in order), calling
/// `emit` for each: a status gives the feedback line(s) of `mode`
/// acknowledging the status's `ack` (in `Both`, the configurator's line
/// first, with its leading space, and only if `configurator_due`), an event
/// its event line, a loss its `EVENTS_LOST` / `TELEMETRY_LOST` line.
pub fn telemetry_lines<S: kernel::Scalar>(
    t: &crate::queue::Telemetry<S>,
    mode: FeedbackMode,
    configurator_due: bool,
    out: &mut Line,
    mut emit: impl FnMut(&Line),
) -> Result<(), Full> {
    use crate::feedback::{configurator_line, configurator_line_beside_driver, driver_line};
    use crate::queue::Telemetry;
    match t {
        Telemetry::Status { status, tick_us, ack } => match mode {
            FeedbackMode::Configurator => {
                configurator_line(out, *ack, status, *tick_us)?;
                emit(out);
            }
            FeedbackMode::Driver => {
                driver_line(out, *ack, status)?;
                emit(out);
            }
            FeedbackMode::Both => {
                if configurator_due {
                    configurator_line_beside_driver(out, *ack, status, *tick_us)?;
                    emit(out);
                }
                driver_line(out, *ack, status)?;
                emit(out);
            }
        },
        Telemetry::Event(e) => {
            event_line(out, e)?;
            emit(out);
        }
        Telemetry::EventsLost(n) => {
            events_lost_line(out, u32::from(*n))?;
            emit(out);
        }
        Telemetry::Lost(n) => {
            telemetry_lost_line(out, *n)?;
            emit(out);
        }
    }
    Ok(())
}

/// `TX_LOST n=<n>`: output lines the port could not take and that were
/// dropped (feedback first, then reports; never a fault or stop line).
/// With `port_closed`, `TX_LOST n=<n> reason=PORT_CLOSED`: lines produced
/// while no host had the port open.
pub fn tx_lost_line(out: &mut Line, n: u32, port_closed: bool) -> Result<(), Full> {
    out.clear();
    push_str(out, "TX_LOST")?;
    kv(out, "n", n)?;
    if port_closed {
        push_str(out, " reason=PORT_CLOSED")?;
    }
    push_byte(out, b'\n')
}

/// True for the event lines that must reach the host whatever else is lost:
/// a latched fault (homing faults included), the soft E-stop and its end,
/// and a cleared latch.
pub const fn is_critical(e: &Event) -> bool {
    matches!(e, Event::Fault(_) | Event::SoftEstop { .. } | Event::Stopped | Event::Enabled(_))
}

// ---- configuration fingerprint -------------------------------------------

const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
const FNV_PRIME: u64 = 0x0000_0100_0000_01b3;

const fn fnv_byte(h: u64, b: u8) -> u64 {
    (h ^ b as u64).wrapping_mul(FNV_PRIME)
}

const fn fnv_u32(h: u64, x: u32) -> u64 {
    let [a, b, c, d] = x.to_le_bytes();
    fnv_byte(fnv_byte(fnv_byte(fnv_byte(h, a), b), c), d)
}

const fn fnv_f32(h: u64, x: f32) -> u64 {
    fnv_u32(h, x.to_bits())
}

const fn fnv_bool(h: u64, x: bool) -> u64 {
    fnv_byte(h, x as u8)
}

const fn fnv_homing(h: u64, c: &HomingConfig) -> u64 {
    // Destructured without `..`: adding a field to the kernel's config is a
    // build error here until the fingerprint covers it.
    let HomingConfig { direction, fast_speed, slow_speed, backoff, switch_position, timeout_ms, max_travel } = *c;
    let h = fnv_byte(h, direction as u8);
    let h = fnv_f32(h, fast_speed);
    let h = fnv_f32(h, slow_speed);
    let h = fnv_f32(h, backoff);
    let h = fnv_f32(h, switch_position);
    let h = fnv_u32(h, timeout_ms);
    fnv_f32(h, max_travel)
}

const fn fnv_joint(h: u64, j: &JointConfig) -> u64 {
    let JointConfig {
        gear_ratio,
        full_steps_per_rev,
        microsteps,
        max_velocity,
        runaway_velocity,
        kp,
        max_acceleration,
        limit_min,
        limit_max,
        encoder_reversed,
        motor_reversed,
        homing,
    } = *j;
    let h = fnv_f32(h, gear_ratio);
    let h = fnv_u32(h, full_steps_per_rev);
    let h = fnv_u32(h, microsteps);
    let h = fnv_f32(h, max_velocity);
    let h = fnv_f32(h, runaway_velocity);
    let h = fnv_f32(h, kp);
    let h = fnv_f32(h, max_acceleration);
    let h = fnv_f32(h, limit_min);
    let h = fnv_f32(h, limit_max);
    let h = fnv_bool(h, encoder_reversed);
    let h = fnv_bool(h, motor_reversed);
    fnv_homing(h, &homing)
}

/// A stable 64-bit fingerprint of every value of an [`ArmConfig`]: FNV-1a
/// over the little-endian bytes of each field in declaration order (f32 by
/// its bit pattern, bools and enums as one byte).
///
/// Hand-written rather than `core::hash`: it must be a `const fn` (so the
/// firmware can print a build-time constant), identical on the host and the
/// target and across compiler versions (`core`'s `Hasher` output is not
/// specified, and `f32` is not `Hash`), and it must visit every field (the
/// exhaustive destructuring makes a new kernel field a build error here).
pub const fn config_fingerprint(c: &ArmConfig) -> u64 {
    let ArmConfig {
        tick_hz,
        joints,
        observer_position_gain,
        observer_velocity_gain,
        deadband,
        command_timeout_ms,
        soft_stop_ms,
        stop_budget_ms,
        max_step_rate,
        segment_min_ms,
        segment_max_ms,
        boot_timeout_ms,
        homing_budget_ms,
        position_margin,
        encoder_invalid_limit,
        following_error,
        following_error_ms,
        homing_settle_ms,
        target_jump_tolerance,
    } = *c;
    let h = fnv_u32(FNV_OFFSET, tick_hz);
    let [j1, j2, j3, j4, j5, j6] = joints;
    let h = fnv_joint(h, &j1);
    let h = fnv_joint(h, &j2);
    let h = fnv_joint(h, &j3);
    let h = fnv_joint(h, &j4);
    let h = fnv_joint(h, &j5);
    let h = fnv_joint(h, &j6);
    let h = fnv_f32(h, observer_position_gain);
    let h = fnv_f32(h, observer_velocity_gain);
    let h = fnv_f32(h, deadband);
    let h = fnv_u32(h, command_timeout_ms);
    let h = fnv_u32(h, soft_stop_ms);
    let h = fnv_u32(h, stop_budget_ms);
    let h = fnv_u32(h, max_step_rate);
    let h = fnv_u32(h, segment_min_ms);
    let h = fnv_u32(h, segment_max_ms);
    let h = fnv_u32(h, boot_timeout_ms);
    let h = fnv_u32(h, homing_budget_ms);
    let h = fnv_f32(h, position_margin);
    let h = fnv_u32(h, encoder_invalid_limit);
    let h = fnv_f32(h, following_error);
    let h = fnv_u32(h, following_error_ms);
    let h = fnv_u32(h, homing_settle_ms);
    fnv_f32(h, target_jump_tolerance)
}

#[cfg(test)]
mod tests {
    use super::*;
    use kernel::config::PAROL6;

    #[test]
    fn telemetry_to_lines() {
        use crate::queue::Telemetry;
        let status = kernel::Status {
            state: State::Homing,
            homing: kernel::HomingStatus::InProgress,
            fault: None,
            position: [0.0f32; 6],
            velocity: [0.0; 6],
            setpoint: [0.0; 6],
            limits: 1,
            homed: 0,
            timeout_armed: false,
            tick: 0,
        };
        let mut out = Line::new();
        let mut lines = Vec::new();
        let t = Telemetry::Status { status, tick_us: 9, ack: 3 };
        telemetry_lines(&t, FeedbackMode::Both, true, &mut out, |l| lines.push(l.to_string())).unwrap();
        telemetry_lines(&t, FeedbackMode::Both, false, &mut out, |l| lines.push(l.to_string())).unwrap();
        telemetry_lines(&Telemetry::<f32>::Lost(2), FeedbackMode::Both, true, &mut out, |l| lines.push(l.to_string()))
            .unwrap();
        assert_eq!(lines.len(), 4);
        // Both: the configurator's line indented by one space, then the driver's.
        assert!(lines[0].starts_with(" <ACK,3,") && lines[0].ends_with(",1,2,9>\n"), "{}", lines[0]);
        assert!(lines[1].starts_with("<ACK,3,") && lines[1].ends_with(",H1>\n"), "{}", lines[1]);
        // Not due: the driver's line only.
        assert!(lines[2].starts_with("<ACK,3,") && lines[2].ends_with(",H1>\n"), "{}", lines[2]);
        assert_eq!(lines[3], "TELEMETRY_LOST n=2\n");
        tx_lost_line(&mut out, 7, false).unwrap();
        assert_eq!(out.as_str(), "TX_LOST n=7\n");
        tx_lost_line(&mut out, 0, true).unwrap();
        assert_eq!(out.as_str(), "TX_LOST n=0 reason=PORT_CLOSED\n");
    }

    #[test]
    fn fnv_known_vectors() {
        // FNV-1a 64 test vectors: "" and "a".
        assert_eq!(FNV_OFFSET, 0xcbf29ce484222325);
        assert_eq!(fnv_byte(FNV_OFFSET, b'a'), 0xaf63dc4c8601ec8c);
    }

    type ArmMut = Box<dyn Fn(&mut ArmConfig)>;
    type JointMut = Box<dyn Fn(&mut JointConfig)>;

    #[test]
    fn fingerprint_changes_with_every_value() {
        const FP: u64 = config_fingerprint(&PAROL6);
        assert_eq!(FP, config_fingerprint(&PAROL6.clone()));
        let muts: Vec<ArmMut> = vec![
            Box::new(|c| c.tick_hz += 1),
            Box::new(|c| c.observer_position_gain += 1.0),
            Box::new(|c| c.observer_velocity_gain += 1.0),
            Box::new(|c| c.following_error += 0.001),
            Box::new(|c| c.following_error_ms += 1),
            Box::new(|c| c.homing_settle_ms += 1),
            Box::new(|c| c.target_jump_tolerance += 0.001),
            Box::new(|c| c.joints[2].homing.max_travel += 0.01),
            Box::new(|c| c.deadband = 0.001),
            Box::new(|c| c.command_timeout_ms += 1),
            Box::new(|c| c.soft_stop_ms += 1),
            Box::new(|c| c.stop_budget_ms += 1),
            Box::new(|c| c.max_step_rate += 1),
            Box::new(|c| c.segment_min_ms += 1),
            Box::new(|c| c.segment_max_ms += 1),
            Box::new(|c| c.boot_timeout_ms += 1),
            Box::new(|c| c.homing_budget_ms += 1),
            Box::new(|c| c.position_margin += 0.01),
            Box::new(|c| c.encoder_invalid_limit += 1),
        ];
        let mut seen = std::collections::HashSet::new();
        seen.insert(FP);
        for m in &muts {
            let mut c = PAROL6;
            m(&mut c);
            assert!(seen.insert(config_fingerprint(&c)));
        }
        for j in 0..6 {
            let jm: Vec<JointMut> = vec![
                Box::new(|j| j.gear_ratio += 0.1),
                Box::new(|j| j.full_steps_per_rev += 1),
                Box::new(|j| j.microsteps *= 2),
                Box::new(|j| j.max_velocity += 0.1),
                Box::new(|j| j.runaway_velocity += 0.1),
                Box::new(|j| j.kp += 0.1),
                Box::new(|j| j.max_acceleration += 0.1),
                Box::new(|j| j.limit_min -= 0.001),
                Box::new(|j| j.limit_max += 0.001),
                Box::new(|j| j.encoder_reversed ^= true),
                Box::new(|j| j.motor_reversed ^= true),
                Box::new(|j| {
                    j.homing.direction = match j.homing.direction {
                        kernel::config::Direction::Positive => kernel::config::Direction::Negative,
                        kernel::config::Direction::Negative => kernel::config::Direction::Positive,
                    }
                }),
                Box::new(|j| j.homing.fast_speed += 0.01),
                Box::new(|j| j.homing.slow_speed += 0.01),
                Box::new(|j| j.homing.backoff += 0.01),
                Box::new(|j| j.homing.switch_position += 0.01),
                Box::new(|j| j.homing.timeout_ms += 1),
            ];
            for m in &jm {
                let mut c = PAROL6;
                m(&mut c.joints[j]);
                assert!(seen.insert(config_fingerprint(&c)), "joint {j}");
            }
        }
    }
}
