//! The stepper drivers' enable decision: energised only in a state in
//! which the kernel may command motion (homing, following targets, or the
//! soft-stop ramp that brings a moving arm to rest), de-energised in every
//! other one (waiting for the encoders, unhomed, latched after a soft stop,
//! latched in a fault).
//!
//! A pure function of the kernel's state after its step, so a board that
//! drives an enable output from it each tick removes torque in the tick a
//! fault is latched. Without motor power J2 and J3 are not held: the
//! arm's own holding (brakes or a mechanical stop) is the integrator's.

use kernel::State;

/// `true` when the drivers may be energised in `state`.
pub const fn drivers_enabled(state: State) -> bool {
    match state {
        State::Homing | State::Operational | State::Stopping => true,
        State::Boot | State::Unhomed | State::SoftEstop | State::Fault => false,
    }
}

/// The enable output's level for `enabled`: high when the line is active
/// high, low when it is active low (the TMC5160's `DRV_ENN` enables the
/// driver while low).
pub const fn enable_level_high(enabled: bool, active_high: bool) -> bool {
    enabled == active_high
}

#[cfg(test)]
mod tests {
    use super::*;
    use kernel::config::PAROL6_VALIDATED;
    use kernel::KernelF32;

    const ALL: [State; 7] = [
        State::Boot,
        State::Unhomed,
        State::Homing,
        State::Operational,
        State::Stopping,
        State::SoftEstop,
        State::Fault,
    ];

    #[test]
    fn only_the_states_that_may_move_enable_the_drivers() {
        let enabled: Vec<State> = ALL.into_iter().filter(|&s| drivers_enabled(s)).collect();
        assert_eq!(enabled, [State::Homing, State::Operational, State::Stopping]);
    }

    #[test]
    fn the_level_follows_the_active_polarity() {
        assert!(enable_level_high(true, true));
        assert!(!enable_level_high(false, true));
        assert!(!enable_level_high(true, false));
        assert!(enable_level_high(false, false));
    }

    #[test]
    fn a_new_kernel_keeps_the_drivers_off() {
        let (k, _authority) = KernelF32::new(&PAROL6_VALIDATED);
        assert!(!drivers_enabled(k.state()), "{:?}", k.state());
    }
}
