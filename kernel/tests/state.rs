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
