//! The wire boundary: framer and parser (SR-23, SR-24).

use crate::setup::PROOF_VALIDATED;
use kernel::{Fx, Scalar, TargetLimits};
use protocol::framer::Framer;
use protocol::parse::{DialectLock, Parser};
use protocol::Command;

/// Longest line the harness feeds (a worst-case driver frame is ~94 bytes).
const LEN: usize = 100;

/// A valid driver frame (docs/PROTOCOL.md's example, inside PAROL6's limits).
const FRAME: &[u8] = b"<1532,0.123,0.050,-0.500,-0.200,1.000,0.000,0.250,0.000,-1.571,0.300,3.142,-0.000>";

/// A line of any bytes: symbolically every byte and every length (LEN + 1
/// symbolic values). For sampling it is biased by hints (no symbolic
/// values: every line they give is one of the raw lines): a quarter of the
/// lines are the valid frame with random digits (so accepted motion frames
/// are common), the others take half their bytes from the frame alphabet.
#[cfg_attr(not(kani), kani::loops)]
fn any_line() -> ([u8; LEN], usize) {
    let mut b = [0u8; LEN];
    #[cfg(not(kani))]
    if kani::runner::hint::<u8>().is_multiple_of(4) {
        for (x, f) in b.iter_mut().zip(FRAME.iter()) {
            *x = if f.is_ascii_digit() && kani::runner::hint() { b'0' + kani::any::<u8>() % 10 } else { *f };
        }
        return (b, FRAME.len());
    }
    for x in b.iter_mut() {
        let raw: u8 = kani::any();
        #[cfg(not(kani))]
        let raw = {
            const ALPHABET: &[u8] = b"<>,.-0123456789HOMENABL";
            if kani::runner::hint() {
                ALPHABET[usize::from(raw) % ALPHABET.len()]
            } else {
                raw
            }
        };
        *x = raw;
    }
    let len = usize::from(kani::any::<u8>()) % (LEN + 1);
    (b, len)
}

/// SR-23, SR-24: parsing any bytes never panics, and every accepted motion
/// frame is finite and inside the joint limits (the kernel's own check).
#[cfg_attr(not(kani), kani::loops)]
fn parser<S: Scalar>() {
    #[cfg(not(kani))]
    kani::runner::needs_unwind(LEN as u32 + 1, "the parser's loops over the line's bytes");
    let (b, len) = any_line();
    let lock = match kani::any::<u8>() % 3 {
        0 => DialectLock::Auto,
        1 => DialectLock::DriverOnly,
        _ => DialectLock::ConfiguratorOnly,
    };
    let p = Parser::<S>::new(&PROOF_VALIDATED, lock);
    let r = p.parse(&b[..len]);
    kani::cover!(r.is_err(), "rejected");
    kani::cover!(matches!(r, Ok(Command::Motion { .. })), "a motion frame accepted (antecedent)");
    if let Ok(Command::Motion { target, .. }) = r {
        assert!(TargetLimits::<S>::new(&PROOF_VALIDATED).check(&target).is_ok());
    }
}

/// Footprint: 102 symbolic values, 0 ticks (100 bytes, a length, the dialect lock).
#[kani::proof]
#[kani::unwind(101)] // any_line: LEN = 100 bytes; the parser's loops are over the line's bytes (uninstrumented)
fn parser_never_panics_and_accepts_only_in_limit_targets_f32() {
    parser::<f32>();
}
/// Footprint: 102 symbolic values, 0 ticks (100 bytes, a length, the dialect lock).
#[kani::proof]
#[kani::unwind(101)] // as the f32 harness
fn parser_never_panics_and_accepts_only_in_limit_targets_fx() {
    parser::<Fx>();
}

/// SR-23: the framer never panics, never yields a line longer than its
/// buffer, and every line it yields is free of terminators.
/// Footprint: 101 symbolic values, 0 ticks (100 bytes and a length).
#[kani::proof]
#[kani::unwind(101)] // any_line and the loop below: at most LEN = 100 bytes
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
