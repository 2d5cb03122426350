//! Reaching kernel states through the public API only.
//!
//! The arm is stationary: every encoder reads a constant count, so the
//! observer sits exactly on its measurement and the harness controls the
//! limit switches. Homing then completes in a few ticks per group with
//! [`PROOF_CONFIG`], which is `PAROL6` with a zero back-off distance and
//! short timeouts (a harness cannot run the real configuration's thousands
//! of ticks). Only those values differ; every code path is the kernel's own.
//!
//! Every tick a harness runs, setup included, goes through [`Checked`]:
//! the one safety monitor (`monitor::Monitor`, written from SAFETY.md, with
//! its own copy of the arm's homing order) checks it, so each harness
//! asserts every per-tick requirement (SR-1, 2, 4..11, 13, 15..19, 25) on
//! every tick besides its own property.

use kernel::config::{ArmConfig, Validated, AXES, PAROL6};
use kernel::homing::Phase;
use kernel::{
    Authority, DriverCause, EncoderSample, HardwareFault, Kernel, MotionKind, MotionTarget, Request, Scalar, Sense,
    State, TickOutput,
};
use monitor::{Monitor, Sent};

/// `PAROL6` with zero homing back-off, switches 0.01 rad inside the limits
/// (the stationary arm homes inside them, so every position it reports is
/// a valid target), and times short enough for a harness: command timeout
/// 3 ms, soft-stop ramp 4 ms, homing 40 ms per axis, homing settle 1 ms.
///
/// This is a **relaxation**: `kernel::config::check` rejects it, for exactly
/// the rules in [`PROOF_RELAXATIONS`] (a test restores those fields from
/// `PAROL6` and gets a configuration `check` accepts, and shows each
/// relaxation alone fails with its listed rule). The command timeout, ramp,
/// switch positions and settle time are changed within the rules.
pub const PROOF_CONFIG: ArmConfig = {
    let mut c = PAROL6;
    let mut i = 0;
    while i < AXES {
        c.joints[i].homing.backoff = 0.0;
        c.joints[i].homing.timeout_ms = 40;
        // The switch 0.01 rad inside the limit it guards, so the stationary
        // arm homes inside its limits (every position it reports is a
        // valid target).
        let j = &c.joints[i];
        c.joints[i].homing.switch_position = match j.homing.direction {
            kernel::config::Direction::Positive => j.limit_max - 0.01,
            kernel::config::Direction::Negative => j.limit_min + 0.01,
        };
        i += 1;
    }
    c.command_timeout_ms = 3;
    // Segments shorter than the command timeout (a rule of `check`).
    c.segment_min_ms = 1;
    c.segment_max_ms = 2;
    c.soft_stop_ms = 4;
    c.homing_settle_ms = 1;
    c
};

/// [`PROOF_CONFIG`] as the kernel takes it: a documented relaxation
/// (`Validated::relaxed`, feature `relaxed-config`; see above).
pub const PROOF_VALIDATED: Validated = Validated::relaxed(PROOF_CONFIG);

/// What [`PROOF_CONFIG`] relaxes of `kernel::config::check`: (field, the
/// rule it breaks, why). Checked by `tests::proof_config_relaxes_exactly_the_named_rules`.
pub const PROOF_RELAXATIONS: [(&str, &str, &str); 3] = [
    (
        "joints[*].homing.backoff = 0",
        "homing back-off must be in (0, 0.5) rad",
        "the arm is stationary: a back-off distance > 0 is never travelled, so homing could not finish",
    ),
    (
        "joints[*].homing.timeout_ms = 40",
        "homing timeout shorter than 1.2x the nominal homing time: homing is impossible",
        "the nominal time is seconds of travel over the whole range; a stationary arm homes in ticks",
    ),
    (
        "soft_stop_ms = 4",
        "soft-stop ramp decelerates faster than max_acceleration",
        "a harness cannot run 100 ticks of ramp; the ramp's shape (v0 (N-k)/N) does not depend on N",
    ),
];

/// The largest unwind the code under test needs per tick: every loop of
/// `kernel/src` and `monitor/src` runs over the six axes (7), the three
/// homing groups (4) or the tick's events (at most 4: 5); listed and checked
/// by the source scan `proofs/tests/loops.rs`. The shim cannot count these
/// loops (it only instruments the proofs crate), so every harness that runs
/// a tick declares it through [`kernel_loops`].
///
/// (`Params::new`'s 65-entry reciprocal table, which needed unwind 66 in
/// `Kernel::new`, is gone: a segment's 1/n is a division per accepted
/// target.)
pub const KERNEL_UNWIND: u32 = 7;

/// Counts one kernel tick against the harness's stated footprint (every
/// tick a harness runs calls it; see `kani::runner::Footprint`).
#[inline(always)]
pub fn count_tick() {
    #[cfg(not(kani))]
    kani::runner::tick();
}

/// Declares the code under test's loops to the shim (see [`KERNEL_UNWIND`]).
#[inline(always)]
pub fn kernel_loops() {
    #[cfg(not(kani))]
    kani::runner::needs_unwind(KERNEL_UNWIND, "the kernel's and monitor's per-axis loops (proofs/tests/loops.rs)");
}

/// A kernel for `config` and its authority: the one place the proofs and
/// the model construct a kernel.
pub fn new_kernel<S: Scalar>(config: &Validated) -> (Kernel<S>, Authority) {
    kernel_loops();
    Kernel::new(config)
}

/// The arm's homing order (docs/spec/robot.md section 4: J6; then
/// J5 and J4; then J1, J2, J3), written out in the monitor independently of
/// the kernel's tables so that a harness cannot inherit a mistake from them.
pub use monitor::SEED_DEPENDENCIES;

/// Counts the stationary encoders read (mid-range, away from the wrap).
pub const COUNTS: [u16; AXES] = [1000, 2000, 3000, 500, 1500, 2500];

/// Sensors of a stationary arm with the given switches pressed.
pub fn still(limits: u8) -> Sense {
    Sense { encoders: COUNTS.map(EncoderSample::Count), limits, hardware_fault: None, link_lost: false }
}

/// Every cause a driver's diagnostics can report (checked complete by
/// `tests::every_hardware_fault_kind_can_be_drawn`).
pub const DRIVER_CAUSES: [DriverCause; 9] = [
    DriverCause::Missing,
    DriverCause::WrongVersion,
    DriverCause::Reset,
    DriverCause::DriverError,
    DriverCause::ChargePump,
    DriverCause::Overtemperature,
    DriverCause::ShortToGround,
    DriverCause::ShortToSupply,
    DriverCause::OpenLoad,
];

/// The hardware fault of kind `kind % 4` (a tick overrun, a refused step
/// rate of axis `n`, a self-test code `n`, a driver diagnostic of axis `n`
/// with cause `cause`).
pub fn hardware_fault(kind: u8, n: u8, cause: u8) -> HardwareFault {
    match kind % 4 {
        0 => HardwareFault::TickOverrun,
        1 => HardwareFault::Driver { axis: n % AXES as u8 },
        2 => HardwareFault::SelfTest(n),
        _ => HardwareFault::DriverDiagnostic {
            axis: n % AXES as u8,
            cause: DRIVER_CAUSES[usize::from(cause) % DRIVER_CAUSES.len()],
        },
    }
}

/// Any hardware fault, of every kind (3 symbolic values).
pub fn any_hardware_fault() -> HardwareFault {
    hardware_fault(kani::any(), kani::any(), kani::any())
}

/// A scalar the harnesses can draw symbolically.
pub trait Sym: Scalar {
    /// The type has non-finite values (NaN, infinities): antecedents about
    /// them are reachable (f32) or vacuous by construction (fixed point).
    const HAS_NON_FINITE: bool;
    /// Any bit pattern.
    fn any() -> Self;
}

impl Sym for f32 {
    const HAS_NON_FINITE: bool = true;
    fn any() -> Self {
        kani::any()
    }
}

impl Sym for kernel::Fx {
    const HAS_NON_FINITE: bool = false;
    fn any() -> Self {
        kernel::Fx::from_bits(kani::any())
    }
}

/// A kernel whose every tick is checked by the monitor (an assertion: a
/// violation fails the harness). It dereferences to the kernel for its
/// read-only API.
#[derive(Clone, Debug)]
pub struct Checked<S: Scalar> {
    k: Kernel<S>,
    mon: Monitor<S>,
}

impl<S: Scalar> Checked<S> {
    /// A fresh kernel with [`PROOF_CONFIG`] (state Boot), its monitor and
    /// its authority.
    pub fn new() -> (Self, Authority) {
        let (k, a) = new_kernel(&PROOF_VALIDATED);
        (Checked { k, mon: Monitor::new(&PROOF_CONFIG) }, a)
    }

    /// One kernel tick, checked by the monitor.
    pub fn tick(&mut self, sense: &Sense, request: Option<Request<S>>) -> TickOutput<S> {
        kernel_loops();
        count_tick();
        let sent = request.as_ref().map(Sent::of);
        let o = self.k.tick(sense, request);
        let r = self.mon.check(sense, sent.as_ref(), &o, Some(&self.k.homing_phases()), None);
        assert!(r.is_ok(), "safety monitor: {r:?}");
        assert!(self.k.invariant(), "the kernel's state invariant");
        o
    }
}

impl<S: Scalar> core::ops::Deref for Checked<S> {
    type Target = Kernel<S>;
    fn deref(&self) -> &Kernel<S> {
        &self.k
    }
}

/// A booted kernel (state Unhomed) and its authority.
pub fn unhomed<S: Scalar>() -> (Checked<S>, Authority) {
    let (mut k, a) = Checked::new();
    k.tick(&still(0), None);
    (k, a)
}

/// Ticks a whole homing run takes on the stationary arm with
/// [`PROOF_CONFIG`] when every seeking axis finds its switch at once (one
/// tick of rest before the run, then per group 8 ticks: fast seek, switch,
/// back-off, slow seek, switch, release, settle, done;
/// measured by `tests::homing_takes_exactly_homing_ticks`).
pub const HOMING_TICKS: u32 = 25;

/// Runs homing to completion by pressing the switch of every seeking axis:
/// [`HOMING_TICKS`] ticks, the loop's bound (it stops early otherwise).
#[cfg_attr(not(kani), kani::loops)]
pub fn run_homing<S: Scalar>(k: &mut Checked<S>) {
    for _ in 0..HOMING_TICKS {
        if k.state() != State::Homing {
            return;
        }
        let mut limits = 0u8;
        for (i, p) in k.homing_phases().iter().enumerate() {
            if matches!(p, Phase::FastSeek | Phase::SlowSeek) {
                limits |= 1 << i;
            }
        }
        k.tick(&still(limits), None);
    }
}

/// A homed, operational kernel with the timeout not yet armed.
pub fn operational<S: Scalar>() -> (Checked<S>, Authority) {
    let (mut k, a) = unhomed::<S>();
    k.tick(&still(0), Some(Request::Home));
    run_homing(&mut k);
    (k, a)
}

/// The measured positions of an operational kernel (a valid target).
pub fn here<S: Scalar>(k: &mut Checked<S>) -> [S; AXES] {
    k.tick(&still(0), None).status.position
}

/// A target at `p` with zero velocities.
pub fn target<S: Scalar>(p: [S; AXES]) -> MotionTarget<S> {
    MotionTarget { position: p, velocity: [S::ZERO; AXES], kind: MotionKind::Stream }
}

/// A sampled end-to-end test: a multi-tick run from power-on, run by the
/// shim like a harness (its covers required, its loops bounded by the
/// given unwind, its cases held to the given footprint, a line in the
/// shim's report) but **not a Kani harness**: its ticks are too many for
/// Kani to finish, and its safety assertions are the one-step lemmas'
/// (`state_props`), which carry them by induction. What each adds is
/// written beside it (reachability of a state from power-on, the ticks of
/// Boot and Homing, which no lemma draws, or a timing over several ticks).
///
/// `end_to_end!(name, body, unwind N, footprint V symbolic values, T ticks)`,
/// with the unwind's reason in a comment on its line.
#[cfg(all(test, not(kani)))]
macro_rules! end_to_end {
    ($name:ident, $body:expr, unwind $u:literal, footprint $v:literal symbolic values, $t:literal ticks) => {
        #[test]
        fn $name() {
            kani::runner::run_harness(
                concat!(module_path!(), "::", stringify!($name)),
                $body,
                Some($u),
                Some(kani::runner::Footprint { symbolic_values: $v, ticks: $t }),
            );
        }
    };
}
#[cfg(all(test, not(kani)))]
pub(crate) use end_to_end;

#[cfg(test)]
mod tests {
    use super::*;

    /// Every `HardwareFault` and `DriverCause` variant comes out of
    /// [`hardware_fault`] for some draw (the matches have no wildcard: a new
    /// variant does not compile until it is drawn).
    #[test]
    fn every_hardware_fault_kind_can_be_drawn() {
        let mut seen = std::collections::BTreeSet::new();
        for kind in 0..4u8 {
            for cause in 0..DRIVER_CAUSES.len() as u8 {
                let f = hardware_fault(kind, 1, cause);
                let id = match f {
                    HardwareFault::TickOverrun => 0,
                    HardwareFault::Driver { .. } => 1,
                    HardwareFault::SelfTest(_) => 2,
                    HardwareFault::DriverDiagnostic { cause, .. } => {
                        3 + match cause {
                            DriverCause::Missing => 0,
                            DriverCause::WrongVersion => 1,
                            DriverCause::Reset => 2,
                            DriverCause::DriverError => 3,
                            DriverCause::ChargePump => 4,
                            DriverCause::Overtemperature => 5,
                            DriverCause::ShortToGround => 6,
                            DriverCause::ShortToSupply => 7,
                            DriverCause::OpenLoad => 8,
                        }
                    }
                };
                seen.insert(id);
            }
        }
        assert_eq!(seen.len(), 3 + DRIVER_CAUSES.len(), "{seen:?}");
    }

    #[test]
    fn kernel_dependencies_match_the_seed() {
        for (j, needs) in SEED_DEPENDENCIES.iter().enumerate() {
            assert_eq!(Kernel::<f32>::dependencies(j), *needs, "J{}", j + 1);
        }
    }

    /// `PROOF_CONFIG` with the relaxed fields restored from `PAROL6`.
    fn unrelaxed() -> ArmConfig {
        let mut c = PROOF_CONFIG;
        for (j, p) in c.joints.iter_mut().zip(PAROL6.joints.iter()) {
            j.homing.backoff = p.homing.backoff;
            j.homing.timeout_ms = p.homing.timeout_ms;
        }
        c.soft_stop_ms = PAROL6.soft_stop_ms;
        c
    }

    #[test]
    fn proof_config_relaxes_exactly_the_named_rules() {
        use kernel::config::check;
        // Everything but the named fields passes the project's own check.
        assert_eq!(check(&unrelaxed()), Ok(()));
        // Each relaxation alone breaks exactly its named rule.
        let mut c = unrelaxed();
        c.joints.iter_mut().for_each(|j| j.homing.backoff = 0.0);
        assert_eq!(check(&c), Err(PROOF_RELAXATIONS[0].1));
        let mut c = unrelaxed();
        c.joints.iter_mut().for_each(|j| j.homing.timeout_ms = 40);
        assert_eq!(check(&c), Err(PROOF_RELAXATIONS[1].1));
        let mut c = unrelaxed();
        c.soft_stop_ms = 4;
        assert_eq!(check(&c), Err(PROOF_RELAXATIONS[2].1));
        // Restoring them gives back PAROL6 but for the in-rule changes
        // (timers, segments, switch positions, settle time).
        let mut c = unrelaxed();
        c.command_timeout_ms = PAROL6.command_timeout_ms;
        c.segment_min_ms = PAROL6.segment_min_ms;
        c.segment_max_ms = PAROL6.segment_max_ms;
        c.homing_settle_ms = PAROL6.homing_settle_ms;
        for (j, p) in c.joints.iter_mut().zip(PAROL6.joints.iter()) {
            j.homing.switch_position = p.homing.switch_position;
        }
        assert_eq!(c, PAROL6);
        for (field, rule, why) in PROOF_RELAXATIONS {
            println!("PROOF_CONFIG relaxes {field}: breaks '{rule}' ({why})");
        }
    }

    #[test]
    fn homing_takes_exactly_homing_ticks() {
        let (mut k, _) = unhomed::<kernel::Fx>();
        k.tick(&still(0), Some(Request::Home));
        let mut n = 0;
        while k.state() == State::Homing {
            let mut limits = 0u8;
            for (i, p) in k.homing_phases().iter().enumerate() {
                if matches!(p, Phase::FastSeek | Phase::SlowSeek) {
                    limits |= 1 << i;
                }
            }
            k.tick(&still(limits), None);
            n += 1;
            assert!(n < 1000);
        }
        assert_eq!(n, HOMING_TICKS, "homing ticks");
        assert_eq!(k.state(), State::Operational);
    }

    #[test]
    fn setup_reaches_operational_in_both_variants() {
        let (k, _) = operational::<f32>();
        assert_eq!(k.state(), State::Operational);
        assert_eq!(k.homed(), 0b11_1111);
        let (k, _) = operational::<kernel::Fx>();
        assert_eq!(k.state(), State::Operational);
    }
}
