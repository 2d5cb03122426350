//! The proptest strategies that draw steps and starts.

use kernel::config::AXES;
use kernel::homing::Phase;
use kernel::HardwareFault;
use proptest::prelude::*;

use monitor::plant::EncoderFault;

use super::steps::range;
use super::{Bad, Start, Step};

/// What the strategies may generate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mix {
    /// Everything, including inputs at the edge of the fault thresholds.
    Full,
    /// For the f32 / fixed-point differential: only inputs whose outcome
    /// cannot depend on rounding (no outside forces, no glitches near the
    /// plausibility window).
    Discrete,
}

fn axis() -> impl Strategy<Value = usize> {
    0..AXES
}

fn fractions() -> impl Strategy<Value = [f64; AXES]> {
    // Mostly inside, sometimes exactly at a limit.
    let one = prop_oneof![8 => 0.0..=1.0f64, 1 => Just(0.0), 1 => Just(1.0)];
    [one.clone(), one.clone(), one.clone(), one.clone(), one.clone(), one]
}

fn velocities() -> impl Strategy<Value = [f64; AXES]> {
    let one = prop_oneof![4 => Just(0.0), 4 => -1.0..=1.0f64, 1 => Just(1.0), 1 => Just(-1.0)];
    [one.clone(), one.clone(), one.clone(), one.clone(), one.clone(), one]
}

fn bad() -> impl Strategy<Value = Bad> {
    prop_oneof![
        (0.001..5.0f64, any::<bool>()).prop_map(|(e, neg)| Bad::OutOfLimits(if neg { -e } else { e })),
        Just(Bad::NanPosition),
        any::<bool>().prop_map(Bad::InfPosition),
        Just(Bad::NanVelocity),
        (0.001..3.0f64).prop_map(Bad::VelocityTooHigh),
    ]
}

fn homing_phase() -> impl Strategy<Value = Phase> {
    prop_oneof![
        Just(Phase::Waiting),
        Just(Phase::FastSeek),
        Just(Phase::BackOff),
        Just(Phase::SlowSeek),
        Just(Phase::Release),
        Just(Phase::Settle),
    ]
}

fn hardware() -> impl Strategy<Value = HardwareFault> {
    prop_oneof![
        Just(HardwareFault::TickOverrun),
        (0u8..6).prop_map(|axis| HardwareFault::Driver { axis }),
        any::<u8>().prop_map(HardwareFault::SelfTest),
    ]
}

fn encoder_fault() -> impl Strategy<Value = EncoderFault> {
    prop_oneof![3 => Just(EncoderFault::Lost), 1 => (4096u16..=u16::MAX).prop_map(EncoderFault::OutOfRange)]
}

/// The random steps.
pub fn step_strategy(mix: Mix) -> BoxedStrategy<Step> {
    let common = prop_oneof![
        40 => (fractions(), velocities(), 8u32..=40, 1u32..=40)
            .prop_map(|(goal, vel, period, count)| Step::Stream { goal, vel, period, count }),
        4 => (axis(), bad(), 0u32..=20).prop_map(|(axis, bad, idle)| Step::BadMotion { axis, bad, idle }),
        8 => prop_oneof![1..=60u32, 90u32..=110, 150u32..=400].prop_map(Step::Silence),
        8 => (fractions(), prop_oneof![0u32..=50, 300u32..=2500])
            .prop_map(|(goal, wait)| Step::GoTo { goal, wait }),
        3 => prop_oneof![1u32..=20, 100u32..=400].prop_map(Step::LinkLoss),
        2 => (axis(), encoder_fault(), 1u32..=6).prop_map(|(axis, fault, ticks)| Step::EncoderLoss { axis, fault, ticks }),
        2 => (any::<u8>(), 1u32..=30).prop_map(|(m, ticks)| Step::LimitHit { mask: m & 0b11_1111, ticks }),
        1 => (hardware(), 1u32..=3).prop_map(|(fault, ticks)| Step::Hardware { fault, ticks }),
        10 => (0u32..=50).prop_map(Step::Enable),
        2 => prop_oneof![0u32..=200, 1000u32..=3000].prop_map(Step::Home),
        2 => (0u8..8, 0u32..=200).prop_map(|(j, n)| Step::HomeJoint(j, n)),
        3 => Just(Step::WaitHoming),
        2 => Just(Step::ReturnInside),
        3 => (axis(), homing_phase(), prop_oneof![1u32..=20, 100u32..=400])
            .prop_map(|(axis, phase, ticks)| Step::HomeLinkLoss { axis, phase, ticks }),
        2 => (axis(), 1u32..=3, 1u32..=2, 3u32..=400)
            .prop_map(|(axis, closed, open, ticks)| Step::Chatter { axis, closed, open, ticks }),
        1 => (axis(), 100u32..=3000).prop_map(|(axis, ticks)| Step::PressedHome { axis, ticks }),
        2 => (fractions(), 2u32..=20, 0u32..=300).prop_map(|(goal, count, idle)| Step::Burst { goal, count, idle }),
    ];
    match mix {
        Mix::Discrete => common.boxed(),
        Mix::Full => prop_oneof![
            76 => common,
            2 => (axis(), -2048i32..=2047, 1u32..=6).prop_map(|(axis, delta, ticks)| Step::Glitch { axis, delta, ticks }),
            1 => (axis(), -2048i32..=2047).prop_map(|(axis, counts)| Step::Slip { axis, counts }),
            3 => (axis(), prop_oneof![-12.0..12.0f64, -1.0..1.0f64], 1u32..=400)
                .prop_map(|(axis, velocity, ticks)| Step::Disturb { axis, velocity, ticks }),
            3 => (axis(), any::<bool>(), prop_oneof![1u32..=30, 100u32..=1500])
                .prop_map(|(axis, reversed, ticks)| Step::BrokenMotor { axis, reversed, ticks }),
            1 => axis().prop_map(|axis| Step::DeadSwitchHome { axis }),
        ]
        .boxed(),
    }
}

/// Initial states: mostly the homed snapshot, sometimes a power-on anywhere
/// in the joint ranges with random encoder offsets.
pub fn start_strategy() -> BoxedStrategy<Start> {
    let r = |i: usize| {
        let (lo, hi) = range(i);
        lo..hi
    };
    let q = [r(0), r(1), r(2), r(3), r(4), r(5)];
    let off = [
        0.0..std::f64::consts::TAU,
        0.0..std::f64::consts::TAU,
        0.0..std::f64::consts::TAU,
        0.0..std::f64::consts::TAU,
        0.0..std::f64::consts::TAU,
        0.0..std::f64::consts::TAU,
    ];
    // Sometimes one joint rests past its homing switch at power-on (the
    // pose a crashed host leaves): the switch is its homing input.
    let past = |i: usize| {
        let h = &kernel::config::PAROL6.joints[i].homing;
        f64::from(h.switch_position) + f64::from(h.direction.sign()) * 0.03
    };
    prop_oneof![
        4 => Just(Start::Homed),
        2 => (q.clone(), off.clone(), proptest::option::weighted(0.5, (0..AXES, 1u64..=120)))
            .prop_map(|(q, offset, boot_lost)| Start::Fresh { q, offset, boot_lost }),
        1 => (q, off, axis()).prop_map(move |(mut q, offset, j)| {
            q[j] = past(j);
            Start::Fresh { q, offset, boot_lost: None }
        }),
    ]
    .boxed()
}
