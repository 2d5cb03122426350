//! Configuration validation (`kernel::config::check`): every clause rejects
//! a configuration that breaks it, and only that clause. Each case starts
//! from the shipped `PAROL6` (which passes), changes one value so exactly
//! one rule is broken, and requires `check` to name that rule: a clause
//! that stopped rejecting, or a value that breaks an earlier rule first,
//! fails the test. Where a rule is a conjunction, each operand that can
//! fail on its own has its own case (the two ends of a range, NaN, ...).
//! The shipped configuration is checked by the compiler (`assert_valid` in
//! a constant); these cases are the inconsistent ones a firmware that
//! defines its own configuration could write.

use kernel::config::{check, ArmConfig, Direction, JointConfig, Validated, AXES, PAROL6};

/// One case: what to break, and the message `check` must return.
struct Case {
    what: &'static str,
    edit: fn(&mut ArmConfig),
    expect: &'static str,
}

fn j(c: &mut ArmConfig, i: usize) -> &mut JointConfig {
    c.joints.get_mut(i).expect("joint index in range")
}

const TICK: &str = "tick_hz must be within 100..=10000";
const ALPHA: &str = "observer alpha (position gain / tick_hz) must be in (0, 1)";
const BETA: &str = "observer beta must be in (0, alpha^2/(2-alpha)] (stable, not oscillatory)";
const DEADBAND: &str = "deadband must be >= 0";
const TIMEOUT: &str = "command timeout and soft-stop ramp must be > 0";
const BUDGET: &str = "command timeout + soft-stop ramp exceed the stop budget";
const RAMP: &str = "soft-stop ramp too long";
const SEGMENTS: &str = "segment lengths must satisfy 1 <= min <= max <= MAX_SEGMENT_TICKS ticks";
const SEGMENT_TIMEOUT: &str = "the longest segment must be shorter than the command timeout";
const BOOT: &str = "boot timeout must allow at least two ticks";
const INVALID: &str = "encoder_invalid_limit above 10 samples: coasting that long is not safe";
const MARGIN: &str = "position margin must be in [0, 1) rad";
const FE: &str = "following error must be in (0, position_margin)";
const FE_TIME: &str = "following error time must be at least two ticks and at most 200 ms";
const SETTLE: &str = "homing settle time above 1 s";
const JUMP: &str = "target jump tolerance must be in [0, 0.1] rad";
const HOMING_TIME: &str = "homing can take longer than the driver waits (sum of group timeouts > homing_budget_ms)";
const HOMING_90: &str = "homing budget above the ROS 2 driver's 90 s wait";
const GEAR: &str = "gear ratio must be in (0, 1000)";
const MICRO: &str = "microsteps must be a power of two <= 256, full steps > 0";
const VMAX: &str = "max velocity must be in (0, 16] rad/s";
const STEPS_RAD: &str = "steps per rad must stay below 32000 (fixed-point step-rate scale)";
const STEP_RATE: &str = "max velocity not reachable within the step-rate limit";
const RUNAWAY: &str = "runaway threshold must be at least 10 % above the command clamp";
const RUNAWAY_HIGH: &str = "runaway threshold absurdly high";
const WINDOW: &str = "encoder plausibility window too wide to unwrap unambiguously";
const ACCEL: &str = "max acceleration must be in (0, 200] rad/s^2";
const SOFT_DECEL: &str = "soft-stop ramp decelerates faster than max_acceleration";
const OVERRUN: &str = "stopping overrun (a T^2 / 8 + following error) exceeds position_margin";
const KP: &str = "Kp must be > 0 and Kp * dt <= 0.5 (discrete loop stable, not oscillatory)";
const LIMITS: &str = "joint limits must be finite and ordered";
const LIMITS_RANGE: &str = "joint limits beyond the plausible range";
const DEADBAND_V: &str = "deadband at or above a joint's max velocity";
const SPEEDS: &str = "homing speeds must satisfy 0 < slow <= fast";
const FAST: &str = "homing fast speed above the joint's max velocity";
const TRAVEL: &str = "homing max_travel must be within [range + switch distance, + 0.25 rad]";
const BACKOFF: &str = "homing back-off must be in (0, 0.5) rad";
const SWITCH: &str = "homing switch position outside limits + margin";
const LANDING: &str = "homing release does not end inside the joint limits";
const HOMING_TIMEOUT: &str = "homing timeout shorter than 1.2x the nominal homing time: homing is impossible";

fn cases() -> Vec<Case> {
    vec![
        // ---- the arm ----
        Case { what: "tick rate below 100 Hz", edit: |c| c.tick_hz = 99, expect: TICK },
        Case { what: "tick rate above 10 kHz", edit: |c| c.tick_hz = 10_001, expect: TICK },
        Case { what: "observer alpha NaN", edit: |c| c.observer_position_gain = f32::NAN, expect: ALPHA },
        Case { what: "observer alpha 0", edit: |c| c.observer_position_gain = 0.0, expect: ALPHA },
        Case { what: "observer alpha 1", edit: |c| c.observer_position_gain = 1000.0, expect: ALPHA },
        Case { what: "observer beta NaN", edit: |c| c.observer_velocity_gain = f32::NAN, expect: BETA },
        Case { what: "observer beta 0", edit: |c| c.observer_velocity_gain = 0.0, expect: BETA },
        Case { what: "observer beta oscillatory", edit: |c| c.observer_velocity_gain = 6000.0, expect: BETA },
        Case { what: "deadband NaN", edit: |c| c.deadband = f32::NAN, expect: DEADBAND },
        Case { what: "deadband negative", edit: |c| c.deadband = -0.001, expect: DEADBAND },
        Case { what: "command timeout 0", edit: |c| c.command_timeout_ms = 0, expect: TIMEOUT },
        Case { what: "soft-stop ramp 0", edit: |c| c.soft_stop_ms = 0, expect: TIMEOUT },
        Case { what: "timeout + ramp over the stop budget", edit: |c| c.stop_budget_ms = 199, expect: BUDGET },
        Case {
            what: "soft-stop ramp over 100,000 ticks",
            edit: |c| {
                c.soft_stop_ms = 100_001;
                c.stop_budget_ms = 200_000;
            },
            expect: RAMP,
        },
        Case { what: "shortest segment 0 ticks", edit: |c| c.segment_min_ms = 0, expect: SEGMENTS },
        Case { what: "shortest segment above the longest", edit: |c| c.segment_min_ms = 41, expect: SEGMENTS },
        Case {
            what: "longest segment above MAX_SEGMENT_TICKS",
            edit: |c| {
                c.segment_max_ms = 257;
                c.command_timeout_ms = 300;
                c.stop_budget_ms = 400;
            },
            expect: SEGMENTS,
        },
        Case {
            what: "longest segment as long as the timeout",
            edit: |c| c.segment_max_ms = 100,
            expect: SEGMENT_TIMEOUT,
        },
        Case { what: "boot timeout of one tick", edit: |c| c.boot_timeout_ms = 1, expect: BOOT },
        Case { what: "coasting over 11 invalid samples", edit: |c| c.encoder_invalid_limit = 11, expect: INVALID },
        Case { what: "position margin NaN", edit: |c| c.position_margin = f32::NAN, expect: MARGIN },
        Case { what: "position margin negative", edit: |c| c.position_margin = -0.1, expect: MARGIN },
        Case { what: "position margin 1 rad", edit: |c| c.position_margin = 1.0, expect: MARGIN },
        Case { what: "following error NaN", edit: |c| c.following_error = f32::NAN, expect: FE },
        Case { what: "following error 0", edit: |c| c.following_error = 0.0, expect: FE },
        Case { what: "following error at the margin", edit: |c| c.following_error = 0.15, expect: FE },
        Case { what: "following error time of one tick", edit: |c| c.following_error_ms = 1, expect: FE_TIME },
        Case { what: "following error time over 200 ms", edit: |c| c.following_error_ms = 201, expect: FE_TIME },
        Case { what: "homing settle over 1 s", edit: |c| c.homing_settle_ms = 1001, expect: SETTLE },
        Case { what: "jump tolerance NaN", edit: |c| c.target_jump_tolerance = f32::NAN, expect: JUMP },
        Case { what: "jump tolerance negative", edit: |c| c.target_jump_tolerance = -0.01, expect: JUMP },
        Case { what: "jump tolerance over 0.1 rad", edit: |c| c.target_jump_tolerance = 0.11, expect: JUMP },
        Case { what: "homing longer than its budget", edit: |c| c.homing_budget_ms = 30_000, expect: HOMING_TIME },
        Case { what: "homing budget over 90 s", edit: |c| c.homing_budget_ms = 90_001, expect: HOMING_90 },
        // ---- a joint (J1 unless stated) ----
        Case { what: "gear ratio NaN", edit: |c| j(c, 0).gear_ratio = f32::NAN, expect: GEAR },
        Case { what: "gear ratio 0", edit: |c| j(c, 0).gear_ratio = 0.0, expect: GEAR },
        Case { what: "gear ratio 1000", edit: |c| j(c, 0).gear_ratio = 1000.0, expect: GEAR },
        Case { what: "full steps 0", edit: |c| j(c, 0).full_steps_per_rev = 0, expect: MICRO },
        Case { what: "microsteps not a power of two", edit: |c| j(c, 0).microsteps = 24, expect: MICRO },
        Case { what: "microsteps 512", edit: |c| j(c, 0).microsteps = 512, expect: MICRO },
        Case { what: "max velocity NaN", edit: |c| j(c, 0).max_velocity = f32::NAN, expect: VMAX },
        Case { what: "max velocity 0", edit: |c| j(c, 0).max_velocity = 0.0, expect: VMAX },
        Case { what: "max velocity over 16 rad/s", edit: |c| j(c, 0).max_velocity = 16.5, expect: VMAX },
        Case {
            what: "32,000 steps per rad or more",
            edit: |c| {
                j(c, 0).gear_ratio = 700.0;
                j(c, 0).max_velocity = 0.01;
            },
            expect: STEPS_RAD,
        },
        Case { what: "max velocity beyond the step rate", edit: |c| c.max_step_rate = 30_000, expect: STEP_RATE },
        Case { what: "runaway threshold NaN", edit: |c| j(c, 0).runaway_velocity = f32::NAN, expect: RUNAWAY },
        Case { what: "runaway threshold at the clamp", edit: |c| j(c, 0).runaway_velocity = 3.0, expect: RUNAWAY },
        Case {
            what: "runaway threshold over 32 rad/s",
            edit: |c| j(c, 0).runaway_velocity = 33.0,
            expect: RUNAWAY_HIGH,
        },
        Case { what: "plausibility window too wide", edit: |c| j(c, 0).runaway_velocity = 31.0, expect: WINDOW },
        Case { what: "max acceleration NaN", edit: |c| j(c, 0).max_acceleration = f32::NAN, expect: ACCEL },
        Case { what: "max acceleration 0", edit: |c| j(c, 0).max_acceleration = 0.0, expect: ACCEL },
        Case { what: "max acceleration over 200", edit: |c| j(c, 0).max_acceleration = 201.0, expect: ACCEL },
        Case {
            what: "soft stop faster than max acceleration",
            edit: |c| j(c, 0).max_acceleration = 20.0,
            expect: SOFT_DECEL,
        },
        Case {
            what: "stop overrun over the position margin",
            edit: |c| {
                c.soft_stop_ms = 200;
                c.stop_budget_ms = 300;
            },
            expect: OVERRUN,
        },
        Case { what: "Kp NaN", edit: |c| j(c, 0).kp = f32::NAN, expect: KP },
        Case { what: "Kp 0", edit: |c| j(c, 0).kp = 0.0, expect: KP },
        Case { what: "Kp dt over 0.5", edit: |c| j(c, 0).kp = 501.0, expect: KP },
        Case { what: "lower limit NaN", edit: |c| j(c, 0).limit_min = f32::NAN, expect: LIMITS },
        Case { what: "upper limit NaN", edit: |c| j(c, 0).limit_max = f32::NAN, expect: LIMITS },
        Case { what: "limits unordered", edit: |c| j(c, 0).limit_max = -1.7, expect: LIMITS },
        Case {
            what: "lower limit beyond the plausible range",
            edit: |c| j(c, 0).limit_min = -30.5,
            expect: LIMITS_RANGE,
        },
        Case {
            what: "upper limit beyond the plausible range",
            edit: |c| j(c, 0).limit_max = 30.5,
            expect: LIMITS_RANGE,
        },
        Case { what: "deadband at a joint's max velocity", edit: |c| c.deadband = 3.0, expect: DEADBAND_V },
        Case { what: "homing fast speed NaN", edit: |c| j(c, 0).homing.fast_speed = f32::NAN, expect: SPEEDS },
        Case { what: "homing slow speed NaN", edit: |c| j(c, 0).homing.slow_speed = f32::NAN, expect: SPEEDS },
        Case { what: "homing slow speed 0", edit: |c| j(c, 0).homing.slow_speed = 0.0, expect: SPEEDS },
        Case { what: "homing slow above fast", edit: |c| j(c, 0).homing.slow_speed = 0.6, expect: SPEEDS },
        Case { what: "homing fast above max velocity", edit: |c| j(c, 0).homing.fast_speed = 3.5, expect: FAST },
        Case { what: "homing max travel NaN", edit: |c| j(c, 0).homing.max_travel = f32::NAN, expect: TRAVEL },
        Case { what: "homing max travel short", edit: |c| j(c, 0).homing.max_travel = 3.0, expect: TRAVEL },
        Case { what: "homing max travel long", edit: |c| j(c, 0).homing.max_travel = 4.0, expect: TRAVEL },
        Case { what: "homing back-off NaN", edit: |c| j(c, 0).homing.backoff = f32::NAN, expect: BACKOFF },
        Case { what: "homing back-off 0", edit: |c| j(c, 0).homing.backoff = 0.0, expect: BACKOFF },
        Case { what: "homing back-off 0.5 rad", edit: |c| j(c, 0).homing.backoff = 0.5, expect: BACKOFF },
        Case {
            what: "homing switch NaN",
            edit: |c| j(c, 0).homing.switch_position = f32::NAN,
            // NaN is beyond neither limit: `beyond` is 0, so max_travel
            // passes and the switch clause names it.
            expect: SWITCH,
        },
        Case {
            what: "homing switch below limit - margin",
            edit: |c| {
                j(c, 0).homing.switch_position = -1.9;
                j(c, 0).homing.max_travel = 3.6;
            },
            expect: SWITCH,
        },
        Case {
            what: "homing switch above limit + margin (J3, positive seek)",
            edit: |c| {
                j(c, 2).homing.switch_position = 1.5;
                j(c, 2).homing.max_travel = 3.5;
            },
            expect: SWITCH,
        },
        Case {
            what: "homing release below the lower limit (J1 seeks positive)",
            edit: |c| j(c, 0).homing.direction = Direction::Positive,
            expect: LANDING,
        },
        Case {
            what: "homing release above the upper limit (J3 seeks negative)",
            edit: |c| j(c, 2).homing.direction = Direction::Negative,
            expect: LANDING,
        },
        Case { what: "homing timeout too short", edit: |c| j(c, 0).homing.timeout_ms = 2_000, expect: HOMING_TIMEOUT },
    ]
}

#[test]
fn the_shipped_configuration_passes() {
    assert_eq!(check(&PAROL6), Ok(()));
    assert!(Validated::new(PAROL6).is_ok());
}

/// The encoder's jump window (`JointConfig::max_jump_counts`): the counts
/// the runaway speed covers in a tick plus two encoder frames, rounded up
/// to a whole count, plus the slack. A whole count is not rounded up (no
/// motion at all: the slack alone); the least motion is one count more;
/// the shipped joints' windows exceed the slack. Catches: the rounding
/// adding a count to a whole number, or none to a fraction.
#[test]
fn the_jump_window_rounds_a_fraction_up_and_keeps_a_whole_count() {
    use kernel::config::JUMP_SLACK_COUNTS;
    let j = PAROL6.joints[0];
    let hz = PAROL6.tick_hz;
    assert_eq!(JointConfig { runaway_velocity: 0.0, ..j }.max_jump_counts(hz), JUMP_SLACK_COUNTS);
    assert_eq!(JointConfig { runaway_velocity: 1e-6, ..j }.max_jump_counts(hz), JUMP_SLACK_COUNTS + 1);
    for j in PAROL6.joints {
        assert!(j.max_jump_counts(hz) > JUMP_SLACK_COUNTS + 1, "{j:?}");
    }
}

/// `assert_valid` (what a firmware's configuration constant calls, so an
/// inconsistent one fails the build) accepts the shipped configuration at
/// run time too.
#[test]
fn assert_valid_accepts_the_shipped_configuration() {
    kernel::config::assert_valid(&PAROL6);
}

/// `assert_valid` stops with the first broken rule's message: a tick rate
/// out of range, evaluated at run time. Catches: an `assert_valid` that
/// does not act on `check`'s verdict.
#[test]
#[should_panic(expected = "tick_hz must be within 100..=10000")]
fn assert_valid_stops_on_an_inconsistent_configuration() {
    kernel::config::assert_valid(&ArmConfig { tick_hz: 50, ..PAROL6 });
}

#[test]
fn every_clause_rejects_a_configuration_that_breaks_it() {
    let mut wrong = Vec::new();
    for case in cases() {
        let mut c = PAROL6;
        (case.edit)(&mut c);
        let got = check(&c);
        if got != Err(case.expect) {
            wrong.push(format!("{}: expected Err({:?}), got {:?}", case.what, case.expect, got));
        }
        // The checked constructor refuses it too.
        if Validated::new(c).is_ok() {
            wrong.push(format!("{}: Validated::new accepted it", case.what));
        }
    }
    assert!(wrong.is_empty(), "{} case(s) wrong:\n{}", wrong.len(), wrong.join("\n"));
}

#[test]
fn every_rule_has_a_case() {
    // Every message `check` can return appears in a case: a rule added to
    // `check` without a case here fails (the list below is the one the
    // cases use; `all_messages_are_distinct` keeps them apart).
    let all = [
        TICK,
        ALPHA,
        BETA,
        DEADBAND,
        TIMEOUT,
        BUDGET,
        RAMP,
        SEGMENTS,
        SEGMENT_TIMEOUT,
        BOOT,
        INVALID,
        MARGIN,
        FE,
        FE_TIME,
        SETTLE,
        JUMP,
        HOMING_TIME,
        HOMING_90,
        GEAR,
        MICRO,
        VMAX,
        STEPS_RAD,
        STEP_RATE,
        RUNAWAY,
        RUNAWAY_HIGH,
        WINDOW,
        ACCEL,
        SOFT_DECEL,
        OVERRUN,
        KP,
        LIMITS,
        LIMITS_RANGE,
        DEADBAND_V,
        SPEEDS,
        FAST,
        TRAVEL,
        BACKOFF,
        SWITCH,
        LANDING,
        HOMING_TIMEOUT,
    ];
    let used: Vec<&str> = cases().iter().map(|c| c.expect).collect();
    for m in all {
        assert!(used.contains(&m), "no case for {m:?}");
    }
    let mut sorted = all.to_vec();
    sorted.sort_unstable();
    sorted.dedup();
    assert_eq!(sorted.len(), all.len(), "two rules share a message");
    // The kernel's source names exactly these messages: count them.
    let src = include_str!("../src/config.rs");
    let in_source = src.matches("return Err(\"").count();
    assert_eq!(in_source, all.len(), "config.rs has {in_source} Err messages, the cases know {}", all.len());
}

#[test]
fn every_joint_is_checked() {
    // The joint loop visits all six joints: breaking each joint alone is
    // rejected with the joint rule's message.
    for i in 0..AXES {
        let mut c = PAROL6;
        j(&mut c, i).kp = 0.0;
        assert_eq!(check(&c), Err(KP), "J{} not checked", i + 1);
    }
}
