//! Recoverability (SR-6, SR-31): a latch with no physical cause is left by
//! `<ENABLE>` (and `<HOME>` where homing was lost), judged on a clone.

use crate::config::MODEL_CONFIG;
use crate::environment::{Perturb, Req};
use crate::identity::ModelScalar;
use crate::model::Supervisor;
use kernel::{Event, Kernel, State};

impl<S: ModelScalar> Supervisor<S> {
    /// Recoverability (SR-6, SR-31): from a state that is latched, or
    /// stopping toward a latch, with no physical cause the operator must
    /// remove, `<ENABLE>` is accepted once the ramp has ended and, where
    /// homing was lost, `<HOME>` starts homing. The physical world stays as
    /// the latch left it: the switches pressed in that tick stay pressed
    /// (an axis stopped on its switch); every other perturbation of the
    /// model lasts one tick. A pressed switch of a homed joint is a cause
    /// only the operator removes: such states are not judged. Returns
    /// whether the kernel came back.
    pub(crate) fn recovers(&self, k: &Kernel<S>, pressed: u8) -> bool {
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
    pub(crate) fn recovers_from_link_loss(&self, k: &Kernel<S>, pressed: u8) -> bool {
        let mut k = k.clone();
        let mut sense = self.sense(Perturb::None, pressed);
        sense.link_lost = true;
        k.tick(&sense, None);
        self.recovers(&k, pressed)
    }
}
