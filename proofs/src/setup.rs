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
//! its own copy of the seed's homing order) checks it, so each harness
//! asserts every per-tick requirement (SR-1, 2, 4..11, 13, 15..19, 25) on
//! every tick besides its own property.

use kernel::config::{ArmConfig, Validated, AXES, PAROL6};
use kernel::homing::Phase;
use kernel::{Authority, EncoderSample, Kernel, MotionKind, MotionTarget, Request, Scalar, Sense, State, TickOutput};
use monitor::{Monitor, Sent};

/// `PAROL6` with zero homing back-off, switches 0.01 rad inside the limits,
/// and times short enough for a harness: command timeout 3 ms, soft-stop
/// ramp 4 ms, homing 40 ms per axis, homing settle 1 ms.
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
    c.soft_stop_ms = 4;
    c.homing_settle_ms = 1;
    c
};

/// [`PROOF_CONFIG`] as the kernel takes it. It fails `config::check` (zero
/// back-off, homing and ramp times too short for the real arm), so it is a
/// documented relaxation (`Validated::relaxed`, feature `relaxed-config`).
pub const PROOF_VALIDATED: Validated = Validated::relaxed(PROOF_CONFIG);

/// The seed's homing order (FIRMWARE_DEVELOPER_GUIDE.md section 6: J6; then
/// J5 and J4; then J1, J2, J3), written out in the monitor independently of
/// the kernel's tables so that a harness cannot inherit a mistake from them.
pub use monitor::SEED_DEPENDENCIES;

/// Counts the stationary encoders read (mid-range, away from the wrap).
pub const COUNTS: [u16; AXES] = [1000, 2000, 3000, 500, 1500, 2500];

/// Sensors of a stationary arm with the given switches pressed.
pub fn still(limits: u8) -> Sense {
    Sense { encoders: COUNTS.map(EncoderSample::Count), limits, hardware_fault: None, link_lost: false }
}

/// A scalar the harnesses can draw symbolically.
pub trait Sym: Scalar {
    /// Any bit pattern.
    fn any() -> Self;
}

impl Sym for f32 {
    fn any() -> Self {
        kani::any()
    }
}

impl Sym for kernel::Fx {
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
        let (k, a) = Kernel::new(&PROOF_VALIDATED);
        (Checked { k, mon: Monitor::new(&PROOF_CONFIG) }, a)
    }

    /// One kernel tick, checked by the monitor.
    pub fn tick(&mut self, sense: &Sense, request: Option<Request<S>>) -> TickOutput<S> {
        let sent = request.as_ref().map(Sent::of);
        let o = self.k.tick(sense, request);
        let r = self.mon.check(sense, sent.as_ref(), &o, Some(&self.k.homing_phases()), None);
        assert!(r.is_ok(), "safety monitor: {r:?}");
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

/// Runs homing to completion by pressing the switch of every seeking axis.
/// At most 40 ticks (three groups of at most 7 ticks each, plus margin).
pub fn run_homing<S: Scalar>(k: &mut Checked<S>) {
    for _ in 0..40 {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernel_dependencies_match_the_seed() {
        for (j, needs) in SEED_DEPENDENCIES.iter().enumerate() {
            assert_eq!(Kernel::<f32>::dependencies(j), *needs, "J{}", j + 1);
        }
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
