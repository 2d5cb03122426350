//! The CI workflow cannot run here (Kani cannot be installed on these
//! machines): this checks that `.github/workflows/ci.yml` parses as YAML and
//! has the structure the safety case relies on.
//!
//! * a job runs the project's test command `./ci/test.sh`;
//! * the Kani jobs use `model-checking/kani-github-action` pinned to an exact
//!   release (or commit), with an exact Kani version;
//! * every harness named in the Kani matrix is a `#[kani::proof]` fn in
//!   `proofs/src`, and every such fn is in exactly one shard;
//! * each harness runs under a wall-clock limit and each job has a timeout;
//! * the proof inventory (`cargo kani list`) is archived as an artifact;
//! * the Kani jobs build under Kani's own (older) rustc: `ci/kani.sh`
//!   matches the workspace's rust-version to it (KANI_MATCH_RUST_VERSION)
//!   and passes `-Z unstable-options --fail-uncoverable`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde_yaml::Value;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("workspace root").to_path_buf()
}

fn workflow() -> Value {
    let path = root().join(".github/workflows/ci.yml");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_yaml::from_str(&text).unwrap_or_else(|e| panic!("{} is not valid YAML: {e}", path.display()))
}

/// Every `#[kani::proof]` fn in `proofs/src/*.rs`: the first `fn NAME` after
/// the attribute (other attributes may come between).
fn proof_harnesses() -> Vec<String> {
    let dir = root().join("proofs/src");
    let mut names = Vec::new();
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("dir entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "rs"))
        .collect();
    files.sort();
    for f in files {
        let text = std::fs::read_to_string(&f).expect("read proofs source");
        let mut want = false;
        for line in text.lines() {
            let t = line.trim();
            if t.starts_with("#[kani::proof]") {
                want = true;
                continue;
            }
            if want {
                if let Some(pos) = t.find("fn ") {
                    let rest = &t[pos + 3..];
                    let name: String = rest.chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect();
                    assert!(!name.is_empty(), "{}: no fn name after #[kani::proof]", f.display());
                    names.push(name);
                    want = false;
                }
            }
        }
        assert!(!want, "{}: #[kani::proof] without a fn", f.display());
    }
    names.sort();
    names
}

fn job<'a>(w: &'a Value, name: &str) -> &'a Value {
    let j = &w["jobs"][name];
    assert!(j.is_mapping(), "job `{name}` missing");
    j
}

fn steps(job: &Value) -> &Vec<Value> {
    job["steps"].as_sequence().expect("steps")
}

fn str_of<'a>(v: &'a Value, what: &str) -> &'a str {
    v.as_str().unwrap_or_else(|| panic!("{what} is not a string: {v:?}"))
}

fn is_exact_version(s: &str) -> bool {
    let parts: Vec<_> = s.split('.').collect();
    parts.len() == 3 && parts.iter().all(|p| !p.is_empty() && p.chars().all(|c| c.is_ascii_digit()))
}

/// `owner/action@ref` pinned to a release tag `vX.Y` / `vX.Y.Z` or a full commit sha.
fn is_pinned(uses: &str, action: &str) -> bool {
    let Some(r) = uses.strip_prefix(action).and_then(|r| r.strip_prefix('@')) else {
        return false;
    };
    let sha = r.len() == 40 && r.chars().all(|c| c.is_ascii_hexdigit());
    let tag = r.strip_prefix('v').is_some_and(|v| {
        let parts: Vec<_> = v.split('.').collect();
        (2..=3).contains(&parts.len()) && parts.iter().all(|p| !p.is_empty() && p.chars().all(|c| c.is_ascii_digit()))
    });
    sha || tag
}

/// The Kani action steps of a job, checked for pinning and version.
fn kani_steps<'a>(w: &Value, job: &'a Value) -> Vec<&'a Value> {
    let ks: Vec<_> = steps(job)
        .iter()
        .filter(|s| s["uses"].as_str().is_some_and(|u| u.starts_with("model-checking/kani-github-action")))
        .collect();
    for s in &ks {
        let uses = str_of(&s["uses"], "uses");
        assert!(is_pinned(uses, "model-checking/kani-github-action"), "not pinned to an exact release: {uses}");
        let v = str_of(&s["with"]["kani-version"], "kani-version");
        let v = if v.contains("env.KANI_VERSION") { str_of(&w["env"]["KANI_VERSION"], "env.KANI_VERSION") } else { v };
        assert!(is_exact_version(v), "kani-version must be exact, got {v}");
    }
    ks
}

#[test]
fn workflow_runs_the_test_command() {
    let w = workflow();
    assert!(w["on"].is_mapping() || w["on"].is_sequence() || w["on"].is_string(), "no triggers");
    let test = job(&w, "test");
    assert!(test["timeout-minutes"].as_u64().is_some(), "test job without timeout");
    assert!(
        steps(test).iter().any(|s| s["run"].as_str().is_some_and(|r| r.trim() == "./ci/test.sh")),
        "no step runs ./ci/test.sh"
    );
    // Every third-party action is pinned.
    for (name, j) in w["jobs"].as_mapping().expect("jobs") {
        for s in steps(j) {
            if let Some(u) = s["uses"].as_str() {
                let action = u.split('@').next().unwrap_or(u);
                assert!(is_pinned(u, action), "job {name:?}: {u} not pinned to a release or commit");
            }
        }
    }
}

#[test]
fn every_kani_harness_is_in_exactly_one_shard() {
    let w = workflow();
    let kani = job(&w, "kani");
    let minutes = kani["timeout-minutes"].as_u64().expect("kani job timeout-minutes");
    let per_harness = str_of(&w["env"]["KANI_HARNESS_TIMEOUT"], "env.KANI_HARNESS_TIMEOUT");
    let per_harness_min: u64 = per_harness.strip_suffix('m').and_then(|m| m.parse().ok()).expect("timeout in minutes");
    let ks = kani_steps(&w, kani);
    assert_eq!(ks.len(), 1, "one Kani step per shard");
    assert_eq!(str_of(&ks[0]["with"]["command"], "command"), "./ci/kani.sh");
    let args = str_of(&ks[0]["with"]["args"], "args");
    assert_eq!(args, "run ${{ matrix.harnesses }}", "the step runs the shard's harnesses");

    let shards = kani["strategy"]["matrix"]["include"].as_sequence().expect("matrix.include");
    assert!(shards.len() >= 2, "sharded across jobs");
    let mut owner: BTreeMap<String, String> = BTreeMap::new();
    for s in shards {
        let shard = str_of(&s["shard"], "shard").to_string();
        let names: Vec<&str> = str_of(&s["harnesses"], "harnesses").split_whitespace().collect();
        assert!(!names.is_empty(), "shard {shard} is empty");
        // Each harness may take its whole limit; the job must allow for it.
        assert!(
            minutes >= per_harness_min * names.len() as u64 + 10,
            "shard {shard}: {} harnesses x {per_harness_min} min do not fit in {minutes} min",
            names.len()
        );
        for n in names {
            if let Some(prev) = owner.insert(n.to_string(), shard.clone()) {
                panic!("harness {n} in shards {prev} and {shard}");
            }
        }
    }
    let proofs = proof_harnesses();
    assert!(!proofs.is_empty(), "no #[kani::proof] found");
    let listed: Vec<String> = owner.keys().cloned().collect();
    let unknown: Vec<_> = listed.iter().filter(|n| !proofs.contains(n)).collect();
    let missing: Vec<_> = proofs.iter().filter(|n| !owner.contains_key(*n)).collect();
    assert!(unknown.is_empty(), "harnesses in the matrix but not in proofs/src: {unknown:?}");
    assert!(missing.is_empty(), "#[kani::proof] fns in no shard: {missing:?}");
    println!("workflow: {} Kani harnesses in {} shards, {per_harness} each", proofs.len(), shards.len());
}

#[test]
fn ci_kani_sh_lists_the_same_harnesses() {
    let out = std::process::Command::new("bash")
        .arg(root().join("ci/kani.sh"))
        .arg("list")
        .output()
        .expect("run ci/kani.sh list");
    assert!(out.status.success(), "ci/kani.sh list failed: {}", String::from_utf8_lossy(&out.stderr));
    let listed: Vec<String> = String::from_utf8(out.stdout).expect("utf-8").lines().map(str::to_string).collect();
    assert_eq!(listed, proof_harnesses());
}

#[test]
fn proof_inventory_is_archived() {
    let w = workflow();
    let inv = job(&w, "kani-inventory");
    assert!(inv["timeout-minutes"].as_u64().is_some());
    let ks = kani_steps(&w, inv);
    assert_eq!(ks.len(), 1);
    assert!(str_of(&ks[0]["with"]["args"], "args").starts_with("inventory"), "runs ci/kani.sh inventory");
    let upload = steps(inv)
        .iter()
        .find(|s| s["uses"].as_str().is_some_and(|u| u.starts_with("actions/upload-artifact@")))
        .expect("an upload-artifact step");
    assert_eq!(str_of(&upload["with"]["path"], "path").trim_end_matches('/'), "kani-inventory");
    assert_eq!(upload["if"].as_str(), Some("always()"));
}

/// The nightly long fuzz run has one job per fuzz target, every target of
/// `protocol/fuzz/fuzz_targets` and no other, each under a timeout.
#[test]
fn fuzz_long_runs_every_fuzz_target() {
    let wf = workflow();
    let job = &wf["jobs"]["fuzz-long"];
    assert!(job["timeout-minutes"].as_u64().is_some_and(|m| m <= 360), "fuzz-long needs a timeout");
    let mut matrix: Vec<String> = job["strategy"]["matrix"]["target"]
        .as_sequence()
        .expect("fuzz-long matrix.target")
        .iter()
        .map(|v| v.as_str().expect("target name").to_string())
        .collect();
    matrix.sort();
    let dir = root().join("protocol/fuzz/fuzz_targets");
    let mut targets: Vec<String> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("dir entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "rs"))
        .map(|p| p.file_stem().expect("stem").to_string_lossy().into_owned())
        .collect();
    targets.sort();
    assert_eq!(matrix, targets, "fuzz-long's matrix and protocol/fuzz/fuzz_targets differ");
    let run = job["steps"]
        .as_sequence()
        .expect("steps")
        .iter()
        .filter_map(|s| s["run"].as_str())
        .find(|r| r.contains("protocol/fuzz/run.sh"))
        .expect("a step runs protocol/fuzz/run.sh");
    assert!(run.contains("FUZZ_TARGETS=${{ matrix.target }}"), "each job fuzzes its own target: {run}");
}

/// Kani builds with its own nightly, whose rustc is older than the
/// workspace's `rust-version`, and `cargo kani` has no
/// `--ignore-rust-version`: every Kani step runs `ci/kani.sh` with
/// `KANI_MATCH_RUST_VERSION=1`, and `ci/kani.sh` matches the rust-version
/// to Kani's rustc before every build (`run` and `inventory`) and passes
/// `--fail-uncoverable` behind `-Z unstable-options`.
#[test]
fn kani_jobs_build_under_kani_s_toolchain_and_fail_uncoverable_covers() {
    let w = workflow();
    assert_eq!(str_of(&w["env"]["KANI_MATCH_RUST_VERSION"], "env.KANI_MATCH_RUST_VERSION"), "1");
    for name in ["kani", "kani-inventory"] {
        let j = job(&w, name);
        let ks = kani_steps(&w, j);
        assert!(!ks.is_empty(), "job {name}: no Kani step");
        for s in ks {
            let v = str_of(&s["env"]["KANI_MATCH_RUST_VERSION"], "step env KANI_MATCH_RUST_VERSION");
            assert!(
                v == "1" || v.contains("env.KANI_MATCH_RUST_VERSION"),
                "job {name}: KANI_MATCH_RUST_VERSION is {v}"
            );
        }
    }
    let manifest = std::fs::read_to_string(root().join("Cargo.toml")).expect("Cargo.toml");
    assert!(manifest.lines().any(|l| l.starts_with("rust-version = ")), "the workspace states a rust-version");
    let script = std::fs::read_to_string(root().join("ci/kani.sh")).expect("ci/kani.sh");
    assert!(script.contains("match_rust_version() {"), "ci/kani.sh defines match_rust_version");
    // Called in `run` and in `inventory`, before cargo kani builds.
    for (arm, build) in [("run)", "cargo kani -p proofs"), ("inventory)", "cargo kani list")] {
        let at = script.find(&format!("\n{arm}\n")).unwrap_or_else(|| panic!("ci/kani.sh: no {arm} arm"));
        let body = &script[at..];
        let m = body.find("match_rust_version").unwrap_or_else(|| panic!("{arm} does not match the rust-version"));
        let b = body.find(build).unwrap_or_else(|| panic!("{arm} does not run {build}"));
        assert!(m < b, "{arm}: the rust-version is matched after the build starts");
    }
    assert!(script.contains("\"-Z unstable-options --fail-uncoverable\""), "ci/kani.sh passes --fail-uncoverable");
}
