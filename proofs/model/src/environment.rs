//! The environment: the requests, sensor perturbations and switch arrivals
//! each configuration offers the kernel on a tick, and the sensor reading
//! and request each one makes.

use crate::identity::ModelScalar;
use crate::model::Supervisor;
use crate::state::St;
use kernel::config::AXES;
use kernel::homing::Phase;
use kernel::{DriverCause, EncoderSample, HardwareFault, MotionTarget, Request, Sense, State};
use proofs::setup::COUNTS;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Req {
    Home,
    HomeJoint(u8),
    Enable,
    MotionNear,
    MotionHere,
    /// The full configuration's third valid target, `NEAR_STREAM` below
    /// the homed arm: a motion toward it accelerates, cruises and brakes
    /// over several ticks. Offered only while the set-points are at rest or
    /// already move toward it (`Supervisor::choices`).
    MotionFar,
    MotionOutOfLimits,
}

/// A one-tick disturbance of the stationary arm's sensors.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) enum Perturb {
    None,
    LostJ1,
    GlitchJ1,
    Hardware(HardwareFault),
    StraySwitch(u8),
}

/// Every kind of hardware fault the HAL reports (SR-21).
pub(crate) const HW_OVERRUN: Perturb = Perturb::Hardware(HardwareFault::TickOverrun);
pub(crate) const HW_DRIVER: Perturb = Perturb::Hardware(HardwareFault::Driver { axis: 2 });
pub(crate) const HW_SELFTEST: Perturb = Perturb::Hardware(HardwareFault::SelfTest(7));
/// A driver's own diagnostics over its SPI link. One cause stands for all:
/// the kernel stores the reported fault and never branches on the cause
/// (`the_kernel_never_reads_a_driver_cause` checks its source).
pub(crate) const HW_DRIVER_DIAG: Perturb =
    Perturb::Hardware(HardwareFault::DriverDiagnostic { axis: 3, cause: DriverCause::Overtemperature });

pub(crate) const PERTURBATIONS: [Perturb; 6] =
    [Perturb::None, Perturb::LostJ1, Perturb::GlitchJ1, HW_OVERRUN, Perturb::StraySwitch(0), Perturb::StraySwitch(5)];
/// The full and stream configurations' perturbations outside homing: every one, with
/// every kind of hardware fault.
pub(crate) const PERTURBATIONS_FULL: [Perturb; 9] = [
    Perturb::None,
    Perturb::LostJ1,
    Perturb::GlitchJ1,
    HW_OVERRUN,
    HW_DRIVER,
    HW_SELFTEST,
    HW_DRIVER_DIAG,
    Perturb::StraySwitch(0),
    Perturb::StraySwitch(5),
];

pub(crate) const REQUESTS_FULL: [Option<Req>; 9] = [
    None,
    Some(Req::Home),
    Some(Req::HomeJoint(0)),
    Some(Req::HomeJoint(5)),
    Some(Req::HomeJoint(9)),
    Some(Req::Enable),
    Some(Req::MotionNear),
    Some(Req::MotionHere),
    Some(Req::MotionOutOfLimits),
];
/// The full configuration's requests: `REQUESTS_FULL` and the 2 mrad target
/// (`Req::MotionFar`), which `Supervisor::choices` offers only while the
/// set-points are at rest or already move toward it.
pub(crate) const REQUESTS_FULL_FAR: [Option<Req>; 10] = [
    None,
    Some(Req::Home),
    Some(Req::HomeJoint(0)),
    Some(Req::HomeJoint(5)),
    Some(Req::HomeJoint(9)),
    Some(Req::Enable),
    Some(Req::MotionNear),
    Some(Req::MotionHere),
    Some(Req::MotionFar),
    Some(Req::MotionOutOfLimits),
];
pub(crate) const REQUESTS_SMALL: [Option<Req>; 5] =
    [None, Some(Req::Home), Some(Req::Enable), Some(Req::MotionNear), Some(Req::MotionOutOfLimits)];
/// The homing configuration: full and per-joint homing (J1, J4, J5, J6 and
/// a bad index), and enable to leave a latch.
pub(crate) const REQUESTS_HOMING_CONFIG: [Option<Req>; 7] = [
    None,
    Some(Req::Home),
    Some(Req::HomeJoint(0)),
    Some(Req::HomeJoint(3)),
    Some(Req::HomeJoint(4)),
    Some(Req::HomeJoint(5)),
    Some(Req::Enable),
];
pub(crate) const PERTURBATIONS_HOMING_CONFIG: [Perturb; 2] = [Perturb::None, HW_OVERRUN];
/// In Homing every request is refused (no state change, a `Rejected`
/// event; `model::tests::a_request_during_homing_changes_nothing_but_the_events`):
/// the full and stream configurations keep one motion request to check that.
pub(crate) const REQUESTS_HOMING: [Option<Req>; 2] = [None, Some(Req::MotionNear)];
/// Perturbations the stream configuration explores during homing (with every
/// arrival order); the small one explores all six there (with all-or-nothing
/// arrivals). A restriction: without it the run outgrew its time budget.
pub(crate) const PERTURBATIONS_HOMING: [Perturb; 4] =
    [Perturb::None, Perturb::LostJ1, HW_OVERRUN, Perturb::StraySwitch(5)];
/// Perturbations the full configuration explores during homing (with every
/// arrival order): every one but the J1 glitch and the J1 stray switch, so
/// every hardware fault kind. A restriction: the two left out change the
/// kernel's state while the axes home and multiply the homing states past
/// what the run's time and memory allow (`proofs/model/README.md`,
/// "Requests and perturbations during homing").
pub(crate) const PERTURBATIONS_HOMING_FULL: [Perturb; 7] =
    [Perturb::None, Perturb::LostJ1, HW_OVERRUN, HW_DRIVER, HW_SELFTEST, HW_DRIVER_DIAG, Perturb::StraySwitch(5)];
/// The tiny configuration's perturbations: those of the full one during
/// homing, with every kind of hardware fault.
pub(crate) const PERTURBATIONS_TINY: [Perturb; 7] =
    [Perturb::None, Perturb::LostJ1, HW_OVERRUN, HW_DRIVER, HW_SELFTEST, HW_DRIVER_DIAG, Perturb::StraySwitch(5)];

/// One tick: a request, a sensor perturbation, and which switches of the
/// moving homing axes are pressed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct Action {
    pub(crate) req: Option<Req>,
    pub(crate) perturb: Perturb,
    pub(crate) pressed: u8,
}

pub(crate) const GLITCH: u16 = COUNTS[0] + 1500;

impl<S: ModelScalar> Supervisor<S> {
    pub(crate) fn sense(&self, p: Perturb, pressed: u8) -> Sense {
        let mut enc = COUNTS.map(EncoderSample::Count);
        let mut limits = pressed;
        let mut hardware_fault = None;
        match p {
            Perturb::None => {}
            Perturb::LostJ1 => enc[0] = EncoderSample::Lost,
            Perturb::GlitchJ1 => enc[0] = EncoderSample::Count(GLITCH),
            Perturb::Hardware(kind) => hardware_fault = Some(kind),
            Perturb::StraySwitch(i) => limits |= 1 << i,
        }
        Sense { encoders: enc, limits, hardware_fault, link_lost: false }
    }

    pub(crate) fn request(&self, r: Req) -> Request<S> {
        let t =
            |p: [S; AXES]| MotionTarget { position: p, velocity: [S::ZERO; AXES], kind: kernel::MotionKind::Stream };
        match r {
            Req::Home => Request::Home,
            Req::HomeJoint(j) => Request::HomeJoint(j),
            Req::Enable => Request::Enable(self.authority.enable()),
            Req::MotionHere => Request::Motion(t(self.here)),
            Req::MotionNear => Request::Motion(t(self.here.map(|x| x.minus(self.near)))),
            Req::MotionFar => Request::Motion(t(self.here.map(|x| x.minus(S::from_f32(crate::model::NEAR_STREAM))))),
            Req::MotionOutOfLimits => Request::Motion(t(self.out_of_limits)),
        }
    }

    /// Whether the configuration draws every hardware fault kind during
    /// homing (`PERTURBATIONS_HOMING_FULL`): the full one, unless
    /// `--homing-restricted` gives it the stream configuration's
    /// perturbations there.
    pub(crate) fn every_fault_in_homing(&self) -> bool {
        self.landing && !crate::model::HOMING_RESTRICTED.load(std::sync::atomic::Ordering::Relaxed)
    }

    /// The environment's choices in state `s`.
    pub(crate) fn choices(&self, s: &St<S>, actions: &mut Vec<Action>) {
        if s.violated != 0 {
            return;
        }
        // Switch arrivals of the seeking homing axes: every subset (full:
        // each axis independently, so every arrival order), or all-or-nothing
        // (small). A switch is released as soon as its axis backs off.
        let mut moving = 0u8;
        if s.k.state() == State::Homing {
            for (i, p) in s.k.homing_phases().iter().enumerate() {
                if matches!(p, Phase::FastSeek | Phase::SlowSeek) {
                    moving |= 1 << i;
                }
            }
        }
        let mut masks: Vec<u8> = Vec::new();
        if self.small {
            masks.push(0);
            if moving != 0 {
                masks.push(moving);
            }
        } else {
            // Every subset of `moving`.
            let mut m = moving;
            loop {
                masks.push(m);
                if m == 0 {
                    break;
                }
                m = (m - 1) & moving;
            }
        }
        let reqs: &[Option<Req>] = if self.homing {
            &REQUESTS_HOMING_CONFIG
        } else if self.small {
            &REQUESTS_SMALL
        } else if s.k.state() == State::Homing {
            &REQUESTS_HOMING
        } else if self.far {
            &REQUESTS_FULL_FAR
        } else {
            &REQUESTS_FULL
        };
        let perturbations: &[Perturb] = if self.homing {
            &PERTURBATIONS_HOMING_CONFIG
        } else if self.tiny {
            &PERTURBATIONS_TINY
        } else if !self.small && s.k.state() == State::Homing && self.every_fault_in_homing() {
            &PERTURBATIONS_HOMING_FULL
        } else if !self.small && s.k.state() == State::Homing {
            &PERTURBATIONS_HOMING
        } else if !self.small {
            &PERTURBATIONS_FULL
        } else {
            &PERTURBATIONS
        };
        // The full configuration's re-targeting restriction: while the
        // set-points move toward the 2 mrad target, no other valid target is
        // sent; while they move toward one of the 20 urad targets, the 2 mrad
        // one is not sent. A 2 mrad re-target of a moving set-point (the
        // stream configuration's growth) is never offered; every motion
        // toward the 2 mrad target starts from rest and runs its course,
        // re-sent or left to the command timeout.
        let offered = |r: &Option<Req>| match r {
            Some(Req::MotionFar) => s.far || s.k.setpoints_at_rest(),
            Some(Req::MotionNear | Req::MotionHere) => !s.far,
            _ => true,
        };
        for &pressed in &masks {
            for &perturb in perturbations {
                for &req in reqs.iter().filter(|r| !self.far || offered(r)) {
                    actions.push(Action { req, perturb, pressed });
                }
            }
        }
    }
}
