//! Tests written for the survivors of a cargo-mutants run on the kernel's
//! logic files (`ci/mutants.sh`, `docs/MUTANTS.md`): each asserts the
//! behaviour SAFETY.md or docs/PROTOCOL.md specify, for both numeric
//! variants, every tick checked by the safety monitor (the common rig).
//! This file: command intake and the target limits
//! (`kernel/src/kernel/intake.rs`, `kernel/src/kernel/params.rs`).
#![allow(clippy::needless_range_loop)] // six axes: indices read best

mod common;

use common::Rig;
use kernel::config::{AXES, PAROL6};
use kernel::{Event, MotionKind, MotionTarget, Reject, Request, RequestKind, Scalar};

const START: [f64; AXES] = [0.3, 0.2, -0.4, 0.5, -0.3, 1.0];

macro_rules! both {
    ($($name:ident),* $(,)?) => {
        mod f32_variant { $( #[test] fn $name() { super::$name::<f32>(); } )* }
        mod fixed_variant { $( #[test] fn $name() { super::$name::<kernel::Fx>(); } )* }
    };
}

both!(target_limits_are_closed_intervals_up_to_the_widened_bound,);

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
