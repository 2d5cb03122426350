//! Model check of the supervisor and homing state machine, with stateright,
//! over the real `kernel::Kernel` (`cargo run -p model --release`).
//!
//! ```text
//! model [--variant fx|f32] [--config full|small|tiny] [--expect-violation NAME] [--timeout S] [--bounded S]
//! ```
//!
//! With no arguments: the full configuration over `Kernel<Fx>` (bounded by
//! `--bounded S`, which applies to the full configuration only), the small
//! configuration over `Kernel<Fx>` (to completion: every reachable state),
//! then the tiny configuration over `Kernel<f32>` (to completion) (its states are identified by
//! formatting them, about 25 times slower per state than the fixed-point
//! hash; the small configuration takes over 10 minutes in f32). `--expect-violation NAME` is for
//! the mutation tests (`mutants.sh`): it succeeds only if a property whose
//! name contains NAME is violated.
//!
//! Abstraction (stated so a reviewer can judge it):
//! - The arm is stationary: every encoder reads a constant count, so the
//!   observer's numeric state is constant and each reachable kernel state is
//!   one of finitely many. What the model varies, independently at every
//!   tick, is everything discrete: which of the seeking homing axes reach
//!   their switches (each axis independently, so every order of arrivals
//!   within a group is explored; a switch releases as soon as its axis
//!   backs off); one sensor perturbation (none,
//!   J1 encoder lost, J1 encoder glitch, a hardware fault, a stray pressed
//!   switch on J1 or J6); and one request (none, home, per-joint home of J1
//!   / J6 / a bad index, enable, two valid motion targets, an out-of-limits
//!   target). A cause that persists is the same choice on consecutive
//!   ticks. The plant keeps only what the SR-7 and SR-11 properties need
//!   (the ramp's start, the J1 run of invalid samples).
//! - Configuration (`MODEL_CONFIG`): `PAROL6` with the timers shortened
//!   within `kernel::config::check` (command timeout 3 ms, segments 1 ms,
//!   boot timeout 2 ms: the kernel keeps its boot tick count in its state
//!   after boot, so each boot length multiplied the state space) and three
//!   documented relaxations, tested by
//!   `tests::model_config_relaxes_exactly_the_named_rules`: zero homing
//!   back-off (a stationary arm never travels one), 8 ms homing timeouts
//!   and a 4 ms soft-stop ramp (faster than `max_acceleration`, PAROL6's).
//!   The kernel's continuous state (set-point velocities,
//!   following-error paths, homing ramps) keeps the model from finishing:
//!   the test command runs it bounded (`--bounded`, sampled evidence).
//! - The full configuration, to fit its time budget, explores during homing
//!   (where every request is refused) only no request and one motion
//!   request, and only four perturbations (none, J1 lost, hardware fault,
//!   J6 stray switch; not the J1 glitch and J1 stray switch).
//! - Reduced configuration (`--config small`, used for the f32 variant and
//!   the mutation tests): requests none / home / enable / near target only,
//!   the switches of the seeking axes arriving all together or not at all,
//!   every perturbation in every state. The two configurations together
//!   cover every arrival order and every perturbation during homing, not
//!   every combination of the two.
//! - Tiny configuration (`--config tiny`, the f32 variant): the small one
//!   with four perturbations (none, J1 lost, hardware fault, J6 stray
//!   switch; not the J1 glitch and the J1 stray switch).
//! - States are identified by `Kernel`'s behavioural hash (everything but the
//!   tick counter and the fault timestamp, which no decision reads) plus the
//!   plant. `Kernel<f32>` has no `Hash` (f32 has none): its states are
//!   identified by its `Debug` text without those two fields (Rust prints
//!   every non-NaN f32 in a form that round-trips, so distinct values give
//!   distinct text; a stationary arm never makes a NaN, and if it did the
//!   "no NaN" property would fail).
//!
//! Every reachable state is explored (breadth first) and every property is
//! checked on every transition or state; the run fails if a property is
//! violated or a `sometimes` property is never reached.

use kernel::config::{ArmConfig, AXES};
use kernel::homing::Phase;
use kernel::{
    Authority, EncoderSample, Event, FaultReason, Fx, HardwareFault, HomingStatus, Kernel, MotionTarget, Request,
    RequestKind, Scalar, Sense, State,
};
use proofs::setup::{new_kernel, COUNTS, PROOF_CONFIG, SEED_DEPENDENCIES};
use stateright::{Checker, DiscoveryClassification, HasDiscoveries, Model, Property};
use std::fmt::Debug;
use std::hash::{DefaultHasher, Hash, Hasher};

const MODEL_CONFIG: ArmConfig = {
    let mut c = PROOF_CONFIG;
    let mut i = 0;
    while i < AXES {
        c.joints[i].homing.timeout_ms = 8;
        // (max_acceleration stays PAROL6's: with the 100 ms ramp restored,
        // `check` bounds it by the ramp and the stopping overrun.)
        i += 1;
    }
    c.segment_min_ms = 1;
    c.segment_max_ms = 1;
    // The rule's minimum (two ticks). The kernel's state keeps its boot tick
    // count after boot (`Hash for Kernel` includes it), so every boot length
    // multiplies the whole state space (measured on the small configuration:
    // 487,087 states with 2 ms; with 50 ms, over 6.5 million and unfinished
    // after 250 s).
    c.boot_timeout_ms = 2;
    c
};

/// What `MODEL_CONFIG` relaxes of `kernel::config::check` (the rule each
/// breaks); the same three as `proofs::setup::PROOF_RELAXATIONS`.
const MODEL_RELAXATIONS: [(&str, &str); 3] = [
    ("joints[*].homing.backoff = 0", "homing back-off must be in (0, 0.5) rad"),
    (
        "joints[*].homing.timeout_ms = 8",
        "homing timeout shorter than 1.2x the nominal homing time: homing is impossible",
    ),
    ("soft_stop_ms = 4", "soft-stop ramp decelerates faster than max_acceleration"),
];

/// The J1 encoder as seen by the plant: the count it was (re)initialised
/// from (every other count differs by more than the plausibility window),
/// and the current run of invalid samples (frozen one above the limit: the
/// count is lost until an enable re-initialises J1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
struct J1 {
    seen: bool,
    reference: u16,
    run: u8,
}

/// The number types the model runs on: how a kernel state is identified.
trait ModelScalar: Scalar + Debug + Send + Sync + 'static {
    const NAME: &'static str;
    fn hash_kernel<H: Hasher>(k: &Kernel<Self>, h: &mut H);
}

impl ModelScalar for Fx {
    const NAME: &'static str = "Kernel<Fx>";
    fn hash_kernel<H: Hasher>(k: &Kernel<Self>, h: &mut H) {
        k.hash(h);
    }
}

impl ModelScalar for f32 {
    const NAME: &'static str = "Kernel<f32>";
    fn hash_kernel<H: Hasher>(k: &Kernel<Self>, h: &mut H) {
        // The Debug text from the per-axis state on, minus `tick: N` (the
        // tick counter and the fault timestamp; `boot_ticks`/`ticks` are
        // other fields and are kept).
        let text = format!("{k:?}");
        // The identity and the parameters (constants, most of the text)
        // come before the per-axis state `axes: [Axis {`.
        let mut rest = text.find("axes: [Axis {").map_or(text.as_str(), |i| &text[i..]);
        while let Some(i) = rest.find("tick: ") {
            let before = &rest[..i];
            let whole_word = !before.ends_with(|c: char| c.is_alphanumeric() || c == '_');
            before.hash(h);
            rest = &rest[i + "tick: ".len()..];
            if whole_word {
                rest = rest.trim_start_matches(|c: char| c.is_ascii_digit());
            } else {
                "tick: ".hash(h);
            }
        }
        rest.hash(h);
    }
}

#[derive(Clone, Debug)]
struct St<S: Scalar> {
    k: Kernel<S>,
    /// The first transition property violated, if any (checked on every
    /// transition, so it needs no history in the state).
    violation: Option<&'static str>,
    /// An enable has been accepted at some point (for reachability only).
    ever_enabled: bool,
    j1: J1,
    /// The soft-stop ramp: its tick (1 on the timeout tick) and the outputs
    /// it started from.
    ramp: Option<(u32, [S; AXES])>,
}

impl<S: ModelScalar> St<S> {
    fn fingerprint(&self) -> u64 {
        let mut h = DefaultHasher::new();
        self.hash(&mut h);
        h.finish()
    }
}

impl<S: ModelScalar> Hash for St<S> {
    fn hash<H: Hasher>(&self, h: &mut H) {
        S::hash_kernel(&self.k, h);
        (self.violation, self.ever_enabled, self.j1).hash(h);
        // The ramp's start equals the kernel's Stopping v0 (hashed above);
        // its tick is the kernel's k + 1.
        self.ramp.map(|(k, _)| k).hash(h);
    }
}

impl<S: ModelScalar> PartialEq for St<S> {
    fn eq(&self, other: &Self) -> bool {
        self.fingerprint() == other.fingerprint()
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Req {
    Home,
    HomeJoint(u8),
    Enable,
    MotionNear,
    MotionHere,
    MotionOutOfLimits,
}

/// A one-tick disturbance of the stationary arm's sensors.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Perturb {
    None,
    LostJ1,
    GlitchJ1,
    Hardware,
    StraySwitch(u8),
}

const PERTURBATIONS: [Perturb; 6] = [
    Perturb::None,
    Perturb::LostJ1,
    Perturb::GlitchJ1,
    Perturb::Hardware,
    Perturb::StraySwitch(0),
    Perturb::StraySwitch(5),
];

const REQUESTS_FULL: [Option<Req>; 9] = [
    None,
    Some(Req::Home),
    Some(Req::HomeJoint(0)),
    Some(Req::HomeJoint(5)),
    Some(Req::HomeJoint(9)),
    Some(Req::Enable),
    Some(Req::MotionNear),
    Some(Req::MotionHere),
    Some(Req::MotionOutOfLimits),
];
const REQUESTS_SMALL: [Option<Req>; 4] = [None, Some(Req::Home), Some(Req::Enable), Some(Req::MotionNear)];
/// In Homing every request is refused (no state change, a `Rejected`
/// event): the full configuration keeps one motion request to check that.
const REQUESTS_HOMING: [Option<Req>; 2] = [None, Some(Req::MotionNear)];
/// Perturbations the full configuration explores during homing (with every
/// arrival order); the small one explores all six there (with all-or-nothing
/// arrivals). Without this the full run outgrew its time budget.
const PERTURBATIONS_HOMING: [Perturb; 4] = [Perturb::None, Perturb::LostJ1, Perturb::Hardware, Perturb::StraySwitch(5)];

/// One tick: a request, a sensor perturbation, and which switches of the
/// moving homing axes are pressed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
struct Action {
    req: Option<Req>,
    perturb: Perturb,
    pressed: u8,
}

struct Supervisor<S: Scalar> {
    /// The initial kernel; every state holds a clone of it (same identity),
    /// so `authority`, returned with it by `Kernel::new`, is accepted.
    init: Kernel<S>,
    authority: Authority,
    here: [S; AXES],
    small: bool,
    /// The tiny configuration (f32): small, and only four perturbations.
    tiny: bool,
}

const GLITCH: u16 = COUNTS[0] + 1500;

/// The joint angle of count `c` on axis `i` before homing (zero offset 0).
fn angle<S: Scalar>(i: usize, c: u16) -> S {
    let j = &MODEL_CONFIG.joints[i];
    let sign = if j.encoder_reversed { -1 } else { 1 };
    S::from_counts(i32::from(c) * sign, S::wide_from_f64(j.rad_per_count()))
}

impl<S: ModelScalar> Supervisor<S> {
    fn sense(&self, p: Perturb, pressed: u8) -> Sense {
        let mut enc = COUNTS.map(EncoderSample::Count);
        let mut limits = pressed;
        let mut hardware_fault = None;
        match p {
            Perturb::None => {}
            Perturb::LostJ1 => enc[0] = EncoderSample::Lost,
            Perturb::GlitchJ1 => enc[0] = EncoderSample::Count(GLITCH),
            Perturb::Hardware => hardware_fault = Some(HardwareFault::TickOverrun),
            Perturb::StraySwitch(i) => limits |= 1 << i,
        }
        Sense { encoders: enc, limits, hardware_fault, link_lost: false }
    }

    fn request(&self, r: Req) -> Request<S> {
        let t =
            |p: [S; AXES]| MotionTarget { position: p, velocity: [S::ZERO; AXES], kind: kernel::MotionKind::Stream };
        match r {
            Req::Home => Request::Home,
            Req::HomeJoint(j) => Request::HomeJoint(j),
            Req::Enable => Request::Enable(self.authority.enable()),
            Req::MotionHere => Request::Motion(t(self.here)),
            Req::MotionNear => Request::Motion(t(self.here.map(|x| x.minus(S::from_f32(0.002))))),
            Req::MotionOutOfLimits => Request::Motion(t([S::from_f32(100.0); AXES])),
        }
    }
}

/// A value as f64 (to 1e-9: every I8F24 and every f32 the model meets).
fn f64v<S: Scalar>(x: S) -> f64 {
    x.to_scaled_int(1_000_000_000) as f64 / 1e9
}

/// Two moving axes of one homing group are in different phases (their
/// switches arrived in different ticks).
fn out_of_step(phases: &[Phase; AXES]) -> bool {
    kernel::config::HOMING_GROUPS.iter().any(|g| {
        let mut ph = (0..AXES).filter(|i| g & (1 << i) != 0 && phases[*i].is_moving()).map(|i| phases[i]);
        ph.next().is_some_and(|first| ph.any(|p| p != first))
    })
}

fn zero<S: Scalar>(o: &[S; AXES]) -> bool {
    o.iter().all(|v| *v == S::ZERO)
}

impl<S: ModelScalar> Model for Supervisor<S> {
    type State = St<S>;
    type Action = Action;

    fn init_states(&self) -> Vec<St<S>> {
        vec![St {
            k: self.init.clone(),
            violation: None,
            ever_enabled: false,
            j1: J1 { seen: false, reference: 0, run: 0 },
            ramp: None,
        }]
    }

    fn actions(&self, s: &St<S>, actions: &mut Vec<Action>) {
        if s.violation.is_some() {
            return;
        }
        // Switch arrivals of the seeking homing axes: every subset (full:
        // each axis independently, so every arrival order), or all-or-nothing
        // (small). A switch is released as soon as its axis backs off.
        let mut moving = 0u8;
        if s.k.state() == State::Homing {
            for (i, p) in s.k.homing_phases().iter().enumerate() {
                if matches!(p, Phase::FastSeek | Phase::SlowSeek) {
                    moving |= 1 << i;
                }
            }
        }
        let mut masks: Vec<u8> = Vec::new();
        if self.small {
            masks.push(0);
            if moving != 0 {
                masks.push(moving);
            }
        } else {
            // Every subset of `moving`.
            let mut m = moving;
            loop {
                masks.push(m);
                if m == 0 {
                    break;
                }
                m = (m - 1) & moving;
            }
        }
        let reqs: &[Option<Req>] = if self.small {
            &REQUESTS_SMALL
        } else if s.k.state() == State::Homing {
            &REQUESTS_HOMING
        } else {
            &REQUESTS_FULL
        };
        let perturbations: &[Perturb] = if self.tiny || (!self.small && s.k.state() == State::Homing) {
            &PERTURBATIONS_HOMING
        } else {
            &PERTURBATIONS
        };
        for &pressed in &masks {
            for &perturb in perturbations {
                for &req in reqs {
                    actions.push(Action { req, perturb, pressed });
                }
            }
        }
    }

    fn next_state(&self, s: &St<S>, a: Action) -> Option<St<S>> {
        let mut n = s.clone();
        let Action { req, perturb, pressed } = a;
        let before = s.k.state();
        let sense = self.sense(perturb, pressed);
        let cause =
            sense.limits & 0x3f != 0 || sense.hardware_fault.is_some() || sense.encoders.contains(&EncoderSample::Lost);
        let o = n.k.tick(&sense, req.map(|r| self.request(r)));
        let out = o.act.velocity;
        let st = o.status.state;
        let has = |f: &dyn Fn(&Event) -> bool| o.events.iter().any(f);
        let mut violations: Vec<&'static str> = Vec::new();
        let mut v = |c: bool, what: &'static str| {
            if c {
                violations.push(what);
            }
        };
        // Outputs.
        v(
            matches!(st, State::Boot | State::Unhomed | State::SoftEstop | State::Fault) && !zero(&out),
            "output in Boot, Unhomed, SoftEstop or Fault",
        );
        v(has(&|e| matches!(e, Event::Fault(_))) && !zero(&out), "a fault tick with output");
        v(out.iter().chain(o.status.position.iter()).any(|x| !x.is_finite()), "a non-finite output or estimate");
        if matches!(st, State::Stopping | State::SoftEstop) && matches!(before, State::Stopping | State::SoftEstop) {
            let prev = s.k.last_output();
            let faster = (0..AXES).any(|i| {
                let (a, b) = (out[i], prev[i]);
                a.abs() > b.abs() || (a != S::ZERO && (a > S::ZERO) != (b > S::ZERO))
            });
            v(faster, "soft stop sped up or reversed");
        }
        // SR-7: the ramp's envelope is v0 (N - k) / N on every axis (within
        // rounding): every output lies between zero and it (a joint follows
        // its braking set-point inside it, so it may stop earlier), and
        // every axis is exactly zero at k = N.
        let stop_ticks = MODEL_CONFIG.soft_stop_ms * MODEL_CONFIG.tick_hz / 1000;
        n.ramp = match (s.ramp, st) {
            // (A fault in the timeout's tick zeroes everything instead.)
            _ if st == State::Stopping && has(&|e| matches!(e, Event::SoftEstop { .. })) => {
                Some((1, s.k.last_output()))
            }
            (Some((k, v0)), State::Stopping | State::SoftEstop) if before == State::Stopping => Some((k + 1, v0)),
            _ => None,
        };
        if let Some((k, v0)) = n.ramp {
            let left = f64::from(stop_ticks.saturating_sub(k)) / f64::from(stop_ticks);
            let outside = (0..AXES).any(|i| {
                let (want, got) = (f64v(v0[i]) * left, f64v(out[i]));
                got.abs() > want.abs() + 1e-6 * (1.0 + want.abs()) || (got != 0.0 && (got > 0.0) != (want > 0.0))
            });
            v(outside, "SR-7: a ramp output outside the envelope v0 (N - k) / N");
            v((k >= stop_ticks) != (st == State::SoftEstop), "SR-7: the ramp did not end in SoftEstop at k = N");
            v(k >= stop_ticks && !zero(&out), "SR-7: not every axis exactly zero at k = N");
        }
        if st == State::Homing {
            let phases = n.k.homing_phases();
            let bad = (0..AXES).any(|i| {
                let needs = SEED_DEPENDENCIES[i];
                if phases[i].is_moving() {
                    n.k.homed() & needs != needs
                } else {
                    out[i] != S::ZERO
                }
            });
            v(bad, "SR-13/16: homing order violated or a non-homing axis moved");
        }
        // SR-10: a pressed switch faults in the same tick in Operational,
        // Stopping, SoftEstop, and during homing on a homed axis at rest.
        // (Not in the tick a HOME is accepted: the switch is then a homing
        // input of a run that starts before the check.)
        let phases_before = s.k.homing_phases();
        // Nor in the tick a per-joint run ends in Unhomed (SR-10 does not
        // list Unhomed; found by this model: a homed J6's switch pressed in
        // that tick, or later in Unhomed, never faults).
        let homing_started = has(&|e| matches!(e, Event::HomingStarted { .. }));
        let ended_unhomed = has(&|e| matches!(e, Event::HomingDone { .. })) && st == State::Unhomed;
        let switch_is_fault = !homing_started
            && !ended_unhomed
            && (0..AXES).any(|i| {
                sense.limits & (1 << i) != 0
                    && (matches!(before, State::Operational | State::Stopping | State::SoftEstop)
                        || (before == State::Homing && s.k.homed() & (1 << i) != 0 && !phases_before[i].is_moving()))
            });
        v(switch_is_fault && st != State::Fault, "SR-10: a limit switch did not fault in the same tick");
        // SR-21: a hardware fault faults in the same tick, in every state.
        v(
            sense.hardware_fault.is_some() && st != State::Fault,
            "SR-21: a hardware fault did not fault in the same tick",
        );
        // SR-11: the (limit + 1)-th consecutive invalid J1 sample (lost, or
        // more than the plausibility window from the count J1 was
        // initialised from) faults in the same tick; fewer are ridden through.
        let limit = MODEL_CONFIG.encoder_invalid_limit as u8;
        let j1 = sense.encoders[0];
        if s.j1.seen && s.j1.run > limit {
            // Faulted: the count is lost until an enable re-initialises J1
            // from its reading (SR-11: the joint must be homed again).
            if has(&|e| matches!(e, Event::Enabled(_))) {
                if let EncoderSample::Count(c) = j1 {
                    n.j1 = J1 { seen: true, reference: c, run: 0 };
                }
            }
        } else if s.j1.seen {
            let valid = j1 == EncoderSample::Count(s.j1.reference);
            n.j1.run = if valid { 0 } else { s.j1.run + 1 };
            let crossed = s.j1.run <= limit && n.j1.run == limit + 1;
            v(crossed && st != State::Fault, "SR-11: the encoder fault did not come in the same tick");
            let j1_fault = has(&|e| {
                matches!(
                    e,
                    Event::Fault(FaultReason::EncoderLost { axis: 0 } | FaultReason::EncoderJump { axis: 0, .. })
                )
            });
            v(n.j1.run <= limit && j1_fault, "SR-11: an encoder fault within the tolerance");
        } else if let EncoderSample::Count(c) = j1 {
            n.j1 = J1 { seen: true, reference: c, run: 0 };
        }
        // SR-1: when the kernel leaves Boot, every estimate is at rest at
        // the angle of the axis's first reading (J1's may be this tick's).
        if has(&|e| matches!(e, Event::Ready)) {
            let off = (0..AXES).any(|i| {
                let c = if i == 0 { n.j1.reference } else { COUNTS[i] };
                o.status.position[i] != angle::<S>(i, c) || o.status.velocity[i] != S::ZERO
            });
            v(off, "SR-1: an estimate does not start at rest at its first reading");
        }
        // Requests.
        let latched = matches!(before, State::Fault | State::SoftEstop);
        v(
            req == Some(Req::Enable) && latched && cause && !matches!(st, State::Fault | State::SoftEstop),
            "SR-6: enable cleared a latch while a cause was present",
        );
        // SR-6: after an accepted enable the set-points are the measured
        // positions and the timeout is disarmed.
        if has(&|e| matches!(e, Event::Enabled(_))) {
            let jump = (0..AXES).any(|i| o.status.setpoint[i] != o.status.position[i]);
            v(jump || o.status.timeout_armed, "SR-6: set-point differs from the position after enable");
        }
        let motion = matches!(req, Some(Req::MotionNear | Req::MotionHere | Req::MotionOutOfLimits));
        let rejected = has(&|e| matches!(e, Event::Rejected { request: RequestKind::Motion, .. }));
        v(motion && before != State::Operational && !rejected, "SR-15: motion accepted outside Operational");
        v(req == Some(Req::MotionOutOfLimits) && !rejected, "SR-17: out-of-limits target accepted");
        v(
            has(&|e| matches!(e, Event::HomingDone { .. })) && o.status.timeout_armed,
            "SR-8: timeout armed right after homing",
        );
        // Latch.
        v(
            before == State::Fault
                && st == State::Fault
                && s.k.fault().map(|f| f.reason) != o.status.fault.map(|f| f.reason),
            "SR-5: latched fault reason changed",
        );
        v((st == State::Fault) != o.status.fault.is_some(), "a fault state without a reason");
        if n.violation.is_none() {
            n.violation = violations.first().copied();
        }
        n.ever_enabled |= has(&|e| matches!(e, Event::Enabled(_)));
        Some(n)
    }

    fn properties(&self) -> Vec<Property<Self>> {
        let mut p = vec![
            // Checked on every transition (the named rules above).
            Property::<Self>::always("no transition violation", |_, s: &St<S>| s.violation.is_none()),
            Property::<Self>::always("zero output in Boot, Unhomed, SoftEstop, Fault", |_, s: &St<S>| {
                !matches!(s.k.state(), State::Boot | State::Unhomed | State::SoftEstop | State::Fault)
                    || zero(&s.k.last_output())
            }),
            Property::<Self>::always("a fault always has its reason", |_, s: &St<S>| {
                (s.k.state() == State::Fault) == s.k.fault().is_some()
            }),
            Property::<Self>::always("the kernel's state invariant (Kernel::invariant)", |_, s: &St<S>| {
                s.k.invariant()
            }),
            Property::<Self>::sometimes("operational", |_, s: &St<S>| s.k.state() == State::Operational),
            Property::<Self>::sometimes("moving in operational", |_, s: &St<S>| {
                s.k.state() == State::Operational && !zero(&s.k.last_output())
            }),
            Property::<Self>::sometimes("soft stop ramping", |_, s: &St<S>| {
                s.k.state() == State::Stopping && !zero(&s.k.last_output())
            }),
            Property::<Self>::sometimes("soft E-stop latched", |_, s: &St<S>| s.k.state() == State::SoftEstop),
            Property::<Self>::sometimes("limit-switch fault", |_, s: &St<S>| {
                matches!(s.k.fault().map(|f| f.reason), Some(FaultReason::LimitSwitch { .. }))
            }),
            Property::<Self>::sometimes("J1 encoder fault", |_, s: &St<S>| {
                matches!(s.k.fault().map(|f| f.reason), Some(FaultReason::EncoderLost { axis: 0 }))
            }),
            Property::<Self>::sometimes("hardware fault", |_, s: &St<S>| {
                matches!(s.k.fault().map(|f| f.reason), Some(FaultReason::Hardware(_)))
            }),
            Property::<Self>::sometimes("homing failed (H3)", |_, s: &St<S>| {
                s.k.homing_status() == HomingStatus::Failed
            }),
            Property::<Self>::sometimes("all joints homed, operational (H2)", |_, s: &St<S>| {
                s.k.homing_status() == HomingStatus::Complete && s.k.state() == State::Operational
            }),
            Property::<Self>::sometimes("enable accepted", |_, s: &St<S>| s.ever_enabled),
        ];
        if !self.small {
            p.push(Property::<Self>::sometimes(
                "axes of one homing group out of step (arrival orders)",
                |_, s: &St<S>| out_of_step(&s.k.homing_phases()),
            ));
        }
        p
    }
}

struct Run {
    unique: usize,
    generated: usize,
    depth: usize,
    secs: f64,
    violated: Vec<String>,
    /// Every reachable state was explored (not stopped by `--bounded`).
    exhaustive: bool,
}

fn run<S: ModelScalar>(cfg: &str, expect: Option<&str>, timeout: Option<u64>, bounded: bool) -> Run {
    let (small, tiny) = (cfg != "full", cfg == "tiny");
    // Valid targets near the stationary arm: it ends homing on its switches,
    // which lie just outside the URDF limits, so clamp 10 mrad inside them.
    let (mut k, _) = proofs::setup::operational::<S>();
    let mut here = proofs::setup::here(&mut k);
    for (i, h) in here.iter_mut().enumerate() {
        let j = &MODEL_CONFIG.joints[i];
        *h = h.clamp_between(S::from_f32(j.limit_min + 0.01), S::from_f32(j.limit_max - 0.01));
    }
    let (init, authority) = new_kernel::<S>(&kernel::config::Validated::relaxed(MODEL_CONFIG));
    let model = Supervisor { init, authority, here, small, tiny };
    let started = std::time::Instant::now();
    // A cap on generated states (stateright counts every generated state, not
    // only unique ones) so that a state explosion reports instead of
    // exhausting memory; reaching it makes the run fail (not exhaustive).
    const CAP: usize = 1_000_000_000;
    let mut b = model.checker().threads(2).target_state_count(CAP);
    if expect.is_some() {
        b = b.finish_when(HasDiscoveries::AnyFailures);
    }
    if let Some(t) = timeout {
        b = b.timeout(std::time::Duration::from_secs(t));
    }
    let checker = b.spawn_bfs();
    // Progress every 30 s (stderr), so a slow run shows how it grows.
    let mut last = std::time::Instant::now();
    while !checker.is_done() {
        std::thread::sleep(std::time::Duration::from_millis(200));
        if last.elapsed().as_secs() >= 30 {
            last = std::time::Instant::now();
            eprintln!(
                "model {}: {:.0} s, {} unique states, {} generated, depth {}",
                S::NAME,
                started.elapsed().as_secs_f64(),
                checker.unique_state_count(),
                checker.state_count(),
                checker.max_depth()
            );
        }
    }
    let checker = checker.join();
    let secs = started.elapsed().as_secs_f64();
    let stopped = timeout.is_some_and(|t| secs >= t as f64) || checker.state_count() >= CAP;
    if stopped && !bounded {
        println!(
            "model: stopped by --timeout or the state cap after {secs:.0} s: NOT exhaustive ({} unique states)",
            checker.unique_state_count()
        );
        std::process::exit(2);
    }
    let mut violated = Vec::new();
    for (name, path) in checker.discoveries() {
        if matches!(checker.discovery_classification(name), DiscoveryClassification::Counterexample) {
            let last = path.last_state();
            violated.push(format!("{name}: {}", last.violation.unwrap_or("(state property)")));
            // The counterexample: its actions, and the last two states' kernel status.
            let states = path.clone().into_states();
            eprintln!("counterexample for '{name}', {} ticks:", states.len().saturating_sub(1));
            for a in path.clone().into_actions() {
                eprintln!("  {a:?}");
            }
            for st in states.iter().rev().take(2).rev() {
                eprintln!(
                    "  state {:?}, fault {:?}, homed {:#08b}, phases {:?}, j1 {:?}",
                    st.k.state(),
                    st.k.fault().map(|f| f.reason),
                    st.k.homed(),
                    st.k.homing_phases(),
                    st.j1
                );
            }
        }
    }
    let r = Run {
        unique: checker.unique_state_count(),
        generated: checker.state_count(),
        depth: checker.max_depth(),
        secs,
        violated,
        exhaustive: true,
    };
    if expect.is_none() {
        if !r.violated.is_empty() {
            println!("model-checked {}: VIOLATED: {:?}", S::NAME, r.violated);
            if stopped {
                std::process::exit(1);
            }
        }
        if stopped {
            // A bounded exploration: every transition property held in every
            // explored state; 'sometimes' properties are not required.
            println!(
                "model {}: bounded exploration stopped after {secs:.0} s: {} unique states to depth {}: NOT exhaustive; no property violated in any explored state",
                S::NAME,
                r.unique,
                r.depth
            );
        } else {
            checker.assert_properties();
        }
    }
    Run { exhaustive: !stopped, ..r }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |k: &str| args.iter().position(|a| a == k).and_then(|i| args.get(i + 1)).map(String::as_str);
    let expect = arg("--expect-violation");
    // `--bounded S`: explore breadth first for at most S seconds and report
    // a bounded exploration (sampled evidence) if it does not finish.
    // Only the full configuration is bounded: the reduced ones (small,
    // tiny) must finish, so that their runs are model checks.
    let bounded = arg("--bounded").and_then(|t| t.parse::<u64>().ok());
    let plain_timeout: Option<u64> = arg("--timeout").and_then(|t| t.parse().ok());
    let runs: Vec<(&str, &str)> = match (arg("--variant"), arg("--config")) {
        (None, None) => vec![("fx", "full"), ("fx", "small"), ("f32", "tiny")],
        (v, c) => vec![(v.unwrap_or("fx"), c.unwrap_or("full"))],
    };
    for (field, rule) in MODEL_RELAXATIONS {
        println!("model: configuration relaxes {field} (breaks '{rule}'; see the doc comment)");
    }
    let mut tsv = String::new();
    for (variant, cfg) in runs {
        if !matches!(cfg, "full" | "small" | "tiny") {
            eprintln!("model: unknown configuration {cfg}");
            std::process::exit(2);
        }
        let (timeout, bounded) = match (cfg, bounded) {
            ("full", Some(b)) => (Some(b), true),
            _ => (plain_timeout, false),
        };
        let r = match variant {
            "fx" => run::<Fx>(cfg, expect, timeout, bounded),
            "f32" => run::<f32>(cfg, expect, timeout, bounded),
            other => {
                eprintln!("model: unknown variant {other}");
                std::process::exit(2);
            }
        };
        let name = if variant == "fx" { "Kernel<Fx>" } else { "Kernel<f32>" };
        println!(
            "{} {name}, {cfg} configuration: {} states ({} unique), max depth {}, {:.1} s",
            if r.exhaustive { "model-checked" } else { "explored (bounded, sampled evidence)" },
            r.generated,
            r.unique,
            r.depth,
            r.secs
        );
        if let Some(want) = expect {
            let hit: Vec<&String> = r.violated.iter().filter(|v| v.contains(want)).collect();
            if hit.is_empty() {
                println!("model: expected a violation of '{want}', found {:?}", r.violated);
                std::process::exit(1);
            }
            println!("model: violated as expected: {hit:?}");
            continue;
        }
        if r.exhaustive {
            println!(
                "model-checked {name}: every property holds in every reachable state; every 'sometimes' property reached"
            );
            tsv.push_str(&format!(
                "model\tmodel-checked\t{}\tholds\tsupervisor + homing, {name}, {cfg} configuration\n",
                r.unique
            ));
        } else {
            tsv.push_str(&format!(
                "model\tsampled\t{}\tholds\tbounded BFS exploration (not exhaustive) to depth {}, {name}, {cfg} configuration\n",
                r.unique, r.depth
            ));
        }
    }
    if expect.is_none() {
        if let Ok(dir) = std::env::var("EVIDENCE_DIR") {
            if let Err(e) = std::fs::write(std::path::Path::new(&dir).join("model.tsv"), tsv) {
                eprintln!("model: cannot write the evidence file in {dir}: {e}");
                std::process::exit(1);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kernel::config::PAROL6;

    #[test]
    fn model_config_relaxes_exactly_the_named_rules() {
        use kernel::config::check;
        let mut c = MODEL_CONFIG;
        for (j, p) in c.joints.iter_mut().zip(PAROL6.joints.iter()) {
            j.homing.backoff = p.homing.backoff;
            j.homing.timeout_ms = p.homing.timeout_ms;
        }
        c.soft_stop_ms = PAROL6.soft_stop_ms;
        assert_eq!(check(&c), Ok(()), "without the relaxations the model's configuration passes check");
        let mut one = c;
        one.soft_stop_ms = 4;
        assert_eq!(check(&one), Err(MODEL_RELAXATIONS[2].1));
        let mut one = c;
        one.joints.iter_mut().for_each(|j| j.homing.backoff = 0.0);
        assert_eq!(check(&one), Err(MODEL_RELAXATIONS[0].1));
        let mut one = c;
        one.joints.iter_mut().for_each(|j| j.homing.timeout_ms = 8);
        assert_eq!(check(&one), Err(MODEL_RELAXATIONS[1].1));

        // Everything else is PAROL6 or shortened within the rules.
        c.command_timeout_ms = PAROL6.command_timeout_ms;
        c.soft_stop_ms = PAROL6.soft_stop_ms;
        c.segment_min_ms = PAROL6.segment_min_ms;
        c.segment_max_ms = PAROL6.segment_max_ms;
        c.boot_timeout_ms = PAROL6.boot_timeout_ms;
        c.homing_settle_ms = PAROL6.homing_settle_ms;
        for (j, p) in c.joints.iter_mut().zip(PAROL6.joints.iter()) {
            j.max_acceleration = p.max_acceleration;
            j.homing.switch_position = p.homing.switch_position;
        }
        assert_eq!(c, PAROL6);
    }

    #[test]
    fn f32_state_identity_ignores_only_the_tick_counters() {
        let (mut a, _) = new_kernel::<f32>(&kernel::config::Validated::relaxed(MODEL_CONFIG));
        let mut b = a.clone();
        let h = |k: &Kernel<f32>| {
            let mut h = DefaultHasher::new();
            f32::hash_kernel(k, &mut h);
            h.finish()
        };
        let s = |c: u16| Sense {
            encoders: [EncoderSample::Count(c); AXES],
            limits: 0,
            hardware_fault: None,
            link_lost: false,
        };
        a.tick(&s(100), None);
        b.tick(&s(100), None);
        b.tick(&s(100), None); // one more tick, same state otherwise
        assert_eq!(h(&a), h(&b));
        let mut c = a.clone();
        c.tick(&s(101), None); // a different estimate
        assert_ne!(h(&a), h(&c));
    }
}
