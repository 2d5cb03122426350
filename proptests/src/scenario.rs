//! Random operating sequences ("steps"), their strategies, and the drivers
//! that play them against the kernel and the plant with the monitor checking
//! every tick.

use std::collections::VecDeque;
use std::sync::OnceLock;

use kernel::config::{AXES, PAROL6, PAROL6_VALIDATED};
use kernel::{
    Authority, Fx, HardwareFault, Kernel, MotionKind, MotionTarget, Request, Scalar, Sense, State, TickOutput,
};
use proptest::prelude::*;

use monitor::plant::{EncoderFault, Plant, Witness, DEFAULT_OFFSETS};
use monitor::{Monitor, Sent, Stats};

/// The pose the homed snapshots were homed from (also the scenario tests' start).
pub const START: [f64; AXES] = [0.3, 0.2, -0.4, 0.5, -0.3, 1.0];
/// The scenario tests' encoder offsets.
pub const OFFSETS: [f64; AXES] = DEFAULT_OFFSETS;
/// Bound on the ticks a `WaitHoming` step waits (every axis's homing timeout
/// is at most 12 s, three groups in sequence).
pub const HOMING_WAIT_MAX: u32 = 40_000;

/// A numeric variant of the kernel, with what the tests need per variant.
pub trait Variant: Scalar {
    /// `"f32"` or `"fx"`.
    const NAME: &'static str;
    /// The variant's worst value for a target field: NaN or infinity for
    /// `f32`; the largest representable value for fixed point, which has no
    /// non-finite values.
    fn non_finite(nan: bool, negative: bool) -> Self;
    /// A kernel homed from [`START`] (with its plant and monitor), made once.
    fn homed_snapshot() -> &'static Snapshot<Self>;
}

/// A kernel, plant and monitor to start a test from.
#[derive(Clone, Debug)]
pub struct Snapshot<S: Scalar> {
    kernel: Kernel<S>,
    plant: Plant,
    mon: Monitor<S>,
    ticks: u64,
}

fn make_snapshot<S: Variant>() -> Snapshot<S> {
    let mut sut = Sut::<S>::fresh(START, OFFSETS);
    sut.tick(None);
    sut.tick(Some(Req::Home));
    for _ in 0..HOMING_WAIT_MAX {
        if sut.k.state() != State::Homing {
            break;
        }
        sut.tick(None);
    }
    assert_eq!(sut.k.state(), State::Operational, "{} snapshot: homing from START failed", S::NAME);
    Snapshot { kernel: sut.k, plant: sut.plant, mon: sut.mon, ticks: sut.ticks }
}

impl Variant for f32 {
    const NAME: &'static str = "f32";
    fn non_finite(nan: bool, negative: bool) -> Self {
        match (nan, negative) {
            (true, _) => f32::NAN,
            (false, false) => f32::INFINITY,
            (false, true) => f32::NEG_INFINITY,
        }
    }
    fn homed_snapshot() -> &'static Snapshot<Self> {
        static S: OnceLock<Snapshot<f32>> = OnceLock::new();
        S.get_or_init(make_snapshot::<f32>)
    }
}

impl Variant for Fx {
    const NAME: &'static str = "fx";
    fn non_finite(_nan: bool, negative: bool) -> Self {
        if negative {
            Fx::MIN
        } else {
            Fx::MAX
        }
    }
    fn homed_snapshot() -> &'static Snapshot<Self> {
        static S: OnceLock<Snapshot<Fx>> = OnceLock::new();
        S.get_or_init(make_snapshot::<Fx>)
    }
}

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
}

/// Something the steps can drive: one kernel, or two in lockstep.
pub trait Driver {
    /// The (reference) plant's joint angles.
    fn q(&self) -> [f64; AXES];
    /// Changes the environment of every plant.
    fn env(&mut self, f: &dyn Fn(&mut Plant));
    /// One tick.
    fn tick(&mut self, req: Option<Req>);
    /// The (reference) kernel's state.
    fn state(&self) -> State;
}

fn range(i: usize) -> (f64, f64) {
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
    }
}

/// What the strategies may generate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mix {
    /// Everything, including inputs at the edge of the fault thresholds.
    Full,
    /// For the f32 / fixed-point differential: only inputs whose outcome
    /// cannot depend on rounding (no outside forces, no glitches near the
    /// plausibility window).
    Discrete,
}

fn axis() -> impl Strategy<Value = usize> {
    0..AXES
}

fn fractions() -> impl Strategy<Value = [f64; AXES]> {
    // Mostly inside, sometimes exactly at a limit.
    let one = prop_oneof![8 => 0.0..=1.0f64, 1 => Just(0.0), 1 => Just(1.0)];
    [one.clone(), one.clone(), one.clone(), one.clone(), one.clone(), one]
}

fn velocities() -> impl Strategy<Value = [f64; AXES]> {
    let one = prop_oneof![4 => Just(0.0), 4 => -1.0..=1.0f64, 1 => Just(1.0), 1 => Just(-1.0)];
    [one.clone(), one.clone(), one.clone(), one.clone(), one.clone(), one]
}

fn bad() -> impl Strategy<Value = Bad> {
    prop_oneof![
        (0.001..5.0f64, any::<bool>()).prop_map(|(e, neg)| Bad::OutOfLimits(if neg { -e } else { e })),
        Just(Bad::NanPosition),
        any::<bool>().prop_map(Bad::InfPosition),
        Just(Bad::NanVelocity),
        (0.001..3.0f64).prop_map(Bad::VelocityTooHigh),
    ]
}

fn hardware() -> impl Strategy<Value = HardwareFault> {
    prop_oneof![
        Just(HardwareFault::TickOverrun),
        (0u8..6).prop_map(|axis| HardwareFault::Driver { axis }),
        any::<u8>().prop_map(HardwareFault::SelfTest),
    ]
}

fn encoder_fault() -> impl Strategy<Value = EncoderFault> {
    prop_oneof![3 => Just(EncoderFault::Lost), 1 => (4096u16..=u16::MAX).prop_map(EncoderFault::OutOfRange)]
}

/// The random steps.
pub fn step_strategy(mix: Mix) -> BoxedStrategy<Step> {
    let common = prop_oneof![
        40 => (fractions(), velocities(), 8u32..=40, 1u32..=40)
            .prop_map(|(goal, vel, period, count)| Step::Stream { goal, vel, period, count }),
        4 => (axis(), bad(), 0u32..=20).prop_map(|(axis, bad, idle)| Step::BadMotion { axis, bad, idle }),
        8 => prop_oneof![1..=60u32, 90u32..=110, 150u32..=400].prop_map(Step::Silence),
        8 => (fractions(), prop_oneof![0u32..=50, 300u32..=2500])
            .prop_map(|(goal, wait)| Step::GoTo { goal, wait }),
        3 => prop_oneof![1u32..=20, 100u32..=400].prop_map(Step::LinkLoss),
        2 => (axis(), encoder_fault(), 1u32..=6).prop_map(|(axis, fault, ticks)| Step::EncoderLoss { axis, fault, ticks }),
        2 => (any::<u8>(), 1u32..=30).prop_map(|(m, ticks)| Step::LimitHit { mask: m & 0b11_1111, ticks }),
        1 => (hardware(), 1u32..=3).prop_map(|(fault, ticks)| Step::Hardware { fault, ticks }),
        10 => (0u32..=50).prop_map(Step::Enable),
        2 => prop_oneof![0u32..=200, 1000u32..=3000].prop_map(Step::Home),
        2 => (0u8..8, 0u32..=200).prop_map(|(j, n)| Step::HomeJoint(j, n)),
        3 => Just(Step::WaitHoming),
        2 => Just(Step::ReturnInside),
    ];
    match mix {
        Mix::Discrete => common.boxed(),
        Mix::Full => prop_oneof![
            76 => common,
            2 => (axis(), -2048i32..=2047, 1u32..=6).prop_map(|(axis, delta, ticks)| Step::Glitch { axis, delta, ticks }),
            1 => (axis(), -2048i32..=2047).prop_map(|(axis, counts)| Step::Slip { axis, counts }),
            3 => (axis(), prop_oneof![-12.0..12.0f64, -1.0..1.0f64], 1u32..=400)
                .prop_map(|(axis, velocity, ticks)| Step::Disturb { axis, velocity, ticks }),
            3 => (axis(), any::<bool>(), prop_oneof![1u32..=30, 100u32..=1500])
                .prop_map(|(axis, reversed, ticks)| Step::BrokenMotor { axis, reversed, ticks }),
            1 => axis().prop_map(|axis| Step::DeadSwitchHome { axis }),
        ]
        .boxed(),
    }
}

/// Initial states: mostly the homed snapshot, sometimes a power-on anywhere
/// in the joint ranges with random encoder offsets.
pub fn start_strategy() -> BoxedStrategy<Start> {
    let r = |i: usize| {
        let (lo, hi) = range(i);
        lo..hi
    };
    let q = [r(0), r(1), r(2), r(3), r(4), r(5)];
    let off = [
        0.0..std::f64::consts::TAU,
        0.0..std::f64::consts::TAU,
        0.0..std::f64::consts::TAU,
        0.0..std::f64::consts::TAU,
        0.0..std::f64::consts::TAU,
        0.0..std::f64::consts::TAU,
    ];
    prop_oneof![
        2 => Just(Start::Homed),
        1 => (q, off, proptest::option::weighted(0.5, (0..AXES, 1u64..=120)))
            .prop_map(|(q, offset, boot_lost)| Start::Fresh { q, offset, boot_lost }),
    ]
    .boxed()
}

/// One kernel against its plant, every tick checked by the monitor.
#[derive(Debug)]
pub struct Sut<S: Variant> {
    /// The kernel under test.
    pub k: Kernel<S>,
    auth: Authority,
    /// Its plant.
    pub plant: Plant,
    /// The monitor.
    pub mon: Monitor<S>,
    /// Ticks run.
    pub ticks: u64,
    /// What was injected into the plant and when (the monitor's plant facts).
    wit: Witness,
    boot_lost_until: Option<(usize, u64)>,
    recent: VecDeque<(u64, Sense, Option<Req>, TickOutput<S>)>,
    /// The last tick's output.
    pub last: Option<TickOutput<S>>,
    /// Its outputs do not move the arm (the fixed-point kernel of a
    /// [`Pair`]): the monitor's clean-plant checks (SR-19's overrun, SR-28's
    /// following error) do not apply to it.
    pub follower: bool,
}

impl<S: Variant> Sut<S> {
    /// A kernel and its plant, monitor and tick count; no history yet.
    fn from_parts(k: Kernel<S>, auth: Authority, plant: Plant, mon: Monitor<S>, ticks: u64) -> Self {
        Sut {
            k,
            auth,
            plant,
            mon,
            ticks,
            wit: Witness::new(),
            boot_lost_until: None,
            recent: VecDeque::new(),
            last: None,
            follower: false,
        }
    }

    /// Power-on at `q`.
    pub fn fresh(q: [f64; AXES], offset: [f64; AXES]) -> Self {
        let (k, auth) = Kernel::new(&PAROL6_VALIDATED);
        Self::from_parts(k, auth, Plant::new(q, offset), Monitor::new(&PAROL6), 0)
    }

    /// From a start description.
    pub fn new(start: &Start) -> Self {
        match start {
            Start::Fresh { q, offset, boot_lost } => {
                let mut s = Self::fresh(*q, *offset);
                if let Some((axis, ticks)) = *boot_lost {
                    s.plant.encoder[axis] = EncoderFault::Lost;
                    s.boot_lost_until = Some((axis, ticks));
                }
                s
            }
            Start::Homed => {
                let s = S::homed_snapshot().clone();
                // A capability works only on the kernel that minted it: the
                // snapshot's authority was not kept, so fork it (same state,
                // fresh identity, its own authority).
                let (kernel, auth) = s.kernel.fork();
                Self::from_parts(kernel, auth, s.plant, s.mon, s.ticks)
            }
        }
    }

    fn request(&self, r: &Req) -> Request<S> {
        let conv = |a: [f64; AXES]| a.map(|x| S::from_f32(x as f32));
        match *r {
            Req::Motion(p, v) => {
                let t = MotionTarget { position: conv(p), velocity: conv(v), kind: MotionKind::Stream };
                Request::Motion(t)
            }
            Req::GoTo(p) => {
                Request::Motion(MotionTarget { position: conv(p), velocity: [S::ZERO; AXES], kind: MotionKind::GoTo })
            }
            Req::BadMotion { base, axis, bad } => {
                let mut t = MotionTarget { position: conv(base), velocity: [S::ZERO; AXES], kind: MotionKind::Stream };
                let j = &PAROL6.joints[axis];
                match bad {
                    Bad::OutOfLimits(e) => {
                        let x = if e < 0.0 { f64::from(j.limit_min) + e } else { f64::from(j.limit_max) + e };
                        t.position[axis] = S::from_f32(x as f32);
                    }
                    Bad::NanPosition => t.position[axis] = S::non_finite(true, false),
                    Bad::InfPosition(neg) => t.position[axis] = S::non_finite(false, neg),
                    Bad::NanVelocity => t.velocity[axis] = S::non_finite(true, false),
                    Bad::VelocityTooHigh(f) => t.velocity[axis] = S::from_f32(j.max_velocity * (1.0 + f as f32)),
                }
                Request::Motion(t)
            }
            Req::Home => Request::Home,
            Req::HomeJoint(j) => Request::HomeJoint(j),
            Req::Enable => Request::Enable(self.auth.enable()),
        }
    }

    /// One tick: sense, kernel, monitor (panics on a violation), plant.
    pub fn tick(&mut self, req: Option<Req>) -> TickOutput<S> {
        self.ticks += 1;
        if let Some((axis, until)) = self.boot_lost_until {
            if self.ticks > until {
                self.plant.encoder[axis] = EncoderFault::None;
                self.boot_lost_until = None;
            }
        }
        let sense = self.plant.sense();
        let request = req.as_ref().map(|r| self.request(r));
        let sent = request.as_ref().map(Sent::of);
        self.wit.before(&self.plant);
        let out = self.k.tick(&sense, request);
        let mut facts = self.wit.after(&self.plant, &out);
        // A kernel whose outputs do not move the arm (the follower of a
        // differential pair) sees an arm driven by someone else.
        facts.disturbed |= self.follower;
        if self.recent.len() == 6 {
            self.recent.pop_front();
        }
        self.recent.push_back((self.ticks, sense, req, out));
        let checked = self.mon.check(&sense, sent.as_ref(), &out, Some(&self.k.homing_phases()), Some(&facts));
        let checked = checked.map_err(|e| e.to_string()).and_then(|()| match self.k.invariant() {
            true => Ok(()),
            false => Err(format!("the kernel's state invariant (Kernel::invariant) broken: {:?}", self.k)),
        });
        if let Err(e) = checked {
            let mut msg = format!("[{}] tick {}: {e}\n  recent ticks:\n", S::NAME, self.ticks);
            for (t, s, r, o) in &self.recent {
                msg += &format!("   #{t} sense {s:?}\n      req {r:?}\n      out {o:?}\n");
            }
            panic!("{msg}");
        }
        self.plant.apply(&out.act.step_rate);
        self.last = Some(out);
        out
    }
}

impl<S: Variant> Driver for Sut<S> {
    fn q(&self) -> [f64; AXES] {
        self.plant.q
    }
    fn env(&mut self, f: &dyn Fn(&mut Plant)) {
        // Injections, slips (encoder offset changes) included, are seen by
        // the witness at the next tick.
        f(&mut self.plant);
    }
    fn tick(&mut self, req: Option<Req>) {
        Sut::tick(self, req);
    }
    fn state(&self) -> State {
        self.k.state()
    }
}

/// The f32 and fixed-point kernels driven in lockstep with the same requests
/// on the same plant: every tick both sense the same arm; the f32 kernel's
/// outputs move it (the fixed-point kernel's are compared, then dropped).
#[derive(Debug)]
pub struct Pair {
    /// The f32 kernel.
    pub a: Sut<f32>,
    /// The fixed-point kernel.
    pub b: Sut<Fx>,
    /// Largest output difference seen (rad/s).
    pub worst_v: f64,
    /// Largest difference of the set-points (rad).
    pub worst_q: f64,
    /// Largest difference of the position estimates (rad).
    pub worst_est: f64,
    /// Output bound asserted (rad/s).
    pub bound_v: f64,
    /// Position bound asserted (rad).
    pub bound_q: f64,
    /// Consecutive ticks (so far) the two kernels' homing phases differ.
    pub skew: u32,
    /// Longest such run.
    pub worst_skew: u32,
    /// Ticks whose homing phases differed (outputs not compared).
    pub skew_ticks: u64,
    /// The set-point profiles of the two kernels took a discrete decision
    /// (accelerate, cruise, brake, land) a tick apart (see
    /// [`PROFILE_SPLIT`]): outputs and set-points are not compared until
    /// they realign ([`RESYNC_TICKS`]) or both kernels resynchronise their
    /// set-points (entering Homing or Fault, or an enable).
    pub split: bool,
    /// How many times that happened.
    pub splits: u32,
    /// Ticks not compared because of a split.
    pub split_ticks: u64,
    /// Consecutive realigned ticks during a split.
    calm: u32,
    /// The tick at which the states differed during a split (a hold versus
    /// latch decided a tick apart, say): the case's comparison ended there.
    /// States differing outside a split fail the test.
    pub diverged: Option<u64>,
    /// The case ended because the fixed-point kernel, which does not drive
    /// the arm, faulted FOLLOWING_ERROR after a split (its path and the arm
    /// drifted apart).
    pub follower_fe: bool,
    /// Ticks whose outputs and set-points were compared.
    pub compared_ticks: u64,
    /// Largest set-point velocity difference seen while compared (rad/s).
    pub worst_sp_vel: f64,
    prev_sp: Option<([f64; AXES], [f64; AXES])>,
    prev_state: State,
}

/// Set-point velocities (from consecutive set-points) of the two variants
/// that differ by more than this fraction of a joint's `dv` (its
/// acceleration per tick) mean the profile took a discrete decision a tick
/// apart (its braking test or landing test fell on the other side of its
/// rounding allowance): one variant's set-point then runs a whole `dv`
/// ahead, and its output with it (by up to `dv` plus the control
/// correction). The monitors still judge every tick of both.
pub const PROFILE_SPLIT: f64 = 0.25;

/// Consecutive ticks with set-points within `BOUND_Q / 10` and set-point
/// velocities within [`PROFILE_SPLIT`] `dv` after which a split ends and
/// the comparison resumes (the acceleration-limited outputs need a few
/// tens of ticks to realign).
pub const RESYNC_TICKS: u32 = 100;

/// Longest run of ticks the homing phases may differ. A phase that ends
/// when the estimate crosses a distance (the back-off) can end a tick apart
/// in the two variants when the crossing falls within their rounding
/// difference (about 5e-6 rad): the later one realigns at the next sensor
/// edge or phase. Everything else must agree at every tick.
pub const MAX_SKEW: u32 = 3;

impl Pair {
    /// Both from `start`.
    pub fn new(start: &Start, bound_v: f64, bound_q: f64) -> Self {
        let mut b = Sut::new(start);
        b.follower = true;
        Pair {
            a: Sut::new(start),
            b,
            worst_v: 0.0,
            worst_q: 0.0,
            worst_est: 0.0,
            bound_v,
            bound_q,
            skew: 0,
            worst_skew: 0,
            skew_ticks: 0,
            split: false,
            splits: 0,
            split_ticks: 0,
            calm: 0,
            diverged: None,
            follower_fe: false,
            compared_ticks: 0,
            worst_sp_vel: 0.0,
            prev_sp: None,
            prev_state: State::Boot,
        }
    }
}

impl Driver for Pair {
    fn q(&self) -> [f64; AXES] {
        self.a.plant.q
    }
    fn env(&mut self, f: &dyn Fn(&mut Plant)) {
        Driver::env(&mut self.a, f);
        Driver::env(&mut self.b, f);
    }
    fn tick(&mut self, req: Option<Req>) {
        // One plant: the fixed-point kernel senses exactly what the f32
        // kernel senses (the f32 kernel's outputs drive the arm).
        self.b.plant = self.a.plant.clone();
        let oa = self.a.tick(req);
        let ob = self.b.tick(req);
        let t = self.a.ticks;
        if self.diverged.is_some() {
            return;
        }
        // A discrete profile decision a tick apart: a split (see `split`).
        let both_op = oa.status.state == State::Operational && ob.status.state == State::Operational;
        let sp_a = oa.status.setpoint.map(f64::from);
        let sp_b = ob.status.setpoint.map(|x| f64::from(x.to_f32()));
        let mut apart = false;
        let mut calm = both_op;
        if let (true, Some((pa, pb))) = (both_op, self.prev_sp) {
            let hz = f64::from(PAROL6.tick_hz);
            for i in 0..AXES {
                let (va, vb) = ((sp_a[i] - pa[i]) * hz, (sp_b[i] - pb[i]) * hz);
                let dv = f64::from(PAROL6.joints[i].max_acceleration) / hz;
                if (va - vb).abs() > PROFILE_SPLIT * dv {
                    apart = true;
                } else if !self.split {
                    self.worst_sp_vel = self.worst_sp_vel.max((va - vb).abs());
                }
                calm &= (sp_a[i] - sp_b[i]).abs() <= self.bound_q / 10.0;
            }
        }
        self.prev_sp = if both_op { Some((sp_a, sp_b)) } else { None };
        if apart {
            if !self.split {
                self.splits += 1;
            }
            self.split = true;
            self.calm = 0;
        } else if self.split {
            let same = oa.status.state == ob.status.state;
            // Entering Homing or Fault, or leaving a latch (enable),
            // resynchronises the set-points to the estimates and restarts
            // the outputs from zero in both kernels. (SoftEstop zeroes the
            // outputs but keeps the set-points where they stopped.)
            let reset = same
                && oa.status.state != self.prev_state
                && (matches!(oa.status.state, State::Homing | State::Fault)
                    || matches!(self.prev_state, State::SoftEstop | State::Fault));
            self.calm = if calm { self.calm + 1 } else { 0 };
            if reset || self.calm >= RESYNC_TICKS {
                self.split = false;
            }
        }
        self.prev_state = oa.status.state;
        if self.split {
            self.split_ticks += 1;
            if oa.status.state != ob.status.state {
                let fe = |o: &Option<kernel::Fault>| matches!(o, Some(f) if matches!(f.reason, kernel::FaultReason::FollowingError { .. }));
                self.follower_fe = fe(&ob.status.fault) && !fe(&oa.status.fault);
                self.diverged = Some(t);
            }
            return;
        }
        self.compared_ticks += 1;
        // The fixed-point kernel does not drive the arm: after a split its
        // path and the arm (driven by the f32 kernel) can drift apart by
        // more than the following-error bound. That ends the case too.
        let fe = |o: &Option<kernel::Fault>| matches!(o, Some(f) if matches!(f.reason, kernel::FaultReason::FollowingError { .. }));
        if self.splits > 0 && oa.status.state != ob.status.state && fe(&ob.status.fault) && !fe(&oa.status.fault) {
            self.diverged = Some(t);
            self.follower_fe = true;
            return;
        }
        assert_eq!(
            oa.status.state, ob.status.state,
            "differential: states differ at tick {t}: f32 {:?} fx {:?}\n f32 events {:?}\n fx events {:?}",
            oa, ob, oa.events, ob.events
        );
        assert_eq!(oa.status.homed, ob.status.homed, "differential: homed differs at tick {t}");
        let kind = |o: &Option<kernel::Fault>| o.map(|f| monitor::fault_kind(&f.reason));
        assert_eq!(kind(&oa.status.fault), kind(&ob.status.fault), "differential: fault kinds differ at tick {t}");
        let differ = self.a.k.homing_phases() != self.b.k.homing_phases();
        // The tick after realigning too: the later kernel's first tick in
        // the new phase.
        let skewed = differ || self.skew > 0;
        if differ {
            self.skew += 1;
            self.skew_ticks += 1;
            self.worst_skew = self.worst_skew.max(self.skew);
            assert!(
                self.skew <= MAX_SKEW,
                "differential: homing phases differ for {} ticks at tick {t}: f32 {:?} fx {:?}",
                self.skew,
                self.a.k.homing_phases(),
                self.b.k.homing_phases()
            );
        } else {
            self.skew = 0;
        }
        for i in 0..AXES {
            let dv = f64::from((oa.act.velocity[i] - ob.act.velocity[i].to_f32()).abs());
            let dq = f64::from((oa.status.setpoint[i] - ob.status.setpoint[i].to_f32()).abs());
            let de = f64::from((oa.status.position[i] - ob.status.position[i].to_f32()).abs());
            if !skewed {
                self.worst_v = self.worst_v.max(dv);
            }
            self.worst_q = self.worst_q.max(dq);
            self.worst_est = self.worst_est.max(de);
            assert!(
                skewed || dv <= self.bound_v,
                "differential: axis {i} outputs differ by {dv} rad/s at tick {t}\n f32 {oa:?}\n fx {ob:?}\n phases f32 {:?} fx {:?}",
                self.a.k.homing_phases(),
                self.b.k.homing_phases()
            );
            assert!(dq <= self.bound_q, "differential: axis {i} set-points differ by {dq} rad at tick {t}");
            assert!(de <= self.bound_q, "differential: axis {i} estimates differ by {de} rad at tick {t}");
        }
    }
    fn state(&self) -> State {
        self.a.k.state()
    }
}

/// Adds a finished run's coverage to a shared total.
pub fn record(total: &std::sync::Mutex<Stats>, s: &Stats) {
    if let Ok(mut t) = total.lock() {
        t.merge(s);
    }
}
