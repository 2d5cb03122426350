//! Tests written for the survivors of a cargo-mutants run on the kernel's
//! logic files (`ci/mutants.sh`, `docs/MUTANTS.md`): each asserts the
//! behaviour SAFETY.md or docs/PROTOCOL.md specify.
//! This file: the kernel itself (`kernel/src/kernel.rs`).
#![allow(clippy::needless_range_loop)] // six axes: indices read best

mod common;

use std::collections::hash_map::DefaultHasher;
use std::hash::{Hash, Hasher};

use common::Rig;
use kernel::config::{AXES, PAROL6_VALIDATED};
use kernel::{Fx, Kernel, State};

const START: [f64; AXES] = [0.3, 0.2, -0.4, 0.5, -0.3, 1.0];

fn hash_of(k: &Kernel<Fx>) -> u64 {
    let mut h = DefaultHasher::new();
    k.hash(&mut h);
    h.finish()
}

/// `Hash for Kernel` (the fixed-point variant) hashes the state that
/// determines the kernel's future behaviour, for the model checker: two
/// kernels in the same state hash alike whatever their identity, and a
/// kernel that has left Boot does not hash like one in Boot. Survivor: the
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
