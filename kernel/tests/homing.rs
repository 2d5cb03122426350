//! Homing: the run's order and per-joint dependencies, a zero taken from
//! the encoder reading, re-homing, `<HOME>` queued during boot and started
//! at once outside it, the settle wait before the run and the stop before
//! it, faults during a run leaving its joints unhomed, a dead switch
//! (SAFETY.md SR-13, SR-14, SR-16, SR-28; docs/PROTOCOL.md 6.6). Both numeric variants,
//! every tick checked by the safety monitor (the common rig).
#![allow(clippy::needless_range_loop)] // six axes: indices read best

mod common;

use common::{both, homed, EncoderFault, Rig, START};
use kernel::config::{AXES, PAROL6};
use kernel::homing::Phase;
use kernel::{Event, FaultReason, HomingStatus, Reject, Request, RequestKind, Scalar, State, StopCause, TickOutput};

both!(
    homing_runs_in_the_seed_order,
    per_joint_homing_respects_dependencies,
    homing_zero_comes_from_the_encoder_reading,
    second_homing_rezeroes,
    home_during_boot_is_queued,
    home_outside_boot_starts_at_once,
    link_loss_during_the_stop_before_homing_drops_the_homing,
    the_homing_run_starts_from_the_estimates_at_the_end_of_the_settle_wait,
    the_estimates_settling_during_the_wait_are_no_following_error,
    a_stalled_motor_faults_during_homing,
    a_fault_during_homing_leaves_the_aborted_axes_unhomed,
    switch_of_a_homed_axis_at_rest_during_homing_faults,
    dead_homing_switch_faults_within_its_travel_and_reports_h3,
);

fn homing_runs_in_the_seed_order<S: Scalar>() {
    let mut r = Rig::<S>::new(START);
    r.run(2);
    let out = r.tick(Some(Request::Home));
    assert_eq!(out.status.homing, HomingStatus::InProgress);
    // Record the first tick at which each axis moves and finishes.
    let mut first_move = [None; AXES];
    let mut done_at = [None; AXES];
    for t in 0..60_000u32 {
        let out = r.tick(None);
        for i in 0..AXES {
            if out.act.velocity[i] != S::ZERO && first_move[i].is_none() {
                first_move[i] = Some(t);
            }
            if r.k.homing_phases()[i] == Phase::Done && done_at[i].is_none() {
                done_at[i] = Some(t);
            }
        }
        if out.status.state != State::Homing {
            break;
        }
    }
    assert_eq!(r.k.state(), State::Operational);
    assert_eq!(r.last.unwrap().status.homing, HomingStatus::Complete);
    let m = first_move.map(|t| t.expect("every axis moved"));
    let d = done_at.map(|t| t.expect("every axis finished"));
    // No axis of a later group moves before the earlier group is done.
    assert!(m[3] > d[5] && m[4] > d[5]);
    assert!(m[0] > d[3].max(d[4]));
    // J6 first; J5 and J4 together after J6; J1..J3 together after J4, J5.
    assert!(m[3] > m[5] && m[4] > m[5]);
    assert_eq!(m[3], m[4]);
    assert!(m[0] > m[3].max(m[4]));
    assert_eq!(m[0], m[1]);
    assert_eq!(m[1], m[2]);
    assert!(r.events.contains(&Event::HomingDone { mask: 0b11_1111 }));
}

fn per_joint_homing_respects_dependencies<S: Scalar>() {
    let mut r = Rig::<S>::new(START);
    r.run(2);
    let out = r.tick(Some(Request::HomeJoint(2)));
    assert!(out.events.iter().any(|e| *e
        == Event::Rejected {
            request: RequestKind::HomeJoint(2),
            reason: Reject::DependencyNotHomed { needs: 0b11_1000 }
        }));
    let out = r.tick(Some(Request::HomeJoint(9)));
    assert!(out.events.iter().any(|e| matches!(e, Event::Rejected { reason: Reject::NoSuchJoint, .. })));
    r.tick(Some(Request::HomeJoint(5)));
    r.run_until(60_000, |o| o.status.state != State::Homing).unwrap();
    assert_eq!(r.k.homed(), 0b10_0000);
    assert_eq!(r.k.state(), State::Unhomed);
    r.tick(Some(Request::HomeJoint(4)));
    r.run_until(60_000, |o| o.status.state != State::Homing).unwrap();
    r.tick(Some(Request::HomeJoint(3)));
    r.run_until(60_000, |o| o.status.state != State::Homing).unwrap();
    for j in 0..3 {
        r.tick(Some(Request::HomeJoint(j)));
        r.run_until(60_000, |o| o.status.state != State::Homing).unwrap();
    }
    assert_eq!(r.k.homed(), 0b11_1111);
    assert_eq!(r.k.state(), State::Operational);
    assert_eq!(r.last.unwrap().status.homing, HomingStatus::Complete);
}

fn homing_zero_comes_from_the_encoder_reading<S: Scalar>() {
    let r = homed::<S>();
    let est = r.last.unwrap().status.position;
    for i in 0..AXES {
        let q = r.plant.q[i];
        assert!((est[i].to_f32() as f64 - q).abs() < 5e-3, "axis {i}: est {:?} true {q}", est[i]);
        // Homing ends inside the joint limits.
        let j = &PAROL6.joints[i];
        assert!(q > j.limit_min as f64 && q < j.limit_max as f64, "axis {i} at {q}");
    }
}

/// C++ defect 2 (docs/spec/robot.md section 6): homing worked once.
fn second_homing_rezeroes<S: Scalar>() {
    let mut r = homed::<S>();
    r.tick(Some(Request::Home));
    assert_eq!(r.k.state(), State::Homing);
    r.run_until(60_000, |o| o.status.state != State::Homing).unwrap();
    assert_eq!(r.k.state(), State::Operational);
    let homed_events = r.events.iter().filter(|e| matches!(e, Event::HomingDone { .. })).count();
    assert_eq!(homed_events, 2);
    // Estimates agree with the true joint angles after each homing.
    let est = r.last.unwrap().status.position;
    for i in 0..AXES {
        assert!((est[i].to_f32() as f64 - r.plant.q[i]).abs() < 5e-3, "axis {i}: {:?} vs {}", est[i], r.plant.q[i]);
    }
    // A third time with a shifted encoder offset: the zero follows the reading.
    r.plant.enc_offset[0] += 0.5;
    r.tick(Some(Request::Home));
    // The offset jump is far above the plausibility window: that is a fault,
    // so clear it first, which is what an operator would do.
    if r.k.state() == State::Fault {
        r.enable();
        r.tick(Some(Request::Home));
    }
    r.run_until(60_000, |o| o.status.state != State::Homing).unwrap();
    let est = r.last.unwrap().status.position;
    assert!((est[0].to_f32() as f64 - r.plant.q[0]).abs() < 5e-3);
}

/// The ROS 2 driver sends `<HOME>` once, possibly while the kernel boots.
fn home_during_boot_is_queued<S: Scalar>() {
    let mut r = Rig::<S>::new(START);
    r.plant.encoder[4] = EncoderFault::Lost; // J5 not readable yet: still booting
    let out = r.tick(Some(Request::Home));
    assert_eq!(out.status.state, State::Boot);
    assert!(out.events.iter().any(|e| *e == Event::HomingQueued));
    assert_eq!(out.status.homing, HomingStatus::InProgress);
    r.plant.encoder[4] = EncoderFault::None;
    let out = r.tick(None);
    assert_eq!(out.status.state, State::Homing);
    r.run_until(60_000, |o| o.status.state != State::Homing).unwrap();
    assert_eq!(r.k.state(), State::Operational);
}

/// `<HOME>` outside Boot starts homing in the same tick (the queued event is
/// for Boot only).
fn home_outside_boot_starts_at_once<S: Scalar>() {
    let mut r = Rig::<S>::new(START);
    r.run(3);
    let out = r.tick(Some(Request::Home));
    assert_eq!(out.status.state, State::Homing);
    assert!(out.events.iter().any(|e| *e == Event::HomingStarted { mask: 0b11_1111 }), "{:?}", out.events);
    assert!(!out.events.iter().any(|e| *e == Event::HomingQueued));
}

/// PROTOCOL.md 6.6: "A lost link during the stop drops the pending homing
/// (`SOFT_ESTOP LINK_LOST`, latched)". Catches: `link_lost` without its
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
/// Catches: the resync on every wait tick but the last (the set-points one
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
/// starts normally. Catches: the following error also checked during the
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
/// its fast seek, not only at the homing timeout. Catches: no
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

/// A fault aborts a homing run: the run's axes are not homed afterwards
/// (also after enable), homing reports failure (H3), and the arm is Unhomed.
fn a_fault_during_homing_leaves_the_aborted_axes_unhomed<S: Scalar>() {
    let mut r = homed::<S>();
    assert_eq!(r.k.homed(), 0b11_1111);
    // Re-home J1..J3 only (their dependencies are homed); fault mid-run.
    r.tick(Some(Request::HomeJoint(0)));
    assert_eq!(r.k.state(), State::Homing);
    r.run(20);
    let mut sense = r.plant.sense();
    sense.hardware_fault = Some(kernel::HardwareFault::TickOverrun);
    let out = r.tick_with(sense, None);
    assert_eq!(out.status.state, State::Fault);
    assert_eq!(out.status.homing, HomingStatus::Failed);
    assert_eq!(out.status.homed, 0b11_1110, "J1's aborted run is not homed");
    let out = r.enable();
    assert_eq!(out.status.state, State::Unhomed);
    assert_eq!(out.status.homed, 0b11_1110);
}

/// During homing a pressed switch of a homed axis at rest means something
/// moved it: a fault.
fn switch_of_a_homed_axis_at_rest_during_homing_faults<S: Scalar>() {
    let mut r = homed::<S>();
    r.tick(Some(Request::HomeJoint(0)));
    r.run(5);
    assert_eq!(r.k.state(), State::Homing);
    let phases = r.k.homing_phases();
    assert!(phases[1..].iter().all(|p| *p == kernel::homing::Phase::Idle), "outside the run: {phases:?}");
    r.plant.force_switch = 0b10_0000; // J6: homed, not in this run
    let out = r.tick(None);
    assert_eq!(out.status.fault.map(|f| f.reason), Some(FaultReason::LimitSwitch { axis: 5 }));

    // An axis not yet homed that rests on its switch while it waits for its
    // group is not a fault: homing will seek from there.
    let mut r = Rig::<S>::new(START);
    r.run(3);
    r.plant.force_switch = 0b1; // J1 waits for J6, J5, J4
    r.tick(Some(Request::Home));
    let out = r.run(20);
    assert_eq!(out.status.state, State::Homing, "{:?}", out.status.fault);
}

/// A dead J6 switch: the fast seek stops at its travel bound (range plus
/// the switch's distance plus 0.1 rad), long before the per-axis timeout
/// (12 s at 2 rad/s would be 24 rad of travel), with H3; motion refused.
fn dead_homing_switch_faults_within_its_travel_and_reports_h3<S: Scalar>() {
    let mut r = Rig::<S>::new(START);
    r.run(2);
    r.plant.dead_switch = 0b10_0000;
    let q0 = r.plant.q[5];
    r.tick(Some(Request::Home));
    let n = r.run_until(60_000, |o| o.status.state != State::Homing).unwrap();
    let out = r.last.unwrap();
    assert_eq!(out.status.state, State::Fault);
    assert_eq!(out.status.homing, HomingStatus::Failed);
    assert_eq!(out.status.fault.unwrap().reason, FaultReason::HomingTravel { axis: 5, phase: Phase::FastSeek });
    let travel = (r.plant.q[5] - q0).abs();
    let bound = f64::from(PAROL6.joints[5].homing.max_travel);
    println!("dead J6 switch: fault after {n} ticks and {travel:.3} rad (bound {bound:.3})");
    assert!(travel <= bound + 0.01, "{travel} > {bound}");
    // The driver sends motion after H3 anyway: refused.
    let out = r.motion(r.plant.q);
    assert!(out.events.iter().any(|e| matches!(e, Event::Rejected { .. })));
    r.run(100);
    let out = r.enable();
    assert_eq!(out.status.state, State::Unhomed);
    assert_eq!(out.status.homing, HomingStatus::Failed);
}
