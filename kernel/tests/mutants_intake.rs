//! Tests written for the survivors of a cargo-mutants run on the kernel's
//! logic files (`ci/mutants.sh`, `docs/MUTANTS.md`): each asserts the
//! behaviour SAFETY.md or docs/PROTOCOL.md specify, for both numeric
//! variants, every tick checked by the safety monitor (the common rig).
//! This file: command intake and the target limits
//! (`kernel/src/kernel/intake.rs`, `kernel/src/kernel/params.rs`).
#![allow(clippy::needless_range_loop)] // six axes: indices read best

mod common;

use common::{both, Rig};
use kernel::config::{ms_to_ticks, AXES, PAROL6};
use kernel::{Event, MotionKind, MotionTarget, Reject, Request, RequestKind, Scalar};

const START: [f64; AXES] = [0.3, 0.2, -0.4, 0.5, -0.3, 1.0];

both!(target_limits_are_closed_intervals_up_to_the_widened_bound,);

#[test]
fn a_stream_sample_exactly_one_segment_away_is_accepted_fixed() {
    a_stream_sample_exactly_one_segment_away_is_accepted::<kernel::Fx>();
}

fn homed<S: Scalar>() -> Rig<S> {
    let mut r = Rig::<S>::new(START);
    r.boot_and_home();
    r
}

/// SR-3 and `TargetLimits`: a joint's position limits are a closed interval,
/// widened outward by one `f32` ulp so that the fixed-point variant still
/// accepts a command of exactly the limit; the widened bound itself is
/// inside. Survivors: `pos < lo` as `pos <= lo`, `pos > hi` as `pos >= hi`
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

/// PROTOCOL.md 6.3: a stream sample "farther from the current set-point
/// (and from the previous target) than one segment can travel (the speed
/// limit times the longest segment, plus the braking distance from the speed
/// limit, plus `target_jump_tolerance`)" is refused: one exactly that far is
/// accepted, and one a step farther is refused. Fixed-point only: its sums
/// are exact, so the sample lies exactly that far from the set-point (in
/// `f32`, `sp + d - sp` need not be `d`). Survivor: the jump test's `>` as
/// `>=`.
fn a_stream_sample_exactly_one_segment_away_is_accepted<S: Scalar>() {
    let mut r = homed::<S>();
    for j in [0usize, 3] {
        let c = &PAROL6.joints[j];
        let seg_s = ms_to_ticks(PAROL6.segment_max_ms, PAROL6.tick_hz) as f32 / PAROL6.tick_hz as f32;
        let d = S::from_f32(
            c.max_velocity * seg_s + c.setpoint_braking_distance(c.max_velocity) + PAROL6.target_jump_tolerance,
        );
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
        let out = r.tick(Some(far(sp[j].plus(d).plus(S::from_f32(1e-4)))));
        let reason = Reject::TargetJump { axis: j as u8 };
        assert!(
            out.events.iter().any(|e| *e == Event::Rejected { request: RequestKind::Motion, reason }),
            "J{}: {:?}",
            j + 1,
            out.events
        );
        let out = r.tick(Some(far(sp[j].minus(d))));
        assert!(out.events.is_empty(), "J{} exactly one segment away: {:?}", j + 1, out.events);
        // A go-to back (it replaces the stream's target and disarms the
        // command timeout); at rest again.
        let back = MotionTarget { position: sp, velocity: [S::ZERO; AXES], kind: MotionKind::GoTo };
        assert!(r.tick(Some(Request::Motion(back))).events.is_empty());
        r.run(2_000);
    }
}
