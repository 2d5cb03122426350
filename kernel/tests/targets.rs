//! What the kernel takes as a target and what it refuses whole: before
//! and during homing, non-finite and out-of-range values, the closed
//! target limits (exactly at a limit is inside), and a stream sample
//! farther than one segment can travel (SAFETY.md SR-3, SR-15, SR-17,
//! SR-30; docs/PROTOCOL.md 6.3). Both numeric variants, every tick checked
//! by the safety monitor (the common rig).
#![allow(clippy::needless_range_loop)] // six axes: indices read best

mod common;

use common::{both, homed, target, Rig, START};
use kernel::config::{ms_to_ticks, AXES, PAROL6};
use kernel::{Event, MotionKind, MotionTarget, Reject, Request, RequestKind, Scalar, State};

both!(
    motion_refused_before_homing_and_during_homing,
    nan_and_out_of_range_targets_are_rejected_whole,
    targets_exactly_at_the_limits_are_accepted_and_just_outside_rejected,
    target_limits_are_closed_intervals_up_to_the_widened_bound,
    a_far_stream_sample_is_refused_as_a_jump,
);

const HOME_POSE: [f64; AXES] = [0.0; AXES];

/// C++ defect 4 (docs/spec/robot.md section 6): commands during homing moved the arm when homing ended.
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

/// C++ defect 5 (docs/spec/robot.md section 6): unparseable fields became 0.0 targets; NaN passed every clamp.
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
/// either side (`TargetLimits::check`).
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

/// SR-3 and `TargetLimits`: a joint's position limits are a closed interval,
/// widened outward by one `f32` ulp so that the fixed-point variant still
/// accepts a command of exactly the limit; the widened bound itself is
/// inside. Catches: `pos < lo` as `pos <= lo`, `pos > hi` as `pos >= hi`
/// (the existing scenario sends the configured limit, one ulp inside).
fn target_limits_are_closed_intervals_up_to_the_widened_bound<S: Scalar>() {
    let mut r = homed::<S>();
    let q = r.plant.q.map(|x| S::from_f32(x as f32));
    for j in 0..AXES {
        let c = &PAROL6.joints[j];
        let lo = S::from_f32(c.limit_min.next_down());
        let hi = S::from_f32(c.limit_max.next_up());
        for pos in [lo, hi] {
            let mut t = MotionTarget { position: q, velocity: [S::ZERO; AXES], kind: MotionKind::GoTo };
            t.position[j] = pos;
            assert_eq!(r.k.validate(&t), Ok(()), "J{} at {pos:?}", j + 1);
            let out = r.tick(Some(Request::Motion(t)));
            assert!(out.events.is_empty(), "J{} at {pos:?}: {:?}", j + 1, out.events);
            // Back where it was, at once (a go-to replaces the target).
            let t = MotionTarget { position: q, velocity: [S::ZERO; AXES], kind: MotionKind::GoTo };
            assert!(r.tick(Some(Request::Motion(t))).events.is_empty());
        }
        // A clear step beyond each bound is refused whole.
        let d = S::from_f32(1e-3);
        for pos in [lo.minus(d), hi.plus(d)] {
            let mut t = MotionTarget { position: q, velocity: [S::ZERO; AXES], kind: MotionKind::GoTo };
            t.position[j] = pos;
            let out = r.tick(Some(Request::Motion(t)));
            let reason = Reject::PositionOutOfLimits { axis: j as u8 };
            assert!(
                out.events.iter().any(|e| *e == Event::Rejected { request: RequestKind::Motion, reason }),
                "J{} at {pos:?}: {:?}",
                j + 1,
                out.events
            );
        }
    }
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
    near[0] += 0.04;
    assert!(r.motion(near).events.is_empty());
}

/// PROTOCOL.md 6.3: a first stream sample from rest is accepted within the
/// set-point's reach over one longest segment (`max_acceleration T^2 / 2`
/// plus `target_jump_tolerance`), and the next within the speed limit over
/// one longest segment of it (plus the tolerance): one exactly that far is
/// accepted, one a step farther refused. Fixed-point only: its sums are
/// exact, so the sample lies exactly that far (in `f32`, `sp + d - sp` need
/// not be `d`). Survivors: each bound's `<=` as `<`.
fn a_stream_sample_exactly_one_segment_away_is_accepted<S: Scalar>() {
    let mut r = homed::<S>();
    for j in [0usize, 3] {
        let c = &PAROL6.joints[j];
        let seg = ms_to_ticks(PAROL6.segment_max_ms, PAROL6.tick_hz);
        let seg_s = seg as f32 / PAROL6.tick_hz as f32;
        let tol = S::from_f32(PAROL6.target_jump_tolerance);
        let reach = S::from_f32(c.max_acceleration * seg_s * seg_s * 0.5).plus(tol);
        let step = S::from_f32(c.max_velocity / PAROL6.tick_hz as f32).times_int(seg as i32).plus(tol);
        // At rest at a go-to's target: set-point and previous target agree.
        let mut p = r.plant.q;
        p[j] = 0.0;
        r.goto(p);
        r.run(2_000);
        let sp = r.last.unwrap().status.setpoint;
        assert_eq!(sp[j], S::from_f32(0.0), "J{} at rest at its target", j + 1);
        let far = |x: S| {
            let mut t = MotionTarget { position: sp, velocity: [S::ZERO; AXES], kind: MotionKind::Stream };
            t.position[j] = x;
            Request::Motion(t)
        };
        let reason = Reject::TargetJump { axis: j as u8 };
        let refused = |out: &kernel::TickOutput<S>| {
            out.events.iter().any(|e| *e == Event::Rejected { request: RequestKind::Motion, reason })
        };
        let lsb = S::from_f32(1e-4);
        let out = r.tick(Some(far(sp[j].minus(reach).minus(lsb))));
        assert!(refused(&out), "J{}: {:?}", j + 1, out.events);
        let first = sp[j].minus(reach);
        let out = r.tick(Some(far(first)));
        assert!(out.events.is_empty(), "J{} exactly the reach away: {:?}", j + 1, out.events);
        let out = r.tick(Some(far(first.minus(step).minus(lsb))));
        assert!(refused(&out), "J{}: {:?}", j + 1, out.events);
        let out = r.tick(Some(far(first.minus(step))));
        assert!(out.events.is_empty(), "J{} exactly one segment from the last sample: {:?}", j + 1, out.events);
        // A go-to back (it replaces the stream's target and disarms the
        // command timeout); at rest again.
        let back = MotionTarget { position: sp, velocity: [S::ZERO; AXES], kind: MotionKind::GoTo };
        assert!(r.tick(Some(Request::Motion(back))).events.is_empty());
        r.run(2_000);
    }
}

#[test]
fn a_stream_sample_exactly_one_segment_away_is_accepted_fixed() {
    a_stream_sample_exactly_one_segment_away_is_accepted::<kernel::Fx>();
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
