//! Stream continuity (`SAFETY.md` SR-30): a driver sample continues its
//! stream (within the speed limit over the time since the previous
//! sample, at least one longest segment, plus the tolerance) or lies where
//! the set-point can be within one longest segment. The previous sample is
//! forgotten when the stream is interrupted (a hold or latch at the
//! timeout, `<ENABLE>`, homing, a go-to). Both numeric variants, every
//! tick checked by the monitor.

mod common;

use common::{both, Rig};
use kernel::config::{AXES, PAROL6};
use kernel::{Event, Reject, RequestKind, Scalar, State};

const START: [f64; AXES] = [0.3, 0.2, -0.4, 0.5, -0.3, 1.0];

both!(a_leap_from_rest_after_enable_is_refused, no_first_sample_beyond_a_tenth_of_a_radian_from_rest);

fn homed<S: Scalar>() -> Rig<S> {
    let mut r = Rig::<S>::new(START);
    r.boot_and_home();
    r
}

fn jumped<S: Scalar>(out: &kernel::TickOutput<S>) -> Option<u8> {
    out.events.iter().find_map(|e| match e {
        Event::Rejected { request: RequestKind::Motion, reason: Reject::TargetJump { axis } } => Some(*axis),
        _ => None,
    })
}

/// After `<ENABLE>` (set-points at the measured pose, at rest) a resumed
/// driver stream whose first sample lies 0.22 rad (J1) and 0.30 rad (J6)
/// from the pose is refused: accepted, it would be followed at full
/// acceleration, motion nobody planned. A sample continuing from the pose
/// is taken.
fn a_leap_from_rest_after_enable_is_refused<S: Scalar>() {
    let mut r = homed::<S>();
    // A stream interrupted while moving: latched by the command timeout.
    let mut p = r.plant.q;
    p[0] += 0.2;
    r.stream_to(p);
    r.run_until(1_000, |o| o.status.state == State::SoftEstop).expect("latches");
    let out = r.enable();
    assert_eq!(out.status.state, State::Operational);
    let pose = out.status.setpoint.map(|x| f64::from(x.to_f32()));
    let mut leap = pose;
    leap[0] += 0.22;
    leap[5] -= 0.30;
    let out = r.motion(leap);
    assert_eq!(jumped(&out), Some(0), "a leap from rest accepted: {:?}", out.events);
    let mut only_j6 = pose;
    only_j6[5] -= 0.30;
    assert_eq!(jumped(&r.motion(only_j6)), Some(5));
    // Nothing moved; a sample continuing from the pose is taken.
    let out = r.run(20);
    assert!(out.status.setpoint.iter().zip(pose.iter()).all(|(a, b)| (f64::from(a.to_f32()) - b).abs() < 1e-6));
    let mut near = pose;
    near[0] += 0.02;
    near[5] -= 0.02;
    assert!(r.motion(near).events.is_empty());
}

/// From rest (after homing, after `<ENABLE>`, after a hold at the command
/// timeout) no first sample farther than 0.1 rad from the set-point is
/// accepted on any joint, in either direction.
fn no_first_sample_beyond_a_tenth_of_a_radian_from_rest<S: Scalar>() {
    let mut r = homed::<S>();
    let check = |r: &mut Rig<S>, when: &str| {
        let sp = r.last.as_ref().map(|o| o.status.setpoint.map(|x| f64::from(x.to_f32()))).unwrap();
        for j in 0..AXES {
            let c = &PAROL6.joints[j];
            for dir in [1.0, -1.0] {
                let mut x = sp;
                x[j] += dir * 0.1001;
                if x[j] < f64::from(c.limit_min) || x[j] > f64::from(c.limit_max) {
                    continue; // refused for its limits, not as a leap
                }
                let out = r.motion(x);
                assert_eq!(jumped(&out), Some(j as u8), "{when}: J{} at {dir} 0.1 rad: {:?}", j + 1, out.events);
            }
        }
    };
    check(&mut r, "after homing");
    r.goto([0.0, 0.1, -0.4, -0.3, 0.0, 0.0]);
    r.run(3_000);
    check(&mut r, "at rest after a go-to");
    // A stream that ends at rest holds at the timeout.
    let mut p = r.plant.q;
    p[2] += 0.03;
    assert!(r.motion(p).events.is_empty());
    r.run_until(1_000, |o| o.events.iter().any(|e| *e == Event::Holding)).expect("holds");
    check(&mut r, "after a hold");
    p[2] += 0.2;
    r.stream_to(p);
    r.run_until(1_000, |o| o.status.state == State::SoftEstop).expect("latches");
    r.enable();
    check(&mut r, "after enable");
}

/// The continuity bounds per joint (`cargo test -p kernel --test continuity
/// -- --nocapture the_bounds` prints them for docs/PROTOCOL.md 6.3 and
/// SAFETY.md SR-30): from rest the set-point's reach over one longest
/// segment plus the tolerance is at most 0.1 rad on every joint.
#[test]
fn the_bounds_per_joint() {
    use kernel::config::ms_to_ticks;
    let c = &PAROL6;
    let t = ms_to_ticks(c.segment_max_ms, c.tick_hz) as f32 / c.tick_hz as f32;
    for (i, j) in c.joints.iter().enumerate() {
        let rest = j.max_acceleration * t * t / 2.0 + c.target_jump_tolerance;
        let sample = j.max_velocity * t + c.target_jump_tolerance;
        println!(
            "J{}: from rest {rest:.4} rad; sample to sample {sample:.3} rad per {:.0} ms (more after a longer gap)",
            i + 1,
            t * 1000.0
        );
        assert!(rest <= 0.1, "J{}: {rest}", i + 1);
    }
}
