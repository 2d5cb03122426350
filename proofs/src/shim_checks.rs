//! The shim's own checks (not harnesses): it must fail a harness whose
//! loop exceeds its declared `#[kani::unwind(N)]`, as Kani's unwinding
//! assertion does, and pass one whose loops fit.

use kani::runner::{check, needs_unwind};

/// Three iterations of a `for`, a `while` and a labelled `loop` with a
/// value: Kani needs `unwind(4)`.
#[kani::loops]
fn three_iterations() {
    let mut n = 0;
    for _ in 0..3 {
        n += 1;
    }
    let mut i = 0;
    while i < 3 {
        i += 1;
    }
    let v = 'outer: loop {
        for k in 0..3 {
            if k == 2 {
                break 'outer k;
            }
        }
    };
    assert!(n == 3 && i == 3 && v == 2);
}

/// A harness body with a loop of `kani::any()` length (0..=5 iterations).
#[kani::loops]
fn symbolic_length() {
    let n: u8 = kani::any::<u8>() % 6;
    kani::cover!(n == 5, "longest");
    for _ in 0..n {}
}

#[test]
fn a_loop_beyond_its_unwind_fails_the_harness() {
    let e = check("three_iterations", three_iterations, Some(3)).expect_err("unwind(3) allows 2 iterations");
    assert!(e.contains("unwinding assertion") && e.contains("allows at most 2"), "{e}");
    let r = check("three_iterations", three_iterations, Some(4)).expect("unwind(4) allows 3 iterations");
    assert_eq!(r.longest_loop, 3);
    // The bound holds for every case, including the one that draws the longest loop.
    let e = check("symbolic_length", symbolic_length, Some(5)).expect_err("5 iterations need unwind(6)");
    assert!(e.contains("unwinding assertion"), "{e}");
    assert!(check("symbolic_length", symbolic_length, Some(6)).is_ok());
    // Without a declared bound the shim counts but does not fail (Kani then
    // unwinds until the loops end).
    assert_eq!(check("three_iterations", three_iterations, None).map(|r| r.longest_loop), Ok(3));
}

fn needs_seven() {
    needs_unwind(7, "a loop in the code under test");
}

#[test]
fn a_declared_loop_of_the_code_under_test_beyond_the_unwind_fails() {
    let e = check("needs_seven", needs_seven, Some(6)).expect_err("6 < 7");
    assert!(e.contains("needs #[kani::unwind(7)]"), "{e}");
    assert_eq!(check("needs_seven", needs_seven, Some(7)).map(|r| r.needed_unwind), Ok(7));
}

/// The harnesses of this crate declare bounds that fit: each one's test runs
/// under the shim with its declared `#[kani::unwind]` (a harness that
/// exceeded it would fail there). This checks the declarations themselves:
/// every harness that runs a kernel tick declares at least `KERNEL_UNWIND`,
/// and every `#[kani::unwind]` has a justification comment.
#[test]
fn every_unwind_is_justified() {
    for f in ["kernel_props.rs", "numeric.rs", "wire.rs"] {
        let text = std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src").join(f))
            .expect("harness source");
        for (n, line) in text.lines().enumerate() {
            if line.trim_start().starts_with("#[kani::unwind(") {
                assert!(line.contains("//"), "{f}:{}: #[kani::unwind] without a justification comment", n + 1);
            }
        }
    }
}
