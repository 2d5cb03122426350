//! The arm configuration the model runs on: PAROL6 with its timers shortened
//! within the configuration rules and three named relaxations.

use kernel::config::{ArmConfig, AXES};
use proofs::setup::PROOF_CONFIG;

pub(crate) const MODEL_CONFIG: ArmConfig = {
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

/// The homing configuration's arm: `MODEL_CONFIG` with J4's homing timeout
/// one tick longer than J5's. On the arm a joint's timeout follows its
/// nominal homing time (1.2 times it, over the joint's range and speeds),
/// so the axes of a group have unequal homing times and the quicker one
/// finishes first and waits, stepped but at rest, for the rest of its
/// group. With every axis at the shortest timeout that homes (8 ms), any
/// axis of a group that finishes later than its sibling has run out of
/// time: the wait is reached, but only toward a homing timeout. J4's
/// 9 ms lets its switch arrive a tick late in its fast seek, so J5 waits
/// in `Done` and the group then completes
/// (`tests::a_late_j4_completes_its_group_while_j5_waits`).
pub(crate) const HOMING_MODEL_CONFIG: ArmConfig = {
    let mut c = MODEL_CONFIG;
    c.joints[3].homing.timeout_ms = 9;
    c
};

/// What `MODEL_CONFIG` relaxes of `kernel::config::check` (the rule each
/// breaks); the same three as `proofs::setup::PROOF_RELAXATIONS`.
pub(crate) const MODEL_RELAXATIONS: [(&str, &str); 3] = [
    ("joints[*].homing.backoff = 0", "homing back-off must be in (0, 0.5) rad"),
    (
        "joints[*].homing.timeout_ms = 8 (J4: 9 in the homing configuration)",
        "homing timeout shorter than 1.2x the nominal homing time: homing is impossible",
    ),
    ("soft_stop_ms = 4", "soft-stop ramp decelerates faster than max_acceleration"),
];

#[cfg(test)]
mod tests {
    use super::*;
    use kernel::config::{Validated, PAROL6};
    use kernel::homing::Phase;
    use kernel::{Fx, Request, State};
    use proofs::setup::{new_kernel, still, HOMING_TICKS};

    /// Whether `<HOME>` on the stationary arm under `c` ends Operational
    /// when every seeking axis's switch arrives on the first tick it seeks
    /// (the fastest run the model's environment offers).
    fn homes(c: ArmConfig) -> bool {
        homes_with_j4_late(c, 0).0
    }

    /// `<HOME>` with every seeking axis's switch arriving on the first tick
    /// it seeks but J4's, which arrives `late` ticks later in its fast
    /// seek: whether the run ends Operational, and how many ticks J5 spent
    /// in `Done` while J4 was still moving.
    fn homes_with_j4_late(c: ArmConfig, late: u32) -> (bool, u32) {
        let (mut k, _) = new_kernel::<Fx>(&Validated::relaxed(c));
        k.tick(&still(0), None);
        k.tick(&still(0), Some(Request::Home));
        let (mut j4_seeking, mut waited) = (0, 0);
        // (`late` more ticks than the fastest run; 16 to spare.)
        for _ in 0..HOMING_TICKS + late + 16 {
            if k.state() != State::Homing {
                break;
            }
            let phases = k.homing_phases();
            if phases[4] == Phase::Done && phases[3].is_moving() {
                waited += 1;
            }
            if phases[3] == Phase::FastSeek {
                j4_seeking += 1;
            }
            let seeking = phases.iter().enumerate().filter(|(_, p)| matches!(p, Phase::FastSeek | Phase::SlowSeek));
            let mut limits = seeking.fold(0u8, |m, (i, _)| m | 1 << i);
            if phases[3] == Phase::FastSeek && j4_seeking <= late {
                limits &= !(1 << 3);
            }
            k.tick(&still(limits), None);
        }
        (k.state() == State::Operational, waited)
    }

    /// The homing configuration reaches a finished axis waiting for its
    /// group and the group then completing: J4's switch a tick late, J5
    /// waits in `Done` and the run homes; with J4 at the 8 ms every other
    /// axis has, the same arrival ends in J4's homing timeout.
    #[test]
    fn a_late_j4_completes_its_group_while_j5_waits() {
        assert_eq!(homes_with_j4_late(HOMING_MODEL_CONFIG, 0), (true, 0), "on time: no wait");
        let (homed, waited) = homes_with_j4_late(HOMING_MODEL_CONFIG, 1);
        assert!(homed && waited > 0, "a tick late: homed {homed}, J5 waited {waited} ticks");
        assert!(!homes_with_j4_late(HOMING_MODEL_CONFIG, 2).0, "two ticks late J4 still homes in 9 ms");
        assert!(!homes_with_j4_late(MODEL_CONFIG, 1).0, "a tick late J4 homes in 8 ms");
        // Only J4's timeout differs from the other configurations' arm.
        let mut c = HOMING_MODEL_CONFIG;
        c.joints[3].homing.timeout_ms = MODEL_CONFIG.joints[3].homing.timeout_ms;
        assert_eq!(c, MODEL_CONFIG);
    }

    /// The 8 ms homing timeout is the shortest with which a homing run can
    /// finish: the model cannot shrink its homing histories by shortening it.
    #[test]
    fn the_homing_timeout_is_the_shortest_that_homes() {
        assert!(homes(MODEL_CONFIG), "the model's configuration homes");
        let mut c = MODEL_CONFIG;
        c.joints.iter_mut().for_each(|j| j.homing.timeout_ms -= 1);
        assert!(!homes(c), "a homing timeout 1 ms shorter still homes");
    }

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
}
