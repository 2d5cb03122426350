//! Whole-kernel scenarios, run for both numeric variants, including the C++
//! firmware's defects (ROBOT.md section 6) as regression tests.
#![allow(clippy::needless_range_loop)] // six axes: indices read best

mod common;

use common::both;

use common::{target, EncoderFault, Rig};
use kernel::config::{AXES, PAROL6};
use kernel::homing::Phase;
use kernel::{Event, FaultReason, Fx, HomingStatus, Reject, Request, RequestKind, Scalar, State};

const START: [f64; AXES] = [0.3, 0.2, -0.4, 0.5, -0.3, 1.0];
const HOME_POSE: [f64; AXES] = [0.0; AXES];

both!(
    power_on_does_not_move,
    homing_runs_in_the_seed_order,
    second_homing_rezeroes,
    homing_zero_comes_from_the_encoder_reading,
    motion_refused_before_homing_and_during_homing,
    no_timeout_between_homing_and_first_command,
    command_timeout_soft_stops_monotonically_and_latches,
    enable_after_soft_stop_resyncs_without_a_jump,
    nan_and_out_of_range_targets_are_rejected_whole,
    limit_switch_outside_homing_faults_and_enable_is_refused_while_pressed,
    runaway_faults_every_axis_in_the_same_tick,
    encoder_loss_and_jump_fault_and_require_rehoming,
    fault_keeps_its_first_reason,
    tracking_at_100_hz,
    dropped_packet_does_not_stretch_motion,
    per_joint_homing_respects_dependencies,
    dead_homing_switch_faults_within_its_travel_and_reports_h3,
    hardware_overrun_faults,
    homed_axis_leaving_its_limits_faults,
    enable_is_refused_when_a_fault_is_detected_in_the_same_tick,
    home_during_boot_is_queued,
    acceleration_is_limited_in_operational,
    encoder_lost_while_fast_does_not_block_enable_forever,
    a_go_to_completes_and_holds,
    a_far_stream_sample_is_refused_as_a_jump,
    targets_exactly_at_the_limits_are_accepted_and_just_outside_rejected,
    boot_timeout_names_the_unready_encoder_on_time,
    counts_out_of_range_are_lost_samples,
    a_fault_during_homing_leaves_the_aborted_axes_unhomed,
    enable_is_refused_while_an_axis_moves_faster_than_its_limit,
    enable_while_stopping_is_refused_as_stopping,
    home_outside_boot_starts_at_once,
    unhomed_arm_outside_the_limits_is_not_a_fault,
    switch_of_a_homed_axis_at_rest_during_homing_faults,
);

/// A joint dragged off its path by an outside force faults on its
/// following error long before it can leave its limits (the position limit
/// is the second line: it keeps enable refused while the joint is outside).
fn homed_axis_leaving_its_limits_faults<S: Scalar>() {
    let mut r = homed::<S>();
    // J2 is dragged harder than its 3 rad/s clamp can resist: it drifts at
    // a net 0.5 rad/s toward its upper limit.
    let q0 = r.plant.q[1];
    r.plant.disturbance[1] = 3.5;
    let n = r.run_until(5_000, |o| o.status.state == State::Fault).expect("fault");
    let out = r.last.unwrap();
    assert_eq!(out.status.fault.unwrap().reason, FaultReason::FollowingError { axis: 1 });
    // The arm is pushed at up to 3.5 rad/s (its output ramps against the
    // push at the acceleration limit): 0.05 rad of error plus the 20 ms the
    // error may last, at that speed.
    let drift = r.plant.q[1] - q0;
    // Plus 20 mrad: the estimate lags the true angle while it accelerates.
    let bound = f64::from(PAROL6.following_error) + 3.5 * (f64::from(PAROL6.following_error_ms) + 1.0) / 1000.0 + 0.02;
    println!("J2 dragged at 3.5 rad/s: following-error fault after {n} ticks, {drift:.3} rad (bound {bound:.3})");
    assert!(drift < bound, "faulted after {drift} rad of drift");
    // Still dragged (outputs are zero in Fault) until past its limit + margin.
    while r.plant.q[1] <= f64::from(PAROL6.joints[1].limit_max + PAROL6.position_margin) + 0.01 {
        r.tick(None);
    }
    r.plant.disturbance[1] = 0.0;
    r.run(300); // at rest again (a moving joint would be refused as too fast)
    let out = r.enable();
    assert!(out.events.iter().any(|e| *e
        == Event::Rejected {
            request: RequestKind::Enable,
            reason: Reject::CauseActive(FaultReason::PositionLimit { axis: 1 })
        }));

    // The lower side: J3 (its switch is at the upper end) dragged below.
    let mut r = homed::<S>();
    r.plant.disturbance[2] = -(f64::from(PAROL6.joints[2].max_velocity) + 0.5);
    r.run_until(10_000, |o| o.status.state == State::Fault).expect("fault");
    assert_eq!(r.last.unwrap().status.fault.unwrap().reason, FaultReason::FollowingError { axis: 2 });
}

fn homed<S: Scalar>() -> Rig<S> {
    let mut r = Rig::<S>::new(START);
    r.boot_and_home();
    r
}

/// C++ defect 1: the first encoder read returned 0 and each joint drove
/// toward it.
fn power_on_does_not_move<S: Scalar>() {
    let mut r = Rig::<S>::new(START);
    let out = r.tick(None);
    assert_eq!(out.status.state, State::Unhomed);
    assert!(out.events.iter().any(|e| *e == Event::Ready));
    let q0 = r.plant.q;
    r.run(2000);
    assert_eq!(r.plant.q, q0, "nothing may move at power-on");
    // The estimate starts at the reading, not at 0 (C++ defect 10 too).
    let est = r.last.unwrap().status.position;
    for i in 0..AXES {
        let j = &PAROL6.joints[i];
        let want = r.plant.counts(i) as f64 * j.rad_per_count();
        assert!((est[i].to_f32() as f64 - want).abs() < 1e-4, "axis {i}");
    }
}

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

/// C++ defect 2: homing worked once.
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

/// C++ defect 4: commands during homing moved the arm when homing ended.
fn motion_refused_before_homing_and_during_homing<S: Scalar>() {
    let mut r = Rig::<S>::new(START);
    r.run(2);
    let out = r.motion(HOME_POSE);
    assert!(out
        .events
        .iter()
        .any(|e| *e == Event::Rejected { request: RequestKind::Motion, reason: Reject::NotHomed }));
    r.tick(Some(Request::Home));
    r.run(100);
    let out = r.motion([0.1; AXES]);
    assert!(out.events.iter().any(|e| *e == Event::Rejected { request: RequestKind::Motion, reason: Reject::Homing }));
    r.run_until(60_000, |o| o.status.state != State::Homing).unwrap();
    // After homing the set-points are the measured positions: nothing moves.
    let q = r.plant.q;
    r.run(500);
    for i in 0..AXES {
        assert!((r.plant.q[i] - q[i]).abs() < 1e-3, "axis {i} moved after homing");
    }
}

/// The ROS 2 driver streams only after it sees H2; the timeout is armed by
/// the first accepted motion command, so a long pause before it is safe.
fn no_timeout_between_homing_and_first_command<S: Scalar>() {
    let mut r = homed::<S>();
    let out = r.run(5_000);
    assert_eq!(out.status.state, State::Operational);
    assert!(!out.status.timeout_armed);
    let out = r.motion(r.plant.q);
    assert!(out.status.timeout_armed);
}

fn command_timeout_soft_stops_monotonically_and_latches<S: Scalar>() {
    let mut r = homed::<S>();
    // Stream a fast move on every axis, then stop sending.
    let mut p = r.plant.q;
    for _ in 0..50 {
        for (i, x) in p.iter_mut().enumerate() {
            let dir = if PAROL6.joints[i].homing.direction.sign() > 0.0 { -1.0 } else { 1.0 };
            *x += dir * 0.02;
        }
        r.motion(p);
        r.run(9);
    }
    // A last sample 0.25 rad further (inside the stream-continuity bound):
    // the set-points are still on their way when the timeout expires, so
    // the motion is interrupted (a stream ending at rest holds instead).
    for (i, x) in p.iter_mut().enumerate() {
        let dir = if PAROL6.joints[i].homing.direction.sign() > 0.0 { -1.0 } else { 1.0 };
        *x += dir * 0.25;
    }
    assert!(r.motion(p).events.is_empty());
    let moving = r.last.unwrap().act.velocity;
    assert!(moving.iter().all(|v| v.abs().to_f32() > 0.5), "{moving:?}");
    // Silence: 100 ms of timeout, then the ramp.
    let mut prev = moving;
    let mut ticks_to_stop = None;
    let mut started = None;
    for t in 1..=400u32 {
        let out = r.tick(None);
        if out.status.state == State::Stopping && started.is_none() {
            started = Some(t);
        }
        if started.is_some() {
            for i in 0..AXES {
                let (a, b) = (out.act.velocity[i], prev[i]);
                assert!(a.abs() <= b.abs(), "axis {i}: speed increased {b:?} -> {a:?}");
                assert!(a == S::ZERO || (a > S::ZERO) == (b > S::ZERO), "axis {i} reversed");
                let dv = (b.to_f32() - a.to_f32()).abs();
                let bound = PAROL6.joints[i].max_velocity / 100.0 * 1.01;
                assert!(dv <= bound, "axis {i}: decel {dv} per tick above {bound}");
            }
        }
        if out.act.velocity.iter().all(|v| *v == S::ZERO) && ticks_to_stop.is_none() {
            ticks_to_stop = Some(t);
        }
        prev = out.act.velocity;
    }
    // The last command was in the tick before this loop began.
    let started = started.expect("soft stop started");
    assert!((100..=102).contains(&started), "timeout {started} ticks after the last command");
    let stop = ticks_to_stop.unwrap();
    assert!(stop <= 200, "standstill {stop} ms after the last command (budget 200)");
    assert_eq!(r.k.state(), State::SoftEstop);
    assert!(r.events.iter().any(|e| matches!(e, Event::SoftEstop { .. })));
    assert!(r.events.contains(&Event::Stopped));
    // Latched: motion is refused until enable.
    let out = r.motion(r.plant.q);
    assert!(out.events.iter().any(|e| *e == Event::Rejected { request: RequestKind::Motion, reason: Reject::Latched }));
}

/// The configurator's "go to" is a single frame with every velocity zero:
/// a point-to-point move that completes (the command timeout does not cut
/// it) and holds. Before issue 12 it was cut 0.9 rad short by the timeout.
fn a_go_to_completes_and_holds<S: Scalar>() {
    let mut r = homed::<S>();
    let mut p = r.plant.q;
    p[0] += 1.2; // J1 at 3 rad/s, 30 rad/s^2: 0.5 s
    let out = r.goto(p);
    assert!(out.events.is_empty(), "{:?}", out.events);
    assert!(!out.status.timeout_armed, "a go-to does not arm the timeout");
    let goal = S::from_f32(p[0] as f32);
    let n = r.run_until(2_000, |o| o.status.setpoint[0] == goal).expect("arrives");
    assert!((480..=560).contains(&n), "set-point arrived after {n} ticks");
    r.run(300);
    assert_eq!(r.k.state(), State::Operational, "holds, no soft stop: {:?}", r.events);
    assert!((r.plant.q[0] - p[0]).abs() < 0.01, "J1 {} vs {}", r.plant.q[0], p[0]);
    assert!(!r.events.iter().any(|e| matches!(e, Event::SoftEstop { .. })));
}

/// A driver-dialect (stream) target farther from the set-point than one
/// segment can travel is refused whole, and nothing moves.
fn a_far_stream_sample_is_refused_as_a_jump<S: Scalar>() {
    let mut r = homed::<S>();
    let mut p = r.plant.q;
    p[0] += 1.2;
    let out = r.motion(p);
    assert!(out
        .events
        .iter()
        .any(|e| *e == Event::Rejected { request: RequestKind::Motion, reason: Reject::TargetJump { axis: 0 } }));
    let out = r.run(50);
    assert!(out.act.velocity.iter().all(|v| v.abs().to_f32() < 0.01));
    // A sample within one segment's travel is taken.
    let mut near = r.plant.q;
    near[0] += 0.1;
    assert!(r.motion(near).events.is_empty());
}

fn enable_after_soft_stop_resyncs_without_a_jump<S: Scalar>() {
    let mut r = homed::<S>();
    let mut p = r.plant.q;
    p[0] += 0.05;
    r.motion(p);
    r.run_until(1000, |o| o.status.state == State::SoftEstop).unwrap();
    let out = r.enable();
    assert!(out.events.iter().any(|e| *e == Event::Enabled(State::Operational)));
    assert_eq!(out.status.homing, HomingStatus::Complete, "still homed: H2");
    // Set-points equal the estimates: the control output is ~zero.
    for i in 0..AXES {
        assert!((out.status.setpoint[i].to_f32() - out.status.position[i].to_f32()).abs() < 1e-3);
        assert!(out.act.velocity[i].abs().to_f32() < 0.01, "axis {i} lurched: {:?}", out.act.velocity[i]);
    }
    assert!(!out.status.timeout_armed);
    // Enable again: nothing to clear.
    let out = r.enable();
    assert!(out.events.iter().any(|e| matches!(e, Event::Rejected { reason: Reject::NothingToClear, .. })));
}

/// C++ defect 5: unparseable fields became 0.0 targets; NaN passed every clamp.
fn nan_and_out_of_range_targets_are_rejected_whole<S: Scalar>() {
    let mut r = homed::<S>();
    let q = r.plant.q;
    r.motion(q);
    let before: Vec<f32> = r.last.unwrap().status.setpoint.iter().map(|s| s.to_f32()).collect();
    let mut bad = q.map(|x| S::from_f32(x as f32));
    bad[3] = S::from_f32(10.0); // J4 far outside its limit
    let out = r.tick(Some(Request::Motion(kernel::MotionTarget {
        position: bad,
        velocity: [S::ZERO; AXES],
        kind: kernel::MotionKind::Stream,
    })));
    assert!(out.events.iter().any(
        |e| *e == Event::Rejected { request: RequestKind::Motion, reason: Reject::PositionOutOfLimits { axis: 3 } }
    ));
    // (A real NaN target exists only in the f32 variant: see f32_nan_target_rejected.)
    let mut t = target::<S>(q);
    t.velocity[5] = S::from_f32(7.0);
    let out = r.tick(Some(Request::Motion(t)));
    assert!(out
        .events
        .iter()
        .any(|e| matches!(e, Event::Rejected { reason: Reject::VelocityTooHigh { axis: 5 }, .. })));
    // No part of a rejected frame was applied.
    let after: Vec<f32> = r.last.unwrap().status.setpoint.iter().map(|s| s.to_f32()).collect();
    for i in 0..AXES {
        assert!((after[i] - before[i]).abs() < 1e-3);
    }
    assert_eq!(r.k.state(), State::Operational);
}

/// Limits are closed intervals: a target exactly at a joint limit, or a
/// velocity of exactly vmax, is accepted; one step outside is rejected, on
/// either side. (Added for mutants of `TargetLimits::check` that the
/// kernel's tests did not catch.)
fn targets_exactly_at_the_limits_are_accepted_and_just_outside_rejected<S: Scalar>() {
    let mut r = homed::<S>();
    let q = r.plant.q.map(|x| S::from_f32(x as f32));
    let j = &PAROL6.joints[2];
    let at = |pos: S, vel: S| {
        // A go-to: far targets are its business (a stream sample that far
        // would be a TARGET_JUMP).
        let mut t = kernel::MotionTarget { position: q, velocity: [S::ZERO; AXES], kind: kernel::MotionKind::GoTo };
        t.position[2] = pos;
        t.velocity[2] = vel;
        Request::Motion(t)
    };
    let (lo, hi, vmax) = (S::from_f32(j.limit_min), S::from_f32(j.limit_max), S::from_f32(j.max_velocity));
    for (pos, vel) in [(lo, S::ZERO), (hi, S::ZERO), (q[2], vmax), (q[2], vmax.neg())] {
        let out = r.tick(Some(at(pos, vel)));
        assert!(out.events.is_empty(), "{pos:?} {vel:?}: {:?}", out.events);
    }
    let d = S::from_f32(0.01);
    for (pos, vel, reason) in [
        (lo.minus(d), S::ZERO, Reject::PositionOutOfLimits { axis: 2 }),
        (hi.plus(d), S::ZERO, Reject::PositionOutOfLimits { axis: 2 }),
        (q[2], vmax.plus(d), Reject::VelocityTooHigh { axis: 2 }),
        (q[2], vmax.plus(d).neg(), Reject::VelocityTooHigh { axis: 2 }),
    ] {
        let out = r.tick(Some(at(pos, vel)));
        assert!(
            out.events.iter().any(|e| *e == Event::Rejected { request: RequestKind::Motion, reason }),
            "{pos:?} {vel:?}: {:?}",
            out.events
        );
    }
}

/// An encoder that never reads: Boot lasts exactly the boot timeout, then a
/// fault naming that encoder (kept by `fault()`).
fn boot_timeout_names_the_unready_encoder_on_time<S: Scalar>() {
    let mut r = Rig::<S>::new(START);
    r.plant.encoder[4] = EncoderFault::Lost;
    let n = kernel::config::ms_to_ticks(PAROL6.boot_timeout_ms, PAROL6.tick_hz);
    for t in 0..n {
        let out = r.tick(None);
        assert_eq!(out.status.state, State::Boot, "tick {t}");
    }
    let out = r.tick(None);
    assert_eq!(out.status.state, State::Fault);
    let want = FaultReason::EncoderNotReady { axis: 4 };
    assert_eq!(out.status.fault.unwrap().reason, want);
    assert_eq!(r.k.fault().map(|f| f.reason), Some(want));
}

/// A reading of 4096 or more is not a count of a 12-bit encoder: it is
/// treated as a lost sample (ridden through, then a fault), never unwrapped.
fn counts_out_of_range_are_lost_samples<S: Scalar>() {
    let mut r = homed::<S>();
    let limit = PAROL6.encoder_invalid_limit;
    let mut out = None;
    for k in 0..=limit {
        let mut sense = r.plant.sense();
        sense.encoders[1] = kernel::EncoderSample::Count(4096);
        let o = r.tick_with(sense, None);
        let want = if k < limit { State::Operational } else { State::Fault };
        assert_eq!(o.status.state, want, "sample {k}");
        out = Some(o);
    }
    assert_eq!(out.unwrap().status.fault.unwrap().reason, FaultReason::EncoderLost { axis: 1 });
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

/// Enable is refused while an axis moves faster than its velocity limit
/// (here pushed at 1.05 vmax, below the runaway threshold), and accepted
/// once it has stopped.
fn enable_is_refused_while_an_axis_moves_faster_than_its_limit<S: Scalar>() {
    let mut r = homed::<S>();
    r.plant.force_switch = 0b1;
    assert_eq!(r.tick(None).status.state, State::Fault);
    r.plant.force_switch = 0;
    let vmax = f64::from(PAROL6.joints[3].max_velocity);
    r.plant.disturbance[3] = 1.05 * vmax;
    r.run(100);
    let out = r.enable();
    assert!(
        out.events.iter().any(|e| *e
            == Event::Rejected {
                request: RequestKind::Enable,
                reason: Reject::CauseActive(FaultReason::Runaway { axis: 3 })
            }),
        "{:?}",
        out.events
    );
    r.plant.disturbance[3] = 0.0;
    r.run(300);
    assert_eq!(r.enable().status.state, State::Operational);
}

/// During the soft-stop ramp enable is refused with its own reason.
fn enable_while_stopping_is_refused_as_stopping<S: Scalar>() {
    let mut r = homed::<S>();
    let mut p = r.plant.q;
    p[0] += 0.2; // still on its way when the timeout expires
    r.motion(p);
    r.run_until(200, |o| o.status.state == State::Stopping).expect("timeout");
    let out = r.enable();
    assert!(
        out.events.iter().any(|e| *e == Event::Rejected { request: RequestKind::Enable, reason: Reject::Stopping }),
        "{:?}",
        out.events
    );
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

/// Before homing the estimate is not in the joint frame: a power-on pose
/// outside the joint limits is not a position fault (only homed, moving
/// axes are checked).
fn unhomed_arm_outside_the_limits_is_not_a_fault<S: Scalar>() {
    let mut r = Rig::<S>::new(START);
    r.run(3);
    // Pushed slowly (0.5 rad/s for 4 s) to 2 rad beyond J1's upper limit.
    r.plant.disturbance[0] = 0.5;
    let out = r.run(4000 + (1000.0 * (f64::from(PAROL6.joints[0].limit_max) - START[0])) as u32 * 2);
    r.plant.disturbance[0] = 0.0;
    assert!(out.status.position[0].to_f32() > PAROL6.joints[0].limit_max + 1.0, "{:?}", out.status.position);
    assert_eq!(out.status.state, State::Unhomed, "{:?}", out.status.fault);
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

/// C++ defect 4: enable cleared a fault while a limit switch was pressed.
fn limit_switch_outside_homing_faults_and_enable_is_refused_while_pressed<S: Scalar>() {
    {
        // A fault that loses no zero keeps homing complete (H2).
        let mut r = homed::<S>();
        r.plant.force_switch = 0b100;
        let out = r.tick(None);
        assert_eq!(out.status.state, State::Fault);
        assert_eq!(out.status.homing, HomingStatus::Complete);
    }
    let mut r = homed::<S>();
    r.motion(r.plant.q);
    r.plant.force_switch = 0b100; // J3
    let out = r.tick(None);
    assert_eq!(out.status.state, State::Fault);
    assert!(out.act.velocity.iter().all(|v| *v == S::ZERO));
    assert_eq!(out.status.fault.unwrap().reason, FaultReason::LimitSwitch { axis: 2 });
    let out = r.enable();
    assert!(out.events.iter().any(|e| *e
        == Event::Rejected {
            request: RequestKind::Enable,
            reason: Reject::CauseActive(FaultReason::LimitSwitch { axis: 2 })
        }));
    assert_eq!(out.status.state, State::Fault);
    r.plant.force_switch = 0;
    r.run(3);
    let out = r.enable();
    assert_eq!(out.status.state, State::Operational);
}

fn runaway_faults_every_axis_in_the_same_tick<S: Scalar>() {
    let mut r = homed::<S>();
    let mut p = r.plant.q;
    p[0] += 0.3;
    r.goto(p);
    r.run(5);
    // J5 is pushed by an outside force beyond its runaway threshold.
    r.plant.disturbance[4] = 9.0;
    let mut faulted = None;
    for _ in 0..200 {
        let out = r.tick(None);
        if out.status.state == State::Fault {
            faulted = Some(out);
            break;
        }
    }
    let out = faulted.expect("runaway detected");
    // Dragged at 9 rad/s, J5 is both off its path and too fast: whichever
    // check sees it first names it; every axis stops in that tick.
    let reason = out.status.fault.unwrap().reason;
    assert!(matches!(reason, FaultReason::Runaway { axis: 4 } | FaultReason::FollowingError { axis: 4 }), "{reason:?}");
    assert!(out.act.velocity.iter().all(|v| *v == S::ZERO), "all axes zero in the fault tick");
    assert!(out.act.step_rate.iter().all(|v| *v == 0));
}

fn encoder_loss_and_jump_fault_and_require_rehoming<S: Scalar>() {
    let limit = PAROL6.encoder_invalid_limit;
    // Up to `limit` lost samples in a row are ridden through (the observer
    // coasts); one more is a fault that zeroes every axis.
    let mut r = homed::<S>();
    r.plant.encoder[2] = EncoderFault::Lost;
    for _ in 0..limit {
        assert_eq!(r.tick(None).status.state, State::Operational);
    }
    let out = r.tick(None);
    assert_eq!(out.status.fault.unwrap().reason, FaultReason::EncoderLost { axis: 2 });
    assert!(out.act.velocity.iter().all(|v| *v == S::ZERO));
    // Only J3 loses its zero; homing is no longer complete (H0, not H2).
    assert_eq!(out.status.homed, 0b11_1011);
    assert_eq!(out.status.homing, HomingStatus::NotRequested);
    let out = r.enable();
    assert!(out.events.iter().any(|e| matches!(e, Event::Rejected { reason: Reject::CauseActive(_), .. })));
    r.plant.encoder[2] = EncoderFault::None;
    let out = r.enable();
    // J3's count was lost: it must be homed again; the others keep theirs.
    assert_eq!(out.status.state, State::Unhomed);
    assert_eq!(out.status.homed, 0b11_1011);
    assert_ne!(out.status.homing, HomingStatus::Complete);

    // A single glitch is skipped; a persistent jump faults.
    let mut r = homed::<S>();
    r.plant.glitch[1] = 1500;
    assert_eq!(r.tick(None).status.state, State::Operational);
    r.plant.glitch[1] = 0;
    assert_eq!(r.run(5).status.state, State::Operational);
    r.plant.glitch[1] = 1500;
    let out = r.run(limit + 1);
    assert!(matches!(out.status.fault.unwrap().reason, FaultReason::EncoderJump { axis: 1, .. }));
    assert!(out.act.velocity.iter().all(|v| *v == S::ZERO));
}

/// Found by the f32/fixed-point differential (CI, session 2): an encoder
/// lost while its joint moved near its velocity limit froze the estimate
/// there, and the enable check read the frozen velocity as a runaway, so
/// the arm could never be enabled again. A lost count is re-initialised
/// from its reading at enable (velocity 0): only the reading's presence is
/// a cause.
fn encoder_lost_while_fast_does_not_block_enable_forever<S: Scalar>() {
    let mut r = Rig::<S>::new(START);
    r.run(3);
    assert_eq!(r.k.state(), State::Unhomed);
    let j = 3;
    let vmax = f64::from(PAROL6.joints[j].max_velocity);
    // Something drives J4 at 1.05 vmax with the outputs at zero: above the
    // enable threshold, below the runaway fault threshold, so no fault yet.
    r.plant.disturbance[j] = 1.05 * vmax;
    let out = r.run(100);
    assert_eq!(out.status.state, State::Unhomed);
    assert!(f64::from(out.status.velocity[j].to_f32()) > vmax, "estimate follows the outside force");
    // Its encoder is lost for longer than the kernel rides through.
    r.plant.encoder[j] = EncoderFault::Lost;
    let out = r.run(PAROL6.encoder_invalid_limit + 1);
    assert_eq!(out.status.fault.unwrap().reason, FaultReason::EncoderLost { axis: j as u8 });
    // The arm stops and the encoder comes back.
    r.plant.disturbance[j] = 0.0;
    r.plant.encoder[j] = EncoderFault::None;
    r.run(50);
    let out = r.enable();
    assert_eq!(out.status.state, State::Unhomed, "events: {:?}", out.events);
    assert_eq!(out.status.velocity[j], S::ZERO);
}

/// Found by the model check: a fault detected while sensing in the same tick
/// as an enable must block that enable.
fn enable_is_refused_when_a_fault_is_detected_in_the_same_tick<S: Scalar>() {
    let mut r = homed::<S>();
    r.plant.force_switch = 0b1;
    assert_eq!(r.tick(None).status.state, State::Fault);
    r.plant.force_switch = 0;
    // Encoder J1 jumps persistently: detected while sensing in the enable tick.
    r.plant.glitch[0] = 1500;
    r.run(PAROL6.encoder_invalid_limit);
    let out = r.enable();
    assert_eq!(out.status.state, State::Fault);
    assert!(out.events.iter().any(|e| matches!(e, Event::Rejected { reason: Reject::CauseActive(_), .. })));
    assert!(!out.events.iter().any(|e| matches!(e, Event::Enabled(_))));
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

/// Enable, or a far target, never steps the velocity by more than one tick's
/// acceleration limit.
fn acceleration_is_limited_in_operational<S: Scalar>() {
    let mut r = homed::<S>();
    let mut p = r.plant.q;
    p[0] = 1.0; // far away: the control law alone would jump to vmax
    let first = r.goto(p);
    let mut prev = first.act.velocity.map(|v| v.to_f32());
    for _ in 0..200 {
        let out = r.tick(None);
        for i in 0..AXES {
            let v = out.act.velocity[i].to_f32();
            let a_step = PAROL6.joints[i].max_acceleration / PAROL6.tick_hz as f32;
            assert!((v - prev[i]).abs() <= a_step * 1.001 + 1e-6, "axis {i}: {} -> {v}", prev[i]);
            prev[i] = v;
        }
    }
    assert!(prev[0] > 2.9, "reaches full speed: {}", prev[0]);
}

fn fault_keeps_its_first_reason<S: Scalar>() {
    let mut r = homed::<S>();
    r.plant.force_switch = 0b1;
    r.tick(None);
    r.plant.encoder[5] = EncoderFault::Lost;
    r.plant.force_switch = 0b11_1111;
    let out = r.run(10);
    assert_eq!(out.status.fault.unwrap().reason, FaultReason::LimitSwitch { axis: 0 });
    let faults = r.events.iter().filter(|e| matches!(e, Event::Fault(_))).count();
    assert_eq!(faults, 1);
}

/// Tracking error at a 100 Hz command rate (ROBOT.md 5: under 8 mrad).
fn tracking_at_100_hz<S: Scalar>() {
    let mut r = homed::<S>();
    let q0 = r.plant.q;
    let mut worst = 0.0f64;
    let mut sum_sq = 0.0;
    let mut n = 0;
    for k in 0..300 {
        let t = k as f64 * 0.01;
        let p = q0.map(|x| x + 0.2 * (1.0 - (t * 2.0).cos()) * 0.5);
        r.motion(p);
        for _ in 0..10 {
            let out = r.tick(None);
            for i in 0..AXES {
                let e = out.status.setpoint[i].to_f32() as f64 - r.plant.q[i];
                worst = worst.max(e.abs());
                sum_sq += e * e;
                n += 1;
            }
        }
    }
    let rms = (sum_sq / n as f64).sqrt();
    println!("tracking at 100 Hz: max {:.2} mrad, rms {:.2} mrad", worst * 1e3, rms * 1e3);
    assert!(worst < 8e-3, "max tracking error {worst}");
}

/// The segment length is the typical interval, not the last one, and the
/// set-point never needs to stop between samples of a steady stream: one
/// lost packet does not stop or stall the motion (the C++ firmware stretched
/// the next segment). J3 streams at 2 rad/s at 100 Hz, one sample is lost.
fn dropped_packet_does_not_stretch_motion<S: Scalar>() {
    let mut r = homed::<S>();
    let mut p = r.plant.q;
    let mut prev = r.last.unwrap().status.setpoint[2].to_f32();
    let mut slowest = f32::MAX;
    for k in 0..40 {
        p[2] -= 0.02;
        if k != 25 {
            let o = r.motion(p);
            assert!(o.events.is_empty(), "{:?}", o.events);
        } else {
            r.tick(None);
        }
        for _ in 0..9 {
            let sp = r.tick(None).status.setpoint[2].to_f32();
            if k >= 15 {
                slowest = slowest.min((prev - sp) * 1000.0);
            }
            prev = sp;
        }
        prev = r.last.unwrap().status.setpoint[2].to_f32();
    }
    println!("J3 at 2 rad/s with one packet lost: slowest set-point speed {slowest:.3} rad/s");
    assert!(slowest > 1.2, "the stream stalled: {slowest} rad/s");
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

fn hardware_overrun_faults<S: Scalar>() {
    let mut r = homed::<S>();
    let mut sense = r.plant.sense();
    sense.hardware_fault = Some(kernel::HardwareFault::TickOverrun);
    let out = r.tick_with(sense, None);
    assert_eq!(out.status.fault.unwrap().reason, FaultReason::Hardware(kernel::HardwareFault::TickOverrun));
    assert!(out.act.velocity.iter().all(|v| *v == S::ZERO));
}

/// The f32 variant with a real NaN in a target.
#[test]
fn f32_nan_target_rejected() {
    let mut r = homed::<f32>();
    let mut t = target::<f32>(r.plant.q);
    t.position[1] = f32::NAN;
    let out = r.tick(Some(Request::Motion(t)));
    assert!(out.events.iter().any(|e| matches!(e, Event::Rejected { reason: Reject::NonFinite { axis: 1 }, .. })));
    let mut t = target::<f32>(r.plant.q);
    t.velocity[0] = f32::INFINITY;
    let out = r.tick(Some(Request::Motion(t)));
    assert!(out.events.iter().any(|e| matches!(e, Event::Rejected { reason: Reject::NonFinite { axis: 0 }, .. })));
    assert_eq!(out.status.state, State::Operational);
}

/// Both variants on the same scenario: their outputs stay close.
#[test]
fn variants_agree_on_the_same_scenario() {
    let mut a = Rig::<f32>::new(START);
    let mut b = Rig::<Fx>::new(START);
    a.run(2);
    b.run(2);
    a.tick(Some(Request::Home));
    b.tick(Some(Request::Home));
    let mut worst_v = 0.0f32;
    let mut worst_p = 0.0f64;
    for _ in 0..60_000 {
        let oa = a.tick(None);
        let ob = b.tick(None);
        assert_eq!(oa.status.state, ob.status.state);
        for i in 0..AXES {
            worst_v = worst_v.max((oa.act.velocity[i] - ob.act.velocity[i].to_f32()).abs());
            worst_p = worst_p.max((a.plant.q[i] - b.plant.q[i]).abs());
        }
        if oa.status.state != State::Homing {
            break;
        }
    }
    let q0 = a.plant.q;
    for k in 0..200 {
        let p = q0.map(|x| x + 0.1 * (k as f64 * 0.03).sin());
        let oa = a.motion(p);
        let ob = b.motion(p);
        assert_eq!(oa.status.state, ob.status.state);
        for _ in 0..9 {
            let oa = a.tick(None);
            let ob = b.tick(None);
            for i in 0..AXES {
                worst_v = worst_v.max((oa.act.velocity[i] - ob.act.velocity[i].to_f32()).abs());
                worst_p = worst_p.max((a.plant.q[i] - b.plant.q[i]).abs());
            }
        }
    }
    println!("f32 vs I8F24: max velocity difference {worst_v:.2e} rad/s, max position difference {worst_p:.2e} rad");
    // The set-point profile takes discrete decisions (accelerate, cruise,
    // brake, land) that rounding can put a tick apart in the two variants:
    // outputs may then differ by up to two ticks of acceleration (J3..J6:
    // 2 x 0.06 rad/s) for a tick; positions stay within a millirad.
    assert!(worst_p < 1e-3, "{worst_p}");
    assert!(worst_v < 0.13, "{worst_v}");
}
