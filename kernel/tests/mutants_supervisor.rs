//! Tests written for the survivors of a cargo-mutants run on the kernel's
//! logic files (`ci/mutants.sh`, `docs/MUTANTS.md`): each asserts the
//! behaviour SAFETY.md or docs/PROTOCOL.md specify, for both numeric
//! variants, every tick checked by the safety monitor (the common rig).
//! This file: the supervisor (`kernel/src/kernel/supervisor.rs`).
#![allow(clippy::needless_range_loop)] // six axes: indices read best

mod common;

use common::{both, Rig};
use kernel::config::{ArmConfig, Validated, AXES, PAROL6};
use kernel::homing::Phase;
use kernel::{Event, FaultReason, HomingStatus, Reject, Request, RequestKind, Scalar, State, StopCause, TickOutput};

const START: [f64; AXES] = [0.3, 0.2, -0.4, 0.5, -0.3, 1.0];

both!(
    link_loss_during_the_stop_before_homing_drops_the_homing,
    the_homing_run_starts_from_the_estimates_at_the_end_of_the_settle_wait,
    the_estimates_settling_during_the_wait_are_no_following_error,
    a_stalled_motor_faults_during_homing,
    a_motor_that_stalls_during_a_soft_stop_faults,
    runaway_faults_in_unhomed_where_no_path_is_followed,
    a_homed_joint_pushed_past_its_limit_faults_on_the_position_limit,
);

fn homed<S: Scalar>() -> Rig<S> {
    let mut r = Rig::<S>::new(START);
    r.boot_and_home();
    r
}

/// PROTOCOL.md 6.6: "A lost link during the stop drops the pending homing
/// (`SOFT_ESTOP LINK_LOST`, latched)". Survivor: `link_lost` without its
/// `Stopping` arm (the stop ran on into homing with the link gone).
fn link_loss_during_the_stop_before_homing_drops_the_homing<S: Scalar>() {
    let mut r = homed::<S>();
    let mut p = r.plant.q;
    p[5] -= 1.0;
    r.goto(p);
    r.run(200);
    let out = r.tick(Some(Request::Home));
    assert!(out.events.iter().any(|e| *e == Event::HomingAfterStop), "{:?}", out.events);
    r.run(10);
    assert_eq!(r.k.state(), State::Stopping);
    r.plant.link_lost = true;
    let out = r.tick(None);
    assert!(out.events.iter().any(|e| *e == Event::SoftEstop { cause: StopCause::LinkLost }), "{:?}", out.events);
    let start = r.events.len();
    r.run_until(500, |o| {
        assert_ne!(o.status.state, State::Homing, "homing started after the link was lost");
        o.status.state != State::Stopping
    })
    .expect("the stop ends");
    assert_eq!(r.k.state(), State::SoftEstop);
    assert!(r.events[start..].contains(&Event::Stopped), "{:?}", &r.events[start..]);
    assert!(!r.events[start..].iter().any(|e| matches!(e, Event::HomingStarted { .. })), "{:?}", r.events);
    // Latched: homing needs <ENABLE> first, even with the link back.
    r.plant.link_lost = false;
    let out = r.tick(Some(Request::Home));
    assert!(
        out.events.iter().any(|e| matches!(e, Event::Rejected { reason: kernel::Reject::Latched, .. })),
        "{:?}",
        out.events
    );
}

/// A homing run rests for the settle time before it moves, then "the
/// commanded paths start from the settled estimates" (the set-points and
/// paths are re-synchronised on the last tick of the wait, and nothing moves
/// them until the run's first step). Shown by a joint dragged slowly while
/// the run waits: on the tick the wait ends, the reported set-point is that
/// tick's estimate, and it stays there while the run's first group moves.
/// Survivor: the resync on every wait tick but the last (the set-points one
/// tick stale).
fn the_homing_run_starts_from_the_estimates_at_the_end_of_the_settle_wait<S: Scalar>() {
    let mut r = Rig::<S>::new(START);
    r.run(3);
    r.plant.disturbance[0] = 0.3;
    r.tick(Some(Request::Home));
    let mut outs: Vec<TickOutput<S>> = Vec::new();
    for _ in 0..2_000 {
        let out = r.tick(None);
        let started = r.k.homing_phases()[5] == Phase::FastSeek;
        outs.push(out);
        if started {
            break;
        }
    }
    assert_eq!(r.k.homing_phases()[5], Phase::FastSeek, "the run never started");
    let n = outs.len();
    assert!(n >= 3, "no settle wait: {n}");
    let end = &outs[n - 2].status;
    let before = &outs[n - 3].status;
    assert_ne!(end.position[0], before.position[0], "J1 did not move during the wait");
    assert_eq!(end.setpoint[0], end.position[0], "set-point at the end of the wait");
    assert_eq!(outs[n - 1].status.setpoint[0], end.position[0], "set-point on the run's first step");
}

/// The settle wait is where the estimates settle: "the observer settles
/// after a stop (its velocity lags a deceleration by tens of ms), then the
/// commanded paths start from the settled estimates". An unhomed J3 pushed
/// at 9 rad/s for 8 ms (too short for the lagging estimate to reach the
/// runaway speed) and released in the tick HOME arrives: its estimate
/// moves on by more than the 50 mrad following-error bound during the wait
/// while the arm is at rest. That is no following error (nothing moved
/// off a command; the safety monitor's SR-28 rule rejects a
/// `FollowingError` with nothing injected since the resync): the run
/// starts normally. Survivor: the following error also checked during the
/// wait (`home_wait > 0` as `false`), which faults here.
fn the_estimates_settling_during_the_wait_are_no_following_error<S: Scalar>() {
    let mut r = Rig::<S>::new(START);
    r.run(3);
    for _ in 0..8 {
        r.plant.disturbance[2] = 9.0;
        r.tick(None);
    }
    r.plant.disturbance[2] = 0.0;
    let out = r.tick(Some(Request::Home));
    assert_eq!(out.status.state, State::Homing);
    let x0 = out.status.position[2].to_f32();
    let mut settled_by = 0.0f32;
    let n = r
        .run_until(200, |o| {
            assert_eq!(o.status.fault, None, "a fault during the settle wait");
            settled_by = settled_by.max((o.status.position[2].to_f32() - x0).abs());
            o.status.homing == HomingStatus::InProgress && o.act.velocity.iter().any(|v| *v != S::ZERO)
        })
        .expect("the run starts");
    assert!(settled_by > PAROL6.following_error, "the estimate moved only {settled_by} rad during the wait");
    assert!(n >= 45, "the run started after {n} ticks, before the 50 ms wait ended");
    r.run_until(60_000, |o| o.status.state != State::Homing).expect("homing finishes");
    assert_eq!(r.k.state(), State::Operational);
}

/// PROTOCOL.md 6.7: FOLLOWING_ERROR "in Operational, Stopping and Homing":
/// a stalled J6 (the first group) faults on its following error early in
/// its fast seek, not only at the homing timeout. Survivor: no
/// following-error check in Homing and Stopping.
fn a_stalled_motor_faults_during_homing<S: Scalar>() {
    let mut r = Rig::<S>::new(START);
    r.run(3);
    r.plant.stalled = 1 << 5;
    r.tick(Some(Request::Home));
    let n = r.run_until(5_000, |o| o.status.state == State::Fault).expect("faults");
    let reason = r.last.unwrap().status.fault.unwrap().reason;
    assert_eq!(reason, FaultReason::FollowingError { axis: 5 }, "after {n} ticks");
}

/// The same in Stopping: J6 stalls the moment a soft stop starts from
/// speed (link lost); the ramp's commanded path runs away from the
/// estimate and the stop ends in a fault, not in a quiet latch.
fn a_motor_that_stalls_during_a_soft_stop_faults<S: Scalar>() {
    let mut r = homed::<S>();
    let mut p = r.plant.q;
    p[5] -= 1.5;
    r.goto(p);
    r.run(150);
    assert!(r.last.unwrap().act.velocity[5].to_f32().abs() > 1.0, "J6 at speed");
    r.plant.link_lost = true;
    r.plant.stalled = 1 << 5;
    let out = r.tick(None);
    assert_eq!(out.status.state, State::Stopping);
    r.run_until(500, |o| o.status.state != State::Stopping).expect("the stop ends");
    let out = r.last.unwrap();
    assert_eq!(out.status.state, State::Fault);
    assert_eq!(out.status.fault.unwrap().reason, FaultReason::FollowingError { axis: 5 });
}

/// SR-9: a joint faster than its runaway speed faults in every state. In
/// Unhomed nothing else can see it (no path is followed, an unhomed arm
/// outside its limits is no fault): a joint pushed past its runaway speed
/// faults as a runaway, within a few ticks of the observer's velocity
/// passing the threshold. Survivor: the runaway check as `==`.
fn runaway_faults_in_unhomed_where_no_path_is_followed<S: Scalar>() {
    let mut r = Rig::<S>::new(START);
    r.run(3);
    assert_eq!(r.k.state(), State::Unhomed);
    let runaway = f64::from(PAROL6.joints[4].runaway_velocity);
    r.plant.disturbance[4] = 1.2 * runaway;
    let n = r.run_until(500, |o| o.status.state == State::Fault).expect("faults");
    let out = r.last.unwrap();
    assert_eq!(out.status.fault.unwrap().reason, FaultReason::Runaway { axis: 4 }, "after {n} ticks");
    assert!(n < 100, "{n} ticks");
}

/// SR-8: a homed joint outside its limits plus the margin faults as a
/// position limit in Operational, the tick it gets there. With the
/// PAROL6's 20 ms following-error time the following error always fires
/// first (it is the first line: `homed_axis_leaving_its_limits_faults`);
/// with the longest time `config::check` allows (200 ms), a joint pushed
/// hard past a limit reaches limit + margin before that, and the position
/// limit is what stops it. Both sides: J1 up (its switch is at the lower
/// end), J3 down (its switch is at the upper end). Survivors: the check's
/// `||` as `&&`, `<` or `>` as `==`.
fn a_homed_joint_pushed_past_its_limit_faults_on_the_position_limit<S: Scalar>() {
    let cfg = Validated::new(ArmConfig { following_error_ms: 200, ..PAROL6 }).expect("valid");
    for (j, up) in [(0usize, true), (2, false)] {
        let mut r = Rig::<S>::with_config(START, &cfg);
        r.boot_and_home();
        let c = &PAROL6.joints[j];
        let (limit, edge) = if up {
            (c.limit_max, c.limit_max + PAROL6.position_margin)
        } else {
            (c.limit_min, c.limit_min - PAROL6.position_margin)
        };
        let mut p = r.plant.q;
        p[j] = f64::from(limit);
        r.goto(p);
        r.run(1_500);
        assert_eq!(r.k.state(), State::Operational);
        // Pushed harder than the joint's speed limit can resist, below
        // its runaway speed.
        let push = 1.1 * f64::from(c.max_velocity);
        r.plant.disturbance[j] = if up { push } else { -push };
        let n = r.run_until(1_000, |o| o.status.state == State::Fault).expect("faults");
        let out = r.last.unwrap();
        assert_eq!(out.status.fault.unwrap().reason, FaultReason::PositionLimit { axis: j as u8 }, "J{}", j + 1);
        // Within a tick's travel of limit + margin.
        let x = f64::from(out.status.position[j].to_f32());
        let beyond = if up { x - f64::from(edge) } else { f64::from(edge) - x };
        assert!((0.0..0.01).contains(&beyond), "J{}: {beyond} rad beyond the edge after {n} ticks", j + 1);
        // Left there at rest, the cause stays present: <ENABLE> is refused
        // (PROTOCOL.md 6.5, CAUSE_ACTIVE). Survivor: `present_cause`'s
        // lower bound as `==`.
        r.plant.disturbance[j] = 0.0;
        r.run(200);
        let out = r.enable();
        let reason = Reject::CauseActive(FaultReason::PositionLimit { axis: j as u8 });
        assert!(
            out.events.iter().any(|e| *e == Event::Rejected { request: RequestKind::Enable, reason }),
            "J{}: {:?}",
            j + 1,
            out.events
        );
        assert_eq!(out.status.state, State::Fault);
    }
}
