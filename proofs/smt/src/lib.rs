//! SMT proofs of the kernel's generic per-axis code.
//!
//! `kernel::Scalar` is implemented for two symbolic types ([`sym::SymF32`]:
//! IEEE binary32; [`sym::SymFx`]: `I8F24` as a 32-bit bit-vector with the
//! `fixed` crate's saturation and rounding) whose values are z3 terms. The
//! kernel's own generic functions (`Scalar::saturate`,
//! `Scalar::clamp_between`, `control::control_law`, `AlphaBeta::step` /
//! `coast`, `Interpolator::advance` with `interp::profile`, the soft-stop
//! and homing ramps of `ramp`, `homing::AxisHoming::step`, composed per
//! mode into the candidate outputs of the SR-2 output gate) run on them
//! unchanged; every `bool` they
//! branch on is a path decision ([`ctx`]), and each property is checked by
//! z3 on every feasible path (or, explored blind, on every path):
//! proved for all inputs, NaN and infinities included.
//!
//! The semantics of every symbolic operation are checked against `f32`
//! and `I8F24` in `tests/semantics.rs`; `tests/broken.rs` shows that
//! broken functions fail. See `README.md`.

pub mod ctx;
pub mod props;
pub mod sym;
pub mod z3;

use ctx::Outcome;
use kernel::Fx;
use sym::{Sym, SymF32, SymFx, B};

/// One proof obligation.
#[derive(Clone, Debug)]
pub struct Proof {
    /// What is proved.
    pub name: &'static str,
    /// `f32` or `I8F24`.
    pub variant: &'static str,
    /// The joints whose constants this instance uses (empty: none).
    pub joints: Vec<usize>,
    /// Not established within the test command's budget (z3 times out on
    /// some path): run only on request (`smt --extended`).
    pub extended: bool,
    /// Explore every decision blind, reusing unsatisfiable cores
    /// ([`ctx::explore_blind`]) instead of asking z3 at each decision.
    pub blind: bool,
    /// With `blind`: decisions on constants take their one value
    /// ([`ctx::explore_blind_evaluating_constants`]).
    pub evaluate_constants: bool,
    /// Builds the property (inputs, preconditions, kernel code).
    pub build: fn(usize) -> Vec<B>,
}

impl Proof {
    /// `J1,J2`-style label of the joints covered.
    pub fn joints_label(&self) -> String {
        if self.joints.is_empty() {
            return "-".to_string();
        }
        self.joints.iter().map(|j| format!("J{}", j + 1)).collect::<Vec<_>>().join(",")
    }

    /// Runs the proof in a fresh z3.
    pub fn run(&self) -> Outcome {
        let j = self.joints.first().copied().unwrap_or(0);
        let build = self.build;
        let f = || build(j).into_iter().map(|b| b.0).collect();
        ctx::session(|| {
            if self.blind && self.evaluate_constants {
                ctx::explore_blind_evaluating_constants(f)
            } else if self.blind {
                ctx::explore_blind(f)
            } else {
                ctx::explore(f)
            }
        })
    }
}

/// Joints grouped by equal `key` (in joint order): one proof per group
/// covers every joint in it, since the proven function sees only the
/// constants the key compares.
fn groups<K: PartialEq>(key: impl Fn(usize) -> K) -> Vec<Vec<usize>> {
    let mut out: Vec<(K, Vec<usize>)> = Vec::new();
    for j in 0..kernel::config::AXES {
        let k = key(j);
        match out.iter_mut().find(|(g, _)| *g == k) {
            Some((_, v)) => v.push(j),
            None => out.push((k, vec![j])),
        }
    }
    out.into_iter().map(|(_, v)| v).collect()
}

fn per_variant<S: Sym>(out: &mut Vec<Proof>) {
    let v = S::VARIANT;
    let one = |name, build| Proof {
        name,
        variant: v,
        joints: Vec::new(),
        extended: false,
        blind: false,
        evaluate_constants: false,
        build,
    };
    out.push(one("saturate", |_| props::saturate::<S>(|x, l| x.saturate(l))));
    out.push(one("clamp_between", |_| props::clamp_between::<S>()));
    // The control law sees (kp, vmax, deadband); group joints by their
    // concrete values in this variant.
    for joints in groups(|j| {
        let jc = &props::CONFIG.joints[j];
        (jc.kp.to_bits(), jc.max_velocity.to_bits(), props::CONFIG.deadband.to_bits())
    }) {
        out.push(Proof {
            name: "control_law",
            variant: v,
            joints,
            extended: false,
            blind: false,
            evaluate_constants: false,
            build: |j| props::control::<S>(j),
        });
    }
    // (I8F24 has no NaN or infinity: nothing to absorb.)
    if S::VARIANT == SymF32::VARIANT {
        out.push(one("observer step: never absorbs NaN/inf", |_| props::observer_non_finite::<S>(false)));
        out.push(one("observer coast: never absorbs NaN/inf", |_| props::observer_non_finite::<S>(true)));
    }
    out.push(one("observer coast: bounded move", |_| props::observer_coast::<S>(1e-5)));
    out.push(one("soft-stop scale: in [0, 1]", |_| props::stop_scale::<S>(1)));
    // Explored blind for the bit-blasting tactic and the product lemmas.
    let blind = |name, build| Proof {
        name,
        variant: v,
        joints: Vec::new(),
        extended: false,
        blind: true,
        evaluate_constants: false,
        build,
    };
    out.push(blind("soft-stop output: finite, zero at the end, inside the envelope and prev", |_| {
        props::stop_output::<S>(kernel::ramp::stop_output)
    }));
    out.push(blind("homing ramp: within the computed vel +- dv", |_| props::homing_ramp::<S>(kernel::ramp::toward)));
    // The SR-2 output gate (`Kernel::check`): each mode's candidate output
    // from its inputs, finite and within vmax (`props::gate_operational`).
    out.push(Proof {
        name: "output gate, Operational: law then acceleration clamp, finite and within vmax",
        variant: v,
        joints: Vec::new(),
        extended: false,
        blind: true,
        evaluate_constants: true,
        build: |_| props::gate_operational::<S>(kernel::control::control_law, props::Pre::ALL),
    });
    out.push(blind("output gate, Stopping: soft-stop output finite and within vmax", |_| {
        props::gate_stopping::<S>(kernel::ramp::stop_output, props::Pre::ALL)
    }));
    out.push(Proof {
        name: "output gate, Homing: homing step finite and within vmax, keeps |vel| <= vmax",
        variant: v,
        joints: Vec::new(),
        extended: false,
        blind: true,
        evaluate_constants: true,
        build: |_| props::gate_homing::<S>(props::Pre::ALL),
    });
}

/// Every proof, for both variants.
pub fn all() -> Vec<Proof> {
    let mut out = Vec::new();
    per_variant::<SymF32>(&mut out);
    per_variant::<SymFx>(&mut out);
    out.push(Proof {
        name: "observer step: between prediction and measurement (+-1e-5, plausible state)",
        variant: SymF32::VARIANT,
        joints: Vec::new(),
        extended: false,
        blind: false,
        evaluate_constants: false,
        build: |_| props::observer_between::<SymF32>(1e-5, false),
    });
    out.push(Proof {
        name: "observer step: between prediction and measurement (exact, every input)",
        variant: SymFx::VARIANT,
        joints: Vec::new(),
        extended: false,
        blind: false,
        evaluate_constants: false,
        build: |_| props::observer_between::<SymFx>(0.0, true),
    });
    // The interpolator sees its profile only: group joints by the concrete
    // profile of each variant. Explored blind (`ctx::explore_blind`): the
    // braking test's decisions are expensive to decide and do not matter
    // to the speed and acceleration bounds.
    use props::InterpProp::{Acceleration, Finite, NeverPasses, Speed};
    let interp = |variant, joints: Vec<usize>, name, extended, build| Proof {
        name,
        variant,
        joints,
        extended,
        blind: true,
        evaluate_constants: false,
        build,
    };
    for joints in groups(props::joint_profile::<f32>) {
        let v = SymF32::VARIANT;
        out.push(interp(v, joints.clone(), "interpolator step: new state finite", false, |j| {
            props::interpolator::<SymF32>(j, Finite, props::advance)
        }));
        out.push(interp(v, joints.clone(), "interpolator step: |vel'| <= vmax + slack", false, |j| {
            props::interpolator::<SymF32>(j, Speed, props::advance)
        }));
        out.push(interp(v, joints.clone(), "interpolator step: |vel' - vel| <= dv + slack", false, |j| {
            props::interpolator::<SymF32>(j, Acceleration, props::advance)
        }));
        out.push(interp(v, joints, "interpolator step: never passes a reachable target", true, |j| {
            props::interpolator::<SymF32>(j, NeverPasses, props::advance)
        }));
    }
    // The set-point guarantee's one-tick lemma (SR-18), both variants, for
    // every profile (so every joint's).
    use props::Guarantee::{Advance, Retarget};
    let every: Vec<usize> = (0..kernel::config::AXES).collect();
    out.push(interp(
        SymF32::VARIANT,
        every.clone(),
        "set-point guarantee: a tick stays in the interval",
        false,
        |_| props::setpoint_guarantee::<SymF32>(Advance),
    ));
    out.push(interp(SymF32::VARIANT, every.clone(), "set-point guarantee: a target's interval", false, |_| {
        props::setpoint_guarantee::<SymF32>(Retarget)
    }));
    out.push(interp(SymFx::VARIANT, every.clone(), "set-point guarantee: a tick stays in the interval", false, |_| {
        props::setpoint_guarantee::<SymFx>(Advance)
    }));
    out.push(interp(SymFx::VARIANT, every, "set-point guarantee: a target's interval", false, |_| {
        props::setpoint_guarantee::<SymFx>(Retarget)
    }));
    for joints in groups(props::joint_profile::<Fx>) {
        let v = SymFx::VARIANT;
        out.push(interp(v, joints.clone(), "interpolator step: new state finite", false, |j| {
            props::interpolator::<SymFx>(j, Finite, props::advance)
        }));
        out.push(interp(v, joints.clone(), "interpolator step: |vel'| <= vmax + slack", false, |j| {
            props::interpolator::<SymFx>(j, Speed, props::advance)
        }));
        out.push(interp(v, joints.clone(), "interpolator step: |vel' - vel| <= dv + slack", false, |j| {
            props::interpolator::<SymFx>(j, Acceleration, props::advance)
        }));
        out.push(interp(v, joints, "interpolator step: never passes a reachable target", true, |j| {
            props::interpolator::<SymFx>(j, NeverPasses, props::advance)
        }));
    }
    out
}

/// The SAFETY.md requirements a proof is evidence for (`SR-2/3` style), by
/// its name: the evidence summary of the test command attaches each proof
/// to these rows and checks that they claim it.
pub fn requirements(name: &str) -> &'static str {
    match name {
        n if n.starts_with("output gate") => "SR-2",
        n if n.starts_with("saturate") || n.starts_with("control_law") => "SR-2/3",
        n if n.starts_with("clamp_between") => "SR-2",
        n if n.starts_with("observer") => "SR-3",
        n if n.starts_with("soft-stop") => "SR-7",
        n if n.starts_with("homing ramp") => "SR-14/25",
        n if n.contains("never passes") || n.starts_with("set-point guarantee") => "SR-18",
        n if n.contains("|vel'| <= vmax") => "SR-18/27",
        n if n.starts_with("interpolator") => "SR-27",
        _ => "SR-?",
    }
}

#[cfg(test)]
mod tests {
    /// The interpolator proofs' profiles are the kernel's own (`Params`):
    /// a proof built from another profile fails here.
    #[test]
    fn the_proofs_profiles_are_the_kernel_s() {
        use kernel::config::PAROL6_VALIDATED;
        let (k32, _) = kernel::Kernel::<f32>::new(&PAROL6_VALIDATED);
        let (kfx, _) = kernel::Kernel::<kernel::Fx>::new(&PAROL6_VALIDATED);
        for j in 0..kernel::config::AXES {
            assert_eq!(k32.profile(j), Some(crate::props::joint_profile::<f32>(j)), "J{}", j + 1);
            assert_eq!(kfx.profile(j), Some(crate::props::joint_profile::<kernel::Fx>(j)), "J{}", j + 1);
        }
    }

    /// The output-gate proofs' preconditions on the configuration hold for
    /// the shipped one, in both variants: each constant as `Params::new`
    /// converts it (`S::from_f32` of the `f32` expression it writes).
    fn gate_preconditions_hold<S: kernel::Scalar>() {
        let c = &crate::props::CONFIG;
        for (i, j) in c.joints.iter().enumerate() {
            let vmax = S::from_f32(j.max_velocity);
            assert!(vmax > S::ZERO && vmax <= S::from_f32(16.0), "J{}: vmax", i + 1);
            let within = |x: S| x.is_finite() && x.abs() <= vmax;
            let step = S::from_f32(j.max_acceleration / c.tick_hz as f32);
            assert!(step.is_finite() && step >= S::ZERO, "J{}: accel_step and homing dv", i + 1);
            let dir = j.homing.direction.sign();
            assert!(within(S::from_f32(j.homing.fast_speed * dir)), "J{}: fast_toward", i + 1);
            assert!(within(S::from_f32(j.homing.slow_speed * dir)), "J{}: slow_toward", i + 1);
        }
    }

    #[test]
    fn the_gate_preconditions_hold_for_the_shipped_configuration() {
        gate_preconditions_hold::<f32>();
        gate_preconditions_hold::<kernel::Fx>();
    }

    #[test]
    fn every_proof_traces_to_a_requirement() {
        for p in super::all() {
            assert_ne!(super::requirements(p.name), "SR-?", "{}", p.name);
        }
    }
}
