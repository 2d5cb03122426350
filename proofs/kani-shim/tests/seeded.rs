//! Seeded-defect self-tests of the shim (`docs/safety/TOOLS.md`): a tool
//! that judges evidence must be shown able to say "sampled" and to fail.
//! A domain too wide to enumerate is reported as sampled, never exhaustive;
//! a small one is enumerated; a `cover!` no case reaches fails the harness;
//! a false assertion and a harness whose every case is discarded fail it.

// The shim's attributes and `cover!` collection name the crate `kani`, as
// the proofs do.
extern crate kani_shim as kani;

use kani::runner::check;

fn quiet() {
    // These harnesses are not evidence for any requirement: keep them out of
    // the test command's shim report.
    std::env::remove_var("KANI_SHIM_REPORT");
}

fn wide_domain() {
    let x: u64 = kani::any();
    kani::assert(x.wrapping_sub(x) == 0, "x - x is 0");
}

fn small_domain() {
    let a: bool = kani::any();
    let b: bool = kani::any();
    kani::assert(u8::from(a) * u8::from(b) == u8::from(a && b), "and as a product");
}

#[kani::loops]
fn uncovered() {
    let x: u8 = kani::any();
    kani::cover!(x == 0 && x == 1, "a condition no input satisfies");
}

#[kani::loops]
fn uncovered_branch() {
    let x: u8 = kani::any();
    if x == 0 && x == 1 {
        kani::cover!(true, "a branch no input takes");
    }
}

#[kani::loops]
fn covered() {
    let x: u8 = kani::any();
    kani::cover!(x == 7, "reachable");
}

fn false_assertion_small() {
    let x: u8 = kani::any();
    kani::assert(x != 200, "x is never 200 (false)");
}

fn false_assertion_wide() {
    let x: u64 = kani::any();
    kani::assert(x % 4 != 3, "x is never 3 mod 4 (false for a quarter of the domain)");
}

fn vacuous() {
    let x: u8 = kani::any();
    kani::assume(x > 255 - x.wrapping_sub(x));
}

#[test]
fn a_wide_domain_is_reported_sampled() {
    quiet();
    let r = check("seeded_wide_domain", wide_domain, None).expect("holds");
    assert_eq!(r.kind, "sampled");
    assert!(r.seed.is_some());
}

#[test]
fn a_small_domain_is_enumerated() {
    quiet();
    let r = check("seeded_small_domain", small_domain, None).expect("holds");
    assert_eq!(r.kind, "exhaustive");
    assert_eq!(r.cases, 4);
}

#[test]
fn an_uncovered_cover_fails_and_a_covered_one_passes() {
    quiet();
    let e = check("seeded_uncovered", uncovered, None).expect_err("an unreachable cover must fail");
    assert!(e.contains("cover never satisfied"), "{e}");
    // A cover whose line never runs is required all the same.
    let e = check("seeded_uncovered_branch", uncovered_branch, None).expect_err("an untaken branch's cover must fail");
    assert!(e.contains("cover never satisfied"), "{e}");
    let r = check("seeded_covered", covered, None).expect("reachable cover");
    assert_eq!(r.covers, (1, 1));
}

#[test]
fn a_false_assertion_fails_enumerated_and_sampled() {
    quiet();
    let e = check("seeded_false_small", false_assertion_small, None).expect_err("enumeration reaches 200");
    assert!(!e.is_empty());
    let e = check("seeded_false_wide", false_assertion_wide, None).expect_err("sampling finds 3 mod 4");
    assert!(!e.is_empty());
}

#[test]
fn a_harness_whose_every_case_is_discarded_fails() {
    quiet();
    assert!(check("seeded_vacuous", vacuous, None).is_err());
}
