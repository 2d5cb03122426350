//! `Kernel::from_spec` (`kernel/src/kernel/invariant.rs`), the constructor
//! of arbitrary states the proofs start from. It exists only with the
//! `proof-states` feature (the proofs enable it; the firmware and the
//! simulator never do), so this file does too: `cargo test --workspace`
//! builds the kernel with it (features are unified with `proofs`'s), and
//! `ci/mutants.sh` passes `--features proof-states`.
#![cfg(feature = "proof-states")]

mod common;

use common::{axis_spec, both};
use kernel::config::{AXES, PAROL6_VALIDATED};
use kernel::{FaultReason, HomingStatus, Kernel, Scalar, SpecMode, State, StateSpec};

both!(a_spec_that_satisfies_the_invariant_gives_that_state, a_spec_that_breaks_the_invariant_gives_none,);

fn spec<S: Scalar>(mode: SpecMode<S>, homed: u8) -> StateSpec<S> {
    StateSpec {
        mode,
        homed,
        axes: core::array::from_fn(|i| axis_spec(S::from_f32(0.1 * i as f32), S::ZERO)),
        armed: false,
        since_cmd: 0,
        since_target: None,
        intervals: [0; 4],
    }
}

/// The kernel built is the state described: its mode, homed mask (only
/// the six joints' bits), homing status, estimates and set-points; and
/// it satisfies the invariant.
fn a_spec_that_satisfies_the_invariant_gives_that_state<S: Scalar>() {
    let (k, _auth) =
        Kernel::<S>::from_spec(&PAROL6_VALIDATED, &spec(SpecMode::Operational, 0xff)).expect("a valid state");
    assert_eq!(k.state(), State::Operational);
    assert_eq!(k.homed(), 0x3f, "bits beyond the six joints are dropped");
    assert_eq!(k.homing_status(), HomingStatus::Complete);
    assert!(k.invariant());
    let st = k.status(0);
    for i in 0..AXES {
        assert_eq!(st.position[i], S::from_f32(0.1 * i as f32), "J{} position", i + 1);
        assert_eq!(st.setpoint[i], st.position[i], "J{} set-point", i + 1);
    }
    let (k, _) = Kernel::<S>::from_spec(&PAROL6_VALIDATED, &spec(SpecMode::Unhomed, 0b0000_0101)).expect("valid");
    assert_eq!(k.state(), State::Unhomed);
    assert_eq!(k.homed(), 0b0000_0101);
    assert_eq!(k.homing_status(), HomingStatus::NotRequested, "partly homed");
    let reason = FaultReason::Runaway { axis: 2 };
    let (k, _) = Kernel::<S>::from_spec(&PAROL6_VALIDATED, &spec(SpecMode::Fault(reason), 0x3f)).expect("valid");
    assert_eq!(k.state(), State::Fault);
    assert_eq!(k.status(0).fault.map(|f| f.reason), Some(reason));
}

/// A described state the invariant refuses is not built.
fn a_spec_that_breaks_the_invariant_gives_none<S: Scalar>() {
    assert!(Kernel::<S>::from_spec(&PAROL6_VALIDATED, &spec(SpecMode::Operational, 0x1f)).is_none(), "unhomed joint");
    let mut s = spec::<S>(SpecMode::Unhomed, 0);
    s.axes[3].last_out = S::from_f32(0.5);
    assert!(Kernel::<S>::from_spec(&PAROL6_VALIDATED, &s).is_none(), "moving at rest");
}
