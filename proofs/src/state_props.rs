//! One-step invariants from a **symbolic kernel state**.
//!
//! The other harnesses start from states replayed from power-on, one
//! concrete state each. These start from *any* state that satisfies the
//! kernel's state invariant (`Kernel::invariant`, `kernel/src/kernel/
//! invariant.rs`): every continuous value (estimates, set-points, targets,
//! set-point velocities, last outputs, the ramp's tick and starting
//! outputs, the commanded paths), the counters (following error, invalid
//! samples, command timeout, stream timing), the homed mask and the mode
//! (Unhomed, Operational, Stopping, SoftEstop, Fault with any reason) are
//! drawn symbolically and built by `Kernel::from_spec` (feature
//! `proof-states`); a drawn state the invariant rejects is assumed away
//! (with a `cover!` that some state is kept). Then one tick with any
//! sensors (any count or a lost sample per encoder, any switches, any
//! hardware fault, link up or lost) and any request (none, any motion
//! target, `<HOME>`, `<HOMEn>`, an `<ENABLE>` this kernel's authority
//! minted). Each harness asserts what the code guarantees for that tick
//! and that the invariant holds again: with `initial_state_satisfies_
//! the_invariant_*`, an inductive argument that it holds in every
//! reachable state of the modes drawn.
//!
//! The `from_one_axis_*` harnesses are the same steps with one axis drawn
//! (its index symbolic too) and the other five at rest (see `Scope`):
//! about a third of the symbolic values, for Kani.
//!
//! Configuration: the real `PAROL6_VALIDATED` (nothing is replayed, so no
//! relaxation is needed). Not drawn: Boot and Homing (their state is a run
//! in progress, which `Kernel::from_spec` does not offer); the first tick
//! from power-on is the base-case harness below, the later Boot ticks and
//! the Homing ticks are covered by the sampled end-to-end tests
//! (`kernel_props`, `motion_props`) and the model.
//!
//! Unwind: no harness loop here runs more than the six axes (7), the same
//! as every loop of the code under test (`setup::KERNEL_UNWIND`).

use crate::numeric::any_target;
use crate::setup::{kernel_loops, Sym};
use kernel::config::{ms_to_ticks, AXES, PAROL6, PAROL6_VALIDATED, POSITION_ABS_MAX};
use kernel::{
    Authority, AxisSpec, EncoderSample, Event, FaultReason, Kernel, Reject, Request, RequestKind, Scalar, Sense,
    SpecMode, State, StateSpec, StopCause,
};

/// Ticks of the command timeout: an armed timeout whose count of ticks
/// since the last command passes it expires.
fn timeout_ticks() -> u32 {
    ms_to_ticks(PAROL6.command_timeout_ms, PAROL6.tick_hz)
}

/// Ticks of the soft-stop ramp (`Params::new`).
fn stop_ticks() -> u32 {
    ms_to_ticks(PAROL6.soft_stop_ms, PAROL6.tick_hz).max(1)
}

fn vmax<S: Scalar>(i: usize) -> S {
    S::from_f32(PAROL6.joints[i].max_velocity)
}

/// Any value with `lo <= v <= hi` (finite bounds). Symbolically: any value
/// and an assumption. Sampled: mostly a fraction of the interval, so few
/// draws are discarded, and now and then a raw draw (its boundary values,
/// NaN, infinities) for the assumption to judge.
fn any_between<S: Sym>(lo: S, hi: S) -> S {
    any_between_mostly(lo, hi, (lo, hi), false)
}

/// [`any_between`], and for sampling, inside the narrower `typical`
/// interval when `typ` (drawn once per state, so that whole states are
/// typical: estimates slow enough and inside the limits for an enable).
/// Symbolically the same: any value in `[lo, hi]`.
#[cfg_attr(not(kani), kani::loops)]
fn any_between_mostly<S: Sym>(lo: S, hi: S, typical: (S, S), typ: bool) -> S {
    #[cfg(kani)]
    let v = {
        let _ = (typical, typ);
        S::any()
    };
    // Under the shim one symbolic value either way: the raw draw, or the
    // fraction (the choice between them is a sampling hint).
    #[cfg(not(kani))]
    let v = if kani::runner::hint::<u8>() == 7 {
        S::any()
    } else {
        let (a, b) = if typ { typical } else { (lo, hi) };
        let f = S::from_f32(f32::from(kani::any::<u16>()) / 65535.0);
        a.plus(b.minus(a).times(f)).clamp_between(a, b)
    };
    kani::assume(v.is_finite() && v >= lo && v <= hi);
    kani::cover!(true, "a draw within the bounds passes the assumption");
    v
}

/// The soft-stop envelope at ramp tick `k` from `v0`, as the kernel's ramp
/// computes it (`ramp::stop_scale` of the reciprocal of N, as
/// `Params::new` forms it).
fn envelope<S: Scalar>(v0: S, k: u32) -> S {
    let n = stop_ticks();
    let left = i32::try_from(n.saturating_sub(k)).unwrap_or(0);
    let scale = kernel::ramp::stop_scale(S::from_f32(1.0 / n as f32), left);
    v0.times(scale)
}

/// The modes a harness draws from.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Draw {
    Operational,
    Stopping,
    Latched,
}

/// What is drawn symbolically: the whole state (every axis), or one axis
/// (its index symbolic too) with the other five at rest where their
/// encoders read, their readings unchanged and any target leaving them
/// there. The one-axis harnesses are the whole-state ones sized for Kani
/// (about a third of the symbolic values); they do not cover other axes
/// in motion at the same time, which only the whole-state harnesses do.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Scope {
    Whole,
    OneAxis(usize),
}

impl Scope {
    fn symbolic(self, i: usize) -> bool {
        match self {
            Scope::Whole => true,
            Scope::OneAxis(a) => a == i,
        }
    }
}

/// A symbolic axis index for a one-axis draw.
#[cfg_attr(not(kani), kani::loops)]
fn one_axis() -> Scope {
    let a = usize::from(kani::any::<u8>() % AXES as u8);
    kani::cover!(a == AXES - 1, "the last axis can be the symbolic one");
    Scope::OneAxis(a)
}

/// An axis at rest where its encoder reads (count 2048), in the middle of
/// its limits: no cause for a fault and nothing to move.
fn at_rest<S: Scalar>(i: usize) -> AxisSpec<S> {
    let j = &PAROL6.joints[i];
    let count = 2048u16;
    let x = S::from_f32((j.limit_min + j.limit_max) / 2.0);
    let sign = if j.encoder_reversed { -1.0 } else { 1.0 };
    let measured = (f64::from(count) * j.rad_per_count() * sign) as f32;
    AxisSpec {
        count,
        zero: x.minus(S::from_f32(measured)),
        x,
        v: S::ZERO,
        setpoint: x,
        target: x,
        sp_velocity: S::ZERO,
        speed: S::ZERO,
        last_out: S::ZERO,
        path: x,
        fe_count: 0,
        invalid: 0,
    }
}

/// Any state of the kind `draw` that the invariant admits, built by
/// `Kernel::from_spec`, and its authority; `scope` says which axes are
/// drawn.
#[cfg_attr(not(kani), kani::loops)]
fn any_state<S: Sym>(draw: Draw, scope: Scope) -> (Kernel<S>, Authority, StateSpec<S>) {
    kernel_loops();
    let n = stop_ticks();
    // Any tick of the ramp; for sampling, half of the draws at its last two.
    let k: u32 = if kani::any() { kani::any::<u32>() % (n + 1) } else { n - kani::any::<u32>() % 2 };
    let mut v0 = [S::ZERO; AXES];
    let mode = match draw {
        Draw::Operational => SpecMode::Operational,
        Draw::Stopping => {
            for i in 0..AXES {
                if scope.symbolic(i) {
                    v0[i] = any_between(vmax::<S>(i).neg(), vmax(i));
                }
            }
            SpecMode::Stopping { k, v0, track: kani::any() }
        }
        Draw::Latched => match kani::any::<u8>() % 3 {
            0 => SpecMode::Unhomed,
            1 => SpecMode::SoftEstop,
            _ => SpecMode::Fault(FaultReason::Runaway { axis: kani::any::<u8>() % AXES as u8 }),
        },
    };
    let big = S::from_f32(POSITION_ABS_MAX);
    let cfg = &PAROL6;
    // A sampling hint (whole states typical or not); no value under Kani.
    #[cfg(not(kani))]
    let typ: bool = kani::runner::hint();
    #[cfg(kani)]
    let typ = false;
    // A sampling hint: every drawn set-point at rest on its target (see
    // below).
    #[cfg(not(kani))]
    let rest_all: bool = kani::runner::hint::<u8>().is_multiple_of(4);
    let mut axes = [AxisSpec {
        count: 0,
        zero: S::ZERO,
        x: S::ZERO,
        v: S::ZERO,
        setpoint: S::ZERO,
        target: S::ZERO,
        sp_velocity: S::ZERO,
        speed: S::ZERO,
        last_out: S::ZERO,
        path: S::ZERO,
        fe_count: 0,
        invalid: 0,
    }; AXES];
    for i in 0..AXES {
        if !scope.symbolic(i) {
            axes[i] = at_rest(i);
            continue;
        }
        let vm = vmax::<S>(i);
        let a = &mut axes[i];
        a.count = kani::any::<u16>() % 4096;
        a.zero = any_between(big.neg(), big);
        let j = &cfg.joints[i];
        let inside = (S::from_f32(j.limit_min), S::from_f32(j.limit_max));
        a.x = any_between_mostly(big.neg(), big, inside, typ);
        a.v = any_between_mostly(S::from_f32(-64.0), S::from_f32(64.0), (vm.neg(), vm), typ);
        // Sampling: a typical state's estimate is where its encoder reads
        // (the zero offset chosen so), so an enable can find no cause.
        #[cfg(not(kani))]
        if typ {
            let sign = if j.encoder_reversed { -1.0 } else { 1.0 };
            let measured = (f64::from(a.count) * j.rad_per_count() * sign) as f32;
            a.zero = a.x.minus(S::from_f32(measured));
        }
        a.setpoint = any_between(big.neg(), big);
        a.target = any_between(big.neg(), big);
        a.sp_velocity = any_between(vm.neg(), vm);
        a.speed = any_between(S::ZERO, big);
        a.path = any_between(big.neg(), big);
        a.fe_count = kani::any::<u32>() % (ms_to_ticks(cfg.following_error_ms, cfg.tick_hz) + 1);
        a.invalid = kani::any::<u32>() % (cfg.encoder_invalid_limit + 1);
        a.last_out = match draw {
            Draw::Operational => any_between(vm.neg(), vm),
            Draw::Stopping => {
                let env = envelope(v0[i], k);
                any_between(env.min(S::ZERO), env.max(S::ZERO))
            }
            Draw::Latched => S::ZERO,
        };
        // Sampling: now and then a set-point at rest on its target and, in
        // Operational, no output (a hint: symbolically these stay any
        // values), so that states with every set-point at rest and arms at
        // rest are drawn.
        #[cfg(not(kani))]
        if rest_all || kani::runner::hint::<u8>().is_multiple_of(4) {
            a.target = a.setpoint;
            a.sp_velocity = S::ZERO;
            if draw == Draw::Operational {
                a.last_out = S::ZERO;
            }
        }
    }
    let seg = (ms_to_ticks(cfg.segment_min_ms, cfg.tick_hz), ms_to_ticks(cfg.segment_max_ms, cfg.tick_hz));
    let interval = || seg.0 + kani::any::<u32>() % (seg.1 - seg.0 + 1);
    let intervals = if kani::any() { [0; 4] } else { [interval(), interval(), interval(), interval()] };
    let spec = StateSpec {
        mode,
        homed: if draw == Draw::Latched { kani::any::<u8>() & 0x3f } else { 0x3f },
        axes,
        armed: kani::any(),
        since_cmd: {
            let c = kani::any::<u32>() % 1000;
            // For sampling, often the tick before the timeout or its
            // expiry (a hint, no symbolic value).
            #[cfg(not(kani))]
            let c = if kani::runner::hint() { timeout_ticks() - 1 + c % 2 } else { c };
            c
        },
        since_target: if kani::any() { Some(kani::any::<u32>() % (seg.1 + 1)) } else { None },
        intervals,
    };
    let built = Kernel::from_spec(&PAROL6_VALIDATED, &spec);
    kani::cover!(built.is_some(), "the invariant admits a drawn state");
    kani::assume(built.is_some());
    let Some((kernel, auth)) = built else { unreachable!("assumed") };
    (kernel, auth, spec)
}

/// Any sensors: per encoder any count (also out of range) or a lost
/// sample, any switches, any hardware fault, the link up or lost. (For
/// sampling, half of the draws read every encoder within a few counts of
/// its last reading; symbolically this is still any count.)
#[cfg_attr(not(kani), kani::loops)]
fn any_sense<S>(spec: &StateSpec<S>, scope: Scope) -> Sense {
    let mut encoders = [EncoderSample::Lost; AXES];
    let near: bool = kani::any();
    for (i, (e, a)) in encoders.iter_mut().zip(spec.axes.iter()).enumerate() {
        if !scope.symbolic(i) {
            *e = EncoderSample::Count(a.count);
        } else if near {
            let d = i32::from(kani::any::<i8>() % 8);
            *e = EncoderSample::Count((i32::from(a.count) + d).rem_euclid(4096) as u16);
        } else if !kani::any::<u8>().is_multiple_of(8) {
            *e = EncoderSample::Count(kani::any());
        }
    }
    Sense {
        encoders,
        // Mostly no switch, so that the other antecedents are sampled too.
        limits: if kani::any() { 0 } else { kani::any() },
        hardware_fault: if kani::any::<u8>().is_multiple_of(8) {
            Some(crate::setup::any_hardware_fault())
        } else {
            None
        },
        link_lost: kani::any::<u8>().is_multiple_of(8),
    }
}

/// Any request: none, any motion target, `<HOME>`, `<HOMEn>`, or an
/// `<ENABLE>` minted by this kernel's authority.
fn any_request<S: Sym>(auth: &Authority, spec: &StateSpec<S>, scope: Scope) -> Option<Request<S>> {
    match kani::any::<u8>() % 5 {
        0 => None,
        1 => Some(Request::Motion(match scope {
            Scope::Whole => any_target::<S>(),
            Scope::OneAxis(a) => {
                // The other axes' targets where they are.
                let mut t = kernel::MotionTarget {
                    position: spec.axes.map(|x| x.x),
                    velocity: [S::ZERO; AXES],
                    kind: kernel::MotionKind::Stream,
                };
                let (lo, hi) = crate::numeric::widened_limits::<S>(a);
                t.position[a] = crate::numeric::any_mostly_in(lo, hi);
                let v = vmax::<S>(a);
                t.velocity[a] = crate::numeric::any_mostly_in(v.neg(), v);
                t
            }
        })),
        2 => Some(Request::Home),
        3 => Some(Request::HomeJoint(kani::any::<u8>() % 8)),
        _ => Some(Request::Enable(auth.enable())),
    }
}

/// Antecedents of one tick that only some draws can reach (only a latched
/// draw starts latched, only an operational one stays Operational, only a
/// stopping one runs a ramp): each harness covers those of its own draw.
#[derive(Clone, Copy, Debug)]
struct Reached {
    /// A latch and no enable (SR-5's antecedent).
    latch_kept: bool,
    /// An enable that cleared a latch.
    latch_cleared: bool,
    /// An operational tick that changed an output (SR-25's antecedent).
    output_changed: bool,
    /// The soft-stop ramp's last tick (SR-7's antecedent).
    ramp_end: bool,
    /// A motion request outside Operational (SR-15's antecedent).
    motion_outside: bool,
    /// A runaway fault latched in this tick (SR-9).
    runaway_fault: bool,
    /// An enable refused while a cause was present (SR-6's antecedent).
    enable_refused_by_cause: bool,
    /// A `<HOME>` or `<HOMEn>` refused by a latch (SR-5).
    home_refused_latched: bool,
    /// A `<HOMEn>` refused while a joint it depends on is unhomed (SR-13).
    dependency_refused: bool,
    /// A homing run started from Unhomed (SR-13, SR-16's antecedent).
    homing_started: bool,
    /// An axis at its invalid-sample limit read an invalid sample
    /// (SR-11's antecedent).
    encoder_loss_at_limit: bool,
    /// An invalid sample below the limit (SR-11's ride-through).
    encoder_loss_ridden: bool,
    /// The link lost while moving in Operational (SR-31's antecedent).
    link_lost_moving: bool,
    /// The command timeout expired with every set-point at rest on its
    /// target (SR-29's antecedent).
    timeout_hold: bool,
    /// The command timeout expired with a set-point travelling (SR-7's
    /// antecedent).
    timeout_stop: bool,
    /// `<HOME>` while the arm moves: the stop first (SR-14's antecedent).
    home_stops_first: bool,
    /// `<HOME>` at rest in Operational: a run starts (SR-14's antecedent).
    rehoming_started: bool,
}

/// One tick from any admitted state of the kind `draw`; asserts what every
/// tick guarantees, and returns the draw-specific antecedents it reached.
///
/// Induction. Invariant: `Kernel::invariant` (SR-32). Base:
/// `initial_state_satisfies_the_invariant` (the state `Kernel::new`
/// builds) and `first_tick_is_still_and_starts_at_the_readings_*` (its
/// first tick). Step: this function, from every state the invariant
/// admits in Unhomed, Operational, Stopping, SoftEstop or Fault, with any
/// sensors and request: the invariant holds after the tick, and so does
/// each property asserted below. Conclusion: each property holds on every
/// tick of every run of `PAROL6` from those states. Condition, not
/// discharged here: the ticks from a Boot state after the first and from
/// a Homing state (not offered by `Kernel::from_spec`) keep the invariant;
/// the sampled end-to-end tests (`kernel_props`, `motion_props`) assert it
/// on each of their ticks, and the model in every state it explores. The
/// one-axis scope (`Scope::OneAxis`) proves the step for states with the
/// other five axes at rest only; the whole-state harnesses for all.
#[cfg_attr(not(kani), kani::loops)]
fn step<S: Sym>(draw: Draw, scope: Scope) -> Reached {
    let (mut k, auth, spec) = any_state::<S>(draw, scope);
    let before = k.state();
    let homed = k.homed();
    let prev = k.last_output();
    let moving = k.moving();
    let at_rest = k.setpoints_at_rest();
    let sense = any_sense(&spec, scope);
    let req = any_request::<S>(&auth, &spec, scope);
    let home_joint = match req {
        Some(Request::HomeJoint(j)) => Some(j),
        _ => None,
    };
    let enable = matches!(req, Some(Request::Enable(_)));
    let home = matches!(req, Some(Request::Home | Request::HomeJoint(_)));
    let motion = matches!(req, Some(Request::Motion(_)));
    let req_none = req.is_none();
    crate::setup::count_tick();
    let o = k.tick(&sense, req);
    let after = o.status.state;
    let out = o.act.velocity;

    // SR-2: every output finite and within its joint's speed limit.
    for i in 0..AXES {
        assert!(out[i].is_finite() && out[i].abs() <= vmax::<S>(i));
    }
    // SR-15: motion is refused outside Operational (the same check the
    // multi-tick `nothing_moves_*` makes from power-on, here from every
    // admitted state of the drawn modes).
    let outside = before != State::Operational;
    if motion && outside {
        assert!(o.events.iter().any(|e| matches!(e, Event::Rejected { request: RequestKind::Motion, .. })));
    }
    // SR-4, SR-5: a fault zeroes every axis in the same tick, and is latched
    // with a reason.
    kani::cover!(after == State::Fault, "a fault");
    if after == State::Fault {
        assert!(out.iter().all(|v| *v == S::ZERO) && o.act.step_rate.iter().all(|r| *r == 0));
        assert!(o.status.fault.is_some());
    }
    // SR-21: a hardware fault faults in the same tick, in every state.
    kani::cover!(sense.hardware_fault.is_some(), "a hardware fault (SR-21 antecedent)");
    if sense.hardware_fault.is_some() {
        assert!(after == State::Fault);
    }
    // SR-10: a homed joint's pressed switch faults in Operational, Stopping
    // and SoftEstop (an unhomed joint's switch is its homing input, and a
    // `<HOME>` accepted in the same tick makes it one).
    let pressed = sense.limits & homed & 0x3f != 0;
    let guarded = matches!(before, State::Operational | State::Stopping | State::SoftEstop);
    kani::cover!(pressed && guarded && !home, "a switch pressed in a guarded state (SR-10 antecedent)");
    if pressed && guarded && !home {
        assert!(after == State::Fault);
    }
    // SR-9: an estimate faster than the runaway threshold faults.
    for i in 0..AXES {
        let runaway = S::from_f32(PAROL6.joints[i].runaway_velocity);
        if o.status.velocity[i].abs() > runaway {
            kani::cover!(true, "an estimate beyond the runaway threshold (SR-9 antecedent)");
            assert!(after == State::Fault);
        }
    }
    // SR-5: only an accepted `<ENABLE>` leaves a latch (a new cause may turn
    // SoftEstop into Fault).
    let latched = matches!(before, State::SoftEstop | State::Fault);
    let after_latched = matches!(after, State::SoftEstop | State::Fault);
    let rejected = |what: fn(&Reject) -> bool| {
        o.events.iter().any(|e| matches!(e, Event::Rejected { reason, .. } if what(reason)))
    };
    let mut reached = Reached {
        latch_kept: latched && !enable,
        latch_cleared: latched && enable && !after_latched,
        output_changed: false,
        ramp_end: false,
        motion_outside: motion && outside,
        runaway_fault: matches!(o.status.fault.map(|f| f.reason), Some(FaultReason::Runaway { .. })),
        enable_refused_by_cause: false,
        home_refused_latched: false,
        dependency_refused: false,
        homing_started: before == State::Unhomed && after == State::Homing,
        encoder_loss_at_limit: false,
        encoder_loss_ridden: false,
        link_lost_moving: false,
        timeout_hold: false,
        timeout_stop: false,
        home_stops_first: false,
        rehoming_started: false,
    };
    if latched && !enable {
        assert!(after == before || after == State::Fault);
    }
    // SR-5: `<HOME>` and `<HOMEn>` are refused while latched (`<HOME>` as
    // latched; `<HOMEn>` for a joint whose dependencies are unhomed is
    // refused for that first, see SR-13 below).
    if latched && home {
        reached.home_refused_latched = true;
        assert!(rejected(|_| true));
        if home_joint.is_none() {
            assert!(rejected(|r| *r == Reject::Latched));
        }
    }
    // SR-6: an enable is refused while a cause the kernel sees at rest is
    // present (a hardware fault, an invalid encoder sample, a homed joint's
    // switch; the estimate's causes are not restated here); an accepted one
    // leaves every set-point at its measured position, the timeout disarmed.
    if latched && enable {
        let invalid = sense.encoders.iter().any(|e| !matches!(e, EncoderSample::Count(c) if *c < 4096));
        let cause = sense.hardware_fault.is_some() || invalid || sense.limits & homed & 0x3f != 0;
        reached.enable_refused_by_cause = cause;
        if cause {
            assert!(after_latched);
        } else if !after_latched {
            assert!(!o.status.timeout_armed);
            for i in 0..AXES {
                assert!(o.status.setpoint[i] == o.status.position[i]);
            }
        }
    }
    // SR-1: no output in Boot, Unhomed or a latch (every state but the
    // three that move).
    if !matches!(after, State::Operational | State::Stopping | State::Homing) {
        assert!(out.iter().all(|v| *v == S::ZERO) && o.act.step_rate.iter().all(|r| *r == 0));
    }
    // SR-13: `<HOMEn>` is refused while a joint it depends on is unhomed.
    if let Some(j) = home_joint {
        let needs = crate::setup::SEED_DEPENDENCIES.get(usize::from(j)).copied().unwrap_or(0);
        if usize::from(j) < AXES && homed & needs != needs {
            reached.dependency_refused = true;
            assert!(rejected(|r| matches!(r, Reject::DependencyNotHomed { .. })));
        }
    }
    // SR-13, SR-16: in the tick a homing run starts, only an axis in a
    // moving homing phase moves, and only one whose dependencies (the
    // monitor's own copy of the homing order) are homed.
    if after == State::Homing {
        let phases = k.homing_phases();
        let homed_now = k.homed();
        for i in 0..AXES {
            if out[i] != S::ZERO {
                let needs = crate::setup::SEED_DEPENDENCIES[i];
                assert!(phases[i].is_moving() && homed_now & needs == needs);
            }
        }
    }
    // SR-11: an axis at its limit of consecutive invalid samples that
    // reads one more faults (outside Fault; the invariant bounds the count
    // by the limit, so this is the sample after the limit).
    for i in 0..AXES {
        let bad = !matches!(sense.encoders[i], EncoderSample::Count(c) if c < 4096);
        if scope.symbolic(i) && before != State::Fault && bad && spec.axes[i].invalid == PAROL6.encoder_invalid_limit {
            reached.encoder_loss_at_limit = true;
            assert!(after == State::Fault);
        }
        // Below the limit the sample is ridden through: a fault in this
        // tick, if any, has another reason.
        if before != State::Fault && bad && spec.axes[i].invalid < PAROL6.encoder_invalid_limit {
            reached.encoder_loss_ridden = true;
            let axis = i as u8;
            let this_encoder = |r: FaultReason| matches!(r, FaultReason::EncoderLost { axis: a } | FaultReason::EncoderJump { axis: a, .. } if a == axis);
            assert!(o.status.fault.is_none_or(|f| !this_encoder(f.reason)));
        }
    }
    // SR-8: the timeout is armed only by an accepted motion command, and
    // a homing run starts with it disarmed.
    if !spec.armed && !motion {
        assert!(!o.status.timeout_armed);
    }
    if after == State::Homing {
        assert!(!o.status.timeout_armed);
    }
    // SR-7, SR-29: in Operational with no request and the link up, the
    // command timeout decides: before it expires nothing stops; when it
    // expires (armed, and the ticks since the last command pass it) a
    // set-point still travelling starts the soft stop, and every set-point
    // at rest on its target holds (`Holding`, the timeout disarmed).
    if before == State::Operational && req_none && !sense.link_lost {
        let expires = spec.armed && spec.since_cmd >= timeout_ticks();
        if !expires {
            assert!(after != State::Stopping);
        } else if at_rest {
            reached.timeout_hold = after == State::Operational;
            assert!(after != State::Stopping);
            if after == State::Operational {
                assert!(o.events.iter().any(|e| *e == Event::Holding) && !o.status.timeout_armed);
            }
        } else {
            reached.timeout_stop = after == State::Stopping;
            assert!(matches!(after, State::Stopping | State::Fault));
            if after == State::Stopping {
                assert!(o
                    .events
                    .iter()
                    .any(|e| matches!(e, Event::SoftEstop { cause: StopCause::CommandTimeout { .. } })));
            }
        }
    }
    // SR-14: `<HOME>` (or `<HOMEn>` of a joint) in Operational, the link
    // up: an arm that moves stops first (Stopping, `HomingAfterStop`), one
    // at rest starts the run at once with the joints it homes counted
    // unhomed (homing is repeatable from every admitted Operational state).
    let joint_ok = home_joint.is_none_or(|j| usize::from(j) < AXES);
    if before == State::Operational && home && joint_ok && !sense.link_lost {
        if moving {
            reached.home_stops_first = after == State::Stopping;
            assert!(matches!(after, State::Stopping | State::Fault));
            if after == State::Stopping {
                assert!(o.events.iter().any(|e| *e == Event::HomingAfterStop));
            }
        } else {
            reached.rehoming_started = after == State::Homing;
            assert!(matches!(after, State::Homing | State::Fault));
            if after == State::Homing {
                let mask = home_joint.map_or(0x3f, |j| 1u8 << j);
                assert!(o.events.iter().any(|e| *e == Event::HomingStarted { mask }));
                assert!(k.homed() & mask == 0);
            }
        }
    }
    // SR-31: the link lost while the arm moves in Operational stops it in
    // the same tick (or a fault does).
    if before == State::Operational && moving && sense.link_lost {
        reached.link_lost_moving = true;
        assert!(matches!(after, State::Stopping | State::Fault));
    }
    // (A latch only in the latched draw.)
    assert!(!latched || draw == Draw::Latched);
    // SR-25: Operational to Operational, each output within one
    // acceleration step of the last (exactly the clamp the code applies).
    if before == State::Operational && after == State::Operational {
        reached.output_changed = out != prev;
        for i in 0..AXES {
            let a = S::from_f32(PAROL6.joints[i].max_acceleration / PAROL6.tick_hz as f32);
            assert!(out[i] >= prev[i].minus(a) && out[i] <= prev[i].plus(a));
        }
    }
    // SR-7: inside a soft stop each output stays between zero and the last
    // one (never grows, never reverses), and the ramp's last tick is exactly
    // zero on every axis together.
    if let SpecMode::Stopping { k: ramp_k, .. } = spec.mode {
        if after != State::Fault {
            for i in 0..AXES {
                assert!(out[i].clamp_between(S::ZERO, prev[i]) == out[i]);
            }
            reached.ramp_end = ramp_k + 1 >= stop_ticks();
            if reached.ramp_end {
                assert!(out.iter().all(|v| *v == S::ZERO));
                assert!(after == State::SoftEstop);
            }
        }
    }
    // The invariant holds again (the inductive step).
    assert!(k.invariant());
    reached
}

/// The induction's base: the state `Kernel::new` builds satisfies the
/// invariant (both variants, the real configuration).
/// Footprint: 0 symbolic values, 0 ticks (two kernels built, no tick).
#[kani::proof]
#[kani::unwind(7)] // the invariant's loops run over the six axes
fn initial_state_satisfies_the_invariant() {
    kernel_loops();
    assert!(Kernel::<f32>::new(&PAROL6_VALIDATED).0.invariant());
    assert!(Kernel::<kernel::Fx>::new(&PAROL6_VALIDATED).0.invariant());
}

/// Footprint: 116 symbolic values, 1 tick (the state (83), sensors (20), request (13)).
#[kani::proof]
#[kani::unwind(7)] // any_state, any_sense and the kernel: six axes (see the module)
fn from_any_operational_state_f32() {
    let r = step::<f32>(Draw::Operational, Scope::Whole);
    kani::cover!(r.output_changed, "an operational tick that changes an output");
    kani::cover!(r.runaway_fault, "a runaway fault (SR-9)");
    kani::cover!(r.link_lost_moving, "the link lost while moving (SR-31 antecedent)");
    kani::cover!(r.timeout_hold, "the timeout expires at rest: holds (SR-29)");
    kani::cover!(r.timeout_stop, "the timeout expires while travelling: stops (SR-7)");
    kani::cover!(r.home_stops_first, "<HOME> while moving stops first (SR-14)");
    kani::cover!(r.rehoming_started, "<HOME> at rest in Operational starts a run (SR-14)");
    kani::cover!(r.encoder_loss_at_limit, "an invalid sample at the limit (SR-11 antecedent)");
    kani::cover!(r.encoder_loss_ridden, "an invalid sample below the limit (SR-11 antecedent)");
}
/// Footprint: 116 symbolic values, 1 tick (the state (83), sensors (20), request (13)).
#[kani::proof]
#[kani::unwind(7)] // as the f32 harness
fn from_any_operational_state_fx() {
    let r = step::<kernel::Fx>(Draw::Operational, Scope::Whole);
    kani::cover!(r.output_changed, "an operational tick that changes an output");
    kani::cover!(r.runaway_fault, "a runaway fault (SR-9)");
    kani::cover!(r.link_lost_moving, "the link lost while moving (SR-31 antecedent)");
    kani::cover!(r.timeout_hold, "the timeout expires at rest: holds (SR-29)");
    kani::cover!(r.timeout_stop, "the timeout expires while travelling: stops (SR-7)");
    kani::cover!(r.home_stops_first, "<HOME> while moving stops first (SR-14)");
    kani::cover!(r.rehoming_started, "<HOME> at rest in Operational starts a run (SR-14)");
    kani::cover!(r.encoder_loss_at_limit, "an invalid sample at the limit (SR-11 antecedent)");
    kani::cover!(r.encoder_loss_ridden, "an invalid sample below the limit (SR-11 antecedent)");
}
/// Footprint: 123 symbolic values, 1 tick (the state (90), sensors (20), request (13)).
#[kani::proof]
#[kani::unwind(7)] // any_state, any_sense and the kernel: six axes (see the module)
fn from_any_stopping_state_f32() {
    let r = step::<f32>(Draw::Stopping, Scope::Whole);
    kani::cover!(r.ramp_end, "the ramp's last tick");
    kani::cover!(r.motion_outside, "motion outside Operational (SR-15 antecedent)");
}
/// Footprint: 123 symbolic values, 1 tick (the state (90), sensors (20), request (13)).
#[kani::proof]
#[kani::unwind(7)] // as the f32 harness
fn from_any_stopping_state_fx() {
    let r = step::<kernel::Fx>(Draw::Stopping, Scope::Whole);
    kani::cover!(r.ramp_end, "the ramp's last tick");
    kani::cover!(r.motion_outside, "motion outside Operational (SR-15 antecedent)");
}
/// Footprint: 113 symbolic values, 1 tick (the state (80), sensors (20), request (13)).
#[kani::proof]
#[kani::unwind(7)] // any_state, any_sense and the kernel: six axes (see the module)
fn from_any_latched_or_unhomed_state_f32() {
    let r = step::<f32>(Draw::Latched, Scope::Whole);
    kani::cover!(r.latch_kept, "a latch and no enable (SR-5 antecedent)");
    kani::cover!(r.latch_cleared, "an enable clears a latch");
    kani::cover!(r.motion_outside, "motion outside Operational (SR-15 antecedent)");
    kani::cover!(r.enable_refused_by_cause, "an enable with a cause present (SR-6 antecedent)");
    kani::cover!(r.home_refused_latched, "a home request in a latch (SR-5 antecedent)");
    kani::cover!(r.dependency_refused, "a per-joint home with a dependency unhomed (SR-13 antecedent)");
    kani::cover!(r.homing_started, "a homing run starts (SR-13, SR-16 antecedent)");
    kani::cover!(r.encoder_loss_at_limit, "an invalid sample at the limit (SR-11 antecedent)");
    kani::cover!(r.encoder_loss_ridden, "an invalid sample below the limit (SR-11 antecedent)");
}
/// Footprint: 113 symbolic values, 1 tick (the state (80), sensors (20), request (13)).
#[kani::proof]
#[kani::unwind(7)] // as the f32 harness
fn from_any_latched_or_unhomed_state_fx() {
    let r = step::<kernel::Fx>(Draw::Latched, Scope::Whole);
    kani::cover!(r.latch_kept, "a latch and no enable (SR-5 antecedent)");
    kani::cover!(r.latch_cleared, "an enable clears a latch");
    kani::cover!(r.motion_outside, "motion outside Operational (SR-15 antecedent)");
    kani::cover!(r.enable_refused_by_cause, "an enable with a cause present (SR-6 antecedent)");
    kani::cover!(r.home_refused_latched, "a home request in a latch (SR-5 antecedent)");
    kani::cover!(r.dependency_refused, "a per-joint home with a dependency unhomed (SR-13 antecedent)");
    kani::cover!(r.homing_started, "a homing run starts (SR-13, SR-16 antecedent)");
    kani::cover!(r.encoder_loss_at_limit, "an invalid sample at the limit (SR-11 antecedent)");
    kani::cover!(r.encoder_loss_ridden, "an invalid sample below the limit (SR-11 antecedent)");
}

// The same steps with one axis symbolic (see `Scope`): a symbolic axis
// index, that axis's state, reading and target, and the shared state
// (mode, counters, switches, hardware fault, link, request kind).

/// Footprint: 37 symbolic values, 1 tick (the axis index, the shared
/// state (11), the axis (12), sensors (10), request (3); `Scope::OneAxis`).
#[kani::proof]
#[kani::unwind(7)] // any_state, any_sense and the kernel: six axes (see the module)
fn from_one_axis_operational_state_f32() {
    let r = step::<f32>(Draw::Operational, one_axis());
    kani::cover!(r.output_changed, "an operational tick that changes an output");
    kani::cover!(r.runaway_fault, "a runaway fault (SR-9)");
    kani::cover!(r.link_lost_moving, "the link lost while moving (SR-31 antecedent)");
    kani::cover!(r.timeout_hold, "the timeout expires at rest: holds (SR-29)");
    kani::cover!(r.timeout_stop, "the timeout expires while travelling: stops (SR-7)");
    kani::cover!(r.home_stops_first, "<HOME> while moving stops first (SR-14)");
    kani::cover!(r.rehoming_started, "<HOME> at rest in Operational starts a run (SR-14)");
    kani::cover!(r.encoder_loss_at_limit, "an invalid sample at the limit (SR-11 antecedent)");
    kani::cover!(r.encoder_loss_ridden, "an invalid sample below the limit (SR-11 antecedent)");
}
/// Footprint: 37 symbolic values, 1 tick (as the f32 harness).
#[kani::proof]
#[kani::unwind(7)] // as the f32 harness
fn from_one_axis_operational_state_fx() {
    let r = step::<kernel::Fx>(Draw::Operational, one_axis());
    kani::cover!(r.output_changed, "an operational tick that changes an output");
    kani::cover!(r.runaway_fault, "a runaway fault (SR-9)");
    kani::cover!(r.link_lost_moving, "the link lost while moving (SR-31 antecedent)");
    kani::cover!(r.timeout_hold, "the timeout expires at rest: holds (SR-29)");
    kani::cover!(r.timeout_stop, "the timeout expires while travelling: stops (SR-7)");
    kani::cover!(r.home_stops_first, "<HOME> while moving stops first (SR-14)");
    kani::cover!(r.rehoming_started, "<HOME> at rest in Operational starts a run (SR-14)");
    kani::cover!(r.encoder_loss_at_limit, "an invalid sample at the limit (SR-11 antecedent)");
    kani::cover!(r.encoder_loss_ridden, "an invalid sample below the limit (SR-11 antecedent)");
}
/// Footprint: 39 symbolic values, 1 tick (the operational draw, the
/// axis's ramp start speed and the track flag).
#[kani::proof]
#[kani::unwind(7)] // any_state, any_sense and the kernel: six axes (see the module)
fn from_one_axis_stopping_state_f32() {
    let r = step::<f32>(Draw::Stopping, one_axis());
    kani::cover!(r.ramp_end, "the ramp's last tick");
    kani::cover!(r.motion_outside, "motion outside Operational (SR-15 antecedent)");
}
/// Footprint: 39 symbolic values, 1 tick (as the f32 harness).
#[kani::proof]
#[kani::unwind(7)] // as the f32 harness
fn from_one_axis_stopping_state_fx() {
    let r = step::<kernel::Fx>(Draw::Stopping, one_axis());
    kani::cover!(r.ramp_end, "the ramp's last tick");
    kani::cover!(r.motion_outside, "motion outside Operational (SR-15 antecedent)");
}
/// Footprint: 39 symbolic values, 1 tick (the shared state, the mode and
/// reason, the homed mask (14), the axis without a last output (11),
/// sensors (10), request (3), the axis index).
#[kani::proof]
#[kani::unwind(7)] // any_state, any_sense and the kernel: six axes (see the module)
fn from_one_axis_latched_or_unhomed_state_f32() {
    let r = step::<f32>(Draw::Latched, one_axis());
    kani::cover!(r.latch_kept, "a latch and no enable (SR-5 antecedent)");
    kani::cover!(r.latch_cleared, "an enable clears a latch");
    kani::cover!(r.motion_outside, "motion outside Operational (SR-15 antecedent)");
    kani::cover!(r.enable_refused_by_cause, "an enable with a cause present (SR-6 antecedent)");
    kani::cover!(r.home_refused_latched, "a home request in a latch (SR-5 antecedent)");
    kani::cover!(r.dependency_refused, "a per-joint home with a dependency unhomed (SR-13 antecedent)");
    kani::cover!(r.homing_started, "a homing run starts (SR-13, SR-16 antecedent)");
    kani::cover!(r.encoder_loss_at_limit, "an invalid sample at the limit (SR-11 antecedent)");
    kani::cover!(r.encoder_loss_ridden, "an invalid sample below the limit (SR-11 antecedent)");
}
/// Footprint: 39 symbolic values, 1 tick (as the f32 harness).
#[kani::proof]
#[kani::unwind(7)] // as the f32 harness
fn from_one_axis_latched_or_unhomed_state_fx() {
    let r = step::<kernel::Fx>(Draw::Latched, one_axis());
    kani::cover!(r.latch_kept, "a latch and no enable (SR-5 antecedent)");
    kani::cover!(r.latch_cleared, "an enable clears a latch");
    kani::cover!(r.motion_outside, "motion outside Operational (SR-15 antecedent)");
    kani::cover!(r.enable_refused_by_cause, "an enable with a cause present (SR-6 antecedent)");
    kani::cover!(r.home_refused_latched, "a home request in a latch (SR-5 antecedent)");
    kani::cover!(r.dependency_refused, "a per-joint home with a dependency unhomed (SR-13 antecedent)");
    kani::cover!(r.homing_started, "a homing run starts (SR-13, SR-16 antecedent)");
    kani::cover!(r.encoder_loss_at_limit, "an invalid sample at the limit (SR-11 antecedent)");
    kani::cover!(r.encoder_loss_ridden, "an invalid sample below the limit (SR-11 antecedent)");
}

/// The first tick from power-on (the induction's base state, built by
/// `Kernel::new` with the real configuration), with any first readings
/// (each encoder any count, in range or not, or a lost sample), any
/// switches, any hardware fault and any request (a motion request with a
/// fixed target: in Boot it is refused by its mode before any value of it
/// is read).
#[cfg_attr(not(kani), kani::loops)]
fn first_tick<S: Sym>() {
    kernel_loops();
    let (mut k, auth) = Kernel::<S>::new(&PAROL6_VALIDATED);
    let mut encoders = [EncoderSample::Lost; AXES];
    for e in encoders.iter_mut() {
        let c: u16 = kani::any();
        // For sampling, mostly a count in range (a hint, no symbolic
        // value); symbolically any count or a loss.
        #[cfg(not(kani))]
        let c = if kani::runner::hint::<u8>().is_multiple_of(8) { c } else { c % 4096 };
        if !kani::any::<u8>().is_multiple_of(8) {
            *e = EncoderSample::Count(c);
        }
    }
    let hardware_fault =
        if kani::any::<u8>().is_multiple_of(8) { Some(crate::setup::any_hardware_fault()) } else { None };
    let sense = Sense { encoders, limits: kani::any(), hardware_fault, link_lost: false };
    let req = match kani::any::<u8>() % 5 {
        0 => None,
        1 => Some(Request::Home),
        2 => Some(Request::HomeJoint(kani::any::<u8>() % 8)),
        3 => Some(Request::Enable(auth.enable())),
        _ => Some(Request::Motion(crate::setup::target([S::ZERO; AXES]))),
    };
    let motion = matches!(req, Some(Request::Motion(_)));
    crate::setup::count_tick();
    let o = k.tick(&sense, req);
    let after = o.status.state;
    let out = o.act.velocity;
    // SR-15: motion is refused in Boot.
    kani::cover!(motion, "motion in Boot (SR-15 antecedent)");
    if motion {
        assert!(o.events.iter().any(|e| matches!(e, Event::Rejected { request: RequestKind::Motion, .. })));
    }
    // SR-1: no output unless a homing run started (a `<HOME>` queued in
    // Boot starts when Boot ends), and then only as SR-13 and SR-16 allow.
    kani::cover!(after == State::Boot, "Boot goes on (a sample missing)");
    kani::cover!(after == State::Unhomed, "booted on the first tick");
    kani::cover!(after == State::Homing, "a home queued in Boot starts");
    if after == State::Homing {
        let phases = k.homing_phases();
        for i in 0..AXES {
            if out[i] != S::ZERO {
                let needs = crate::setup::SEED_DEPENDENCIES[i];
                assert!(phases[i].is_moving() && k.homed() & needs == needs);
            }
        }
    } else {
        assert!(out.iter().all(|v| *v == S::ZERO) && o.act.step_rate.iter().all(|r| *r == 0));
    }
    // SR-1: when Boot ends, each observer is at rest at its first reading.
    if after == State::Unhomed {
        for i in 0..AXES {
            let EncoderSample::Count(c) = sense.encoders[i] else { unreachable!("Boot ends with every count read") };
            let j = &PAROL6.joints[i];
            assert!(!j.encoder_reversed, "the expected reading below is a forward encoder's");
            let expect = S::from_counts(i32::from(c), S::wide_from_f64(j.rad_per_count()));
            assert!(o.status.position[i] == expect && o.status.velocity[i] == S::ZERO);
        }
    }
    assert!(k.invariant());
}

/// The base case in Boot: one tick from `Kernel::new`'s state. States in
/// Boot after that (a sample still missing) and in Homing are not drawn;
/// the sampled end-to-end test `kernel_props::nothing_moves_unless_homed_and_homing_order_holds_*` and the model
/// cover those ticks.
/// Footprint: 19 symbolic values, 1 tick (six readings and whether each
/// is lost (12), switches, the hardware fault (4), the request (2)).
#[kani::proof]
#[kani::unwind(7)] // first_tick, the kernel and the invariant: six axes
fn first_tick_is_still_and_starts_at_the_readings_f32() {
    first_tick::<f32>();
}
/// Footprint: 19 symbolic values, 1 tick (as the f32 harness).
#[kani::proof]
#[kani::unwind(7)] // as the f32 harness
fn first_tick_is_still_and_starts_at_the_readings_fx() {
    first_tick::<kernel::Fx>();
}
