//! The shim's own checks (not harnesses): it must fail a harness whose
//! loop exceeds its declared `#[kani::unwind(N)]`, as Kani's unwinding
//! assertion does, and pass one whose loops fit; and it must fail a harness
//! with a cover never satisfied, also one whose line never runs, as Kani's
//! `--fail-uncoverable` fails an UNSATISFIABLE or UNREACHABLE cover; and
//! it must fail a harness that draws more symbolic values or runs more
//! ticks than its stated footprint, counting no sampling hint.

use kani::runner::{check, check_within, needs_unwind, Footprint};

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

/// A cover in a branch no case enters (its line never runs).
#[kani::loops]
fn cover_in_a_dead_branch() {
    let b: bool = kani::any();
    kani::assume(!b);
    if b {
        kani::cover!(true, "the dead branch");
    }
}

/// A cover whose line runs but whose condition never holds.
#[kani::loops]
fn unsatisfiable_cover() {
    let x: u8 = kani::any();
    kani::cover!(x.wrapping_mul(2) == 1, "impossible"); // 2x is even modulo 256
}

/// A cover written in a function the macros do not instrument: unknown to
/// the shim until reached.
fn undeclared_cover() {
    kani::cover!(true, "in an uninstrumented function");
}

fn calls_undeclared() {
    undeclared_cover();
}

/// A helper whose cover is satisfied only in some cases.
#[kani::loops]
fn helper_with_a_branch_cover(x: u8) {
    if x == 7 {
        kani::cover!(true, "x is 7");
    }
}

fn calls_the_helper() {
    helper_with_a_branch_cover(kani::any());
}

#[test]
fn a_cover_never_satisfied_fails_the_harness_even_when_its_line_never_runs() {
    let e = check("cover_in_a_dead_branch", cover_in_a_dead_branch, None).expect_err("an unreachable cover");
    assert!(e.contains("cover never satisfied") && e.contains("the dead branch"), "{e}");
    let e = check("unsatisfiable_cover", unsatisfiable_cover, None).expect_err("an unsatisfiable cover");
    assert!(e.contains("cover never satisfied") && e.contains("impossible"), "{e}");
    let e = check("calls_undeclared", calls_undeclared, None).expect_err("an undeclared cover");
    assert!(e.contains("was not declared before it was reached"), "{e}");
    // A helper's cover declared at its entry, satisfied by one of the 256
    // exhaustively enumerated cases.
    let r = check("calls_the_helper", calls_the_helper, None).expect("x == 7 is reachable");
    assert_eq!((r.kind, r.covers), ("exhaustive", (1, 1)));
    assert_eq!(check("symbolic_length", symbolic_length, Some(6)).map(|r| r.covers), Ok((1, 1)));
}

/// The harnesses of this crate declare bounds that fit: each one's test runs
/// under the shim with its declared `#[kani::unwind]` (a harness that
/// exceeded it would fail there). This checks the declarations themselves:
/// every harness that runs a kernel tick declares at least `KERNEL_UNWIND`,
/// and every `#[kani::unwind]` and every end-to-end test's unwind has a
/// justification comment, in every file of `proofs/src`.
#[test]
fn every_unwind_is_justified() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .expect("harness sources")
        .map(|e| e.expect("entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "rs"))
        .collect();
    files.sort();
    let mut harness_files = 0;
    for path in &files {
        let f = path.file_name().and_then(|n| n.to_str()).unwrap_or("?");
        let text = std::fs::read_to_string(path).expect("harness source");
        harness_files += usize::from(text.contains("#[kani::proof]") || text.contains("\nend_to_end!("));
        let lines: Vec<&str> = text.lines().collect();
        for (n, line) in lines.iter().enumerate() {
            if line.trim_start().starts_with("#[kani::unwind(") {
                assert!(line.contains("//"), "{f}:{}: #[kani::unwind] without a justification comment", n + 1);
            }
            // A sampled end-to-end test gives its unwind as an argument,
            // justified on the comment line above it.
            if line.starts_with("end_to_end!(") {
                let above = n.checked_sub(1).and_then(|m| lines.get(m)).copied().unwrap_or("");
                assert!(
                    above.trim_start().starts_with("//") && above.contains("Unwind:"),
                    "{f}:{}: end_to_end! without an `Unwind:` justification on the line above",
                    n + 1
                );
            }
        }
    }
    // Every file with harnesses or end-to-end tests was read (kernel_props,
    // motion_props, numeric, state_props, wire).
    assert!(harness_files >= 5, "only {harness_files} harness files in {}", dir.display());
}

/// Three symbolic values (a `u8`, an array of two `bool`s), two ticks, and
/// a sampling hint.
fn three_values_two_ticks() {
    let _: u8 = kani::any();
    let _: [bool; 2] = kani::any();
    let _: u32 = kani::runner::hint();
    kani::runner::tick();
    kani::runner::tick();
}

#[test]
fn a_harness_beyond_its_stated_footprint_fails() {
    let exact = Footprint { symbolic_values: 3, ticks: 2 };
    let r = check_within("three_values_two_ticks", three_values_two_ticks, None, Some(exact)).expect("within");
    assert_eq!(r.footprint, exact, "the hint is not a symbolic value");
    let e = check_within(
        "three_values_two_ticks",
        three_values_two_ticks,
        None,
        Some(Footprint { symbolic_values: 2, ticks: 2 }),
    )
    .expect_err("three symbolic values against two stated");
    assert!(e.contains("symbolic footprint exceeded"), "{e}");
    let e = check_within(
        "three_values_two_ticks",
        three_values_two_ticks,
        None,
        Some(Footprint { symbolic_values: 3, ticks: 1 }),
    )
    .expect_err("two ticks against one stated");
    assert!(e.contains("runs a tick beyond the 1"), "{e}");
}

/// Every harness source file of `dir` (`proofs/src` but this file), with
/// its text: what the source scans below read.
fn harness_sources(dir: &std::path::Path) -> Vec<(std::path::PathBuf, String)> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).expect("harness sources") {
        let path = entry.expect("entry").path();
        if path.extension().is_none_or(|x| x != "rs") || path.ends_with("shim_checks.rs") {
            continue;
        }
        let text = std::fs::read_to_string(&path).expect("harness source");
        files.push((path, text));
    }
    files
}

/// Every `kani::cover!` in the harness sources is written in a function
/// the shim instruments (`#[kani::proof]` or `kani::loops`), so that it is
/// declared, hence required, whenever its function is entered, also when
/// its own line never runs. (A cover elsewhere fails its harness only when
/// it is reached.) What remains outside the shim's reach: a helper that no
/// case of a harness ever enters; real Kani with `--fail-uncoverable`
/// reports its covers UNREACHABLE.
#[test]
fn every_cover_is_in_an_instrumented_function() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut covers = 0;
    let mut bare = Vec::new();
    for (path, text) in harness_sources(&dir) {
        let lines: Vec<&str> = text.lines().collect();
        // The attributes of the function each line is in.
        let mut instrumented = false;
        let mut current = String::new();
        for (n, line) in lines.iter().enumerate() {
            let t = line.trim_start();
            let is_fn = ["fn ", "pub fn ", "pub(crate) fn "].iter().any(|p| t.starts_with(p));
            if is_fn && !line.starts_with("    ") {
                current = t.split('(').next().unwrap_or(t).to_string();
                instrumented = lines[..n]
                    .iter()
                    .rev()
                    .take_while(|l| {
                        let l = l.trim_start();
                        l.starts_with("#[") || l.starts_with("//")
                    })
                    .any(|l| l.contains("#[kani::proof]") || l.contains("kani::loops"));
            }
            if t.contains("kani::cover!") && !t.starts_with("//") {
                covers += 1;
                if !instrumented {
                    bare.push(format!("{}:{} in {current}", path.display(), n + 1));
                }
            }
        }
    }
    assert!(covers >= 20, "only {covers} covers found in {}", dir.display());
    assert!(bare.is_empty(), "covers in functions the shim does not instrument: {bare:?}");
}

/// Every `kani::assume` in the harness sources is paired with a
/// `kani::cover!` within three lines of it (before or after), in an
/// instrumented function (checked above), so that an assumption no draw
/// satisfies fails its harness instead of making it vacuous.
#[test]
fn every_assume_is_paired_with_a_cover() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let (mut assumes, mut unpaired) = (0, Vec::new());
    for (path, text) in harness_sources(&dir) {
        let lines: Vec<&str> = text.lines().collect();
        for (n, line) in lines.iter().enumerate() {
            let t = line.trim_start();
            if t.starts_with("kani::assume(") {
                assumes += 1;
                let near = &lines[n.saturating_sub(3)..(n + 4).min(lines.len())];
                if !near.iter().any(|l| l.trim_start().starts_with("kani::cover!(")) {
                    unpaired.push(format!("{}:{}", path.display(), n + 1));
                }
            }
        }
    }
    assert!(assumes >= 5, "only {assumes} assumptions found in {}", dir.display());
    assert!(unpaired.is_empty(), "kani::assume without a kani::cover! within three lines: {unpaired:?}");
}
