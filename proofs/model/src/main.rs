//! Model check of the supervisor and homing state machine, with stateright,
//! over the real `kernel::Kernel<Fx>` (`cargo run -p model --release`).
//!
//! Abstraction (stated so a reviewer can judge it):
//! - The arm is stationary: every encoder reads a constant count, so the
//!   observer's numeric state is constant and each reachable kernel state is
//!   one of finitely many. What the model varies, independently at every
//!   tick, is everything discrete: whether the switches of the axes seeking
//!   them arrive (so homing can succeed or time out); one sensor
//!   perturbation (none, J1 encoder lost, J1 encoder glitch, a hardware
//!   fault, a stray pressed switch on J1 or J6); and one request (none, home,
//!   per-joint home of J1 / J6 / a bad index, enable, two valid motion
//!   targets, an out-of-limits target). A cause that persists is the same
//!   choice on consecutive ticks, so the plant needs no state of its own.
//! - Configuration: `PAROL6` with zero homing back-off and short times
//!   (command timeout 3 ms, ramp 4 ms, homing 8 ms per axis, segments 1 ms,
//!   acceleration limit never binding)
//!   so every timer can expire within the explored space. Same code, smaller
//!   constants.
//! - States are identified by `Kernel`'s behavioural hash (everything but the
//!   tick counter and the fault timestamp, which no decision reads) plus the
//!   plant and the last outputs.
//!
//! Every reachable state is explored (breadth first) and every property is
//! checked in every state; the run fails if a property is violated or a
//! `sometimes` property is never reached.

use kernel::config::{ArmConfig, AXES};
use kernel::homing::Phase;
use kernel::{
    Authority, EncoderSample, Event, Fx, HardwareFault, HomingStatus, Kernel, MotionTarget, Request, RequestKind,
    Scalar, Sense, State,
};
use proofs::setup::{COUNTS, PROOF_CONFIG, SEED_DEPENDENCIES};
use stateright::{Checker, Model, Property};
use std::hash::{DefaultHasher, Hash, Hasher};

const MODEL_CONFIG: ArmConfig = {
    let mut c = PROOF_CONFIG;
    let mut i = 0;
    while i < AXES {
        c.joints[i].homing.timeout_ms = 8;
        // Never binding (>> 2 vmax per tick): the acceleration limit makes
        // each output depend on the whole command history, which only
        // multiplies states; it has its own harness (SR-25) and tests.
        c.joints[i].max_acceleration = 100_000.0;
        i += 1;
    }
    c.segment_min_ms = 1;
    c.segment_max_ms = 1;
    c
};

#[derive(Clone, Debug)]
struct St {
    k: Kernel<Fx>,
    /// The first transition property violated, if any (checked on every
    /// transition, so it needs no history in the state).
    violation: Option<&'static str>,
    /// An enable has been accepted at some point (for reachability only).
    ever_enabled: bool,
}

impl St {
    fn fingerprint(&self) -> u64 {
        let mut h = DefaultHasher::new();
        self.hash(&mut h);
        h.finish()
    }
}

impl Hash for St {
    fn hash<H: Hasher>(&self, h: &mut H) {
        self.k.hash(h);
        (self.violation, self.ever_enabled).hash(h);
    }
}

impl PartialEq for St {
    fn eq(&self, other: &Self) -> bool {
        self.fingerprint() == other.fingerprint()
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Req {
    Home,
    HomeJoint(u8),
    Enable,
    MotionNear,
    MotionHere,
    MotionOutOfLimits,
}

/// A one-tick disturbance of the stationary arm's sensors.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Perturb {
    None,
    LostJ1,
    GlitchJ1,
    Hardware,
    StraySwitch(u8),
}

const PERTURBATIONS: [Perturb; 6] = [
    Perturb::None,
    Perturb::LostJ1,
    Perturb::GlitchJ1,
    Perturb::Hardware,
    Perturb::StraySwitch(0),
    Perturb::StraySwitch(5),
];

/// One tick: a request, a sensor perturbation, and whether the seeking axes
/// reach their switches.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
struct Action {
    req: Option<Req>,
    perturb: Perturb,
    arrive: bool,
}

struct Supervisor {
    /// The initial kernel; every state holds a clone of it (same identity),
    /// so `authority`, returned with it by `Kernel::new`, is accepted.
    init: Kernel<Fx>,
    authority: Authority,
    here: [Fx; AXES],
}

impl Supervisor {
    fn sense(&self, s: &St, p: Perturb, arrive: bool) -> Sense {
        let mut enc = COUNTS.map(EncoderSample::Count);
        let mut limits = 0u8;
        let mut hardware_fault = None;
        match p {
            Perturb::None => {}
            Perturb::LostJ1 => enc[0] = EncoderSample::Lost,
            Perturb::GlitchJ1 => enc[0] = EncoderSample::Count(COUNTS[0] + 1500),
            Perturb::Hardware => hardware_fault = Some(HardwareFault::TickOverrun),
            Perturb::StraySwitch(i) => limits |= 1 << i,
        }
        if arrive {
            for (i, ph) in s.k.homing_phases().iter().enumerate() {
                if matches!(ph, Phase::FastSeek | Phase::SlowSeek) {
                    limits |= 1 << i;
                }
            }
        }
        Sense { encoders: enc, limits, hardware_fault, link_lost: false }
    }

    fn request(&self, r: Req) -> Request<Fx> {
        let t =
            |p: [Fx; AXES]| MotionTarget { position: p, velocity: [Fx::ZERO; AXES], kind: kernel::MotionKind::Stream };
        match r {
            Req::Home => Request::Home,
            Req::HomeJoint(j) => Request::HomeJoint(j),
            Req::Enable => Request::Enable(self.authority.enable()),
            Req::MotionHere => Request::Motion(t(self.here)),
            Req::MotionNear => Request::Motion(t(self.here.map(|x| x.minus(Fx::from_f32(0.002))))),
            Req::MotionOutOfLimits => Request::Motion(t([Fx::from_f32(100.0); AXES])),
        }
    }
}

fn zero(o: &[Fx; AXES]) -> bool {
    o.iter().all(|v| *v == Fx::ZERO)
}

impl Model for Supervisor {
    type State = St;
    type Action = Action;

    fn init_states(&self) -> Vec<St> {
        vec![St { k: self.init.clone(), violation: None, ever_enabled: false }]
    }

    fn actions(&self, s: &St, actions: &mut Vec<Action>) {
        if s.violation.is_some() {
            return;
        }
        let arrivals: &[bool] = if s.k.state() == State::Homing { &[false, true] } else { &[false] };
        let reqs = [
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
        for &arrive in arrivals {
            for perturb in PERTURBATIONS {
                for req in reqs {
                    actions.push(Action { req, perturb, arrive });
                }
            }
        }
    }

    fn next_state(&self, s: &St, a: Action) -> Option<St> {
        let mut n = s.clone();
        let Action { req, perturb, arrive } = a;
        let before = s.k.state();
        let sense = self.sense(s, perturb, arrive);
        let cause =
            sense.limits & 0x3f != 0 || sense.hardware_fault.is_some() || sense.encoders.contains(&EncoderSample::Lost);
        let o = n.k.tick(&sense, req.map(|r| self.request(r)));
        let out = o.act.velocity;
        let st = o.status.state;
        let mut v = |c: bool, what: &'static str| {
            if c && n.violation.is_none() {
                n.violation = Some(what);
            }
        };
        // Outputs.
        v(
            matches!(st, State::Boot | State::Unhomed | State::SoftEstop | State::Fault) && !zero(&out),
            "output in Boot, Unhomed, SoftEstop or Fault",
        );
        v(o.events.iter().any(|e| matches!(e, Event::Fault(_))) && !zero(&out), "a fault tick with output");
        if matches!(st, State::Stopping | State::SoftEstop) && matches!(before, State::Stopping | State::SoftEstop) {
            let prev = s.k.last_output();
            let faster = (0..AXES).any(|i| {
                let (a, b) = (out[i], prev[i]);
                Scalar::abs(a) > Scalar::abs(b) || (a != Fx::ZERO && (a > Fx::ZERO) != (b > Fx::ZERO))
            });
            v(faster, "soft stop sped up or reversed");
        }
        if st == State::Homing {
            let phases = n.k.homing_phases();
            let bad = (0..AXES).any(|i| {
                let needs = SEED_DEPENDENCIES[i];
                if phases[i].is_moving() {
                    n.k.homed() & needs != needs
                } else {
                    out[i] != Fx::ZERO
                }
            });
            v(bad, "homing order violated or a non-homing axis moved");
        }
        // Requests.
        let latched = matches!(before, State::Fault | State::SoftEstop);
        v(
            req == Some(Req::Enable) && latched && cause && !matches!(st, State::Fault | State::SoftEstop),
            "enable cleared a latch while a cause was present",
        );
        let motion = matches!(req, Some(Req::MotionNear | Req::MotionHere | Req::MotionOutOfLimits));
        let rejected = o.events.iter().any(|e| matches!(e, Event::Rejected { request: RequestKind::Motion, .. }));
        v(motion && before != State::Operational && !rejected, "motion accepted outside Operational");
        v(req == Some(Req::MotionOutOfLimits) && !rejected, "out-of-limits target accepted");
        v(
            o.events.iter().any(|e| matches!(e, Event::HomingDone { .. })) && o.status.timeout_armed,
            "timeout armed right after homing",
        );
        // Latch.
        v(
            before == State::Fault
                && st == State::Fault
                && s.k.fault().map(|f| f.reason) != o.status.fault.map(|f| f.reason),
            "latched fault reason changed",
        );
        v((st == State::Fault) != o.status.fault.is_some(), "fault state without a reason");
        n.ever_enabled |= o.events.iter().any(|e| matches!(e, Event::Enabled(_)));
        Some(n)
    }

    fn properties(&self) -> Vec<Property<Self>> {
        vec![
            // Checked on every transition (outputs, homing order, soft-stop
            // monotonicity, enable, motion acceptance, latch).
            Property::always("no transition violation", |_, s: &St| s.violation.is_none()),
            Property::always("zero output in Boot, Unhomed, SoftEstop, Fault", |_, s: &St| {
                !matches!(s.k.state(), State::Boot | State::Unhomed | State::SoftEstop | State::Fault)
                    || zero(&s.k.last_output())
            }),
            Property::always("a fault always has its reason", |_, s: &St| {
                (s.k.state() == State::Fault) == s.k.fault().is_some()
            }),
            Property::sometimes("operational", |_, s: &St| s.k.state() == State::Operational),
            Property::sometimes("moving in operational", |_, s: &St| {
                s.k.state() == State::Operational && !zero(&s.k.last_output())
            }),
            Property::sometimes("soft stop ramping", |_, s: &St| {
                s.k.state() == State::Stopping && !zero(&s.k.last_output())
            }),
            Property::sometimes("soft E-stop latched", |_, s: &St| s.k.state() == State::SoftEstop),
            Property::sometimes("fault", |_, s: &St| s.k.state() == State::Fault),
            Property::sometimes("homing failed (H3)", |_, s: &St| s.k.homing_status() == HomingStatus::Failed),
            Property::sometimes("all joints homed, operational (H2)", |_, s: &St| {
                s.k.homing_status() == HomingStatus::Complete && s.k.state() == State::Operational
            }),
            Property::sometimes("enable accepted", |_, s: &St| s.ever_enabled),
        ]
    }
}

fn main() {
    // Valid targets near the stationary arm: it ends homing on its switches,
    // which lie just outside the URDF limits, so clamp 10 mrad inside them.
    let (mut k, _) = proofs::setup::operational::<Fx>();
    let mut here = proofs::setup::here(&mut k);
    for (i, h) in here.iter_mut().enumerate() {
        let j = &MODEL_CONFIG.joints[i];
        *h = h.clamp_between(Fx::from_f32(j.limit_min + 0.01), Fx::from_f32(j.limit_max - 0.01));
    }
    let (init, authority) = Kernel::<Fx>::new(&kernel::config::Validated::relaxed(MODEL_CONFIG));
    let model = Supervisor { init, authority, here };
    let started = std::time::Instant::now();
    // A cap on generated states (stateright counts every generated state, not
    // only unique ones) so that a state explosion reports instead of
    // exhausting memory; reaching it makes the run fail (not exhaustive).
    const CAP: usize = 1_000_000_000;
    let checker = model.checker().threads(2).target_state_count(CAP).spawn_bfs().join();
    let secs = started.elapsed().as_secs_f64();
    println!(
        "model-checked: {} states ({} unique), max depth {}, {secs:.1} s",
        checker.state_count(),
        checker.unique_state_count(),
        checker.max_depth()
    );
    if checker.state_count() >= CAP {
        println!("model: state cap {CAP} reached: NOT exhaustive");
        std::process::exit(2);
    }
    checker.assert_properties();
    println!("model-checked: every property holds in every reachable state; every 'sometimes' property reached");
    if let Ok(dir) = std::env::var("EVIDENCE_DIR") {
        let line =
            format!("model\tmodel-checked\t{}\tholds\tsupervisor + homing, Kernel<Fx>\n", checker.unique_state_count());
        if let Err(e) = std::fs::write(std::path::Path::new(&dir).join("model.tsv"), line) {
            eprintln!("model: cannot write the evidence file in {dir}: {e}");
            std::process::exit(1);
        }
    }
}
