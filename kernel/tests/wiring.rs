//! The configuration's wiring facts (SAFETY.md SR-1, SR-2, SR-28): a motor
//! wired reversed (`motor_reversed`: a positive step turns the joint
//! negative) and an encoder mounted reversed (`encoder_reversed`: its count
//! falls as the joint turns positive). The kernel built from such a
//! configuration steps the other way and reads the count with the other
//! sign, so the arm moves the right way: it homes, goes where it is sent and
//! its estimate follows the joint. The test plant turns and reads as the
//! configuration says, and the safety monitor (which knows the same two
//! facts) checks every tick; both numeric variants.
//!
//! Catches: a kernel that ignores either flag (the step direction or the
//! estimate's sign not following it) drives that joint away from its
//! commanded path, and the following-error check faults during homing.

mod common;

use common::{both, Rig, START};
use kernel::config::{ArmConfig, Validated, AXES, PAROL6};
use kernel::{Scalar, State};

both!(
    a_motor_wired_reversed_moves_its_joint_the_right_way,
    an_encoder_mounted_reversed_reads_its_joint_the_right_way,
    a_reversed_motor_read_by_a_reversed_encoder_moves_the_right_way,
);

/// J1, J3, J5 wired reversed.
fn a_motor_wired_reversed_moves_its_joint_the_right_way<S: Scalar>() {
    moves_the_right_way::<S>(0b01_0101, 0);
}

/// J2, J4, J6 read reversed.
fn an_encoder_mounted_reversed_reads_its_joint_the_right_way<S: Scalar>() {
    moves_the_right_way::<S>(0, 0b10_1010);
}

/// J1 and J6 both ways, J2 only its motor, J3 only its encoder.
fn a_reversed_motor_read_by_a_reversed_encoder_moves_the_right_way<S: Scalar>() {
    moves_the_right_way::<S>(0b10_0011, 0b10_0101);
}

/// The PAROL6 configuration with the motors of `motor` (bit per joint)
/// wired reversed and the encoders of `encoder` mounted reversed.
fn wired(motor: u8, encoder: u8) -> Validated {
    let mut c: ArmConfig = PAROL6;
    for (i, j) in c.joints.iter_mut().enumerate() {
        j.motor_reversed = motor & (1 << i) != 0;
        j.encoder_reversed = encoder & (1 << i) != 0;
    }
    Validated::new(c).expect("valid")
}

/// Boots and homes the arm wired as given (homing drives every joint to
/// its switch, so a joint turning or read the wrong way faults there), then
/// sends each joint 0.3 rad toward the middle of its range and checks, on every
/// tick of the move: the estimate's change since the start within 25 mrad
/// of the joint's (half the following-error bound; the observer lags about
/// 10 mrad at speed, a wrong sign is off by twice the distance moved); a
/// non-zero step rate against the velocity on a reversed motor, with it on
/// the others; at the end, still Operational, every joint within 10 mrad
/// of its target and its estimate's change within 1 mrad of the joint's.
fn moves_the_right_way<S: Scalar>(motor: u8, encoder: u8) {
    let cfg = wired(motor, encoder);
    let mut r = Rig::<S>::with_config(START, &cfg);
    r.boot_and_home();
    let from = r.plant.q;
    let x0 = r.last.as_ref().expect("ticked").status.position.map(|x| f64::from(x.to_f32()));
    // 0.3 rad toward the middle of each joint's range (the homed pose is
    // near a limit on some joints).
    let goal: [f64; AXES] = core::array::from_fn(|i| {
        let j = &cfg.config().joints[i];
        let mid = 0.5 * f64::from(j.limit_min + j.limit_max);
        from[i] + if mid > from[i] { 0.3 } else { -0.3 }
    });
    let out = r.goto(goal);
    assert!(out.events.is_empty(), "{:?}", out.events);
    let mut stepped = [0u32; AXES];
    for _ in 0..1_500 {
        let out = r.tick(None);
        for i in 0..AXES {
            let moved = f64::from(out.status.position[i].to_f32()) - x0[i];
            let turned = r.plant.q[i] - from[i];
            assert!((moved - turned).abs() < 0.025, "J{}: estimate moved {moved}, joint {turned}", i + 1);
            let (v, rate) = (out.act.velocity[i].to_f32(), out.act.step_rate[i]);
            if rate != 0 && v != 0.0 {
                let reversed = motor & (1 << i) != 0;
                assert_eq!((rate > 0) == (v > 0.0), !reversed, "J{}: step rate {rate} for velocity {v}", i + 1);
                stepped[i] += 1;
            }
        }
    }
    assert_eq!(r.k.state(), State::Operational, "events: {:?}", r.events);
    for i in 0..AXES {
        assert!(stepped[i] > 100, "J{} stepped on {} ticks only", i + 1, stepped[i]);
        let q = r.plant.q[i];
        assert!((q - goal[i]).abs() < 0.01, "J{}: at {q}, sent to {} from {}", i + 1, goal[i], from[i]);
        let moved = f64::from(r.last.as_ref().expect("ticked").status.position[i].to_f32()) - x0[i];
        assert!(
            (moved - (q - from[i])).abs() < 1e-3,
            "J{}: at rest, estimate moved {moved}, joint {}",
            i + 1,
            q - from[i]
        );
    }
}
