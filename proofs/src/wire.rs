//! The wire boundary: framer and parser (SR-23, SR-24).

use crate::setup::PROOF_VALIDATED;
use kernel::{Fx, Scalar, TargetLimits};
use protocol::framer::Framer;
use protocol::parse::{DialectLock, Parser};
use protocol::Command;

/// Longest line the harness feeds (a worst-case driver frame is ~94 bytes).
const LEN: usize = 100;

/// A line of any bytes, biased toward frame syntax for sampling (half of the
/// bytes come from the frame alphabet); symbolically every byte is free.
fn any_line() -> ([u8; LEN], usize) {
    const ALPHABET: &[u8] = b"<>,.-0123456789HOMENABL";
    let mut b = [0u8; LEN];
    for x in b.iter_mut() {
        let raw: u8 = kani::any();
        *x = if kani::any() { ALPHABET[usize::from(raw) % ALPHABET.len()] } else { raw };
    }
    let len = usize::from(kani::any::<u8>()) % (LEN + 1);
    (b, len)
}

/// SR-23, SR-24: parsing any bytes never panics, and every accepted motion
/// frame is finite and inside the joint limits (the kernel's own check).
fn parser<S: Scalar>() {
    let (b, len) = any_line();
    let lock = match kani::any::<u8>() % 3 {
        0 => DialectLock::Auto,
        1 => DialectLock::DriverOnly,
        _ => DialectLock::ConfiguratorOnly,
    };
    let p = Parser::<S>::new(&PROOF_VALIDATED, lock);
    let r = p.parse(&b[..len]);
    kani::cover!(r.is_err(), "rejected");
    if let Ok(Command::Motion { target, .. }) = r {
        assert!(TargetLimits::<S>::new(&PROOF_VALIDATED).check(&target).is_ok());
    }
}

#[kani::proof]
#[kani::unwind(101)] // the line's bytes; the parser's loops are over them
fn parser_never_panics_and_accepts_only_in_limit_targets_f32() {
    parser::<f32>();
}
#[kani::proof]
#[kani::unwind(101)]
fn parser_never_panics_and_accepts_only_in_limit_targets_fx() {
    parser::<Fx>();
}

/// SR-23: the framer never panics, never yields a line longer than its
/// buffer, and every line it yields is free of terminators.
#[kani::proof]
#[kani::unwind(101)]
fn framer_is_bounded_and_never_panics() {
    let (b, len) = any_line();
    let mut f = Framer::<32>::new();
    let mut lines = 0u32;
    for &byte in &b[..len] {
        if let Some(Ok(line)) = f.push(byte) {
            assert!(line.len() <= 32);
            assert!(!line.contains(&b'\n') && !line.contains(&b'\r'));
            lines += 1;
        }
    }
    kani::cover!(lines > 0, "a line came out");
}
