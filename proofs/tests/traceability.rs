//! SAFETY.md's traceability matrix is checked: every requirement has a row;
//! every row has a Kani harness or executed evidence of a named kind; every
//! harness named exists in `proofs/src`; every harness in `proofs/src`
//! traces to some requirement; every test the "tests" column names exists
//! in the repository; every clause of an "executed here" cell starts with
//! its evidence kind; and every SMT proof a row quotes exists in
//! `proofs/smt`.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

const KINDS: [&str; 7] = ["exhaustive", "model-checked", "sampled", "SMT", "symbolic", "build", "emulated"];

/// The words a clause of an "executed here" cell starts with: the evidence
/// kinds of docs/spec/evidence.md that run here (an enumerated slice is
/// named as such, "tested" is a deterministic test of named cases).
const HEADS: [&str; 8] =
    ["exhaustive", "enumerated slice", "model-checked", "SMT", "sampled", "build", "emulated", "tested"];

/// The top-level `;`-separated clauses of a cell whose first words are no
/// evidence kind (`HEADS`): the evidence summary reads each clause's kind
/// from its first words, so a kind named later in a clause ("proved by
/// SMT", "the run-time test emulated") would be claimed without being
/// checked against the run.
fn clauses_without_kind(cell: &str) -> Vec<String> {
    clauses(cell).into_iter().filter(|c| !HEADS.iter().any(|h| c.starts_with(h))).collect()
}

/// The top-level `;`-separated clauses of a cell, trimmed (a `;` inside
/// parentheses belongs to its clause), as the evidence summary splits them.
fn clauses(cell: &str) -> Vec<String> {
    let (mut out, mut cur, mut depth) = (Vec::new(), String::new(), 0i32);
    for ch in cell.chars() {
        match ch {
            '(' => depth += 1,
            ')' => depth -= 1,
            ';' if depth == 0 => {
                out.push(std::mem::take(&mut cur));
                continue;
            }
            _ => {}
        }
        cur.push(ch);
    }
    out.push(cur);
    out.into_iter().map(|c| c.trim().to_string()).filter(|c| !c.is_empty()).collect()
}

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
        let unnamed = clauses_without_kind(executed);
        assert!(
            unnamed.is_empty(),
            "{id}: each clause of the executed cell starts with its kind ({HEADS:?}): {unnamed:?}"
        );
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
    assert!(harnesses().contains("from_one_axis_operational_state_fx"));
}

/// Every `.rs` file of the repository (its three workspaces), `target/`
/// and hidden directories left out.
fn rust_sources(dir: &Path, out: &mut String) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let p = e.path();
        let name = e.file_name().to_string_lossy().to_string();
        if name.starts_with('.') || name == "target" {
            continue;
        }
        if p.is_dir() {
            rust_sources(&p, out);
        } else if name.ends_with(".rs") {
            out.push_str(&std::fs::read_to_string(&p).unwrap_or_default());
            out.push('\n');
        }
    }
}

/// The names in the "tests" column of SAFETY.md's matrix that name nothing
/// in `sources`. A backticked lower-case path is checked when it names a
/// test: its last segment contains `_` and is defined as `fn NAME`,
/// `end_to_end!(NAME` (the proofs' end-to-end tests) or a field `pub
/// NAME:` (the configuration's wiring flags); `NAME_*` needs one such name
/// starting with `NAME_` (a test's variants); a leading module of
/// `module::*::name` or `module::*` must exist as `module.rs`, `module/` or
/// `mod module`. Rustdoc attributes (`compile_fail`) name a kind of doc
/// test, not a test, and are skipped.
fn unknown_test_names(safety: &str, sources: &str, files: &BTreeSet<String>) -> Vec<String> {
    let defines = |name: &str, prefix: bool| {
        let tail = if prefix { "" } else { "(" };
        ["fn ", "end_to_end!(", "pub "].iter().any(|lead| {
            let needle = format!("{lead}{name}");
            sources.match_indices(&needle).any(|(i, _)| {
                let after = &sources[i + needle.len()..];
                prefix
                    || after.starts_with(tail)
                    || after.starts_with('<')
                    || after.starts_with(',')
                    || (*lead == "pub " && after.starts_with(':'))
            })
        })
    };
    let module =
        |m: &str| files.contains(m) || sources.contains(&format!("mod {m} ")) || sources.contains(&format!("mod {m};"));
    let mut bad = Vec::new();
    for r in rows(safety, "## 6. Traceability and evidence") {
        let (Some(id), Some(tests)) = (r.first(), r.get(3)) else { continue };
        for name in backticked(tests) {
            let path_like = !name.is_empty()
                && name
                    .chars()
                    .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_' || c == ':' || c == '*');
            if !path_like || name == "compile_fail" {
                continue;
            }
            let parts: Vec<&str> = name.split("::").collect();
            if parts.len() > 1 && parts[1] == "*" && !module(parts[0]) {
                bad.push(format!("{id}: `{name}`: no module `{}`", parts[0]));
                continue;
            }
            let last = parts.last().copied().unwrap_or("");
            if last == "*" || !last.contains('_') {
                continue;
            }
            let ok = match last.strip_suffix('*') {
                Some(stem) => defines(stem, true),
                None => defines(last, false),
            };
            if !ok {
                bad.push(format!("{id}: `{name}` names no test, end-to-end test or field in the repository"));
            }
        }
    }
    bad
}

/// The module names the repository's files give (`motion.rs` -> `motion`,
/// a directory `setup/` -> `setup`).
fn module_files(dir: &Path, out: &mut BTreeSet<String>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let name = e.file_name().to_string_lossy().to_string();
        if name.starts_with('.') || name == "target" {
            continue;
        }
        if e.path().is_dir() {
            out.insert(name.clone());
            module_files(&e.path(), out);
        } else if let Some(stem) = name.strip_suffix(".rs") {
            out.insert(stem.to_string());
        }
    }
}

#[test]
fn every_test_the_matrix_names_exists() {
    let safety = std::fs::read_to_string(root().join("SAFETY.md")).expect("SAFETY.md");
    let (mut sources, mut files) = (String::new(), BTreeSet::new());
    rust_sources(root(), &mut sources);
    module_files(root(), &mut files);
    let bad = unknown_test_names(&safety, &sources, &files);
    assert!(bad.is_empty(), "SAFETY.md's tests column names tests that do not exist:\n{}", bad.join("\n"));
}

#[test]
fn the_test_name_check_rejects_a_name_that_names_nothing() {
    let sources = "mod faults;\nfn runaway_faults<S: Scalar>() {}\nend_to_end!(homing_is_repeatable_f32, x);\n\
                   pub encoder_reversed: bool,\n";
    let files: BTreeSet<String> = ["faults".to_string()].into();
    let doc = |tests: &str| format!("## 6. Traceability and evidence\n| SR-1 | none | sampled | {tests} |\n");
    let check = |tests: &str| unknown_test_names(&doc(tests), sources, &files);
    assert!(check("`faults::*::runaway_faults`, `homing_is_repeatable_*`, `encoder_reversed`, `faults::*`").is_empty());
    assert!(check("`compile_fail` doc test, `protocol` queue tests, `kernel/tests/common`").is_empty());
    // A made-up test, a test renamed away, a prefix no variant has, a
    // module that does not exist.
    assert_eq!(check("`faults::*::runaway_faults_in_the_same_tick`").len(), 1);
    assert_eq!(check("`runaway_fault`").len(), 1);
    assert_eq!(check("`homing_is_idempotent_*`").len(), 1);
    assert_eq!(check("`fault::*::runaway_faults`").len(), 1);
    assert_eq!(check("`encoder_reversed_twice`").len(), 1);
}

#[test]
fn a_clause_that_does_not_start_with_its_kind_is_refused() {
    assert!(clauses_without_kind("sampled (shim; a); SMT (b); enumerated slices (c); tested (d)").is_empty());
    assert!(clauses_without_kind("emulated (twin: x; y); build (z)").is_empty());
    assert_eq!(clauses_without_kind("sampled (a); proved by SMT (b)"), vec!["proved by SMT (b)"]);
    assert_eq!(
        clauses_without_kind("emulated (a); the run-time test emulated: b"),
        vec!["the run-time test emulated: b"]
    );
}

/// The quoted names in the SMT clauses of SAFETY.md's matrix that name
/// neither a proof of the SMT step (a string in `smt_lib`,
/// `proofs/smt/src/lib.rs`, which holds every proof's name) nor a section
/// heading of `smt_readme` (`proofs/smt/README.md`). The evidence summary
/// matches SMT records to rows by requirement only; this catches a row
/// that quotes a proof the step does not have, also where the SMT step
/// does not run (`QUICK=1`).
fn unknown_smt_names(safety: &str, smt_lib: &str, smt_readme: &str) -> Vec<String> {
    let literals: Vec<&str> = smt_lib.split('"').skip(1).step_by(2).collect();
    let headings: Vec<&str> = smt_readme.lines().filter_map(|l| l.strip_prefix("## ")).collect();
    let mut bad = Vec::new();
    for r in rows(safety, "## 6. Traceability and evidence") {
        let (Some(id), Some(executed)) = (r.first(), r.get(2)) else { continue };
        for clause in clauses(executed).iter().filter(|c| c.starts_with("SMT")) {
            for quoted in clause.split('"').skip(1).step_by(2) {
                let known =
                    literals.iter().any(|l| l.contains(quoted)) || headings.iter().any(|h| h.starts_with(quoted));
                if !known {
                    bad.push(format!("{id}: SMT clause quotes \"{quoted}\", which is no proof of proofs/smt"));
                }
            }
        }
    }
    bad
}

#[test]
fn every_smt_proof_the_matrix_quotes_exists() {
    let read = |p: &str| std::fs::read_to_string(root().join(p)).unwrap_or_else(|e| panic!("{p}: {e}"));
    let bad = unknown_smt_names(&read("SAFETY.md"), &read("proofs/smt/src/lib.rs"), &read("proofs/smt/README.md"));
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

#[test]
fn the_smt_name_check_rejects_a_proof_the_step_does_not_have() {
    let lib =
        r#"name: "output gate, Operational: law then clamp", "interpolator step: never passes a reachable target""#;
    let readme = "# SMT\n## The SR-2 output gate (`props::gate_*`)\n";
    let doc = |cell: &str| format!("## 6. Traceability and evidence\n| SR-2 | none | {cell} | t |\n");
    let ok = doc(r#"SMT (proofs: "output gate, Operational", "never passes"; `README.md`, "The SR-2 output gate")"#);
    assert!(unknown_smt_names(&ok, lib, readme).is_empty());
    let made_up = doc(r#"SMT (proofs: "output gate, Fault")"#);
    assert_eq!(unknown_smt_names(&made_up, lib, readme).len(), 1);
    // Quotes outside an SMT clause are not proof names.
    assert!(unknown_smt_names(&doc(r#"model-checked (property "SR-2: x"); SMT (a)"#), lib, readme).is_empty());
}

// The safety-function layer (`docs/safety/`): hazards scored to a PL_r,
// safety functions, validation cases and the conditions of use.

/// Rows of the markdown tables in `doc` whose first cell starts with
/// `prefix` (`SF-`, `H-`, `VC-`, ...), split into trimmed cells.
fn prefixed_rows(doc: &str, prefix: &str) -> Vec<Vec<String>> {
    let start = format!("| {prefix}");
    doc.lines()
        .filter(|l| l.starts_with(&start))
        .map(|l| l.trim().trim_matches('|').split(" | ").map(|c| c.trim().to_string()).collect())
        .collect()
}

/// The text of the section that starts with `heading` (up to the next `## `).
fn section<'a>(doc: &'a str, heading: &str) -> Option<&'a str> {
    let start = doc.find(heading)?;
    let rest = &doc[start..];
    let end = rest[heading.len()..].find("\n## ").map(|e| e + heading.len()).unwrap_or(rest.len());
    Some(&rest[..end])
}

/// Identifiers `PREFIXn` (for example `SR-12`) in a cell, in order.
fn ids(cell: &str, prefix: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = cell;
    while let Some(i) = rest.find(prefix) {
        let after = &rest[i + prefix.len()..];
        let digits: String = after.chars().take_while(char::is_ascii_digit).collect();
        if !digits.is_empty() {
            out.push(format!("{prefix}{digits}"));
        }
        rest = &after[digits.len()..];
    }
    out
}

/// ISO 13849-1 Annex A risk graph: S, F, P -> PL_r.
fn risk_graph(s: &str, f: &str, p: &str) -> Option<&'static str> {
    Some(match (s, f, p) {
        ("S1", "F1", "P1") => "a",
        ("S1", "F1", "P2") | ("S1", "F2", "P1") => "b",
        ("S1", "F2", "P2") | ("S2", "F1", "P1") => "c",
        ("S2", "F1", "P2") | ("S2", "F2", "P1") => "d",
        ("S2", "F2", "P2") => "e",
        _ => return None,
    })
}

/// Every gap between SAFETY.md and the documents of `docs/safety/`; empty
/// when the safety-function layer is complete.
fn safety_case_gaps(safety: &str, risk: &str, plan: &str, manual: &str) -> Vec<String> {
    let mut gaps = Vec::new();
    let srs: BTreeSet<String> = rows(safety, "## 5. Safety requirements").iter().map(|r| r[0].clone()).collect();
    if srs.is_empty() {
        gaps.push("SAFETY.md lists no requirements".to_string());
    }

    // Safety functions, as RISK.md defines them and SAFETY.md 5a maps them.
    let mut sf_srs: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let mut sf_pl: BTreeMap<String, String> = BTreeMap::new();
    for r in prefixed_rows(risk, "SF-") {
        if r.len() != 8 {
            gaps.push(format!("RISK.md: safety function row needs 8 cells: {r:?}"));
            continue;
        }
        if !["a", "b", "c", "d", "e"].contains(&r[2].as_str()) {
            gaps.push(format!("RISK.md: {} has no PL_r (a..e): '{}'", r[0], r[2]));
        }
        for (i, what) in [(4, "safe state"), (5, "stop category"), (6, "reaction-time budget")] {
            if r[i].is_empty() {
                gaps.push(format!("RISK.md: {} has no {what}", r[0]));
            }
        }
        let named = ids(&r[7], "SR-");
        if named.is_empty() && !r[7].starts_with("none") {
            gaps.push(format!("RISK.md: {} names no SR and does not say none", r[0]));
        }
        sf_srs.insert(r[0].clone(), named.into_iter().collect());
        sf_pl.insert(r[0].clone(), r[2].clone());
    }
    let layer = section(safety, "## 5a.").unwrap_or("");
    if layer.is_empty() {
        gaps.push("SAFETY.md has no section 5a (safety functions)".to_string());
    }
    let mut mapped = BTreeSet::new();
    let mut in_safety = BTreeSet::new();
    for r in prefixed_rows(layer, "SF-") {
        if r.len() != 4 {
            gaps.push(format!("SAFETY.md 5a: row needs 4 cells: {r:?}"));
            continue;
        }
        in_safety.insert(r[0].clone());
        let named: BTreeSet<String> = ids(&r[2], "SR-").into_iter().collect();
        for id in &named {
            if !srs.contains(id) {
                gaps.push(format!("SAFETY.md 5a: {} names {id}, which is not a requirement", r[0]));
            }
        }
        match sf_srs.get(&r[0]) {
            None => gaps.push(format!("SAFETY.md 5a: {} is not defined in RISK.md", r[0])),
            Some(risk_named) if *risk_named != named => {
                gaps.push(format!("{}: SRs differ between SAFETY.md 5a {named:?} and RISK.md {risk_named:?}", r[0]))
            }
            Some(_) => {}
        }
        if sf_pl.get(&r[0]) != Some(&r[3]) {
            gaps.push(format!("{}: PL_r differs between SAFETY.md 5a ({}) and RISK.md", r[0], r[3]));
        }
        mapped.extend(named);
    }
    for sf in sf_srs.keys() {
        if !in_safety.contains(sf) {
            gaps.push(format!("{sf} of RISK.md is missing from SAFETY.md 5a"));
        }
    }
    for id in &srs {
        if !mapped.contains(id) {
            gaps.push(format!("{id} maps to no safety function (add it to SAFETY.md 5a and RISK.md section 5)"));
        }
    }

    // Hazards: SAFETY.md's log plus RISK.md's mechanical ones, each scored.
    let logged: BTreeSet<String> = section(safety, "## 4.")
        .map(|s| prefixed_rows(s, "H-").into_iter().map(|r| r[0].clone()).collect())
        .unwrap_or_default();
    let mut scored = BTreeSet::new();
    let mut serves: BTreeMap<String, String> = BTreeMap::new();
    for r in prefixed_rows(risk, "H-") {
        if r.len() != 8 {
            gaps.push(format!("RISK.md: hazard row needs 8 cells: {r:?}"));
            continue;
        }
        scored.insert(r[0].clone());
        match risk_graph(&r[2], &r[3], &r[4]) {
            None => gaps.push(format!("{}: S/F/P not scored: '{}' '{}' '{}'", r[0], r[2], r[3], r[4])),
            Some(pl) if pl != r[5] => gaps
                .push(format!("{}: PL_r '{}' is not the risk graph's {pl} for {} {} {}", r[0], r[5], r[2], r[3], r[4])),
            Some(_) => {}
        }
        let sfs = ids(&r[6], "SF-");
        if sfs.is_empty() {
            gaps.push(format!("{} maps to no safety function", r[0]));
        }
        for sf in sfs {
            if !sf_pl.contains_key(&sf) {
                gaps.push(format!("{}: {sf} is not defined in RISK.md", r[0]));
            }
            let e = serves.entry(sf).or_insert_with(|| "a".to_string());
            if r[5] > *e {
                *e = r[5].clone();
            }
        }
    }
    for h in &logged {
        if !scored.contains(h) {
            gaps.push(format!("{h} of SAFETY.md section 4 is not scored in RISK.md"));
        }
    }
    for (sf, pl) in &sf_pl {
        match serves.get(sf) {
            None => gaps.push(format!("{sf} serves no hazard")),
            Some(max) if max != pl => gaps.push(format!("{sf}: PL_r {pl} is not the highest of its hazards' ({max})")),
            Some(_) => {}
        }
    }

    // Validation: one case per SF and per SR.
    let mut cases = BTreeSet::new();
    for r in prefixed_rows(plan, "VC-") {
        if r.len() != 7 {
            gaps.push(format!("VALIDATION-PLAN.md: case row needs 7 cells: {r:?}"));
            continue;
        }
        let id = r[0].trim_start_matches("VC-").to_string();
        if !sf_pl.contains_key(&id) && !srs.contains(&id) {
            gaps.push(format!("VALIDATION-PLAN.md: {} covers neither an SF nor an SR", r[0]));
        }
        if r[1].is_empty() || r[3].is_empty() || r[4].is_empty() {
            gaps.push(format!("VALIDATION-PLAN.md: {} lacks its fault, pass criterion or runs", r[0]));
        }
        if backticked(&r[5]).is_empty() && !r[5].starts_with("none: ") {
            gaps.push(format!("VALIDATION-PLAN.md: {} names no scenario and gives no reason", r[0]));
        }
        cases.insert(id);
    }
    for id in sf_pl.keys().chain(srs.iter()) {
        if !cases.contains(id) {
            gaps.push(format!("{id} has no validation case (VC-{id} in VALIDATION-PLAN.md)"));
        }
    }

    // Residual risks of SAFETY.md section 8 -> CSTR or an accepted rationale.
    let cstrs: BTreeSet<String> = prefixed_rows(manual, "CSTR-").into_iter().map(|r| r[0].clone()).collect();
    let residual = section(safety, "## 8.").unwrap_or("");
    let mut items: Vec<String> = Vec::new();
    for line in residual.lines().skip(1) {
        if let Some(item) = line.strip_prefix("- ") {
            items.push(item.to_string());
        } else if let (Some(last), true) = (items.last_mut(), line.starts_with("  ")) {
            last.push(' ');
            last.push_str(line.trim());
        }
    }
    let mut covered = vec![false; items.len()];
    for r in prefixed_rows(manual, "RR-") {
        if r.len() != 3 {
            gaps.push(format!("SAFETY-MANUAL.md: residual-risk row needs 3 cells: {r:?}"));
            continue;
        }
        let phrase = r[1].trim_matches('"');
        let hits: Vec<usize> = items.iter().enumerate().filter(|(_, t)| t.contains(phrase)).map(|(i, _)| i).collect();
        if hits.len() != 1 {
            gaps.push(format!("{}: '{phrase}' occurs in {} items of SAFETY.md section 8, not one", r[0], hits.len()));
        }
        for i in hits {
            covered[i] = true;
        }
        let named = ids(&r[2], "CSTR-");
        for c in &named {
            if !cstrs.contains(c) {
                gaps.push(format!("{}: {c} is not a constraint of SAFETY-MANUAL.md", r[0]));
            }
        }
        if named.is_empty() && !r[2].starts_with("accepted: ") {
            gaps.push(format!("{} maps to no CSTR and gives no accepted rationale", r[0]));
        }
    }
    if items.is_empty() {
        gaps.push("SAFETY.md section 8 lists no residual risks".to_string());
    }
    for (item, ok) in items.iter().zip(covered) {
        if !ok {
            gaps.push(format!("residual risk not carried into SAFETY-MANUAL.md: '{item}'"));
        }
    }
    gaps
}

fn safety_docs() -> [String; 4] {
    ["SAFETY.md", "docs/safety/RISK.md", "docs/safety/VALIDATION-PLAN.md", "docs/safety/SAFETY-MANUAL.md"]
        .map(|p| std::fs::read_to_string(root().join(p)).unwrap_or_else(|e| panic!("{p}: {e}")))
}

#[test]
fn every_hazard_sr_sf_case_and_residual_risk_is_traced() {
    let [safety, risk, plan, manual] = safety_docs();
    let gaps = safety_case_gaps(&safety, &risk, &plan, &manual);
    assert!(gaps.is_empty(), "safety-function layer has gaps:\n{}", gaps.join("\n"));
}

/// Each kind of gap, put into a copy of the real documents, is reported.
#[test]
fn the_safety_case_check_fails_on_each_kind_of_gap() {
    let [safety, risk, plan, manual] = safety_docs();
    let replace = |doc: &str, from: &str, to: &str| {
        assert!(doc.contains(from), "the gap test's anchor '{from}' is gone");
        doc.replacen(from, to, 1)
    };
    let cases: [(&str, [String; 4], &str); 7] = [
        (
            "a hazard without PL_r",
            [
                safety.clone(),
                replace(&risk, "| S2 | F1 | P2 | d | SF-1 |", "| S2 | F1 | P2 |  | SF-1 |"),
                plan.clone(),
                manual.clone(),
            ],
            "H-1: PL_r '' is not the risk graph's d",
        ),
        (
            "a hazard not scored",
            [
                safety.clone(),
                replace(&risk, "| H-9 | wrong zero | S2 | F1 | P1 |", "| H-9 | wrong zero | S2 | F1 | ? |"),
                plan.clone(),
                manual.clone(),
            ],
            "H-9: S/F/P not scored",
        ),
        (
            "a hazard without a safety function",
            [
                safety.clone(),
                replace(&risk, "| c | SF-7 | every later move", "| c | - | every later move"),
                plan.clone(),
                manual.clone(),
            ],
            "H-9 maps to no safety function",
        ),
        (
            "an SR without a safety function",
            [replace(&safety, "SR-21, SR-22, SR-28, ", "SR-21, SR-22, "), risk.clone(), plan.clone(), manual.clone()],
            "SR-28 maps to no safety function",
        ),
        (
            "an SF without a validation case",
            [safety.clone(), risk.clone(), replace(&plan, "| VC-SF-6 |", "| XX-SF-6 |"), manual.clone()],
            "SF-6 has no validation case",
        ),
        (
            "an SR without a validation case",
            [safety.clone(), risk.clone(), replace(&plan, "| VC-SR-30 |", "| XX-SR-30 |"), manual.clone()],
            "SR-30 has no validation case",
        ),
        (
            "a residual risk without a constraint",
            [
                replace(
                    &safety,
                    "\n## 8. Residual risks",
                    "\n## 8. Residual risks\n\n- A new residual risk nobody carried over.",
                ),
                risk.clone(),
                plan.clone(),
                manual.clone(),
            ],
            "residual risk not carried into SAFETY-MANUAL.md: 'A new residual risk",
        ),
    ];
    for (what, [s, r, p, m], expected) in &cases {
        let gaps = safety_case_gaps(s, r, p, m);
        assert!(
            gaps.iter().any(|g| g.contains(expected)),
            "{what}: expected a gap containing '{expected}', got {gaps:?}"
        );
    }
}

/// The commit `docs/MUTANTS.md`'s result heading names ("## Result: one run
/// at <commit>"), and the same commit in SAFETY.md's mutation line.
fn mutation_commit(mutants: &str, safety: &str) -> Result<String, String> {
    let heading = "## Result: one run at ";
    let start = mutants.find(heading).ok_or("docs/MUTANTS.md has no '## Result: one run at <commit>'")?;
    let commit: String = mutants[start + heading.len()..].chars().take_while(char::is_ascii_hexdigit).collect();
    if commit.len() < 7 {
        return Err(format!("docs/MUTANTS.md's result heading names no commit: '{commit}'"));
    }
    if !safety.contains(&format!("one run at {commit}")) {
        return Err(format!("SAFETY.md does not give the mutation run at {commit} that docs/MUTANTS.md gives"));
    }
    Ok(commit)
}

/// The mutation score is of the kernel in this tree: the commit the run
/// mutated has the same `kernel/src` as the checkout. A change to the
/// kernel's sources fails this until the run is redone at a commit that
/// has them (`docs/MUTANTS.md`, "The commands").
#[test]
fn the_mutation_score_is_of_the_kernel_in_this_tree() {
    let read = |p: &str| std::fs::read_to_string(root().join(p)).unwrap_or_else(|e| panic!("{p}: {e}"));
    let commit = mutation_commit(&read("docs/MUTANTS.md"), &read("SAFETY.md")).unwrap_or_else(|e| panic!("{e}"));
    if !root().join(".git").exists() {
        eprintln!("not a git checkout: the kernel's sources cannot be compared with {commit}");
        return;
    }
    let out = std::process::Command::new("git")
        .current_dir(root())
        .args(["diff", "--stat", &commit, "--", "kernel/src"])
        .output()
        .expect("git runs");
    assert!(out.status.success(), "git diff {commit}: {}", String::from_utf8_lossy(&out.stderr));
    let diff = String::from_utf8_lossy(&out.stdout);
    assert!(
        diff.trim().is_empty(),
        "kernel/src differs from {commit}, the commit of docs/MUTANTS.md's mutation run: redo the run\n{diff}"
    );
}

#[test]
fn the_mutation_commit_must_agree_between_the_documents() {
    let mutants = "text\n## Result: one run at b7a42de\n";
    assert_eq!(mutation_commit(mutants, "one run at b7a42de of every file").as_deref(), Ok("b7a42de"));
    assert!(mutation_commit(mutants, "one run at 4e1f941").is_err());
    assert!(mutation_commit("## Result: one run at HEAD\n", "one run at HEAD").is_err());
    assert!(mutation_commit("no heading", "one run at b7a42de").is_err());
}
