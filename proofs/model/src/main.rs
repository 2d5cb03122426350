//! Model check of the supervisor and homing state machine, with stateright,
//! over the real `kernel::Kernel` (`cargo run -p model --release`).
//!
//! ```text
//! model [--variant fx|f32] [--config full|small|tiny|homing] [--expect-violation NAME] [--timeout S] [--bounded S]
//! ```
//!
//! With no arguments: the full configuration over `Kernel<Fx>` (bounded by
//! `--bounded S`, which applies to the full configuration only), the small
//! and the homing configurations over `Kernel<Fx>` (to completion: every
//! reachable state), then the tiny configuration over `Kernel<f32>` (to
//! completion) (its states are identified by formatting them, about 25
//! times slower per state than the fixed-point hash; the small
//! configuration takes over 10 minutes in f32). `--expect-violation NAME`
//! is for the mutation tests (`mutants.sh`): it stops at, and succeeds only
//! on, a violation of a property whose name contains NAME.
//!
//! Properties: each transition check (`checks!`) and each state property is
//! a property of its own, named by the requirements it checks (`SR-5: a
//! latch left without an accepted enable`); SAFETY.md's rows name them. A
//! transition check applies where its antecedent holds; a run lists as
//! backing evidence (`model.tsv`) only the state properties and the checks
//! whose antecedent held on some explored transition, and prints the
//! others as not exercised.
//!
//! Abstraction (stated so a reviewer can judge it):
//! - The arm is stationary: every encoder reads a constant count, so the
//!   observer's numeric state is constant and each reachable kernel state is
//!   one of finitely many. What the model varies, independently at every
//!   tick, is everything discrete: which of the seeking homing axes reach
//!   their switches (each axis independently, so every order of arrivals
//!   within a group is explored; a switch releases as soon as its axis
//!   backs off); one sensor perturbation (none,
//!   J1 encoder lost, J1 encoder glitch, a hardware fault of each kind, a
//!   stray pressed switch on J1 or J6); and one request (none, home,
//!   per-joint home of J1 / J6 / a bad index, enable, two valid motion
//!   targets, a target 10 mrad beyond J1's limit). Only J1's encoder and
//!   the J1 and J6 switches are perturbed: every joint is checked by the
//!   same per-axis code, which `evidence_tests::every_joint_is_checked_like_j1_and_j6`
//!   shows joint by joint. A cause that persists is the same choice on consecutive
//!   ticks. The plant keeps only what the SR-7 and SR-11 properties need
//!   (the ramp's start, the J1 run of invalid samples).
//! - Configuration (`MODEL_CONFIG`): `PAROL6` with the timers shortened
//!   within `kernel::config::check` (command timeout 3 ms, segments 1 ms,
//!   boot timeout 2 ms: the kernel keeps its boot tick count in its state
//!   after boot, so each boot length multiplied the state space) and three
//!   documented relaxations, tested by
//!   `tests::model_config_relaxes_exactly_the_named_rules`: zero homing
//!   back-off (a stationary arm never travels one), 8 ms homing timeouts
//!   and a 4 ms soft-stop ramp (faster than `max_acceleration`, PAROL6's).
//!   The kernel's continuous state (set-point velocities,
//!   following-error paths, homing ramps) keeps the model from finishing:
//!   the test command runs it bounded (`--bounded`, sampled evidence).
//! - The full configuration, to fit its time budget, explores during homing
//!   (where every request is refused) only no request and one motion
//!   request, and only four perturbations (none, J1 lost, hardware fault,
//!   J6 stray switch; not the J1 glitch and J1 stray switch).
//! - Reduced configuration (`--config small`, used for the f32 variant and
//!   the mutation tests): requests none / home / enable / near target /
//!   beyond J1's limit only,
//!   the switches of the seeking axes arriving all together or not at all,
//!   every perturbation in every state. The two configurations together
//!   cover every arrival order and every perturbation during homing, not
//!   every combination of the two.
//! - Tiny configuration (`--config tiny`, the f32 variant): the small one
//!   with six perturbations (none, J1 lost, each of the three hardware
//!   fault kinds, J6 stray switch; not the J1 glitch and the J1 stray
//!   switch). The small configuration draws only the tick overrun; the full
//!   one every kind outside homing.
//! - Homing configuration (`--config homing`): requests none / home /
//!   per-joint home of J1, J4, J5, J6 / enable, every subset of the seeking
//!   axes' switches on every tick (every arrival order), perturbations none
//!   and a tick overrun (to leave a run by a fault and an enable). With the
//!   small one it gives complete runs for every arrival order and
//!   `<HOMEn>` (SR-13, SR-14, SR-16).
//! - States are identified by `Kernel`'s behavioural hash (everything but the
//!   tick counter and the fault timestamp, which no decision reads) plus the
//!   plant. `Kernel<f32>` has no `Hash` (f32 has none): its states are
//!   identified by its `Debug` text without those two fields (Rust prints
//!   every non-NaN f32 in a form that round-trips, so distinct values give
//!   distinct text; a stationary arm never makes a NaN, and if it did the
//!   "no NaN" property would fail).
//!
//! Recoverability (SR-6, SR-31; property "SR-6/31: recoverability: ..."):
//! wherever a latch is entered (or a stop toward one starts), and in every
//! homing state with the host link lost there, the kernel is cloned and
//! driven, with the switches pressed in that tick held pressed and nothing
//! else perturbed, through the end of the ramp, `<ENABLE>` and, where
//! homing was lost, `<HOME>`: both must be accepted unless a homed joint's
//! switch is pressed (a cause only the operator removes). The lost link is
//! judged on the clone only, not explored as a perturbation (as one it more
//! than doubled the small configuration's state space). A kernel that takes
//! an unhomed joint's switch for a cause (`mutants.sh`,
//! `lock-up-on-homing-switch`) fails it.
//!
//! Every reachable state is explored (breadth first) and every property is
//! checked on every transition or state; the run fails if a property is
//! violated or a `sometimes` property is never reached (the bounded run
//! too: an exploration that never reached one did not reach what it
//! shows).

use kernel::config::{ArmConfig, AXES};
use kernel::homing::Phase;
use kernel::{
    Authority, EncoderSample, Event, FaultReason, Fx, HardwareFault, HomingStatus, Kernel, MotionTarget, Request,
    RequestKind, Scalar, Sense, State,
};
use proofs::setup::{new_kernel, COUNTS, PROOF_CONFIG, SEED_DEPENDENCIES};
use stateright::{Checker, DiscoveryClassification, Expectation, HasDiscoveries, Model, Property};
use std::fmt::Debug;
use std::hash::{DefaultHasher, Hash, Hasher};
use std::sync::atomic::{AtomicU64, Ordering};

const MODEL_CONFIG: ArmConfig = {
    let mut c = PROOF_CONFIG;
    let mut i = 0;
    while i < AXES {
        c.joints[i].homing.timeout_ms = 8;
        // (max_acceleration stays PAROL6's: with the 100 ms ramp restored,
        // `check` bounds it by the ramp and the stopping overrun.)
        i += 1;
    }
    c.segment_min_ms = 1;
    c.segment_max_ms = 1;
    // The rule's minimum (two ticks). The kernel's state keeps its boot tick
    // count after boot (`Hash for Kernel` includes it), so every boot length
    // multiplies the whole state space (measured on the small configuration:
    // 487,087 states with 2 ms; with 50 ms, over 6.5 million and unfinished
    // after 250 s).
    c.boot_timeout_ms = 2;
    c
};

/// What `MODEL_CONFIG` relaxes of `kernel::config::check` (the rule each
/// breaks); the same three as `proofs::setup::PROOF_RELAXATIONS`.
const MODEL_RELAXATIONS: [(&str, &str); 3] = [
    ("joints[*].homing.backoff = 0", "homing back-off must be in (0, 0.5) rad"),
    (
        "joints[*].homing.timeout_ms = 8",
        "homing timeout shorter than 1.2x the nominal homing time: homing is impossible",
    ),
    ("soft_stop_ms = 4", "soft-stop ramp decelerates faster than max_acceleration"),
];

/// The J1 encoder as seen by the plant: the count it was (re)initialised
/// from (every other count differs by more than the plausibility window),
/// and the current run of invalid samples (frozen one above the limit: the
/// count is lost until an enable re-initialises J1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
struct J1 {
    seen: bool,
    reference: u16,
    run: u8,
}

/// The number types the model runs on: how a kernel state is identified.
trait ModelScalar: Scalar + Debug + Send + Sync + 'static {
    const NAME: &'static str;
    fn hash_kernel<H: Hasher>(k: &Kernel<Self>, h: &mut H);
}

impl ModelScalar for Fx {
    const NAME: &'static str = "Kernel<Fx>";
    fn hash_kernel<H: Hasher>(k: &Kernel<Self>, h: &mut H) {
        k.hash(h);
    }
}

impl ModelScalar for f32 {
    const NAME: &'static str = "Kernel<f32>";
    fn hash_kernel<H: Hasher>(k: &Kernel<Self>, h: &mut H) {
        // The Debug text from the per-axis state on, minus `tick: N` (the
        // tick counter and the fault timestamp; `boot_ticks`/`ticks` are
        // other fields and are kept).
        let text = format!("{k:?}");
        // The identity and the parameters (constants, most of the text)
        // come before the per-axis state `axes: [Axis {`.
        let mut rest = text.find("axes: [Axis {").map_or(text.as_str(), |i| &text[i..]);
        while let Some(i) = rest.find("tick: ") {
            let before = &rest[..i];
            let whole_word = !before.ends_with(|c: char| c.is_alphanumeric() || c == '_');
            before.hash(h);
            rest = &rest[i + "tick: ".len()..];
            if whole_word {
                rest = rest.trim_start_matches(|c: char| c.is_ascii_digit());
            } else {
                "tick: ".hash(h);
            }
        }
        rest.hash(h);
    }
}

/// Declares the model's transition checks: each is a property of its own
/// (named by the requirements it checks, `SR-n` or `SR-n/m`), checked on
/// every transition whose antecedent holds.
macro_rules! checks {
    ($($v:ident => $name:literal,)*) => {
        /// A transition check (see `checks!`).
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        enum Check {
            $($v,)*
        }

        impl Check {
            const ALL: &'static [Check] = &[$(Check::$v,)*];

            const fn name(self) -> &'static str {
                match self {
                    $(Check::$v => $name,)*
                }
            }

            const fn bit(self) -> u64 {
                1 << self as u32
            }
        }

        /// One `always` property per transition check: no explored
        /// transition violated it.
        fn check_properties<S: ModelScalar>() -> Vec<Property<Supervisor<S>>> {
            vec![$(Property::<Supervisor<S>>::always($name, |_, s: &St<S>| s.violated & Check::$v.bit() == 0),)*]
        }
    };
}

checks! {
    IdleOutput => "SR-1/4/5: output in Boot, Unhomed, SoftEstop or Fault",
    FaultTickOutput => "SR-4: output in the tick a fault is detected",
    Finite => "SR-2/3: a non-finite output or estimate",
    StopMonotone => "SR-7: the soft stop sped up or reversed",
    RampEnvelope => "SR-7: a ramp output outside the envelope v0 (N - k) / N",
    RampEnds => "SR-7: the ramp did not end in SoftEstop at k = N",
    RampZero => "SR-7: not every axis exactly zero at k = N",
    HomingOrder => "SR-13: an axis moved in homing before its dependencies were homed",
    HomingIdleAxis => "SR-16: an axis not in a moving homing phase output non-zero",
    RehomeClears => "SR-14: a re-homed axis still counted homed when its run started",
    HomedBeforeCapture => "SR-14: an axis of a homing run counted homed before its zero was captured",
    RunHomes => "SR-14: a homing run ended without homing its axes",
    LimitSwitch => "SR-10: a limit switch did not fault in the same tick",
    HardwareFault => "SR-21: a hardware fault did not fault in the same tick",
    EncoderFaultInTime => "SR-11: the encoder fault did not come in the same tick",
    EncoderRideThrough => "SR-11: an encoder fault within the tolerance",
    BootAtRest => "SR-1: an estimate does not start at rest at its first reading",
    EnableWithCause => "SR-6: enable cleared a latch while a cause was present",
    EnableSync => "SR-6: a set-point differs from its position after enable",
    MotionOutsideOperational => "SR-15: motion accepted outside Operational",
    OutOfLimits => "SR-17: an out-of-limits target accepted",
    ArmedAfterHoming => "SR-8: the timeout armed right after homing",
    ArmedOnlyByMotion => "SR-8: the timeout armed by anything but an accepted motion",
    DisarmedByEnableOrHoming => "SR-8: the timeout armed after an enable or a homing start",
    LatchReason => "SR-5: a latched fault's reason changed",
    LatchLeftOnlyByEnable => "SR-5: a latch left without an accepted enable",
    FaultReason => "SR-5: a fault state without a reason",
    Recoverable => "SR-6/31: recoverability: enable or home refused after a latch with no physical cause",
}

/// The checks whose antecedent held on some explored transition of the
/// current run (a check never exercised backs nothing: the run reports
/// it, and the evidence record lists only the exercised ones).
static EXERCISED: AtomicU64 = AtomicU64::new(0);

/// The checks of one transition.
#[derive(Default)]
struct Checks {
    exercised: u64,
    violated: u64,
}

impl Checks {
    /// `antecedent`: the check applies to this transition; `holds`: it is
    /// satisfied.
    fn check(&mut self, c: Check, antecedent: bool, holds: bool) {
        if antecedent {
            self.exercised |= c.bit();
            if !holds {
                self.violated |= c.bit();
            }
        }
    }

    fn record(&self) {
        if self.exercised & !EXERCISED.load(Ordering::Relaxed) != 0 {
            EXERCISED.fetch_or(self.exercised, Ordering::Relaxed);
        }
    }
}

impl<S: ModelScalar> Supervisor<S> {
    /// SR-14: a homing run re-zeroes every axis it homes: an axis of the run
    /// is not homed before its zero is captured (also when it was homed
    /// before the run: re-homing), and a run that ends (not failed) has
    /// homed all of its axes.
    fn rehoming_checks<'e>(&self, s: &St<S>, n: &St<S>, events: impl Iterator<Item = &'e Event>, c: &mut Checks) {
        if n.k.state() == State::Homing {
            let phases = n.k.homing_phases();
            for (i, p) in phases.iter().enumerate() {
                let before_capture = matches!(p, Phase::Waiting | Phase::FastSeek | Phase::BackOff | Phase::SlowSeek);
                c.check(Check::HomedBeforeCapture, before_capture, n.k.homed() & (1 << i) == 0);
            }
        }
        for e in events {
            if let Event::HomingStarted { mask } = e {
                c.check(Check::RehomeClears, s.k.homed() & mask != 0, n.k.homed() & mask == 0);
            }
            if let Event::HomingDone { mask } = e {
                // (A fault in the same tick may un-home a joint whose
                // encoder count was lost: SR-11.)
                let ended = s.k.state() == State::Homing && n.k.state() != State::Fault;
                c.check(Check::RunHomes, ended, n.k.homed() & mask == *mask);
            }
        }
    }
}

#[derive(Clone, Debug)]
struct St<S: Scalar> {
    k: Kernel<S>,
    /// The transition checks violated on the way into this state (a bit per
    /// `Check`; checked on every transition, so no history is needed).
    violated: u64,
    /// An enable has been accepted at some point (for reachability only).
    ever_enabled: bool,
    j1: J1,
    /// The soft-stop ramp: its tick (1 on the timeout tick) and the outputs
    /// it started from.
    ramp: Option<(u32, [S; AXES])>,
}

impl<S: ModelScalar> St<S> {
    fn fingerprint(&self) -> u64 {
        let mut h = DefaultHasher::new();
        self.hash(&mut h);
        h.finish()
    }
}

impl<S: ModelScalar> Hash for St<S> {
    fn hash<H: Hasher>(&self, h: &mut H) {
        S::hash_kernel(&self.k, h);
        (self.violated, self.ever_enabled, self.j1).hash(h);
        // The ramp's start equals the kernel's Stopping v0 (hashed above);
        // its tick is the kernel's k + 1.
        self.ramp.map(|(k, _)| k).hash(h);
    }
}

impl<S: ModelScalar> PartialEq for St<S> {
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
    Hardware(HardwareFault),
    StraySwitch(u8),
}

/// Every kind of hardware fault the HAL reports (SR-21).
const HW_OVERRUN: Perturb = Perturb::Hardware(HardwareFault::TickOverrun);
const HW_DRIVER: Perturb = Perturb::Hardware(HardwareFault::Driver { axis: 2 });
const HW_SELFTEST: Perturb = Perturb::Hardware(HardwareFault::SelfTest(7));

const PERTURBATIONS: [Perturb; 6] =
    [Perturb::None, Perturb::LostJ1, Perturb::GlitchJ1, HW_OVERRUN, Perturb::StraySwitch(0), Perturb::StraySwitch(5)];
/// The full configuration's perturbations outside homing: every one, with
/// every kind of hardware fault.
const PERTURBATIONS_FULL: [Perturb; 8] = [
    Perturb::None,
    Perturb::LostJ1,
    Perturb::GlitchJ1,
    HW_OVERRUN,
    HW_DRIVER,
    HW_SELFTEST,
    Perturb::StraySwitch(0),
    Perturb::StraySwitch(5),
];

const REQUESTS_FULL: [Option<Req>; 9] = [
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
const REQUESTS_SMALL: [Option<Req>; 5] =
    [None, Some(Req::Home), Some(Req::Enable), Some(Req::MotionNear), Some(Req::MotionOutOfLimits)];
/// The homing configuration: full and per-joint homing (J1, J4, J5, J6 and
/// a bad index), and enable to leave a latch.
const REQUESTS_HOMING_CONFIG: [Option<Req>; 7] = [
    None,
    Some(Req::Home),
    Some(Req::HomeJoint(0)),
    Some(Req::HomeJoint(3)),
    Some(Req::HomeJoint(4)),
    Some(Req::HomeJoint(5)),
    Some(Req::Enable),
];
const PERTURBATIONS_HOMING_CONFIG: [Perturb; 2] = [Perturb::None, HW_OVERRUN];
/// In Homing every request is refused (no state change, a `Rejected`
/// event): the full configuration keeps one motion request to check that.
const REQUESTS_HOMING: [Option<Req>; 2] = [None, Some(Req::MotionNear)];
/// Perturbations the full configuration explores during homing (with every
/// arrival order); the small one explores all six there (with all-or-nothing
/// arrivals). Without this the full run outgrew its time budget.
const PERTURBATIONS_HOMING: [Perturb; 4] = [Perturb::None, Perturb::LostJ1, HW_OVERRUN, Perturb::StraySwitch(5)];
/// The tiny configuration's perturbations: those of the full one during
/// homing, with every kind of hardware fault.
const PERTURBATIONS_TINY: [Perturb; 6] =
    [Perturb::None, Perturb::LostJ1, HW_OVERRUN, HW_DRIVER, HW_SELFTEST, Perturb::StraySwitch(5)];

/// One tick: a request, a sensor perturbation, and which switches of the
/// moving homing axes are pressed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
struct Action {
    req: Option<Req>,
    perturb: Perturb,
    pressed: u8,
}

struct Supervisor<S: Scalar> {
    /// The initial kernel; every state holds a clone of it (same identity),
    /// so `authority`, returned with it by `Kernel::new`, is accepted.
    init: Kernel<S>,
    authority: Authority,
    here: [S; AXES],
    /// A target just outside J1's limits, within a stream sample's reach of
    /// the homed arm (so only the limits can refuse it).
    out_of_limits: [S; AXES],
    small: bool,
    /// The tiny configuration (f32): small, and six perturbations.
    tiny: bool,
    /// The homing configuration: the per-joint requests and every arrival
    /// order, with no perturbation but the tick overrun.
    homing: bool,
}

const GLITCH: u16 = COUNTS[0] + 1500;

/// The joint angle of count `c` on axis `i` before homing (zero offset 0).
fn angle<S: Scalar>(i: usize, c: u16) -> S {
    let j = &MODEL_CONFIG.joints[i];
    let sign = if j.encoder_reversed { -1 } else { 1 };
    S::from_counts(i32::from(c) * sign, S::wide_from_f64(j.rad_per_count()))
}

impl<S: ModelScalar> Supervisor<S> {
    fn sense(&self, p: Perturb, pressed: u8) -> Sense {
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

    /// Recoverability (SR-6, SR-31): from a state that is latched, or
    /// stopping toward a latch, with no physical cause the operator must
    /// remove, `<ENABLE>` is accepted once the ramp has ended and, where
    /// homing was lost, `<HOME>` starts homing. The physical world stays as
    /// the latch left it: the switches pressed in that tick stay pressed
    /// (an axis stopped on its switch); every other perturbation of the
    /// model lasts one tick. A pressed switch of a homed joint is a cause
    /// only the operator removes: such states are not judged. Returns
    /// whether the kernel came back.
    fn recovers(&self, k: &Kernel<S>, pressed: u8) -> bool {
        if pressed & k.homed() != 0 {
            return true;
        }
        let mut k = k.clone();
        let sense = self.sense(Perturb::None, pressed);
        let stop_ticks = MODEL_CONFIG.soft_stop_ms * MODEL_CONFIG.tick_hz / 1000;
        // A few rounds: a transient cause (an encoder whose count was
        // re-initialised from a glitch faults once more on the true
        // reading) may latch again in between; a cause that persists
        // refuses every round. Bounded: 4 rounds of at most the ramp and
        // three ticks.
        for _ in 0..4 {
            for _ in 0..=stop_ticks {
                if k.state() != State::Stopping {
                    break;
                }
                k.tick(&sense, None);
            }
            match k.state() {
                State::SoftEstop | State::Fault => {
                    let o = k.tick(&sense, Some(self.request(Req::Enable)));
                    if !o.events.iter().any(|e| matches!(e, Event::Enabled(_))) {
                        k.tick(&sense, None);
                        continue;
                    }
                }
                State::Operational | State::Homing => return true,
                _ => {}
            }
            match k.state() {
                State::Unhomed => {
                    let o = k.tick(&sense, Some(self.request(Req::Home)));
                    if o.events.iter().any(|e| matches!(e, Event::HomingStarted { .. })) {
                        return true;
                    }
                }
                State::Operational => return true,
                _ => {}
            }
        }
        false
    }

    /// SR-31's case of recoverability: the host link lost in this homing
    /// state (the seeking axes' switches as this tick left them, held
    /// pressed), then restored: the run ends latched and must be
    /// recoverable. Judged on a clone, so a lost link adds no state to the
    /// exploration (as a perturbation of its own it more than doubled the
    /// small configuration's state space).
    fn recovers_from_link_loss(&self, k: &Kernel<S>, pressed: u8) -> bool {
        let mut k = k.clone();
        let mut sense = self.sense(Perturb::None, pressed);
        sense.link_lost = true;
        k.tick(&sense, None);
        self.recovers(&k, pressed)
    }

    fn request(&self, r: Req) -> Request<S> {
        let t =
            |p: [S; AXES]| MotionTarget { position: p, velocity: [S::ZERO; AXES], kind: kernel::MotionKind::Stream };
        match r {
            Req::Home => Request::Home,
            Req::HomeJoint(j) => Request::HomeJoint(j),
            Req::Enable => Request::Enable(self.authority.enable()),
            Req::MotionHere => Request::Motion(t(self.here)),
            Req::MotionNear => Request::Motion(t(self.here.map(|x| x.minus(S::from_f32(0.002))))),
            Req::MotionOutOfLimits => Request::Motion(t(self.out_of_limits)),
        }
    }
}

/// A value as f64 (to 1e-9: every I8F24 and every f32 the model meets).
fn f64v<S: Scalar>(x: S) -> f64 {
    x.to_scaled_int(1_000_000_000) as f64 / 1e9
}

/// Two moving axes of one homing group are in different phases (their
/// switches arrived in different ticks).
fn out_of_step(phases: &[Phase; AXES]) -> bool {
    kernel::config::HOMING_GROUPS.iter().any(|g| {
        let mut ph = (0..AXES).filter(|i| g & (1 << i) != 0 && phases[*i].is_moving()).map(|i| phases[i]);
        ph.next().is_some_and(|first| ph.any(|p| p != first))
    })
}

fn zero<S: Scalar>(o: &[S; AXES]) -> bool {
    o.iter().all(|v| *v == S::ZERO)
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
        }]
    }

    fn actions(&self, s: &St<S>, actions: &mut Vec<Action>) {
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
        } else {
            &REQUESTS_FULL
        };
        let perturbations: &[Perturb] = if self.homing {
            &PERTURBATIONS_HOMING_CONFIG
        } else if self.tiny {
            &PERTURBATIONS_TINY
        } else if !self.small && s.k.state() == State::Homing {
            &PERTURBATIONS_HOMING
        } else if !self.small {
            &PERTURBATIONS_FULL
        } else {
            &PERTURBATIONS
        };
        for &pressed in &masks {
            for &perturb in perturbations {
                for &req in reqs {
                    actions.push(Action { req, perturb, pressed });
                }
            }
        }
    }

    fn next_state(&self, s: &St<S>, a: Action) -> Option<St<S>> {
        let mut n = s.clone();
        let Action { req, perturb, pressed } = a;
        let before = s.k.state();
        let sense = self.sense(perturb, pressed);
        let o = n.k.tick(&sense, req.map(|r| self.request(r)));
        // A switch is a cause on a joint homed after the tick only (SR-6,
        // SR-10: an unhomed joint's switch is its homing input, and an
        // enable unhomes a joint whose encoder count was lost).
        let cause = sense.limits & o.status.homed & 0x3f != 0
            || sense.hardware_fault.is_some()
            || sense.encoders.contains(&EncoderSample::Lost);
        let out = o.act.velocity;
        let st = o.status.state;
        let has = |f: &dyn Fn(&Event) -> bool| o.events.iter().any(f);
        let mut c = Checks::default();
        // Outputs.
        c.check(
            Check::IdleOutput,
            matches!(st, State::Boot | State::Unhomed | State::SoftEstop | State::Fault),
            zero(&out),
        );
        c.check(Check::FaultTickOutput, has(&|e| matches!(e, Event::Fault(_))), zero(&out));
        c.check(Check::Finite, true, out.iter().chain(o.status.position.iter()).all(|x| x.is_finite()));
        if matches!(st, State::Stopping | State::SoftEstop) && matches!(before, State::Stopping | State::SoftEstop) {
            let prev = s.k.last_output();
            let faster = (0..AXES).any(|i| {
                let (a, b) = (out[i], prev[i]);
                a.abs() > b.abs() || (a != S::ZERO && (a > S::ZERO) != (b > S::ZERO))
            });
            c.check(Check::StopMonotone, true, !faster);
        }
        // SR-7: the ramp's envelope is v0 (N - k) / N on every axis (within
        // rounding): every output lies between zero and it (a joint follows
        // its braking set-point inside it, so it may stop earlier), and
        // every axis is exactly zero at k = N.
        let stop_ticks = MODEL_CONFIG.soft_stop_ms * MODEL_CONFIG.tick_hz / 1000;
        n.ramp = match (s.ramp, st) {
            // (A fault in the timeout's tick zeroes everything instead.)
            _ if st == State::Stopping && has(&|e| matches!(e, Event::SoftEstop { .. })) => {
                Some((1, s.k.last_output()))
            }
            (Some((k, v0)), State::Stopping | State::SoftEstop) if before == State::Stopping => Some((k + 1, v0)),
            _ => None,
        };
        if let Some((k, v0)) = n.ramp {
            let left = f64::from(stop_ticks.saturating_sub(k)) / f64::from(stop_ticks);
            let outside = (0..AXES).any(|i| {
                let (want, got) = (f64v(v0[i]) * left, f64v(out[i]));
                got.abs() > want.abs() + 1e-6 * (1.0 + want.abs()) || (got != 0.0 && (got > 0.0) != (want > 0.0))
            });
            c.check(Check::RampEnvelope, true, !outside);
            c.check(Check::RampEnds, true, (k >= stop_ticks) == (st == State::SoftEstop));
            c.check(Check::RampZero, k >= stop_ticks, zero(&out));
        }
        if st == State::Homing {
            let phases = n.k.homing_phases();
            for i in 0..AXES {
                let needs = SEED_DEPENDENCIES[i];
                if phases[i].is_moving() {
                    c.check(Check::HomingOrder, true, n.k.homed() & needs == needs);
                } else {
                    c.check(Check::HomingIdleAxis, true, out[i] == S::ZERO);
                }
            }
        }
        self.rehoming_checks(s, &n, o.events.iter(), &mut c);
        // SR-10: a homed joint's pressed switch faults in the same tick in
        // Operational, Stopping, SoftEstop, and during homing at rest (an
        // unhomed joint's switch is its homing input in every state).
        // (Not in the tick a HOME is accepted: the switch is then a homing
        // input of a run that starts before the check.)
        let phases_before = s.k.homing_phases();
        // Nor in the tick a per-joint run ends in Unhomed (SR-10 does not
        // list Unhomed: a homed J6's switch pressed in that tick, or later
        // in Unhomed, does not fault).
        let homing_started = has(&|e| matches!(e, Event::HomingStarted { .. }));
        let ended_unhomed = has(&|e| matches!(e, Event::HomingDone { .. })) && st == State::Unhomed;
        let switch_is_fault = !homing_started
            && !ended_unhomed
            && (0..AXES).any(|i| {
                sense.limits & s.k.homed() & (1 << i) != 0
                    && (matches!(before, State::Operational | State::Stopping | State::SoftEstop)
                        || (before == State::Homing && !phases_before[i].is_moving()))
            });
        c.check(Check::LimitSwitch, switch_is_fault, st == State::Fault);
        // SR-21: a hardware fault faults in the same tick, in every state.
        c.check(Check::HardwareFault, sense.hardware_fault.is_some(), st == State::Fault);
        // SR-11: the (limit + 1)-th consecutive invalid J1 sample (lost, or
        // more than the plausibility window from the count J1 was
        // initialised from) faults in the same tick; fewer are ridden through.
        let limit = MODEL_CONFIG.encoder_invalid_limit as u8;
        let j1 = sense.encoders[0];
        if s.j1.seen && s.j1.run > limit {
            // Faulted: the count is lost until an enable re-initialises J1
            // from its reading (SR-11: the joint must be homed again).
            if has(&|e| matches!(e, Event::Enabled(_))) {
                if let EncoderSample::Count(c) = j1 {
                    n.j1 = J1 { seen: true, reference: c, run: 0 };
                }
            }
        } else if s.j1.seen {
            let valid = j1 == EncoderSample::Count(s.j1.reference);
            n.j1.run = if valid { 0 } else { s.j1.run + 1 };
            let crossed = s.j1.run <= limit && n.j1.run == limit + 1;
            c.check(Check::EncoderFaultInTime, crossed, st == State::Fault);
            let j1_fault = has(&|e| {
                matches!(
                    e,
                    Event::Fault(FaultReason::EncoderLost { axis: 0 } | FaultReason::EncoderJump { axis: 0, .. })
                )
            });
            c.check(Check::EncoderRideThrough, n.j1.run <= limit && !valid, !j1_fault);
        } else if let EncoderSample::Count(c) = j1 {
            n.j1 = J1 { seen: true, reference: c, run: 0 };
        }
        // SR-1: when the kernel leaves Boot, every estimate is at rest at
        // the angle of the axis's first reading (J1's may be this tick's).
        if has(&|e| matches!(e, Event::Ready)) {
            let off = (0..AXES).any(|i| {
                let c = if i == 0 { n.j1.reference } else { COUNTS[i] };
                o.status.position[i] != angle::<S>(i, c) || o.status.velocity[i] != S::ZERO
            });
            c.check(Check::BootAtRest, true, !off);
        }
        // Requests.
        let latched = matches!(before, State::Fault | State::SoftEstop);
        c.check(
            Check::EnableWithCause,
            req == Some(Req::Enable) && latched && cause,
            matches!(st, State::Fault | State::SoftEstop),
        );
        // SR-6: after an accepted enable the set-points are the measured
        // positions.
        let enabled = has(&|e| matches!(e, Event::Enabled(_)));
        c.check(Check::EnableSync, enabled, (0..AXES).all(|i| o.status.setpoint[i] == o.status.position[i]));
        let motion = matches!(req, Some(Req::MotionNear | Req::MotionHere | Req::MotionOutOfLimits));
        let rejected = has(&|e| matches!(e, Event::Rejected { request: RequestKind::Motion, .. }));
        c.check(Check::MotionOutsideOperational, motion && before != State::Operational, rejected);
        c.check(Check::OutOfLimits, req == Some(Req::MotionOutOfLimits), rejected);
        // SR-8: armed only by an accepted motion, disarmed by homing and
        // enable.
        c.check(Check::ArmedAfterHoming, has(&|e| matches!(e, Event::HomingDone { .. })), !o.status.timeout_armed);
        c.check(Check::ArmedOnlyByMotion, !s.k.status(0).timeout_armed && o.status.timeout_armed, motion && !rejected);
        c.check(Check::DisarmedByEnableOrHoming, enabled || homing_started, !o.status.timeout_armed);
        // SR-5: a latch keeps its first reason and only an accepted enable
        // leaves it.
        c.check(
            Check::LatchReason,
            before == State::Fault && st == State::Fault,
            s.k.fault().map(|f| f.reason) == o.status.fault.map(|f| f.reason),
        );
        c.check(Check::LatchLeftOnlyByEnable, latched, matches!(st, State::Fault | State::SoftEstop) || enabled);
        c.check(Check::FaultReason, true, (st == State::Fault) == o.status.fault.is_some());
        // SR-6/31: recoverability, judged where a latch is entered (or a
        // stop toward one starts; the states that stay latched are the same
        // kernel with one-tick perturbations, which the recovery does not
        // repeat), and for a link lost in every homing state.
        let entering = matches!(st, State::SoftEstop | State::Fault | State::Stopping) && st != before;
        if entering {
            c.check(Check::Recoverable, true, self.recovers(&n.k, pressed));
        }
        if st == State::Homing {
            c.check(Check::Recoverable, true, self.recovers_from_link_loss(&n.k, pressed));
        }
        n.violated |= c.violated;
        n.ever_enabled |= enabled;
        c.record();
        Some(n)
    }

    fn properties(&self) -> Vec<Property<Self>> {
        // Checked on every transition (`checks!`), then on every state.
        let mut p = check_properties::<S>();
        p.extend([
            Property::<Self>::always("SR-1/5: a state in Boot, Unhomed, SoftEstop or Fault with output", |_, s| {
                !matches!(s.k.state(), State::Boot | State::Unhomed | State::SoftEstop | State::Fault)
                    || zero(&s.k.last_output())
            }),
            Property::<Self>::always("SR-5: a fault state without its reason", |_, s| {
                (s.k.state() == State::Fault) == s.k.fault().is_some()
            }),
            Property::<Self>::always(
                "SR-32: a state outside the kernel's state invariant (Kernel::invariant)",
                |_, s| s.k.invariant(),
            ),
            Property::<Self>::sometimes("operational", |_, s| s.k.state() == State::Operational),
            Property::<Self>::sometimes("all joints homed, operational (H2)", |_, s| {
                s.k.homing_status() == HomingStatus::Complete && s.k.state() == State::Operational
            }),
            Property::<Self>::sometimes("hardware fault: tick overrun", |_, s| {
                matches!(s.k.fault().map(|f| f.reason), Some(FaultReason::Hardware(HardwareFault::TickOverrun)))
            }),
            Property::<Self>::sometimes("enable accepted", |_, s| s.ever_enabled),
        ]);
        if self.homing {
            p.extend([
                Property::<Self>::sometimes("axes of one homing group out of step (arrival orders)", |_, s| {
                    out_of_step(&s.k.homing_phases())
                }),
                Property::<Self>::sometimes("a per-joint run of J6 (<HOME6>)", |_, s| {
                    s.k.state() == State::Homing && s.k.homing_phases()[0] == Phase::Idle
                }),
                Property::<Self>::sometimes("J1 re-homed alone (<HOME1>)", |_, s| {
                    s.k.state() == State::Homing
                        && s.k.homing_phases()[0].is_moving()
                        && s.k.homing_phases()[5] == Phase::Idle
                }),
            ]);
            return p;
        }
        p.extend([
            Property::<Self>::sometimes("moving in operational", |_, s| {
                s.k.state() == State::Operational && !zero(&s.k.last_output())
            }),
            Property::<Self>::sometimes("soft stop ramping", |_, s| {
                s.k.state() == State::Stopping && !zero(&s.k.last_output())
            }),
            Property::<Self>::sometimes("soft E-stop latched", |_, s| s.k.state() == State::SoftEstop),
            Property::<Self>::sometimes("limit-switch fault", |_, s| {
                matches!(s.k.fault().map(|f| f.reason), Some(FaultReason::LimitSwitch { .. }))
            }),
            Property::<Self>::sometimes("J1 encoder fault", |_, s| {
                matches!(s.k.fault().map(|f| f.reason), Some(FaultReason::EncoderLost { axis: 0 }))
            }),
            Property::<Self>::sometimes("homing failed (H3)", |_, s| s.k.homing_status() == HomingStatus::Failed),
        ]);
        if !self.small {
            p.push(Property::<Self>::sometimes(
                "axes of one homing group out of step (arrival orders)",
                |_, s: &St<S>| out_of_step(&s.k.homing_phases()),
            ));
        }
        if self.tiny || !self.small {
            p.extend([
                Property::<Self>::sometimes("hardware fault: driver", |_, s| {
                    matches!(s.k.fault().map(|f| f.reason), Some(FaultReason::Hardware(HardwareFault::Driver { .. })))
                }),
                Property::<Self>::sometimes("hardware fault: self-test", |_, s| {
                    matches!(s.k.fault().map(|f| f.reason), Some(FaultReason::Hardware(HardwareFault::SelfTest(_))))
                }),
            ]);
        }
        p
    }
}

struct Run {
    unique: usize,
    generated: usize,
    depth: usize,
    secs: f64,
    violated: Vec<String>,
    /// Every reachable state was explored (not stopped by `--bounded`).
    exhaustive: bool,
    /// The `always` properties that held and applied in this run: every
    /// state property, and each transition check whose antecedent held on
    /// some explored transition.
    backing: Vec<&'static str>,
}

/// The measured positions of a kernel homed on the stationary arm
/// (`proofs::setup::operational`'s run, without its safety monitor: the
/// mutation tests must reach the model's properties, not stop at the
/// monitor during this set-up).
fn homed_positions<S: ModelScalar>() -> [S; AXES] {
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
fn supervisor<S: ModelScalar>(cfg: &str) -> Supervisor<S> {
    let (small, tiny, homing) = (matches!(cfg, "small" | "tiny"), cfg == "tiny", cfg == "homing");
    // Valid targets near the stationary arm: it ends homing on its switches,
    // which lie just outside the URDF limits, so clamp 10 mrad inside them.
    let mut here = homed_positions::<S>();
    for (i, h) in here.iter_mut().enumerate() {
        let j = &MODEL_CONFIG.joints[i];
        *h = h.clamp_between(S::from_f32(j.limit_min + 0.01), S::from_f32(j.limit_max - 0.01));
    }
    let (init, authority) = new_kernel::<S>(&kernel::config::Validated::relaxed(MODEL_CONFIG));
    // J1 10 mrad beyond its nearer limit (20 mrad from `here`, well within
    // a stream sample's reach), every other joint where it is.
    let mut out_of_limits = here;
    let j1 = &MODEL_CONFIG.joints[0];
    let (lo, hi) = (S::from_f32(j1.limit_min), S::from_f32(j1.limit_max));
    out_of_limits[0] =
        if here[0].minus(lo) < hi.minus(here[0]) { lo.minus(S::from_f32(0.01)) } else { hi.plus(S::from_f32(0.01)) };
    Supervisor { init, authority, here, out_of_limits, small, tiny, homing }
}

fn run<S: ModelScalar>(cfg: &str, expect: Option<&str>, timeout: Option<u64>, bounded: bool) -> Run {
    let model = supervisor::<S>(cfg);
    let started = std::time::Instant::now();
    // A cap on generated states (stateright counts every generated state, not
    // only unique ones) so that a state explosion reports instead of
    // exhausting memory; reaching it makes the run fail (not exhaustive).
    const CAP: usize = 1_000_000_000;
    // Stop as soon as a property named like `want` is violated.
    let wanted: std::collections::BTreeSet<&'static str> =
        model.properties().iter().map(|p| p.name).filter(|n| expect.is_some_and(|w| n.contains(w))).collect();
    let mut b = model.checker().threads(2).target_state_count(CAP);
    EXERCISED.store(0, Ordering::Relaxed);
    if let Some(want) = expect {
        let names = wanted;
        if names.is_empty() {
            println!("model: no property is named like '{want}'");
            std::process::exit(1);
        }
        b = b.finish_when(HasDiscoveries::AnyOf(names));
    }
    if let Some(t) = timeout {
        b = b.timeout(std::time::Duration::from_secs(t));
    }
    let checker = b.spawn_bfs();
    // Progress every 30 s (stderr), so a slow run shows how it grows.
    let mut last = std::time::Instant::now();
    while !checker.is_done() {
        std::thread::sleep(std::time::Duration::from_millis(200));
        if last.elapsed().as_secs() >= 30 {
            last = std::time::Instant::now();
            eprintln!(
                "model {}: {:.0} s, {} unique states, {} generated, depth {}",
                S::NAME,
                started.elapsed().as_secs_f64(),
                checker.unique_state_count(),
                checker.state_count(),
                checker.max_depth()
            );
        }
    }
    let checker = checker.join();
    let secs = started.elapsed().as_secs_f64();
    let stopped = timeout.is_some_and(|t| secs >= t as f64) || checker.state_count() >= CAP;
    if stopped && !bounded {
        println!(
            "model: stopped by --timeout or the state cap after {secs:.0} s: NOT exhaustive ({} unique states)",
            checker.unique_state_count()
        );
        std::process::exit(2);
    }
    let mut violated = Vec::new();
    for (name, path) in checker.discoveries() {
        if matches!(checker.discovery_classification(name), DiscoveryClassification::Counterexample) {
            violated.push(name.to_string());
            // The counterexample: its actions, and the last two states' kernel status.
            let states = path.clone().into_states();
            eprintln!("counterexample for '{name}', {} ticks:", states.len().saturating_sub(1));
            for a in path.clone().into_actions() {
                eprintln!("  {a:?}");
            }
            for st in states.iter().rev().take(2).rev() {
                eprintln!(
                    "  state {:?}, fault {:?}, homed {:#08b}, phases {:?}, j1 {:?}",
                    st.k.state(),
                    st.k.fault().map(|f| f.reason),
                    st.k.homed(),
                    st.k.homing_phases(),
                    st.j1
                );
            }
        }
    }
    let exercised = EXERCISED.load(Ordering::Relaxed);
    let checks: Vec<&'static str> = Check::ALL.iter().map(|c| c.name()).collect();
    let mut backing = Vec::new();
    for p in checker.model().properties() {
        if p.expectation != Expectation::Always || violated.iter().any(|v| v == p.name) {
            continue;
        }
        match Check::ALL.iter().find(|c| c.name() == p.name) {
            Some(c) if exercised & c.bit() == 0 => {
                if expect.is_none() {
                    println!("model {} {cfg}: not exercised (backs nothing here): {}", S::NAME, p.name);
                }
            }
            _ => backing.push(p.name),
        }
    }
    debug_assert!(checks.len() <= 64);
    let r = Run {
        unique: checker.unique_state_count(),
        generated: checker.state_count(),
        depth: checker.max_depth(),
        secs,
        violated,
        exhaustive: true,
        backing,
    };
    if expect.is_none() {
        if !r.violated.is_empty() {
            println!("model-checked {}: VIOLATED: {:?}", S::NAME, r.violated);
            if stopped {
                std::process::exit(1);
            }
        }
        if stopped {
            // A bounded exploration must still have reached every
            // 'sometimes' property (else it explored too little to back
            // what those properties show reachable).
            let missed: Vec<&str> = checker
                .model()
                .properties()
                .iter()
                .filter(|p| p.expectation == Expectation::Sometimes && checker.discovery(p.name).is_none())
                .map(|p| p.name)
                .collect();
            if !missed.is_empty() {
                println!("model {}: bounded exploration never reached the 'sometimes' properties {missed:?}", S::NAME);
                std::process::exit(1);
            }
            // A bounded exploration: every property held in every explored
            // state and every 'sometimes' property was reached.
            println!(
                "model {}: bounded exploration stopped after {secs:.0} s: {} unique states to depth {}: NOT exhaustive; no property violated in any explored state; every 'sometimes' property reached",
                S::NAME,
                r.unique,
                r.depth
            );
        } else {
            checker.assert_properties();
        }
    }
    Run { exhaustive: !stopped, ..r }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |k: &str| args.iter().position(|a| a == k).and_then(|i| args.get(i + 1)).map(String::as_str);
    let expect = arg("--expect-violation");
    // `--bounded S`: explore breadth first for at most S seconds and report
    // a bounded exploration (sampled evidence) if it does not finish.
    // Only the full configuration is bounded: the reduced ones (small,
    // tiny) must finish, so that their runs are model checks.
    let bounded = arg("--bounded").and_then(|t| t.parse::<u64>().ok());
    let plain_timeout: Option<u64> = arg("--timeout").and_then(|t| t.parse().ok());
    let runs: Vec<(&str, &str)> = match (arg("--variant"), arg("--config")) {
        (None, None) => vec![("fx", "full"), ("fx", "small"), ("fx", "homing"), ("f32", "tiny")],
        (v, c) => vec![(v.unwrap_or("fx"), c.unwrap_or("full"))],
    };
    for (field, rule) in MODEL_RELAXATIONS {
        println!("model: configuration relaxes {field} (breaks '{rule}'; see the doc comment)");
    }
    let mut tsv = String::new();
    for (variant, cfg) in runs {
        if !matches!(cfg, "full" | "small" | "tiny" | "homing") {
            eprintln!("model: unknown configuration {cfg}");
            std::process::exit(2);
        }
        let (timeout, bounded) = match (cfg, bounded) {
            ("full", Some(b)) => (Some(b), true),
            _ => (plain_timeout, false),
        };
        let r = match variant {
            "fx" => run::<Fx>(cfg, expect, timeout, bounded),
            "f32" => run::<f32>(cfg, expect, timeout, bounded),
            other => {
                eprintln!("model: unknown variant {other}");
                std::process::exit(2);
            }
        };
        let name = if variant == "fx" { "Kernel<Fx>" } else { "Kernel<f32>" };
        println!(
            "{} {name}, {cfg} configuration: {} states ({} unique), max depth {}, {:.1} s",
            if r.exhaustive { "model-checked" } else { "explored (bounded, sampled evidence)" },
            r.generated,
            r.unique,
            r.depth,
            r.secs
        );
        if let Some(want) = expect {
            let hit: Vec<&String> = r.violated.iter().filter(|v| v.contains(want)).collect();
            if hit.is_empty() {
                println!("model: expected a violation of '{want}', found {:?}", r.violated);
                std::process::exit(1);
            }
            println!("model: violated as expected: {hit:?}");
            continue;
        }
        if r.exhaustive {
            println!(
                "model-checked {name}: every property holds in every reachable state; every 'sometimes' property reached"
            );
            tsv.push_str(&format!(
                "model\tmodel-checked\t{}\tholds\tsupervisor + homing, {name}, {cfg} configuration\t{}\n",
                r.unique,
                r.backing.join("|")
            ));
        } else {
            tsv.push_str(&format!(
                "model\tsampled\t{}\tholds\tbounded BFS exploration (not exhaustive) to depth {}, {name}, {cfg} configuration\t{}\n",
                r.unique,
                r.depth,
                r.backing.join("|")
            ));
        }
    }
    if expect.is_none() {
        if let Ok(dir) = std::env::var("EVIDENCE_DIR") {
            if let Err(e) = std::fs::write(std::path::Path::new(&dir).join("model.tsv"), tsv) {
                eprintln!("model: cannot write the evidence file in {dir}: {e}");
                std::process::exit(1);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kernel::config::PAROL6;

    #[test]
    fn model_config_relaxes_exactly_the_named_rules() {
        use kernel::config::check;
        let mut c = MODEL_CONFIG;
        for (j, p) in c.joints.iter_mut().zip(PAROL6.joints.iter()) {
            j.homing.backoff = p.homing.backoff;
            j.homing.timeout_ms = p.homing.timeout_ms;
        }
        c.soft_stop_ms = PAROL6.soft_stop_ms;
        assert_eq!(check(&c), Ok(()), "without the relaxations the model's configuration passes check");
        let mut one = c;
        one.soft_stop_ms = 4;
        assert_eq!(check(&one), Err(MODEL_RELAXATIONS[2].1));
        let mut one = c;
        one.joints.iter_mut().for_each(|j| j.homing.backoff = 0.0);
        assert_eq!(check(&one), Err(MODEL_RELAXATIONS[0].1));
        let mut one = c;
        one.joints.iter_mut().for_each(|j| j.homing.timeout_ms = 8);
        assert_eq!(check(&one), Err(MODEL_RELAXATIONS[1].1));

        // Everything else is PAROL6 or shortened within the rules.
        c.command_timeout_ms = PAROL6.command_timeout_ms;
        c.soft_stop_ms = PAROL6.soft_stop_ms;
        c.segment_min_ms = PAROL6.segment_min_ms;
        c.segment_max_ms = PAROL6.segment_max_ms;
        c.boot_timeout_ms = PAROL6.boot_timeout_ms;
        c.homing_settle_ms = PAROL6.homing_settle_ms;
        for (j, p) in c.joints.iter_mut().zip(PAROL6.joints.iter()) {
            j.max_acceleration = p.max_acceleration;
            j.homing.switch_position = p.homing.switch_position;
        }
        assert_eq!(c, PAROL6);
    }

    #[test]
    fn f32_state_identity_ignores_only_the_tick_counters() {
        let (mut a, _) = new_kernel::<f32>(&kernel::config::Validated::relaxed(MODEL_CONFIG));
        let mut b = a.clone();
        let h = |k: &Kernel<f32>| {
            let mut h = DefaultHasher::new();
            f32::hash_kernel(k, &mut h);
            h.finish()
        };
        let s = |c: u16| Sense {
            encoders: [EncoderSample::Count(c); AXES],
            limits: 0,
            hardware_fault: None,
            link_lost: false,
        };
        a.tick(&s(100), None);
        b.tick(&s(100), None);
        b.tick(&s(100), None); // one more tick, same state otherwise
        assert_eq!(h(&a), h(&b));
        let mut c = a.clone();
        c.tick(&s(101), None); // a different estimate
        assert_ne!(h(&a), h(&c));
    }
}

#[cfg(test)]
mod evidence_tests {
    use super::*;
    use std::collections::BTreeSet;

    /// Every property of every configuration of the model.
    fn model_properties() -> BTreeSet<&'static str> {
        let mut names = BTreeSet::new();
        for cfg in ["full", "small", "tiny", "homing"] {
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
}
