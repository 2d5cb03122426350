//! Whole-kernel scenarios, run for both numeric variants, including the C++
//! firmware's defects (ROBOT.md section 6) as regression tests.
#![allow(clippy::needless_range_loop)] // six axes: indices read best

mod common;

use common::{target, EncoderFault, Rig};
use kernel::config::{AXES, PAROL6};
use kernel::homing::Phase;
use kernel::{Event, FaultReason, Fx, HomingStatus, Reject, Request, RequestKind, Scalar, State};

const START: [f64; AXES] = [0.3, 0.2, -0.4, 0.5, -0.3, 1.0];
const HOME_POSE: [f64; AXES] = [0.0; AXES];

macro_rules! both {
    ($($name:ident),* $(,)?) => {
        mod f32_variant { $( #[test] fn $name() { super::$name::<f32>(); } )* }
        mod fixed_variant { $( #[test] fn $name() { super::$name::<kernel::Fx>(); } )* }
    };
}

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
    homing_timeout_reports_h3_and_refuses_motion,
    hardware_overrun_faults,
    homed_axis_leaving_its_limits_faults,
    enable_is_refused_when_a_fault_is_detected_in_the_same_tick,
    home_during_boot_is_queued,
    acceleration_is_limited_in_operational,
    encoder_lost_while_fast_does_not_block_enable_forever,
    a_single_far_target_is_cut_short_by_the_timeout,
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

fn homed_axis_leaving_its_limits_faults<S: Scalar>() {
    let mut r = homed::<S>();
    // J2 is dragged harder than its 3 rad/s clamp can resist, so it drifts at
    // a net 0.5 rad/s (below its runaway speed) past its upper limit + margin.
    r.plant.disturbance[1] = 3.5;
    let n = r.run_until(5_000, |o| o.status.state == State::Fault).expect("position fault");
    let out = r.last.unwrap();
    assert_eq!(out.status.fault.unwrap().reason, FaultReason::PositionLimit { axis: 1 });
    let over = r.plant.q[1] - (PAROL6.joints[1].limit_max + PAROL6.position_margin) as f64;
    assert!((0.0..0.01).contains(&over), "detected {over} rad past the margin after {n} ticks");
    // Enable is refused while it is still outside.
    r.plant.disturbance[1] = 0.0;
    let out = r.enable();
    assert!(out.events.iter().any(|e| *e
        == Event::Rejected {
            request: RequestKind::Enable,
            reason: Reject::CauseActive(FaultReason::PositionLimit { axis: 1 })
        }));

    // The lower side: J3 (its switch is at the upper end) dragged below.
    let mut r = homed::<S>();
    r.plant.disturbance[2] = -(f64::from(PAROL6.joints[2].max_velocity) + 0.5);
    r.run_until(10_000, |o| o.status.state == State::Fault).expect("position fault");
    assert_eq!(r.last.unwrap().status.fault.unwrap().reason, FaultReason::PositionLimit { axis: 2 });
    r.plant.disturbance[2] = 0.0;
    let out = r.enable();
    assert!(
        out.events.iter().any(|e| *e
            == Event::Rejected {
                request: RequestKind::Enable,
                reason: Reject::CauseActive(FaultReason::PositionLimit { axis: 2 })
            }),
        "{:?}",
        out.events
    );
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
    // The last command was 9 ticks before this loop began.
    let started = started.expect("soft stop started") + 9;
    assert!((100..=102).contains(&started), "timeout {started} ticks after the last command");
    let stop = ticks_to_stop.unwrap() + 9;
    assert!(stop <= 200, "standstill {stop} ms after the last command (budget 200)");
    assert_eq!(r.k.state(), State::SoftEstop);
    assert!(r.events.iter().any(|e| matches!(e, Event::SoftEstop { .. })));
    assert!(r.events.contains(&Event::Stopped));
    // Latched: motion is refused until enable.
    let out = r.motion(r.plant.q);
    assert!(out.events.iter().any(|e| *e == Event::Rejected { request: RequestKind::Motion, reason: Reject::Latched }));
}

/// The configurator's "go to" is a single command. The seed (and issue 2)
/// define the soft E-stop by the command timeout alone: 100 ms after that
/// command the arm ramps down and latches, wherever the set-point is. A
/// settle-until-arrival variant was built and reverted (session 2) because
/// it departs from that rule; this test pins the decision.
fn a_single_far_target_is_cut_short_by_the_timeout<S: Scalar>() {
    let mut r = homed::<S>();
    let mut p = r.plant.q;
    p[0] += 1.2; // J1 at 3 rad/s: 400 ms of set-point travel
    let out = r.motion(p);
    assert!(out.events.is_empty(), "{:?}", out.events);
    let started = r.run_until(400, |o| o.status.state == State::Stopping).expect("the timeout fires");
    assert!((100..=102).contains(&started), "soft stop {started} ticks after the command");
    let stopped = r.run_until(200, |o| o.status.state == State::SoftEstop).expect("and latches");
    assert!(started + stopped <= 200, "standstill {} ms after the command", started + stopped);
    let short = (p[0] - r.plant.q[0]).abs();
    println!("J1 stopped {short:.3} rad short of a 1.2 rad go-to");
    assert!(short > 0.5, "the move was cut short, not completed");
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
        let mut t = kernel::MotionTarget { position: q, velocity: [S::ZERO; AXES], kind: kernel::MotionKind::Stream };
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
    r.motion(r.plant.q);
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
    r.motion(p);
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
        r.motion(p);
    }
    let out = faulted.expect("runaway detected");
    assert_eq!(out.status.fault.unwrap().reason, FaultReason::Runaway { axis: 4 });
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
    let mut prev = [0.0f32; AXES];
    for _ in 0..200 {
        let out = r.motion(p);
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

/// The segment length is the typical interval, not the last one: one lost
/// packet does not slow the next segment (the C++ firmware stretched it).
fn dropped_packet_does_not_stretch_motion<S: Scalar>() {
    let mut r = homed::<S>();
    let mut p = r.plant.q;
    for _ in 0..10 {
        p[0] += 0.005;
        r.motion(p);
        r.run(9);
    }
    // Drop one packet: 20 ms gap.
    r.run(10);
    p[0] += 0.01;
    let out = r.motion(p);
    let start = out.status.setpoint[0].to_f32();
    let out = r.run(10);
    let end = out.status.setpoint[0].to_f32();
    let target = p[0] as f32;
    assert!((end - target).abs() < 1e-4, "segment stretched: {start} -> {end}, target {target}");
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

fn homing_timeout_reports_h3_and_refuses_motion<S: Scalar>() {
    let mut r = Rig::<S>::new(START);
    r.run(2);
    // J6's switch is unplugged: it never triggers (move it out of reach).
    r.plant.cfg.joints[5].homing.switch_position = 100.0;
    r.tick(Some(Request::Home));
    let n = r.run_until(60_000, |o| o.status.state != State::Homing).unwrap();
    let out = r.last.unwrap();
    assert_eq!(out.status.state, State::Fault);
    assert_eq!(out.status.homing, HomingStatus::Failed);
    assert!(matches!(out.status.fault.unwrap().reason, FaultReason::HomingTimeout { axis: 5, phase: Phase::FastSeek }));
    assert!(n <= 12_001, "{n}");
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
    assert!(worst_p < 1e-3, "{worst_p}");
    assert!(worst_v < 0.05, "{worst_v}");
}
