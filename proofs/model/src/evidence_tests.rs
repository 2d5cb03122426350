//! SAFETY.md's model-checked rows against the model's properties and the
//! mutants, and the per-joint argument for the joints the model perturbs.

use crate::model::supervisor;
use kernel::config::AXES;
use kernel::{EncoderSample, FaultReason, Fx, Sense, State};
use proofs::setup::{COUNTS, PROOF_CONFIG};
use stateright::Model;
use std::collections::BTreeSet;

/// Every property of every configuration of the model.
fn model_properties() -> BTreeSet<&'static str> {
    let mut names = BTreeSet::new();
    for cfg in ["full", "stream", "small", "tiny", "homing"] {
        names.extend(supervisor::<Fx>(cfg).properties().iter().map(|p| p.name));
    }
    names
}

/// The `property "NAME"` of a SAFETY.md cell.
fn named(cell: &str) -> Vec<&str> {
    cell.split("property \"").skip(1).filter_map(|r| r.split('"').next()).collect()
}

#[test]
fn every_model_checked_row_has_a_property_and_a_mutant() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");
    let safety = std::fs::read_to_string(format!("{root}/SAFETY.md")).expect("SAFETY.md");
    let mutants = std::fs::read_to_string(format!("{root}/proofs/model/mutants.sh")).expect("mutants.sh");
    // The property each mutant expects (the last argument of `mutant`).
    let expected: Vec<&str> = mutants
        .lines()
        .filter_map(|l| l.trim().strip_prefix("small ").or_else(|| l.trim().strip_prefix("homing ")))
        .map(|p| p.trim_matches(|c| c == '\'' || c == '"'))
        .collect();
    let props = model_properties();
    let mut rows = 0;
    for line in safety.lines().filter(|l| l.starts_with("| SR-")) {
        let cells: Vec<&str> = line.split(" | ").collect();
        let (id, executed) = (cells[0].trim_start_matches("| "), cells.get(2).copied().unwrap_or(""));
        if !executed.contains("model-checked") {
            continue;
        }
        rows += 1;
        let names = named(executed);
        assert!(!names.is_empty(), "{id}: says model-checked but names no model property");
        for n in &names {
            assert!(props.contains(n), "{id}: names \"{n}\", which is no property of the model");
        }
        assert!(
            names.iter().any(|n| expected.contains(n)),
            "{id}: no mutant in mutants.sh fails any of its properties {names:?}"
        );
    }
    assert!(rows >= 15, "only {rows} model-checked rows found: the table's format changed");
    // Every mutant expects a property the model has.
    for e in &expected {
        assert!(props.contains(e), "mutants.sh expects \"{e}\", which is no property of the model");
    }
}

/// The model perturbs only J1's encoder and the J1 and J6 switches. The
/// kernel checks every axis with the same code (`Kernel::check`, the
/// per-axis `sense_and_estimate`); this test shows every joint behaves
/// as J1 and J6 do in the model: a pressed switch in Operational faults
/// in the same tick with that joint's reason, and the
/// (limit + 1)-th lost sample of any joint faults in its tick, fewer
/// are ridden through.
#[test]
fn every_joint_is_checked_like_j1_and_j6() {
    let still = |limits: u8, lost: Option<usize>| {
        let mut encoders = COUNTS.map(EncoderSample::Count);
        if let Some(i) = lost {
            encoders[i] = EncoderSample::Lost;
        }
        Sense { encoders, limits, hardware_fault: None, link_lost: false }
    };
    let limit = PROOF_CONFIG.encoder_invalid_limit;
    for i in 0..AXES {
        let (mut k, _) = proofs::setup::operational::<Fx>();
        let o = k.tick(&still(1 << i, None), None);
        assert_eq!(o.status.state, State::Fault, "J{}: switch", i + 1);
        assert_eq!(o.status.fault.map(|f| f.reason), Some(FaultReason::LimitSwitch { axis: i as u8 }));

        let (mut k, _) = proofs::setup::operational::<Fx>();
        for t in 1..=limit {
            let o = k.tick(&still(0, Some(i)), None);
            assert_eq!(o.status.state, State::Operational, "J{}: lost sample {t} of {limit} ridden through", i + 1);
        }
        let o = k.tick(&still(0, Some(i)), None);
        assert_eq!(o.status.state, State::Fault, "J{}: sample {} lost", i + 1, limit + 1);
        assert_eq!(o.status.fault.map(|f| f.reason), Some(FaultReason::EncoderLost { axis: i as u8 }));
    }
}

#[test]
fn every_hardware_fault_kind_is_drawn_in_the_tiny_and_full_configurations() {
    use crate::environment::{Perturb, PERTURBATIONS_FULL, PERTURBATIONS_TINY};
    use kernel::HardwareFault;
    // The exhaustive match makes a new kind a compile error here until the
    // model draws it (SR-21: every kind faults in the same tick).
    let kind = |f: &HardwareFault| match f {
        HardwareFault::TickOverrun => 0,
        HardwareFault::Driver { .. } => 1,
        HardwareFault::SelfTest(_) => 2,
        HardwareFault::DriverDiagnostic { .. } => 3,
    };
    for (name, set) in [("tiny", &PERTURBATIONS_TINY[..]), ("full", &PERTURBATIONS_FULL[..])] {
        let drawn: BTreeSet<u8> = set
            .iter()
            .filter_map(|p| match p {
                Perturb::Hardware(f) => Some(kind(f)),
                _ => None,
            })
            .collect();
        assert_eq!(drawn, (0..4).collect(), "the {name} configuration draws hardware fault kinds {drawn:?}");
    }
}

#[test]
fn the_kernel_never_reads_a_driver_cause() {
    // The model draws one driver-diagnostic cause for all: sound only while
    // the kernel stores the reported fault without branching on its cause.
    let src = concat!(env!("CARGO_MANIFEST_DIR"), "/../../kernel/src");
    let mut stack = vec![std::path::PathBuf::from(src)];
    let mut files = 0;
    while let Some(p) = stack.pop() {
        for e in std::fs::read_dir(&p).expect("kernel/src") {
            let path = e.expect("entry").path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|x| x == "rs") {
                files += 1;
                let text = std::fs::read_to_string(&path).expect("source");
                let uses = text.matches("DriverCause::").count();
                let defines = path.ends_with("types.rs");
                assert!(defines || uses == 0, "{} reads DriverCause ({uses} uses)", path.display());
            }
        }
    }
    assert!(files > 5, "kernel/src has {files} files");
}
