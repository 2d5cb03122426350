//! The model: its configurations (full, stream, small, tiny, homing) and the
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
    /// How far below `here` the second valid target lies, on every joint
    /// (`NEAR_LANDING` in the full configuration, `NEAR_STREAM` in the
    /// others).
    pub(crate) near: S,
    /// The full configuration: valid targets `NEAR_LANDING` apart.
    pub(crate) landing: bool,
    /// The full configuration: a third valid target `NEAR_STREAM` below
    /// `here` (`Req::MotionFar`), sent only from rest or to re-send it.
    pub(crate) far: bool,
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

/// The second valid target's distance below `here` in the full
/// configuration (rad): a motion toward either target lands in one tick on
/// every joint (20 urad in a 1 ms tick is 0.02 rad/s, under the smallest
/// per-tick velocity step of the arm's set-points, J1's and J2's
/// 0.024 rad/s, `tests::a_near_motion_lands_in_one_tick`), so the
/// set-points' positions and velocities take finitely many values and the
/// configuration finishes. What it still reaches: motions interrupted and
/// reversed (a target sent while the set-point moves toward the other),
/// soft stops from a moving set-point, every request, perturbation and
/// arrival order. What it does not: a set-point cruising or braking by the
/// braking test (the stream configuration's 2 mrad targets, bounded).
pub(crate) const NEAR_LANDING: f32 = 0.000_02;
/// The second valid target's distance in the other configurations (rad):
/// within a stream sample's reach, far enough that a motion accelerates,
/// cruises and brakes over several ticks.
pub(crate) const NEAR_STREAM: f32 = 0.002;

/// `--no-far`: the full configuration without its 2 mrad target (only the
/// 20 urad ones), to show that the `sometimes` properties the target is
/// there for (the command timeout's soft stop, SoftEstop, a cruising and a
/// braking set-point) fail where it is not offered.
pub(crate) static NO_FAR: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// `--homing-restricted`: the full configuration with the stream
/// configuration's alphabet during homing (`REQUESTS_HOMING`,
/// `PERTURBATIONS_HOMING`, no merged requests), to regenerate the figures
/// measured with it.
pub(crate) static HOMING_RESTRICTED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// The model of configuration `cfg` (full, stream, small, tiny, homing).
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
    let landing = cfg == "full";
    let near = S::from_f32(if landing { NEAR_LANDING } else { NEAR_STREAM });
    let far = landing && !NO_FAR.load(std::sync::atomic::Ordering::Relaxed);
    Supervisor { init, authority, here, near, landing, far, out_of_limits, small, tiny, homing }
}

impl<S: ModelScalar> Model for Supervisor<S> {
    type State = St<S>;
    type Action = Action;

    fn init_states(&self) -> Vec<St<S>> {
        vec![St {
            k: self.init.clone(),
            violated: 0,
            enabled: false,
            j1: J1 { seen: false, reference: 0, run: 0 },
            ramp: None,
            group_waited: false,
            far: false,
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

#[cfg(test)]
mod tests {
    use super::*;
    use kernel::{Fx, MotionKind, MotionTarget};
    use proofs::setup::{still, HOMING_TICKS};

    /// The full configuration's kernel, homed on the stationary arm (every
    /// seeking axis's switch arriving on the first tick it seeks).
    fn homed(m: &Supervisor<Fx>) -> Kernel<Fx> {
        let mut k = m.init.clone();
        k.tick(&still(0), None);
        k.tick(&still(0), Some(Request::Home));
        for _ in 0..HOMING_TICKS {
            let phases = k.homing_phases();
            let seeking = phases.iter().enumerate().filter(|(_, p)| matches!(p, Phase::FastSeek | Phase::SlowSeek));
            let limits = seeking.fold(0u8, |m, (i, _)| m | 1 << i);
            k.tick(&still(limits), None);
        }
        k
    }

    /// From rest, a motion toward the full configuration's near target
    /// lands on it in the tick that accepts it, on every joint (its
    /// distance in one tick is a speed under every joint's per-tick
    /// velocity step); toward the 2 mrad target of the other
    /// configurations it does not.
    #[test]
    fn a_near_motion_lands_in_one_tick() {
        let hz = MODEL_CONFIG.tick_hz;
        for j in &MODEL_CONFIG.joints {
            let dv = kernel::interp::joint_profile::<f32>(j, hz).dv;
            assert!(NEAR_LANDING * hz as f32 <= dv, "{} rad/s > dv {dv}", NEAR_LANDING * hz as f32);
        }
        for (cfg, lands) in [("full", true), ("stream", false)] {
            let m = supervisor::<Fx>(cfg);
            let mut k = homed(&m);
            assert_eq!(k.state(), State::Operational);
            let target = m.here.map(|x| x.minus(m.near));
            let t = MotionTarget { position: target, velocity: [Fx::ZERO; AXES], kind: MotionKind::Stream };
            let o = k.tick(&still(0), Some(Request::Motion(t)));
            assert_eq!(o.status.state, State::Operational);
            assert_eq!(
                o.status.setpoint == target,
                lands,
                "{cfg}: set-points {:?}, target {target:?}",
                o.status.setpoint
            );
        }
    }

    /// The full configuration's 2 mrad target (`Req::MotionFar`) is what its
    /// `sometimes` properties of the command timeout, cruising and braking
    /// need: re-sent every tick, a motion toward it from rest runs longer
    /// than the 3 ms command timeout and some set-point cruises and brakes
    /// on the way (`Supervisor::ahead`); sent once, the timeout soft-stops
    /// it and the ramp latches SoftEstop. A motion toward the 20 urad target
    /// (`Req::MotionNear`) does none of it.
    #[test]
    fn the_far_target_cruises_brakes_and_meets_the_command_timeout() {
        use crate::environment::{Perturb, Req};
        use crate::state::{St, J1};
        let m = supervisor::<Fx>("full");
        assert!(m.far);
        let still = m.sense(Perturb::None, 0);
        let st = |k: &Kernel<Fx>| St {
            k: k.clone(),
            violated: 0,
            enabled: false,
            j1: J1 { seen: true, reference: proofs::setup::COUNTS[0], run: 0 },
            ramp: None,
            group_waited: false,
            far: true,
            ticks: 0,
        };
        for (req, far) in [(Req::MotionFar, true), (Req::MotionNear, false)] {
            let mut k = homed(&m);
            let (mut ticks, mut cruises, mut brakes) = (0, false, false);
            while ticks < 100 {
                let o = k.tick(&still, Some(m.request(req)));
                assert_eq!(o.status.state, State::Operational, "{req:?}");
                ticks += 1;
                if k.setpoints_at_rest() {
                    break;
                }
                if let Some(a) = m.ahead(&st(&k)) {
                    (cruises, brakes) = (cruises || a.cruises, brakes || a.brakes);
                }
            }
            assert!(k.setpoints_at_rest(), "{req:?}: no arrival in 100 ticks");
            println!("{req:?}, re-sent every tick: arrives after {ticks} ticks; cruises {cruises}, brakes {brakes}");
            let timeout = MODEL_CONFIG.command_timeout_ms * MODEL_CONFIG.tick_hz / 1000;
            assert_eq!((ticks > timeout, cruises, brakes), (far, far, far), "{req:?}: {ticks} ticks");
            // Sent once: the timeout soft-stops a moving arm (far only), then
            // SoftEstop after the ramp.
            let mut k = homed(&m);
            k.tick(&still, Some(m.request(req)));
            let mut states = Vec::new();
            for _ in 0..12 {
                states.push(k.tick(&still, None).status.state);
            }
            assert_eq!(states.contains(&State::SoftEstop), far, "{req:?}: {states:?}");
        }
    }

    /// The fact the full and stream configurations' restriction of requests
    /// during homing to none and one motion rests on (`REQUESTS_HOMING`):
    /// in Homing every request of the full alphabet is
    /// refused, with a `Rejected` event, and the tick reaches the kernel the
    /// tick without a request reaches (every field: its `Debug` text), with
    /// the same outputs and status. From every tick of a run with every
    /// seeking switch arriving at once, and from the same run with no
    /// switch ever arriving (to its homing timeout), under every
    /// perturbation of the full configuration.
    #[test]
    fn a_request_during_homing_changes_nothing_but_the_events() {
        use crate::environment::{PERTURBATIONS_FULL, REQUESTS_FULL_FAR};
        let m = supervisor::<Fx>("full");
        let mut compared = 0;
        for arrive in [true, false] {
            let mut k = m.init.clone();
            k.tick(&still(0), None);
            k.tick(&still(0), Some(Request::Home));
            for _ in 0..HOMING_TICKS {
                if k.state() != State::Homing {
                    break;
                }
                let phases = k.homing_phases();
                let seeking = phases.iter().enumerate().filter(|(_, p)| matches!(p, Phase::FastSeek | Phase::SlowSeek));
                let limits = if arrive { seeking.fold(0u8, |m, (i, _)| m | 1 << i) } else { 0 };
                for &p in &PERTURBATIONS_FULL {
                    let sense = m.sense(p, limits);
                    let mut none = k.clone();
                    let o = none.tick(&sense, None);
                    for &r in REQUESTS_FULL_FAR.iter().flatten() {
                        let mut with = k.clone();
                        let w = with.tick(&sense, Some(m.request(r)));
                        assert_eq!(format!("{with:?}"), format!("{none:?}"), "{r:?} under {p:?}");
                        assert_eq!((w.act, w.status), (o.act, o.status), "{r:?} under {p:?}");
                        assert!(w.events.iter().any(|e| matches!(e, kernel::Event::Rejected { .. })), "{r:?}");
                        compared += 1;
                    }
                }
                k.tick(&still(limits), None);
            }
        }
        println!("{compared} requests during homing compared with none");
        assert!(compared > 1000, "{compared}");
    }
}
