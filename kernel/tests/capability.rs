//! An enable capability works only on the kernel whose `Authority` minted
//! it (and on clones of that kernel, which are the same kernel): any other
//! kernel refuses it with `Reject::ForeignCapability`, reported as a
//! `Rejected` event, and clears nothing. Both numeric variants.

use kernel::config::PAROL6_VALIDATED;
use kernel::{
    EncoderSample, Event, FaultReason, HardwareFault, Kernel, Reject, Request, RequestKind, Scalar, Sense, State,
    TickOutput,
};

fn quiet() -> Sense {
    Sense { encoders: [EncoderSample::Count(1000); 6], limits: 0, hardware_fault: None, link_lost: false }
}

fn overrun() -> Sense {
    Sense { hardware_fault: Some(HardwareFault::TickOverrun), ..quiet() }
}

fn refused_as_foreign<S: Scalar>(out: &TickOutput<S>) -> bool {
    let mut events = out.events.iter();
    let refused = Event::Rejected { request: RequestKind::Enable, reason: Reject::ForeignCapability };
    events.next() == Some(&refused) && events.next().is_none()
}

/// A kernel latched in Fault by a hardware overrun (cause gone afterwards).
fn latched<S: Scalar>() -> (Kernel<S>, kernel::Authority) {
    let (mut k, auth) = Kernel::<S>::new(&PAROL6_VALIDATED);
    assert_eq!(k.tick(&quiet(), None).status.state, State::Unhomed);
    let out = k.tick(&overrun(), None);
    assert_eq!(out.status.state, State::Fault);
    (k, auth)
}

fn foreign_capability_is_refused_and_the_arm_stays_latched<S: Scalar>() {
    let (mut a, auth_a) = latched::<S>();
    let (mut b, auth_b) = latched::<S>();
    let fault_b = b.fault();
    assert_eq!(fault_b.map(|f| f.reason), Some(FaultReason::Hardware(HardwareFault::TickOverrun)));

    // A's capability on B: refused, reported, nothing cleared.
    for _ in 0..3 {
        let out = b.tick(&quiet(), Some(Request::Enable(auth_a.enable())));
        assert!(refused_as_foreign(&out), "{:?}", out.events);
        assert_eq!(out.status.state, State::Fault);
        assert_eq!(out.status.fault, fault_b, "the latched fault and its first reason are kept");
        assert!(out.act.velocity.iter().all(|v| *v == S::ZERO));
        assert!(out.act.step_rate.iter().all(|r| *r == 0));
    }
    assert_eq!(b.state(), State::Fault);
    assert_eq!(b.fault(), fault_b);

    // Each kernel's own capability still works (the cause is gone).
    let out = b.tick(&quiet(), Some(Request::Enable(auth_b.enable())));
    assert!(out.events.iter().any(|e| *e == Event::Enabled(State::Unhomed)), "{:?}", out.events);
    assert_eq!(b.fault(), None);
    let out = a.tick(&quiet(), Some(Request::Enable(auth_a.enable())));
    assert!(out.events.iter().any(|e| *e == Event::Enabled(State::Unhomed)), "{:?}", out.events);
}

#[test]
fn foreign_capability_is_refused_and_the_arm_stays_latched_f32() {
    foreign_capability_is_refused_and_the_arm_stays_latched::<f32>();
}

#[test]
fn foreign_capability_is_refused_and_the_arm_stays_latched_fx() {
    foreign_capability_is_refused_and_the_arm_stays_latched::<kernel::Fx>();
}

/// The foreign check comes first: in a state with nothing to clear the
/// refusal still names the capability, not the state.
fn foreign_capability_is_refused_in_every_state<S: Scalar>() {
    let (mut k, _auth) = Kernel::<S>::new(&PAROL6_VALIDATED);
    let (_other, foreign) = Kernel::<S>::new(&PAROL6_VALIDATED);
    let out = k.tick(&quiet(), Some(Request::Enable(foreign.enable())));
    assert!(out.events.iter().any(|e| *e == Event::Ready));
    assert!(out.events.iter().any(|e| matches!(e, Event::Rejected { reason: Reject::ForeignCapability, .. })));
    let out = k.tick(&quiet(), Some(Request::Enable(foreign.enable())));
    assert!(refused_as_foreign(&out), "{:?}", out.events);
    assert_eq!(out.status.state, State::Unhomed);
}

#[test]
fn foreign_capability_is_refused_in_every_state_f32() {
    foreign_capability_is_refused_in_every_state::<f32>();
}

#[test]
fn foreign_capability_is_refused_in_every_state_fx() {
    foreign_capability_is_refused_in_every_state::<kernel::Fx>();
}

/// A clone is the same kernel (a model checker's states): its authority
/// works on it. A fork is a new kernel with its own authority, and neither
/// authority works on the other.
fn clones_share_and_forks_do_not_share_the_authority<S: Scalar>() {
    let (k, auth) = latched::<S>();
    let mut clone = k.clone();
    let out = clone.tick(&quiet(), Some(Request::Enable(auth.enable())));
    assert!(out.events.iter().any(|e| *e == Event::Enabled(State::Unhomed)), "{:?}", out.events);

    let (mut fork, fork_auth) = k.fork();
    assert_eq!(fork.state(), State::Fault);
    assert_eq!(fork.fault(), k.fault());
    let out = fork.tick(&quiet(), Some(Request::Enable(auth.enable())));
    assert!(refused_as_foreign(&out), "{:?}", out.events);
    assert_eq!(fork.state(), State::Fault);
    let mut original = k;
    let out = original.tick(&quiet(), Some(Request::Enable(fork_auth.enable())));
    assert!(refused_as_foreign(&out), "{:?}", out.events);
    assert_eq!(original.state(), State::Fault);
    let out = fork.tick(&quiet(), Some(Request::Enable(fork_auth.enable())));
    assert!(out.events.iter().any(|e| *e == Event::Enabled(State::Unhomed)), "{:?}", out.events);
}

#[test]
fn clones_share_and_forks_do_not_share_the_authority_f32() {
    clones_share_and_forks_do_not_share_the_authority::<f32>();
}

#[test]
fn clones_share_and_forks_do_not_share_the_authority_fx() {
    clones_share_and_forks_do_not_share_the_authority::<kernel::Fx>();
}
