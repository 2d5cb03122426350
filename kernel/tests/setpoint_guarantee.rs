//! The set-point guarantee (`SAFETY.md` SR-18): a set-point stays inside
//! the interval spanned by its position when last at rest and every target
//! accepted since, and passes its current target only by the stopping
//! distance's excess at acceptance; a driver sample that would start a
//! stream inside a moving set-point's stopping distance is refused
//! (SR-30). Both numeric variants, every tick checked by the monitor.

mod common;

use common::{both, Rig};
use kernel::config::AXES;
use kernel::{Event, Reject, RequestKind, Scalar, State};

const START: [f64; AXES] = [0.3, 0.2, -0.4, 0.5, -0.3, 1.0];

both!(a_driver_frame_inside_a_go_to_s_stopping_distance_is_refused, a_go_to_s_set_point_stays_between_start_and_target);

fn homed<S: Scalar>() -> Rig<S> {
    let mut r = Rig::<S>::new(START);
    r.boot_and_home();
    r
}

/// A configurator go-to drives J6 from 0.5 toward -5.5 rad at full speed;
/// with its set-point past -0.134 rad (at 6 rad/s) a driver frame for
/// -0.250 rad arrives (0.12 rad ahead, inside the 0.37 rad stopping
/// distance). It is refused
/// (`TARGET_JUMP J6`): accepted, the set-point would run on to -0.50 rad
/// and the arm stop 0.25 rad past the frame. The go-to goes on to its target.
fn a_driver_frame_inside_a_go_to_s_stopping_distance_is_refused<S: Scalar>() {
    let mut r = homed::<S>();
    let mut p = r.plant.q;
    p[5] = 0.5;
    r.goto(p);
    r.run(3_000);
    let start = r.last.as_ref().map(|o| o.status.setpoint).unwrap();
    assert_eq!(start[5].to_f32(), 0.5);
    p[5] = -5.5;
    assert!(r.goto(p).events.is_empty());
    r.run_until(3_000, |o| o.status.setpoint[5].to_f32() <= -0.134).expect("on its way");
    let v = r.k.status(0).velocity[5].to_f32();
    assert!(v < -5.0, "J6 at full speed: {v}");
    let frame: [f64; AXES] = core::array::from_fn(|i| if i == 5 { -0.25 } else { p[i] });
    let out = r.motion(frame);
    assert!(
        out.events
            .iter()
            .any(|e| *e == Event::Rejected { request: RequestKind::Motion, reason: Reject::TargetJump { axis: 5 } }),
        "the frame inside the stopping distance was accepted: {:?}",
        out.events
    );
    // The go-to continues to its target, never past it, never back.
    let mut prev = out.status.setpoint[5].to_f32();
    for _ in 0..4_000 {
        let sp = r.tick(None).status.setpoint[5].to_f32();
        assert!(sp <= prev + 1e-6 && sp >= -5.5 - 1e-6, "{prev} -> {sp}");
        prev = sp;
    }
    assert_eq!(prev, S::from_f32(-5.5).to_f32());
    assert_eq!(r.k.state(), State::Operational);
}

/// The guarantee's interval on a go-to: from rest toward a target, the
/// set-point never leaves `[start, target]`, on every joint at once.
fn a_go_to_s_set_point_stays_between_start_and_target<S: Scalar>() {
    let mut r = homed::<S>();
    let from = r.last.as_ref().map(|o| o.status.setpoint.map(|x| f64::from(x.to_f32()))).unwrap();
    let to = [-1.0, 0.8, 1.0, -2.0, 2.0, -6.0];
    assert!(r.goto(to).events.is_empty());
    for _ in 0..5_000 {
        let sp = r.tick(None).status.setpoint;
        for i in 0..AXES {
            let (lo, hi) = (from[i].min(to[i]) - 1e-6, from[i].max(to[i]) + 1e-6);
            let x = f64::from(sp[i].to_f32());
            assert!(x >= lo && x <= hi, "J{}: {x} outside [{lo}, {hi}]", i + 1);
        }
    }
}

/// The proofs (Kani harnesses, SMT, the exhaustive sweep) build each
/// joint's set-point profile with `interp::joint_profile`: it is the one the
/// kernel runs, in both variants (at `setpoint_acceleration()`, not the
/// output's `max_acceleration`).
#[test]
fn the_proofs_profile_is_the_kernel_s() {
    use kernel::config::{PAROL6, PAROL6_VALIDATED};
    use kernel::interp::joint_profile;
    let (k32, _) = kernel::Kernel::<f32>::new(&PAROL6_VALIDATED);
    let (kfx, _) = kernel::Kernel::<kernel::Fx>::new(&PAROL6_VALIDATED);
    for (j, jc) in PAROL6.joints.iter().enumerate() {
        assert_eq!(k32.profile(j), Some(joint_profile::<f32>(jc, PAROL6.tick_hz)), "J{}", j + 1);
        assert_eq!(kfx.profile(j), Some(joint_profile::<kernel::Fx>(jc, PAROL6.tick_hz)), "J{}", j + 1);
        // Not the output's acceleration: the set-point's share of it.
        let output = kernel::interp::profile::<f32>(jc.max_velocity, jc.max_acceleration, PAROL6.tick_hz);
        assert_ne!(k32.profile(j), Some(output), "J{}", j + 1);
    }
    assert_eq!(k32.profile(6), None);
}
