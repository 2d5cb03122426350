//! The model: its configurations (full, small, tiny, homing) and the
//! stateright `Model` over the real kernel.

use crate::config::{HOMING_MODEL_CONFIG, MODEL_CONFIG};
use crate::environment::Action;
use crate::identity::ModelScalar;
use crate::state::{St, J1};
use kernel::config::AXES;
use kernel::homing::Phase;
use kernel::{Authority, Kernel, Request, Scalar, State};
use proofs::setup::new_kernel;
use stateright::{Model, Property};

pub(crate) struct Supervisor<S: Scalar> {
    /// The initial kernel; every state holds a clone of it (same identity),
    /// so `authority`, returned with it by `Kernel::new`, is accepted.
    pub(crate) init: Kernel<S>,
    pub(crate) authority: Authority,
    pub(crate) here: [S; AXES],
    /// A target just outside J1's limits, within a stream sample's reach of
    /// the homed arm (so only the limits can refuse it).
    pub(crate) out_of_limits: [S; AXES],
    pub(crate) small: bool,
    /// The tiny configuration (f32): small, and six perturbations.
    pub(crate) tiny: bool,
    /// The homing configuration: the per-joint requests and every arrival
    /// order, with no perturbation but the tick overrun.
    pub(crate) homing: bool,
}

/// The measured positions of a kernel homed on the stationary arm
/// (`proofs::setup::operational`'s run, without its safety monitor: the
/// mutation tests must reach the model's properties, not stop at the
/// monitor during this set-up).
pub(crate) fn homed_positions<S: ModelScalar>() -> [S; AXES] {
    use proofs::setup::{still, HOMING_TICKS, PROOF_VALIDATED};
    let (mut k, _) = new_kernel::<S>(&PROOF_VALIDATED);
    k.tick(&still(0), None);
    k.tick(&still(0), Some(Request::Home));
    for _ in 0..HOMING_TICKS {
        if k.state() != State::Homing {
            break;
        }
        let phases = k.homing_phases();
        let seeking = phases.iter().enumerate().filter(|(_, p)| matches!(p, Phase::FastSeek | Phase::SlowSeek));
        let limits = seeking.fold(0u8, |m, (i, _)| m | 1 << i);
        k.tick(&still(limits), None);
    }
    k.tick(&still(0), None).status.position
}

/// The model of configuration `cfg` (full, small, tiny, homing).
pub(crate) fn supervisor<S: ModelScalar>(cfg: &str) -> Supervisor<S> {
    let (small, tiny, homing) = (matches!(cfg, "small" | "tiny"), cfg == "tiny", cfg == "homing");
    // Valid targets near the stationary arm: it ends homing on its switches,
    // which lie just outside the URDF limits, so clamp 10 mrad inside them.
    let mut here = homed_positions::<S>();
    for (i, h) in here.iter_mut().enumerate() {
        let j = &MODEL_CONFIG.joints[i];
        *h = h.clamp_between(S::from_f32(j.limit_min + 0.01), S::from_f32(j.limit_max - 0.01));
    }
    // The homing configuration's J4 has a longer homing timeout (so J5
    // finishes first and waits for it); nothing else differs.
    let arm = if homing { HOMING_MODEL_CONFIG } else { MODEL_CONFIG };
    let (init, authority) = new_kernel::<S>(&kernel::config::Validated::relaxed(arm));
    // J1 10 mrad beyond its nearer limit (20 mrad from `here`, well within
    // a stream sample's reach), every other joint where it is.
    let mut out_of_limits = here;
    let j1 = &MODEL_CONFIG.joints[0];
    let (lo, hi) = (S::from_f32(j1.limit_min), S::from_f32(j1.limit_max));
    out_of_limits[0] =
        if here[0].minus(lo) < hi.minus(here[0]) { lo.minus(S::from_f32(0.01)) } else { hi.plus(S::from_f32(0.01)) };
    Supervisor { init, authority, here, out_of_limits, small, tiny, homing }
}

impl<S: ModelScalar> Model for Supervisor<S> {
    type State = St<S>;
    type Action = Action;

    fn init_states(&self) -> Vec<St<S>> {
        vec![St {
            k: self.init.clone(),
            violated: 0,
            ever_enabled: false,
            j1: J1 { seen: false, reference: 0, run: 0 },
            ramp: None,
            group_waited: false,
            ticks: 0,
        }]
    }

    fn actions(&self, s: &St<S>, actions: &mut Vec<Action>) {
        self.choices(s, actions);
    }

    fn next_state(&self, s: &St<S>, a: Action) -> Option<St<S>> {
        Some(self.step(s, a))
    }

    fn properties(&self) -> Vec<Property<Self>> {
        self.state_properties()
    }
}
