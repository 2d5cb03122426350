//! The kernel's observable state: `Hash for Kernel` follows the state that
//! determines its future (what the model checker relies on), and the status
//! reports the six joints' limit bits as sensed.

mod common;

use std::collections::hash_map::DefaultHasher;
use std::hash::{Hash, Hasher};

use common::{Rig, START};
use kernel::config::PAROL6_VALIDATED;
use kernel::{Fx, Kernel, State};

fn hash_of(k: &Kernel<Fx>) -> u64 {
    let mut h = DefaultHasher::new();
    k.hash(&mut h);
    h.finish()
}

/// `Hash for Kernel` (the fixed-point variant) hashes the state that
/// determines the kernel's future behaviour, for the model checker: two
/// kernels in the same state hash alike whatever their identity, and a
/// kernel that has left Boot does not hash like one in Boot. Catches: the
/// hash replaced by nothing (every state alike: the model would explore
/// one state).
#[test]
fn the_kernel_hash_follows_its_state_not_its_identity() {
    let (a, _) = Kernel::<Fx>::new(&PAROL6_VALIDATED);
    let (b, _) = Kernel::<Fx>::new(&PAROL6_VALIDATED);
    assert_eq!(hash_of(&a), hash_of(&b), "fresh kernels, different identities");
    let mut r = Rig::<Fx>::new(START);
    let boot = hash_of(&r.k);
    assert_eq!(boot, hash_of(&a));
    r.run(3);
    assert_eq!(r.k.state(), State::Unhomed);
    assert_ne!(hash_of(&r.k), boot, "Unhomed hashes like Boot");
    let (f, _) = r.k.fork();
    assert_eq!(hash_of(&f), hash_of(&r.k), "a fork is the same state");
}

/// PROTOCOL.md's status reports one limit bit per joint: bits beyond the
/// six joints of the sensed mask (a board reporting more inputs) are not
/// reported, the six are reported as sensed. Catches: `limits & ALL` in
/// `Kernel::status` as `|` and as `^`.
#[test]
fn the_status_reports_the_six_joints_limit_bits_as_sensed() {
    for (sensed, reported) in [(0xffu8, 0x3fu8), (0xc0, 0), (0b0000_0101, 0b0000_0101), (0x3f, 0x3f), (0, 0)] {
        let (k, _) = Kernel::<f32>::new(&PAROL6_VALIDATED);
        assert_eq!(k.status(sensed).limits, reported, "sensed {sensed:#04x}");
        let (k, _) = Kernel::<Fx>::new(&PAROL6_VALIDATED);
        assert_eq!(k.status(sensed).limits, reported, "sensed {sensed:#04x}");
    }
}

/// The events of a tick replace the last tick's in the caller's buffer:
/// `Kernel::tick_into` clears it first, and `len`, `is_empty` and `iter`
/// agree. Boot's first tick reports `Ready`; the next, quiet, tick none;
/// `<HOME>` then `HomingStarted`. No event is ever dropped (one per source
/// per tick fits the buffer).
#[test]
fn a_tick_s_events_replace_the_last_tick_s() {
    use kernel::{Actuation, Event, Events};
    let (mut k, _auth) = Kernel::<Fx>::new(&PAROL6_VALIDATED);
    let r = Rig::<Fx>::new(START);
    let sense = r.plant.sense();
    let mut events = Events::new();
    let mut act = Actuation::<Fx>::zero();
    let mut tick = |k: &mut Kernel<Fx>, req: Option<kernel::Request<Fx>>, events: &mut Events| {
        k.tick_into(&sense, req, &mut act, events);
        assert_eq!(events.len(), events.iter().count());
        assert_eq!(events.is_empty(), events.iter().next().is_none());
        assert_eq!(events.dropped(), 0);
    };
    tick(&mut k, None, &mut events);
    assert_eq!(events.iter().copied().collect::<Vec<_>>(), vec![Event::Ready]);
    assert_eq!(events.len(), 1);
    assert!(!events.is_empty());
    tick(&mut k, None, &mut events);
    assert!(events.is_empty(), "the last tick's events are still there: {events:?}");
    assert_eq!(events.len(), 0);
    tick(&mut k, Some(kernel::Request::Home), &mut events);
    assert!(events.iter().any(|e| matches!(e, Event::HomingStarted { .. })), "{events:?}");
}

/// The digit of the `H<d>` status token: 0 not requested, 1 in progress,
/// 2 complete, 3 failed.
#[test]
fn homing_status_digits() {
    use kernel::HomingStatus;
    let digits = [HomingStatus::NotRequested, HomingStatus::InProgress, HomingStatus::Complete, HomingStatus::Failed]
        .map(HomingStatus::as_u8);
    assert_eq!(digits, [0, 1, 2, 3]);
}
