//! SAFETY.md's traceability matrix is checked: every requirement has a row;
//! every row has a Kani harness or executed evidence of a named kind; every
//! harness named exists in `proofs/src`; and every harness in `proofs/src`
//! traces to some requirement.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

const KINDS: [&str; 6] = ["exhaustive", "model-checked", "sampled", "SMT", "symbolic", "build"];

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("workspace root")
}

/// Rows `| SR-n | ... |` of the table that follows `heading`.
fn rows(doc: &str, heading: &str) -> Vec<Vec<String>> {
    let start = doc.find(heading).unwrap_or_else(|| panic!("SAFETY.md has no '{heading}'"));
    let section = &doc[start..];
    let end = section[heading.len()..].find("\n## ").map(|e| e + heading.len()).unwrap_or(section.len());
    section[..end]
        .lines()
        .filter(|l| l.starts_with("| SR-"))
        .map(|l| l.trim_matches('|').split(" | ").map(|c| c.trim().to_string()).collect())
        .collect()
}

fn backticked(cell: &str) -> Vec<String> {
    cell.split('`').skip(1).step_by(2).map(str::to_string).collect()
}

/// Names of `#[kani::proof]` functions in `proofs/src`.
fn harnesses() -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    let dir = root().join("proofs/src");
    for e in std::fs::read_dir(&dir).expect("proofs/src") {
        let p = e.expect("entry").path();
        if p.extension().is_some_and(|x| x == "rs") {
            let text = std::fs::read_to_string(&p).expect("read");
            let mut armed = false;
            for line in text.lines().map(str::trim) {
                if line.starts_with("#[kani::proof]") {
                    armed = true;
                } else if armed && line.starts_with("fn ") {
                    let name = line[3..].split('(').next().expect("fn name").trim().to_string();
                    out.insert(name);
                    armed = false;
                }
            }
        }
    }
    out
}

#[test]
fn safety_matrix_is_complete_and_every_harness_exists() {
    let doc = std::fs::read_to_string(root().join("SAFETY.md")).expect("SAFETY.md");
    let reqs = rows(&doc, "## 5. Safety requirements");
    let matrix = rows(&doc, "## 6. Traceability and evidence");
    let ids: BTreeSet<String> = reqs.iter().map(|r| r[0].clone()).collect();
    assert!(ids.len() >= 26, "requirements: {ids:?}");
    let mut seen = BTreeMap::new();
    let existing = harnesses();
    let mut named = BTreeSet::new();
    for r in &matrix {
        assert_eq!(r.len(), 4, "matrix row needs 4 cells: {r:?}");
        let (id, kani, executed) = (&r[0], &r[1], &r[2]);
        assert!(ids.contains(id), "{id} in the matrix but not in the requirements");
        assert!(seen.insert(id.clone(), ()).is_none(), "{id} twice in the matrix");
        let harness = backticked(kani);
        let has_evidence = KINDS.iter().any(|k| executed.contains(k));
        assert!(!harness.is_empty() || has_evidence, "{id}: no harness and no executed evidence");
        assert!(has_evidence, "{id}: executed evidence must name its kind ({KINDS:?}): '{executed}'");
        assert!(!executed.contains("symbolic"), "{id}: symbolic evidence cannot be executed here");
        // Kinds are claimed positively; a negated kind would be miscounted.
        assert!(!executed.contains("not model-checked"), "{id}: say what ran, not what did not");
        for h in harness {
            assert!(existing.contains(&h), "{id}: harness `{h}` does not exist in proofs/src");
            named.insert(h);
        }
    }
    for id in &ids {
        assert!(seen.contains_key(id), "{id} has no row in the traceability matrix");
    }
    let orphans: Vec<_> = existing.difference(&named).collect();
    assert!(orphans.is_empty(), "harnesses not traced to any requirement: {orphans:?}");
}

#[test]
fn the_checker_rejects_a_missing_harness() {
    // The checker itself must be able to fail: a made-up harness name is not
    // among the harnesses found.
    assert!(!harnesses().contains("this_harness_does_not_exist"));
    assert!(harnesses().contains("operational_tick_is_safe_fx"));
}
