//! The steps of a random operating sequence and how one is played.

use kernel::config::{AXES, PAROL6};
use kernel::homing::Phase;
use kernel::{HardwareFault, State};

use monitor::plant::EncoderFault;

use super::{Driver, HOMING_WAIT_MAX};

/// How a test case starts.
#[derive(Clone, Debug, PartialEq)]
pub enum Start {
    /// From the homed snapshot (Operational, at the homing end pose).
    Homed,
    /// Power-on with the arm at `q` and these encoder offsets.
    Fresh {
        /// Joint angles (rad).
        q: [f64; AXES],
        /// Encoder offsets (rad of motor angle).
        offset: [f64; AXES],
        /// An encoder that gives no reading for the first ticks (a boot
        /// timeout when longer than 50 ms).
        boot_lost: Option<(usize, u64)>,
    },
}

/// A bad field in a motion target.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bad {
    /// Position beyond the limit by this much (rad; sign picks the side).
    OutOfLimits(f64),
    /// NaN position (fixed point: its largest value).
    NanPosition,
    /// Infinite position (fixed point: its extreme value).
    InfPosition(bool),
    /// NaN velocity (fixed point: its largest value).
    NanVelocity,
    /// Host velocity above the limit by this fraction.
    VelocityTooHigh(f64),
}

/// A request, variant-independent.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Req {
    /// A stream sample (positions, host velocities).
    Motion([f64; AXES], [f64; AXES]),
    /// A go-to (a configurator frame whose six velocities are all zero).
    GoTo([f64; AXES]),
    /// A target at `base` with one bad field on `axis`.
    BadMotion {
        /// Positions of the other axes.
        base: [f64; AXES],
        /// Axis with the bad field.
        axis: usize,
        /// What is wrong.
        bad: Bad,
    },
    /// Home all.
    Home,
    /// Home one joint (may be out of range).
    HomeJoint(u8),
    /// Enable (a capability minted by the authority).
    Enable,
}

/// One step of a random sequence: a request and/or an environment change,
/// and the ticks it lasts.
#[derive(Clone, Debug, PartialEq)]
pub enum Step {
    /// Stream `count` targets, one every `period` ticks, on a straight line
    /// from the current pose to `goal` (fractions of each joint's range; 0 and
    /// 1 are exactly the limits), with host velocities `vel` (fractions of the
    /// joint's limit).
    Stream {
        /// Goal, fraction of range per joint.
        goal: [f64; AXES],
        /// Host velocity, fraction of the limit per joint.
        vel: [f64; AXES],
        /// Ticks between targets.
        period: u32,
        /// Targets sent.
        count: u32,
    },
    /// A go-to (configurator-style frame, all velocities zero) to `goal`
    /// (fractions of each joint's range, as for `Stream`), then `wait` ticks.
    GoTo {
        /// Goal, fraction of range per joint.
        goal: [f64; AXES],
        /// Ticks after.
        wait: u32,
    },
    /// The host link is reported lost for `ticks` (a cable pull).
    LinkLoss(u32),
    /// The motor of `axis` turns the wrong way (`reversed`) or not at all
    /// for `ticks` (can fault: following error, homing travel).
    BrokenMotor {
        /// Axis.
        axis: usize,
        /// Reversed rather than stalled.
        reversed: bool,
        /// Duration.
        ticks: u32,
    },
    /// The homing switch of `axis` never closes during a full homing run
    /// (a broken wire): `<HOME>`, then until homing ends (at most
    /// [`HOMING_WAIT_MAX`] ticks).
    DeadSwitchHome {
        /// Axis.
        axis: usize,
    },
    /// One bad target, then `idle` ticks.
    BadMotion {
        /// Axis with the bad field.
        axis: usize,
        /// What is wrong.
        bad: Bad,
        /// Ticks after.
        idle: u32,
    },
    /// No requests (a dropout when longer than the command timeout).
    Silence(u32),
    /// Encoder `axis` lost (or out of range) for `ticks`.
    EncoderLoss {
        /// Axis.
        axis: usize,
        /// Kind of loss.
        fault: EncoderFault,
        /// Duration.
        ticks: u32,
    },
    /// Encoder `axis` reads `delta` counts off for `ticks` (a glitch; long
    /// ones are count jumps).
    Glitch {
        /// Axis.
        axis: usize,
        /// Counts added.
        delta: i32,
        /// Duration.
        ticks: u32,
    },
    /// Encoder `axis` slips by `counts` for good (a jump that persists).
    Slip {
        /// Axis.
        axis: usize,
        /// Counts.
        counts: i32,
    },
    /// Switches in `mask` pressed for `ticks` (a limit hit or a stuck switch).
    LimitHit {
        /// Joints.
        mask: u8,
        /// Duration.
        ticks: u32,
    },
    /// A hardware fault reported for `ticks`.
    Hardware {
        /// The fault.
        fault: HardwareFault,
        /// Duration.
        ticks: u32,
    },
    /// An outside force moves `axis` at `velocity` rad/s for `ticks`.
    Disturb {
        /// Axis.
        axis: usize,
        /// Extra velocity.
        velocity: f64,
        /// Duration.
        ticks: u32,
    },
    /// The operator brings every joint back inside its limits (0.5 rad/s,
    /// at most 20 000 ticks).
    ReturnInside,
    /// Enable, then `idle` ticks.
    Enable(u32),
    /// Home all, then `wait` ticks.
    Home(u32),
    /// Home one joint (0..=7: 6 and 7 do not exist), then `wait` ticks.
    HomeJoint(u8, u32),
    /// Run until homing ends (at most [`HOMING_WAIT_MAX`] ticks).
    WaitHoming,
    /// `<HOME>` (unless homing already), wait until `axis` is in `phase`
    /// (at most [`HOMING_WAIT_MAX`] ticks), then the host link lost for
    /// `ticks`: a link loss in that homing phase.
    HomeLinkLoss {
        /// Axis.
        axis: usize,
        /// The homing phase (a moving phase, or `Waiting`).
        phase: Phase,
        /// Duration of the loss.
        ticks: u32,
    },
    /// The switch of `axis` chatters: closed `closed` ticks, open `open`
    /// ticks, for `ticks` (a worn or loose switch).
    Chatter {
        /// Axis.
        axis: usize,
        /// Ticks closed per cycle.
        closed: u32,
        /// Ticks open per cycle.
        open: u32,
        /// Duration.
        ticks: u32,
    },
    /// The switch of `axis` held pressed (an arm resting on it) while
    /// `<HOME>` runs for `ticks`, then released.
    PressedHome {
        /// Axis.
        axis: usize,
        /// Duration.
        ticks: u32,
    },
    /// `count` stream samples toward `goal` on consecutive ticks (a burst
    /// the main loop hands over one per tick), then `idle` ticks.
    Burst {
        /// Goal, fraction of range per joint.
        goal: [f64; AXES],
        /// Samples.
        count: u32,
        /// Ticks after.
        idle: u32,
    },
}

/// A joint of `q` rests on (past) its homing switch.
pub fn on_a_switch(q: &[f64; AXES]) -> bool {
    PAROL6.joints.iter().zip(q.iter()).any(|(j, q)| {
        let s = f64::from(j.homing.switch_position);
        match j.homing.direction {
            kernel::config::Direction::Positive => *q >= s,
            kernel::config::Direction::Negative => *q <= s,
        }
    })
}

/// The interaction class of `step` (ticks per class per run are printed
/// by the state-machine test): a link loss, an enable and a home in each
/// state; a link loss in each homing phase; the switch patterns (chatter,
/// pressed while homing, pressed at power-on); go-to and stream mixed;
/// bursts. `d` is the driver before the step, `prev` the step before it
/// (`None` for the first), `start` the case's start.
pub fn class<D: Driver + ?Sized>(d: &D, step: &Step, prev: Option<&Step>, start: &Start) -> String {
    let st = d.state();
    let first = prev.is_none();
    match step {
        Step::LinkLoss(_) => format!("link loss in {st:?}"),
        Step::Enable(_) => format!("enable in {st:?}"),
        Step::Home(_) | Step::HomeJoint(..) => format!("home in {st:?}"),
        Step::HomeLinkLoss { axis, phase, .. } => format!("link loss in homing, J{} {phase:?}", axis + 1),
        Step::Chatter { .. } => format!("chatter in {st:?}"),
        Step::PressedHome { .. } => "switch pressed while homing".to_string(),
        _ if first && matches!(start, Start::Fresh { q, .. } if on_a_switch(q)) => {
            "first step after power-on on a switch".to_string()
        }
        Step::Burst { .. } => format!("burst in {st:?}"),
        Step::GoTo { .. } if matches!(prev, Some(Step::Stream { .. } | Step::Burst { .. })) => {
            "go-to after a stream".to_string()
        }
        Step::Stream { .. } if matches!(prev, Some(Step::GoTo { .. })) => "stream after a go-to".to_string(),
        _ => "other".to_string(),
    }
}

pub(super) fn range(i: usize) -> (f64, f64) {
    let j = &PAROL6.joints[i];
    (f64::from(j.limit_min), f64::from(j.limit_max))
}

/// Fractions of each joint's range to angles (exactly the limit at 0 and 1).
fn angles(goal: &[f64; AXES]) -> [f64; AXES] {
    std::array::from_fn(|i| {
        let (lo, hi) = range(i);
        if goal[i] <= 0.0 {
            lo
        } else if goal[i] >= 1.0 {
            hi
        } else {
            lo + goal[i] * (hi - lo)
        }
    })
}

/// Largest distance (rad) between the samples of a multi-sample stream
/// step: below every joint's segment travel (J1, J2: 3 rad/s x 40 ms plus
/// the braking distance 0.15 and the tolerance 0.02 = 0.29 rad).
pub const STREAM_STEP: f64 = 0.25;

/// Fraction of each joint's speed limit an even-count stream step moves at.
pub const STREAM_SPEED: f64 = 0.8;

/// Plays one step.
pub fn run_step<D: Driver + ?Sized>(d: &mut D, step: &Step) {
    let idle = |d: &mut D, n: u32| {
        for _ in 0..n {
            d.tick(None);
        }
    };
    match step {
        Step::Stream { goal, vel, period, count } => {
            let q0 = d.q();
            let goal = angles(goal);
            let v: [f64; AXES] = std::array::from_fn(|i| vel[i] * f64::from(PAROL6.joints[i].max_velocity));
            // A stream of several samples moves at most `STREAM_STEP` per
            // sample (within a segment's travel: the kernel refuses farther
            // samples as jumps); with an even count also at most
            // `STREAM_SPEED` of each joint's speed limit (a host the arm can
            // follow: its set-points land at the last sample soon after).
            // A single sample may be a leap.
            let dt = f64::from(*period) / f64::from(PAROL6.tick_hz);
            let needed = (0..AXES)
                .map(|i| {
                    let d = (goal[i] - q0[i]).abs();
                    let by_speed = if count % 2 == 0 {
                        d / (STREAM_SPEED * f64::from(PAROL6.joints[i].max_velocity) * dt)
                    } else {
                        0.0
                    };
                    (d / STREAM_STEP).max(by_speed).ceil() as u32
                })
                .max()
                .unwrap_or(1);
            let count = if *count > 1 { (*count).max(needed) } else { *count };
            let count = &count;
            for k in 1..=*count {
                let f = f64::from(k) / f64::from(*count);
                let p: [f64; AXES] =
                    std::array::from_fn(|i| if k == *count { goal[i] } else { q0[i] + (goal[i] - q0[i]) * f });
                d.tick(Some(Req::Motion(p, v)));
                idle(d, period.saturating_sub(1));
            }
        }
        Step::GoTo { goal, wait } => {
            d.tick(Some(Req::GoTo(angles(goal))));
            idle(d, *wait);
        }
        Step::LinkLoss(n) => {
            d.env(&|p| p.link_lost = true);
            idle(d, *n);
            d.env(&|p| p.link_lost = false);
        }
        Step::BrokenMotor { axis, reversed, ticks } => {
            let m = 1u8 << axis;
            if *reversed {
                d.env(&|p| p.reversed |= m);
            } else {
                d.env(&|p| p.stalled |= m);
            }
            idle(d, *ticks);
            d.env(&|p| {
                p.reversed &= !m;
                p.stalled &= !m;
            });
        }
        Step::DeadSwitchHome { axis } => {
            let m = 1u8 << axis;
            d.env(&|p| p.dead_switch |= m);
            d.tick(Some(Req::Home));
            for _ in 0..HOMING_WAIT_MAX {
                if d.state() != State::Homing {
                    break;
                }
                d.tick(None);
            }
            d.env(&|p| p.dead_switch &= !m);
        }
        Step::BadMotion { axis, bad, idle: n } => {
            let base = d.q().map(|x| x.clamp(-1.6, 1.6));
            d.tick(Some(Req::BadMotion { base, axis: *axis, bad: *bad }));
            idle(d, *n);
        }
        Step::Silence(n) => idle(d, *n),
        Step::EncoderLoss { axis, fault, ticks } => {
            let (a, f) = (*axis, *fault);
            d.env(&|p| p.encoder[a] = f);
            idle(d, *ticks);
            d.env(&|p| p.encoder[a] = EncoderFault::None);
        }
        Step::Glitch { axis, delta, ticks } => {
            let (a, g) = (*axis, *delta);
            d.env(&|p| p.glitch[a] = g);
            idle(d, *ticks);
            d.env(&|p| p.glitch[a] = 0);
        }
        Step::Slip { axis, counts } => {
            let (a, c) = (*axis, *counts);
            d.env(&|p| p.enc_offset[a] += f64::from(c) * core::f64::consts::TAU / 4096.0);
            d.tick(None);
        }
        Step::LimitHit { mask, ticks } => {
            let m = *mask;
            d.env(&|p| p.force_switch |= m);
            idle(d, *ticks);
            d.env(&|p| p.force_switch = 0);
        }
        Step::Hardware { fault, ticks } => {
            let f = *fault;
            d.env(&|p| p.hardware_fault = Some(f));
            idle(d, *ticks);
            d.env(&|p| p.hardware_fault = None);
        }
        Step::Disturb { axis, velocity, ticks } => {
            let (a, v) = (*axis, *velocity);
            d.env(&|p| p.disturbance[a] = v);
            idle(d, *ticks);
            d.env(&|p| p.disturbance[a] = 0.0);
        }
        Step::ReturnInside => {
            for _ in 0..20_000 {
                let q = d.q();
                let push: [f64; AXES] = std::array::from_fn(|i| {
                    let (lo, hi) = range(i);
                    if q[i] < lo + 0.01 {
                        0.5
                    } else if q[i] > hi - 0.01 {
                        -0.5
                    } else {
                        0.0
                    }
                });
                if push == [0.0; AXES] {
                    break;
                }
                d.env(&|p| p.disturbance = push);
                d.tick(None);
            }
            d.env(&|p| p.disturbance = [0.0; AXES]);
        }
        Step::Enable(n) => {
            d.tick(Some(Req::Enable));
            idle(d, *n);
        }
        Step::Home(n) => {
            d.tick(Some(Req::Home));
            idle(d, *n);
        }
        Step::HomeJoint(j, n) => {
            d.tick(Some(Req::HomeJoint(*j)));
            idle(d, *n);
        }
        Step::WaitHoming => {
            for _ in 0..HOMING_WAIT_MAX {
                if d.state() != State::Homing {
                    break;
                }
                d.tick(None);
            }
        }
        Step::HomeLinkLoss { axis, phase, ticks } => {
            if d.state() != State::Homing {
                d.tick(Some(Req::Home));
            }
            for _ in 0..HOMING_WAIT_MAX {
                if d.state() != State::Homing || d.phases().get(*axis) == Some(phase) {
                    break;
                }
                d.tick(None);
            }
            d.env(&|p| p.link_lost = true);
            idle(d, *ticks);
            d.env(&|p| p.link_lost = false);
        }
        Step::Chatter { axis, closed, open, ticks } => {
            let m = 1u8 << axis;
            let period = closed.saturating_add(*open).max(1);
            for t in 0..*ticks {
                let on = t % period < *closed;
                d.env(&|p| if on { p.force_switch |= m } else { p.force_switch &= !m });
                d.tick(None);
            }
            d.env(&|p| p.force_switch &= !m);
        }
        Step::PressedHome { axis, ticks } => {
            let m = 1u8 << axis;
            d.env(&|p| p.force_switch |= m);
            d.tick(Some(Req::Home));
            idle(d, *ticks);
            d.env(&|p| p.force_switch &= !m);
        }
        Step::Burst { goal, count, idle: n } => {
            let q0 = d.q();
            let goal = angles(goal);
            // Within one segment's travel per sample (`STREAM_STEP`).
            let far = (0..AXES).map(|i| (goal[i] - q0[i]).abs()).fold(0.0, f64::max);
            let count = (*count).max((far / STREAM_STEP).ceil() as u32).max(1);
            for k in 1..=count {
                let f = f64::from(k) / f64::from(count);
                let p: [f64; AXES] = std::array::from_fn(|i| q0[i] + (goal[i] - q0[i]) * f);
                d.tick(Some(Req::Motion(p, [0.0; AXES])));
            }
            idle(d, *n);
        }
    }
}
