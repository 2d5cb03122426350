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
        // ---- an infinity, where the range test alone would let it through ----
        Case { what: "deadband +inf", edit: |c| c.deadband = f32::INFINITY, expect: DEADBAND },
        Case { what: "runaway threshold +inf", edit: |c| j(c, 0).runaway_velocity = f32::INFINITY, expect: RUNAWAY },
        Case { what: "lower limit -inf", edit: |c| j(c, 0).limit_min = f32::NEG_INFINITY, expect: LIMITS },
        Case { what: "upper limit +inf", edit: |c| j(c, 0).limit_max = f32::INFINITY, expect: LIMITS },
        Case { what: "homing fast speed +inf", edit: |c| j(c, 0).homing.fast_speed = f32::INFINITY, expect: SPEEDS },
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

/// One bound of a rule: a configuration exactly on it, and one just past
/// it. `check` names the first broken rule, so the configuration on the
/// bound must pass the rule under test: `at_expect` is `Ok` or the message
/// of a rule `check` tests after it (named where the bound breaks a later
/// rule); the one past it must be refused by the rule itself. A bound whose
/// strictness changed (`<` for `<=`, `>` for `>=`) fails one of the two.
struct Edge {
    what: &'static str,
    at: fn(&mut ArmConfig),
    at_expect: Result<(), &'static str>,
    past: fn(&mut ArmConfig),
    past_expect: &'static str,
}

/// The fast seek's travel bound of joint `i` as the rule states it: the
/// range plus the switch's distance beyond the limit it lies past (f32,
/// in the rule's order of operations).
fn travel_need(c: &ArmConfig, i: usize) -> f32 {
    let jc = c.joints[i];
    let s = jc.homing.switch_position;
    let beyond = if s > jc.limit_max {
        s - jc.limit_max
    } else if s < jc.limit_min {
        jc.limit_min - s
    } else {
        0.0
    };
    jc.limit_max - jc.limit_min + beyond
}

/// Where joint `i`'s homing release ends, as the rule states it: the
/// switch, then back against the seek direction by the back-off and the
/// braking distance from the fast speed, `v^2 / 2a`.
fn landing(c: &ArmConfig, i: usize) -> f32 {
    let jc = c.joints[i];
    let h = jc.homing;
    let sign = match h.direction {
        Direction::Positive => 1.0,
        Direction::Negative => -1.0,
    };
    h.switch_position - sign * (h.backoff + h.fast_speed * h.fast_speed / (2.0 * jc.max_acceleration))
}

/// J1 with its upper limit at `limit` (below the switch's side, J1 seeks
/// negative) and its fast-seek travel re-sized to the new range.
fn j1_upper_limit(c: &mut ArmConfig, limit: f32) {
    j(c, 0).limit_max = limit;
    j(c, 0).homing.max_travel = travel_need(c, 0) + 0.1;
}

/// J3 (seeks positive) with its lower limit at `limit`, travel re-sized.
fn j3_lower_limit(c: &mut ArmConfig, limit: f32) {
    j(c, 2).limit_min = limit;
    j(c, 2).homing.max_travel = travel_need(c, 2) + 0.1;
}

/// J1 with a slow seek as fast as its fast seek (0.5 rad/s) and
/// 50 rad/s^2: its nominal homing time is 3.4 / 0.5 + 4 x 0.05 / 0.5 +
/// 2 x 0.05 / 0.5 + 4 x 0.5 / 50 = 7.44 s, plus the 50 ms settle:
/// 7 490 ms, and 1.2 times that is 8 988 ms (both exact in f32).
fn j1_homing_8988(c: &mut ArmConfig) {
    j(c, 0).homing.slow_speed = 0.5;
    j(c, 0).max_acceleration = 50.0;
}

/// The acceleration at which J1's soft-stop rule is an equality in f32:
/// `3 rad/s x 1000 = a x 100 ms x 1.0001`.
const J1_SOFT_STOP_EDGE: f32 = 29.997;

/// J1 rebuilt so that its clamp needs a whole number of steps per second
/// exactly (in the f64 arithmetic of the step-rate rule): 1 405 497 235
/// full steps, one microstep, a gear of 0x3901a640 (about 1.236e-4) give
/// exactly 27 658 steps per rad, and 4 rad/s of it exactly 110 632 steps/s
/// (the other joints need at most J3's 110 590). A step rate limit of
/// exactly that is the rule's bound. (Acceleration 40 rad/s^2 so the soft
/// stop can stop 4 rad/s in 100 ms; runaway at 1.25 x the clamp.)
fn j1_exact_step_rate(c: &mut ArmConfig) {
    let jc = j(c, 0);
    jc.full_steps_per_rev = J1_EXACT_FULL_STEPS;
    jc.microsteps = 1;
    jc.gear_ratio = f32::from_bits(J1_EXACT_GEAR_BITS);
    jc.max_velocity = 4.0;
    jc.runaway_velocity = 5.0;
    jc.max_acceleration = 40.0;
}

const J1_EXACT_FULL_STEPS: u32 = 1_405_497_235;
const J1_EXACT_GEAR_BITS: u32 = 0x3901_a640;
const J1_EXACT_STEP_RATE: u32 = 110_632;

fn edges() -> Vec<Edge> {
    vec![
        // ---- the arm ----
        Edge {
            what: "tick rate 100 Hz (observer gains scaled to alpha 0.1, beta 0.005)",
            at: |c| {
                c.tick_hz = 100;
                c.observer_position_gain = 10.0;
                c.observer_velocity_gain = 50.0;
            },
            // At 100 Hz a tick of J3's runaway motion spans more than a
            // quarter turn of its encoder: the next rule that can refuse.
            at_expect: Err(WINDOW),
            past: |c| {
                c.tick_hz = 99;
                c.observer_position_gain = 9.9;
                c.observer_velocity_gain = 49.0;
            },
            past_expect: TICK,
        },
        Edge {
            what: "tick rate 10 kHz (gains scaled, longest segment 25 ms = 250 ticks)",
            at: |c| {
                c.tick_hz = 10_000;
                c.observer_position_gain = 1000.0;
                c.observer_velocity_gain = 500_000.0;
                c.segment_max_ms = 25;
            },
            at_expect: Ok(()),
            past: |c| {
                c.tick_hz = 10_001;
                c.observer_position_gain = 1000.0;
                c.observer_velocity_gain = 500_000.0;
                c.segment_max_ms = 25;
            },
            past_expect: TICK,
        },
        Edge {
            what: "observer beta 0.05 % above alpha^2 / (2 - alpha) (within the 0.1 % rounding allowance)",
            at: |c| c.observer_velocity_gain = 0.01 / 1.9 * 1.0005 * 1e6,
            at_expect: Ok(()),
            past: |c| c.observer_velocity_gain = 0.01 / 1.9 * 1.002 * 1e6,
            past_expect: BETA,
        },
        Edge {
            what: "soft-stop ramp of 100,000 ticks",
            at: |c| {
                c.soft_stop_ms = 100_000;
                c.stop_budget_ms = 200_000;
            },
            // A 100 s ramp lets a stop overrun by far more than the margin.
            at_expect: Err(OVERRUN),
            past: |c| {
                c.soft_stop_ms = 100_001;
                c.stop_budget_ms = 200_000;
            },
            past_expect: RAMP,
        },
        Edge {
            what: "shortest segment of one tick",
            at: |c| c.segment_min_ms = 1,
            at_expect: Ok(()),
            past: |c| c.segment_min_ms = 0,
            past_expect: SEGMENTS,
        },
        Edge {
            what: "shortest segment equal to the longest (40 ms)",
            at: |c| c.segment_min_ms = 40,
            at_expect: Ok(()),
            past: |c| c.segment_min_ms = 41,
            past_expect: SEGMENTS,
        },
        Edge {
            what: "longest segment of MAX_SEGMENT_TICKS (256 ms at 1 kHz)",
            at: |c| {
                c.segment_max_ms = 256;
                c.command_timeout_ms = 300;
                c.stop_budget_ms = 400;
            },
            at_expect: Ok(()),
            past: |c| {
                c.segment_max_ms = 257;
                c.command_timeout_ms = 300;
                c.stop_budget_ms = 400;
            },
            past_expect: SEGMENTS,
        },
        Edge {
            what: "boot timeout of two ticks",
            at: |c| c.boot_timeout_ms = 2,
            at_expect: Ok(()),
            past: |c| c.boot_timeout_ms = 1,
            past_expect: BOOT,
        },
        Edge {
            what: "coasting over 10 invalid samples",
            at: |c| c.encoder_invalid_limit = 10,
            // J3's window times 11 exceeds a quarter turn: the joint rule.
            at_expect: Err(WINDOW),
            past: |c| c.encoder_invalid_limit = 11,
            past_expect: INVALID,
        },
        Edge {
            what: "following error time of two ticks",
            at: |c| c.following_error_ms = 2,
            at_expect: Ok(()),
            past: |c| c.following_error_ms = 1,
            past_expect: FE_TIME,
        },
        Edge {
            what: "following error time of 200 ms",
            at: |c| c.following_error_ms = 200,
            at_expect: Ok(()),
            past: |c| c.following_error_ms = 201,
            past_expect: FE_TIME,
        },
        Edge {
            what: "homing settle time of 1 s (every homing timeout 20 s)",
            at: |c| {
                c.homing_settle_ms = 1000;
                c.joints.iter_mut().for_each(|jc| jc.homing.timeout_ms = 20_000);
            },
            at_expect: Ok(()),
            past: |c| {
                c.homing_settle_ms = 1001;
                c.joints.iter_mut().for_each(|jc| jc.homing.timeout_ms = 20_000);
            },
            past_expect: SETTLE,
        },
        Edge {
            // The groups' slowest joints: J6 12 s; J4, J5 10 s; J1-J3 12 s;
            // plus the 50 ms settle: 34 050 ms.
            what: "homing budget equal to the sum of the groups' slowest timeouts plus the settle",
            at: |c| c.homing_budget_ms = 34_050,
            at_expect: Ok(()),
            past: |c| c.homing_budget_ms = 34_049,
            past_expect: HOMING_TIME,
        },
        Edge {
            what: "homing budget of 90 s",
            at: |c| c.homing_budget_ms = 90_000,
            at_expect: Ok(()),
            past: |c| c.homing_budget_ms = 90_001,
            past_expect: HOMING_90,
        },
        // ---- a joint (J1 unless stated) ----
        Edge {
            what: "256 microsteps (gear 1, so steps per rad stay below 32 000)",
            at: |c| {
                j(c, 0).gear_ratio = 1.0;
                j(c, 0).microsteps = 256;
            },
            at_expect: Ok(()),
            past: |c| {
                j(c, 0).gear_ratio = 1.0;
                j(c, 0).microsteps = 512;
            },
            past_expect: MICRO,
        },
        Edge {
            what: "step rate limit exactly what the clamp needs (110 632 steps/s, J1 rebuilt)",
            at: |c| {
                j1_exact_step_rate(c);
                c.max_step_rate = J1_EXACT_STEP_RATE;
            },
            at_expect: Ok(()),
            past: |c| {
                j1_exact_step_rate(c);
                c.max_step_rate = J1_EXACT_STEP_RATE - 1;
            },
            past_expect: STEP_RATE,
        },
        Edge {
            what: "runaway threshold of 32 rad/s (gear 1, so the encoder window stays narrow)",
            at: |c| {
                j(c, 0).gear_ratio = 1.0;
                j(c, 0).runaway_velocity = 32.0;
            },
            at_expect: Ok(()),
            past: |c| {
                j(c, 0).gear_ratio = 1.0;
                j(c, 0).runaway_velocity = 32.0f32.next_up();
            },
            past_expect: RUNAWAY_HIGH,
        },
        Edge {
            what: "soft-stop ramp decelerating exactly at max acceleration (times the 1.0001 allowance)",
            at: |c| j(c, 0).max_acceleration = J1_SOFT_STOP_EDGE,
            at_expect: Ok(()),
            past: |c| j(c, 0).max_acceleration = J1_SOFT_STOP_EDGE.next_down(),
            past_expect: SOFT_DECEL,
        },
        Edge {
            what: "lower limit at -(POSITION_ABS_MAX - 2) = -30 rad",
            at: |c| j(c, 0).limit_min = -30.0,
            // The range is now 31.7 rad: the fast seek's travel bound no
            // longer covers it, the next rule.
            at_expect: Err(TRAVEL),
            past: |c| j(c, 0).limit_min = (-30.0f32).next_down(),
            past_expect: LIMITS_RANGE,
        },
        Edge {
            what: "upper limit at POSITION_ABS_MAX - 2 = 30 rad",
            at: |c| j(c, 0).limit_max = 30.0,
            at_expect: Err(TRAVEL),
            past: |c| j(c, 0).limit_max = 30.0f32.next_up(),
            past_expect: LIMITS_RANGE,
        },
        Edge {
            what: "homing fast speed equal to max velocity (3 rad/s)",
            at: |c| j(c, 0).homing.fast_speed = 3.0,
            at_expect: Ok(()),
            past: |c| j(c, 0).homing.fast_speed = 3.0f32.next_up(),
            past_expect: FAST,
        },
        Edge {
            what: "fast-seek travel exactly range + switch distance (J1, switch below the lower limit)",
            at: |c| j(c, 0).homing.max_travel = travel_need(c, 0),
            at_expect: Ok(()),
            past: |c| j(c, 0).homing.max_travel = travel_need(c, 0).next_down(),
            past_expect: TRAVEL,
        },
        Edge {
            what: "fast-seek travel exactly range + switch distance + 0.25 rad (J1)",
            at: |c| j(c, 0).homing.max_travel = travel_need(c, 0) + 0.25,
            at_expect: Ok(()),
            past: |c| j(c, 0).homing.max_travel = (travel_need(c, 0) + 0.25).next_up(),
            past_expect: TRAVEL,
        },
        Edge {
            what: "fast-seek travel exactly range + switch distance (J3, switch above the upper limit)",
            at: |c| j(c, 2).homing.max_travel = travel_need(c, 2),
            at_expect: Ok(()),
            past: |c| j(c, 2).homing.max_travel = travel_need(c, 2).next_down(),
            past_expect: TRAVEL,
        },
        Edge {
            what: "fast-seek travel exactly range + switch distance + 0.25 rad (J3)",
            at: |c| j(c, 2).homing.max_travel = travel_need(c, 2) + 0.25,
            at_expect: Ok(()),
            past: |c| j(c, 2).homing.max_travel = (travel_need(c, 2) + 0.25).next_up(),
            past_expect: TRAVEL,
        },
        Edge {
            what: "homing release ending exactly on the upper limit (J1 seeks negative)",
            at: |c| j1_upper_limit(c, landing(c, 0)),
            at_expect: Ok(()),
            past: |c| j1_upper_limit(c, landing(c, 0).next_down()),
            past_expect: LANDING,
        },
        Edge {
            what: "homing release ending exactly on the lower limit (J3 seeks positive)",
            at: |c| j3_lower_limit(c, landing(c, 2)),
            at_expect: Ok(()),
            past: |c| j3_lower_limit(c, landing(c, 2).next_up()),
            past_expect: LANDING,
        },
        Edge {
            what: "homing timeout exactly 1.2 x the nominal homing time (8 988 ms)",
            at: |c| {
                j1_homing_8988(c);
                j(c, 0).homing.timeout_ms = 8_988;
            },
            at_expect: Ok(()),
            past: |c| {
                j1_homing_8988(c);
                j(c, 0).homing.timeout_ms = 8_987;
            },
            past_expect: HOMING_TIMEOUT,
        },
    ]
}

/// Every bound `check` enforces, on the bound and just past it (`Edge`).
/// Catches: a bound whose strictness changed, a bound moved (a tolerance
/// divided instead of multiplied, a term's sign), a group's slowest joint
/// taken from the wrong joints in the homing budget.
#[test]
fn every_bound_passes_on_itself_and_refuses_just_past() {
    // The boundary values are exact where the rule compares f32 products.
    assert_eq!(3.0f32 * 1000.0, J1_SOFT_STOP_EDGE * 100.0 * 1.0001);
    let spr = f64::from(J1_EXACT_FULL_STEPS) * f64::from(f32::from_bits(J1_EXACT_GEAR_BITS)) / std::f64::consts::TAU;
    assert_eq!(4.0 * spr, f64::from(J1_EXACT_STEP_RATE));
    let mut wrong = Vec::new();
    for e in edges() {
        let mut c = PAROL6;
        (e.at)(&mut c);
        let got = check(&c);
        if got != e.at_expect {
            wrong.push(format!("{} (on the bound): expected {:?}, got {:?}", e.what, e.at_expect, got));
        }
        let mut c = PAROL6;
        (e.past)(&mut c);
        let got = check(&c);
        if got != Err(e.past_expect) {
            wrong.push(format!("{} (past the bound): expected Err({:?}), got {:?}", e.what, e.past_expect, got));
        }
    }
    assert!(wrong.is_empty(), "{} bound(s) wrong:\n{}", wrong.len(), wrong.join("\n"));
}

/// The homing budget takes each group's slowest joint: with J1 at 20 s
/// (group J1-J3) the sum is 12 + 10 + 20 s plus the 50 ms settle, and
/// J4 at 11 s (group J4, J5) adds one second more. A group that took
/// another group's joints, or every joint, or the last joint instead of the
/// slowest, gives another sum.
#[test]
fn the_homing_budget_sums_each_group_s_slowest_timeout() {
    let mut c = PAROL6;
    j(&mut c, 0).homing.timeout_ms = 20_000;
    c.homing_budget_ms = 42_050;
    assert_eq!(check(&c), Ok(()));
    c.homing_budget_ms = 42_049;
    assert_eq!(check(&c), Err(HOMING_TIME));
    j(&mut c, 3).homing.timeout_ms = 11_000;
    c.homing_budget_ms = 43_050;
    assert_eq!(check(&c), Ok(()));
    c.homing_budget_ms = 43_049;
    assert_eq!(check(&c), Err(HOMING_TIME));
}

/// A joint with stated values, for the derived quantities below.
fn stated_joint(max_acceleration: f32, fast_speed: f32, slow_speed: f32, backoff: f32) -> JointConfig {
    let mut jc = PAROL6.joints[0];
    jc.max_acceleration = max_acceleration;
    jc.homing.fast_speed = fast_speed;
    jc.homing.slow_speed = slow_speed;
    jc.homing.backoff = backoff;
    jc
}

fn close(got: f32, want: f64, tol: f64) -> bool {
    (f64::from(got) - want).abs() <= tol
}

/// `homing_nominal_ms`: the fast seek over the range, back-off and release
/// at the fast speed (four back-offs), the slow seek over two back-offs,
/// four ramps to or from the fast speed (`4 v_fast / a`), plus the settle
/// time. J1's range 3.4 rad, fast 0.5, slow 0.1 rad/s, back-off 0.05 rad,
/// 50 rad/s^2, settle 50 ms: 6.8 + 0.4 + 1.0 + 0.04 s = 8 290 ms. The
/// shipped J1 (slow 0.05 rad/s, 30 rad/s^2): 6.8 + 0.4 + 2.0 + 0.0667 s
/// + 50 ms = 9 316.67 ms.
#[test]
fn the_nominal_homing_time_is_seeks_back_offs_ramps_and_settle() {
    let jc = stated_joint(50.0, 0.5, 0.1, 0.05);
    let want = (3.4 / 0.5 + 4.0 * 0.05 / 0.5 + 2.0 * 0.05 / 0.1 + 4.0 * 0.5 / 50.0) * 1000.0 + 50.0;
    assert!((want - 8290.0f64).abs() < 1e-9);
    let got = jc.homing_nominal_ms(50);
    assert!(close(got, want, 0.01), "{got} ms, expected {want} ms");
    // Without the settle time: 50 ms less.
    let got = jc.homing_nominal_ms(0);
    assert!(close(got, want - 50.0, 0.01), "{got} ms, expected {} ms", want - 50.0);
    let shipped = PAROL6.joints[0];
    let want = (3.4 / 0.5 + 4.0 * 0.05 / 0.5 + 2.0 * 0.05 / 0.05 + 4.0 * 0.5 / 30.0) * 1000.0 + 50.0;
    let got = shipped.homing_nominal_ms(PAROL6.homing_settle_ms);
    assert!(close(got, want, 0.01), "{got} ms, expected {want} ms");
}

/// `braking_distance`: `v^2 / 2a`; at 3 rad/s and 15 rad/s^2, 0.3 rad, in
/// either direction. `setpoint_braking_distance`: the same at the
/// set-points' acceleration, 0.8 a = 12 rad/s^2: 0.375 rad. The shipped
/// J1's fast seek (0.5 rad/s, 30 rad/s^2) brakes in 1/240 rad.
#[test]
fn braking_distances_are_v_squared_over_twice_the_acceleration() {
    let jc = stated_joint(15.0, 0.5, 0.05, 0.05);
    for v in [3.0f32, -3.0] {
        assert!(close(jc.braking_distance(v), 0.3, 1e-6), "{}", jc.braking_distance(v));
        assert!(close(jc.setpoint_braking_distance(v), 0.375, 1e-6), "{}", jc.setpoint_braking_distance(v));
    }
    assert!(close(jc.braking_distance(0.0), 0.0, 0.0));
    let shipped = PAROL6.joints[0];
    assert!(close(shipped.braking_distance(0.5), 1.0 / 240.0, 1e-7), "{}", shipped.braking_distance(0.5));
}

/// `homing_phase_travel`: a phase other than the fast seek may travel four
/// back-offs and two braking distances from the fast speed. Back-off
/// 0.05 rad, fast 3 rad/s, 15 rad/s^2: 0.2 + 2 x 0.3 = 0.8 rad; the shipped
/// J1: 0.2 + 2/240 rad.
#[test]
fn a_homing_phase_travels_four_back_offs_and_two_braking_distances() {
    let jc = stated_joint(15.0, 3.0, 0.05, 0.05);
    assert!(close(jc.homing_phase_travel(), 0.8, 1e-6), "{}", jc.homing_phase_travel());
    let shipped = PAROL6.joints[0];
    assert!(close(shipped.homing_phase_travel(), 0.2 + 2.0 / 240.0, 1e-6), "{}", shipped.homing_phase_travel());
}

/// The shipped runaway thresholds are 1.25 times each joint's command
/// clamp (the risk analysis's figure; `check` requires at least 1.1):
/// 3.75 rad/s for J1 and J2, 7.5 rad/s for J3 to J6.
#[test]
fn the_shipped_runaway_thresholds_are_1_25_times_the_clamp() {
    let want = [3.75f32, 3.75, 7.5, 7.5, 7.5, 7.5];
    for (jc, w) in PAROL6.joints.iter().zip(want) {
        assert_eq!(jc.runaway_velocity, w);
        assert_eq!(jc.runaway_velocity, jc.max_velocity * 1.25);
    }
}

/// The shipped fast seeks may travel the joint's range plus the switch's
/// distance beyond its limit plus 0.1 rad (SAFETY.md SR-14), computed in
/// f32 in that order: J1 3.52 rad, J6 12.686 rad.
#[test]
fn the_shipped_fast_seek_travel_is_range_plus_switch_distance_plus_0_1() {
    for (i, jc) in PAROL6.joints.iter().enumerate() {
        let want = travel_need(&PAROL6, i) + 0.1;
        assert_eq!(jc.homing.max_travel, want, "J{}", i + 1);
    }
    assert!(close(PAROL6.joints[0].homing.max_travel, 3.52, 1e-6));
    assert!(close(PAROL6.joints[5].homing.max_travel, 12.686, 1e-5));
}
