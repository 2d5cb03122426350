//! The transition checks: one `always` property each, named by the
//! requirements it checks, and which of them a run exercised.

use crate::identity::ModelScalar;
use crate::model::Supervisor;
use crate::state::St;
use stateright::Property;
use std::sync::atomic::{AtomicU64, Ordering};

/// Declares the model's transition checks: each is a property of its own
/// (named by the requirements it checks, `SR-n` or `SR-n/m`), checked on
/// every transition whose antecedent holds.
macro_rules! checks {
    ($($v:ident => $name:literal,)*) => {
        /// A transition check (see `checks!`).
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub(crate) enum Check {
            $($v,)*
        }

        impl Check {
            pub(crate) const ALL: &'static [Check] = &[$(Check::$v,)*];

            pub(crate) const fn name(self) -> &'static str {
                match self {
                    $(Check::$v => $name,)*
                }
            }

            pub(crate) const fn bit(self) -> u64 {
                1 << self as u32
            }
        }

        /// One `always` property per transition check: no explored
        /// transition violated it.
        pub(crate) fn check_properties<S: ModelScalar>() -> Vec<Property<Supervisor<S>>> {
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
    WaitAtRest => "SR-14/16: a finished homing axis moved, left Done or faulted while its group was still moving",
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
pub(crate) static EXERCISED: AtomicU64 = AtomicU64::new(0);

/// The checks of one transition.
#[derive(Default)]
pub(crate) struct Checks {
    pub(crate) exercised: u64,
    pub(crate) violated: u64,
}

impl Checks {
    /// `antecedent`: the check applies to this transition; `holds`: it is
    /// satisfied.
    pub(crate) fn check(&mut self, c: Check, antecedent: bool, holds: bool) {
        if antecedent {
            self.exercised |= c.bit();
            if !holds {
                self.violated |= c.bit();
            }
        }
    }

    pub(crate) fn record(&self) {
        if self.exercised & !EXERCISED.load(Ordering::Relaxed) != 0 {
            EXERCISED.fetch_or(self.exercised, Ordering::Relaxed);
        }
    }
}
