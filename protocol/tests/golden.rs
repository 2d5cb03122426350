//! Golden tests: every example line of docs/spec/hosts.md parses to the expected
//! values (f32 and Fx), and formatted feedback passes both clients' rules.
#![allow(clippy::approx_constant)] // the spec's literals (3.142, 1.5708) are data, not pi

mod common;

use common::*;
use kernel::config::{PAROL6, PAROL6_VALIDATED};
use kernel::{
    Event, FaultReason, Fx, HardwareFault, HomingStatus, Reject, RequestKind, Scalar, State, Status, StopCause,
};
use protocol::feedback::{configurator_line, driver_line, state_byte};
use protocol::receiver::{Received, Receiver};
use protocol::report::{banner_line, config_fingerprint, event_line};
use protocol::{Command, Dialect, DialectLock, Line, Parser, ProtocolConfig};

fn parser<S: Scalar>() -> Parser<S> {
    Parser::new(&PAROL6_VALIDATED, DialectLock::Auto)
}

fn motion<S: Scalar>(line: &str) -> (u32, Dialect, [f64; 6], [f64; 6]) {
    match parser::<S>().parse(line.as_bytes()) {
        Ok(Command::Motion { seq, dialect, target }) => {
            (seq, dialect, target.position.map(|x| x.to_f32() as f64), target.velocity.map(|x| x.to_f32() as f64))
        }
        other => panic!("{line}: {other:?}"),
    }
}

fn close(a: [f64; 6], b: [f64; 6]) -> bool {
    // f32 rounding of a 3-4 decimal number, or Fx resolution 6e-8
    a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-6)
}

fn check_both(line: &str, seq: u32, dialect: Dialect, p: [f64; 6], v: [f64; 6]) {
    for (s, d, gp, gv) in [
        {
            let (s, d, gp, gv) = motion::<f32>(line);
            (s, d, gp, gv)
        },
        motion::<Fx>(line),
    ] {
        assert_eq!((s, d), (seq, dialect), "{line}");
        assert!(close(gp, p), "{line}: positions {gp:?}");
        assert!(close(gv, v), "{line}: velocities {gv:?}");
    }
}

#[test]
fn driver_examples() {
    assert_eq!(parser::<f32>().parse(b"<HOME>"), Ok(Command::Home));
    assert_eq!(parser::<Fx>().parse(b"<HOME>"), Ok(Command::Home));
    check_both(
        "<0,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000>",
        0,
        Dialect::Driver,
        [0.0; 6],
        [0.0; 6],
    );
    check_both(
        "<1532,0.123,0.050,-0.500,-0.200,1.000,0.000,0.250,0.000,-1.571,0.300,3.142,-0.000>",
        1532,
        Dialect::Driver,
        [0.123, -0.5, 1.0, 0.25, -1.571, 3.142],
        [0.05, -0.2, 0.0, 0.0, 0.3, 0.0],
    );
    check_both(
        "<4294967295,-0.471,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000>",
        4294967295,
        Dialect::Driver,
        [-0.471, 0.0, 0.0, 0.0, 0.0, 0.0],
        [0.0; 6],
    );
}

#[test]
fn configurator_examples() {
    check_both(
        "<0,0.1000,0.0000,0.0000,0.0000,0.0000,0.0000,0.3000,0.0000,0.0000,0.0000,0.0000,0.0000>",
        0,
        Dialect::Configurator,
        [0.1, 0.0, 0.0, 0.0, 0.0, 0.0],
        [0.3, 0.0, 0.0, 0.0, 0.0, 0.0],
    );
    assert_eq!(parser::<f32>().parse(b"<ENABLE>"), Ok(Command::Enable));
    assert_eq!(parser::<Fx>().parse(b"<HOME3>"), Ok(Command::HomeJoint(2)));
}

fn status<S: Scalar>(p: [f64; 6], v: [f64; 6], homing: HomingStatus, state: State, limits: u8) -> Status<S> {
    let p = p.map(|x| S::parse_decimal(&format!("{x}")).unwrap());
    let v = v.map(|x| S::parse_decimal(&format!("{x}")).unwrap());
    Status {
        state,
        homing,
        fault: None,
        position: p,
        velocity: v,
        setpoint: p,
        limits,
        homed: 0,
        timeout_armed: false,
        tick: 0,
    }
}

const DRIVER_EXAMPLE: &str = "<ACK,250,-0.471,0.000,-0.803,0.500,1.292,0.000,-2.531,0.000,2.094,0.000,0.000,0.000,H1>";
const CONFIG_EXAMPLE: &str =
    "<ACK,42,0.1234,-0.5000,1.0000,0.2500,-1.5708,3.1416,0.0500,-0.2000,0.0000,0.0000,0.3000,-0.0000,0,1,3>";

fn feedback_examples<S: Scalar>() {
    let st = status::<S>(
        [-0.471, -0.803, 1.292, -2.531, 2.094, 0.0],
        [0.0, 0.5, 0.0, 0.0, 0.0, 0.0],
        HomingStatus::InProgress,
        State::Homing,
        0,
    );
    let mut out = Line::new();
    driver_line(&mut out, 250, &st).unwrap();
    assert_eq!(out.as_str(), format!("{DRIVER_EXAMPLE}\n"));
    let view = driver_accepts(&out).unwrap();
    assert_eq!(view.seq, 250);
    assert_eq!(view.homing, Some(1));
    assert_eq!(view.velocity[1], 0.5);
    // the configurator skips the driver's line
    assert_eq!(configurator_accepts(&out), None);

    let st = status::<S>(
        [0.1234, -0.5, 1.0, 0.25, -1.5708, 3.1416],
        [0.05, -0.2, 0.0, 0.0, 0.3, -0.0],
        HomingStatus::Complete,
        State::Operational,
        0,
    );
    configurator_line(&mut out, 42, &st, 3).unwrap();
    // we print a negative zero as 0.0000 (the sign comes from the rounded integer)
    assert_eq!(out.as_str(), format!("{}\n", CONFIG_EXAMPLE.replace(",-0.0000,", ",0.0000,")));
    let view = configurator_accepts(&out).unwrap();
    assert_eq!(view.seq, 42);
    assert_eq!(view.position, [0.1234, -0.5, 1.0, 0.25, -1.5708, 3.1416]);
    assert_eq!((view.limits, view.state, view.extra), (0.0, 1.0, Some(3.0)));
    // the spec's own example passes our re-implementation of the regex
    assert!(configurator_accepts(CONFIG_EXAMPLE).is_some());
    assert!(driver_accepts(DRIVER_EXAMPLE).is_some());
}

#[test]
fn feedback_matches_spec_examples_f32() {
    feedback_examples::<f32>();
}

#[test]
fn feedback_matches_spec_examples_fx() {
    feedback_examples::<Fx>();
}

#[test]
fn both_lines_per_period_serve_both_clients() {
    let st = status::<f32>([0.1; 6], [0.0; 6], HomingStatus::Complete, State::Operational, 0b100);
    let mut text = String::new();
    let mut out = Line::new();
    configurator_line(&mut out, 7, &st, 12).unwrap();
    text.push_str(&out);
    driver_line(&mut out, 7, &st).unwrap();
    text.push_str(&out);
    // the driver keeps the newest `<` line: its own
    let d = driver_accepts(&text).unwrap();
    assert_eq!((d.seq, d.homing), (7, Some(2)));
    // the configurator takes the line that matches its regex
    let c: Vec<_> = text.lines().filter_map(configurator_accepts).collect();
    assert_eq!(c.len(), 1);
    assert_eq!((c[0].limits, c[0].state, c[0].extra), (4.0, 1.0, Some(12.0)));
}

#[test]
fn state_bytes() {
    assert_eq!(state_byte(State::Boot), 1);
    assert_eq!(state_byte(State::Unhomed), 1);
    assert_eq!(state_byte(State::Operational), 1);
    assert_eq!(state_byte(State::Homing), 2);
    assert_eq!(state_byte(State::Stopping), 3);
    assert_eq!(state_byte(State::SoftEstop), 3);
    assert_eq!(state_byte(State::Fault), 3);
}

#[test]
fn worst_case_values_fit_and_never_print_nan_or_inf() {
    let mut st = status::<f32>([0.0; 6], [0.0; 6], HomingStatus::Failed, State::Fault, 0xFF);
    st.position = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, f32::MAX, f32::MIN, -f32::NAN];
    st.velocity = [f32::MIN; 6];
    let mut out = Line::new();
    configurator_line(&mut out, u32::MAX, &st, u32::MAX).unwrap();
    assert!(is_clean_line(&out));
    assert!(!out.to_lowercase().contains("nan") && !out.to_lowercase().contains("inf"), "{out}");
    let c = configurator_accepts(&out).unwrap();
    assert_eq!((c.position[0], c.limits, c.state), (0.0, 63.0, 3.0));
    driver_line(&mut out, u32::MAX, &st).unwrap();
    assert!(driver_accepts(&out).is_some(), "{out}");
    // Fx extremes
    let mut st = status::<Fx>([0.0; 6], [0.0; 6], HomingStatus::Failed, State::Fault, 0);
    st.position = [Fx::MIN, Fx::MAX, Fx::MIN, Fx::MAX, Fx::DELTA, -Fx::DELTA];
    configurator_line(&mut out, 0, &st, 0).unwrap();
    assert!(configurator_accepts(&out).is_some(), "{out}");
    assert!(out.contains("-128.0000,128.0000"), "{out}");
    assert!(out.contains(",0.0000,0.0000,"), "{out}");
}

fn ev(e: Event) -> String {
    let mut out = Line::new();
    event_line(&mut out, &e).unwrap();
    assert!(is_clean_line(&out) && !out.starts_with('<'), "{out:?}");
    out.trim_end().to_string()
}

#[test]
fn event_lines() {
    assert_eq!(ev(Event::Ready), "READY");
    assert_eq!(ev(Event::Fault(FaultReason::LimitSwitch { axis: 2 })), "FAULT LIMIT_SWITCH J3");
    assert_eq!(ev(Event::Fault(FaultReason::EncoderJump { axis: 0, delta: -512 })), "FAULT ENCODER_JUMP J1 delta=-512");
    assert_eq!(
        ev(Event::Fault(FaultReason::HomingTimeout { axis: 2, phase: kernel::homing::Phase::FastSeek })),
        "HOMING_FAULT HOMING_TIMEOUT J3 phase=FAST_SEEK"
    );
    assert_eq!(ev(Event::Fault(FaultReason::Hardware(HardwareFault::Driver { axis: 1 }))), "FAULT HARDWARE DRIVER J2");
    assert_eq!(
        ev(Event::Fault(FaultReason::Hardware(HardwareFault::DriverDiagnostic {
            axis: 2,
            cause: kernel::DriverCause::Overtemperature
        }))),
        "FAULT HARDWARE DRIVER_DIAG J3 OVERTEMP"
    );
    assert_eq!(ev(Event::HomingStarted { mask: 0x3F }), "HOMING_STARTED mask=0x3F");
    assert_eq!(ev(Event::HomingDone { mask: 0x3F }), "HOMING_DONE mask=0x3F");
    assert_eq!(
        ev(Event::SoftEstop { cause: StopCause::CommandTimeout { since_command_ms: 103 } }),
        "SOFT_ESTOP since_cmd_ms=103"
    );
    assert_eq!(ev(Event::SoftEstop { cause: StopCause::LinkLost }), "SOFT_ESTOP LINK_LOST");
    assert_eq!(ev(Event::Holding), "HOLDING at rest, timeout disarmed");
    assert_eq!(ev(Event::HomingAfterStop), "HOMING_QUEUED stopping first");
    assert_eq!(ev(Event::Fault(FaultReason::FollowingError { axis: 0 })), "FAULT FOLLOWING_ERROR J1");
    assert_eq!(
        ev(Event::Fault(FaultReason::HomingTravel { axis: 5, phase: kernel::homing::Phase::FastSeek })),
        "HOMING_FAULT HOMING_TRAVEL J6 phase=FAST_SEEK"
    );
    assert_eq!(
        ev(Event::Rejected { request: RequestKind::Motion, reason: Reject::TargetJump { axis: 1 } }),
        "REFUSED MOTION TARGET_JUMP J2"
    );
    assert_eq!(
        ev(Event::Rejected { request: RequestKind::Home, reason: Reject::Latched }),
        "REFUSED HOME LATCHED_ENABLE_FIRST"
    );
    assert_eq!(ev(Event::Stopped), "STOPPED");
    assert_eq!(ev(Event::Enabled(State::Unhomed)), "ENABLED state=UNHOMED");
    assert_eq!(
        ev(Event::Rejected { request: RequestKind::Motion, reason: Reject::NotHomed }),
        "REFUSED MOTION NOT_HOMED"
    );
    assert_eq!(
        ev(Event::Rejected { request: RequestKind::HomeJoint(2), reason: Reject::DependencyNotHomed { needs: 0x38 } }),
        "REFUSED HOME3 DEPENDENCY_NOT_HOMED needs=0x38"
    );
    assert_eq!(
        ev(Event::Rejected {
            request: RequestKind::Enable,
            reason: Reject::CauseActive(FaultReason::LimitSwitch { axis: 0 })
        }),
        "REFUSED ENABLE CAUSE_ACTIVE LIMIT_SWITCH J1"
    );
    assert_eq!(
        ev(Event::Rejected { request: RequestKind::Enable, reason: Reject::ForeignCapability }),
        "REFUSED ENABLE FOREIGN_CAPABILITY"
    );
}

#[test]
fn only_faults_and_soft_estops_reach_the_fault_log() {
    use kernel::homing::Phase;
    let faults = [
        FaultReason::EncoderLost { axis: 5 },
        FaultReason::EncoderJump { axis: 5, delta: i32::MIN },
        FaultReason::EncoderNotReady { axis: 5 },
        FaultReason::Runaway { axis: 5 },
        FaultReason::LimitSwitch { axis: 5 },
        FaultReason::PositionLimit { axis: 5 },
        FaultReason::Numeric { axis: 255 },
        FaultReason::HomingTimeout { axis: 5, phase: Phase::Release },
        FaultReason::Hardware(HardwareFault::TickOverrun),
        FaultReason::Hardware(HardwareFault::SelfTest(255)),
    ];
    let causes = [
        kernel::DriverCause::Missing,
        kernel::DriverCause::WrongVersion,
        kernel::DriverCause::Reset,
        kernel::DriverCause::DriverError,
        kernel::DriverCause::ChargePump,
        kernel::DriverCause::Overtemperature,
        kernel::DriverCause::ShortToGround,
        kernel::DriverCause::ShortToSupply,
        kernel::DriverCause::OpenLoad,
    ];
    let driver = causes.map(|cause| FaultReason::Hardware(HardwareFault::DriverDiagnostic { axis: 5, cause }));
    for f in faults.into_iter().chain(driver) {
        assert!(ev(Event::Fault(f)).contains("FAULT"));
        let refused = ev(Event::Rejected { request: RequestKind::Enable, reason: Reject::CauseActive(f) });
        assert!(!refused.contains("FAULT") && !refused.contains("SOFT_ESTOP"), "{refused}");
    }
    let rejects = [
        Reject::Booting,
        Reject::NotHomed,
        Reject::Homing,
        Reject::Latched,
        Reject::Stopping,
        Reject::PositionOutOfLimits { axis: 0 },
        Reject::VelocityTooHigh { axis: 0 },
        Reject::NonFinite { axis: 0 },
        Reject::NoSuchJoint,
        Reject::DependencyNotHomed { needs: 1 },
        Reject::NothingToClear,
        Reject::ForeignCapability,
    ];
    for r in rejects {
        for request in [RequestKind::Motion, RequestKind::Home, RequestKind::HomeJoint(5), RequestKind::Enable] {
            let l = ev(Event::Rejected { request, reason: r });
            assert!(!l.contains("FAULT") && !l.contains("SOFT_ESTOP"), "{l}");
        }
    }
    for s in [State::Boot, State::Unhomed, State::Homing, State::Operational, State::Stopping] {
        assert!(!ev(Event::Enabled(s)).contains("FAULT"));
    }
    assert!(ev(Event::SoftEstop { cause: StopCause::CommandTimeout { since_command_ms: 0 } }).contains("SOFT_ESTOP"));
    assert!(ev(Event::SoftEstop { cause: StopCause::LinkLost }).contains("SOFT_ESTOP"));
    assert!(!ev(Event::Holding).contains("SOFT_ESTOP") && !ev(Event::Holding).contains("FAULT"));
}

#[test]
fn rejections_and_drops_are_reported() {
    let mut rx: Receiver<f32> = Receiver::new(&PAROL6_VALIDATED, ProtocolConfig::DEFAULT);
    let input = b"<home>\n<5,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000>\n\
<5,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000>\n\
<1,0.00,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000,0.000>\n\x00\x01\n";
    let mut lines = Vec::new();
    let mut out = Line::new();
    for &b in input.iter() {
        if let Some(r) = rx.push(b, 0) {
            if r.report(&mut out).unwrap() {
                assert!(is_clean_line(&out));
                lines.push(out.trim_end().to_string());
            }
        }
    }
    assert_eq!(
        lines,
        [
            "REJECT UNKNOWN_KEYWORD count=1",
            "STALE_CMD seq=5 last=5 reason=DUPLICATE count=1",
            "REJECT BAD_DECIMALS field=1 decimals=2 count=2",
            "REJECT NON_PRINTABLE byte=0x00 at=0 count=3",
        ]
    );
    let long = [b'1'; 200];
    let mut got = None;
    for &b in long.iter().chain(b"\n") {
        got = rx.push(b, 0).or(got);
    }
    got.unwrap().report(&mut out).unwrap();
    assert_eq!(out.as_str(), "REJECT LINE_TOO_LONG len=200 count=4\n");
    assert!(matches!(got, Some(Received::Rejected { .. })));
}

#[test]
fn banner() {
    const FP: u64 = config_fingerprint(&PAROL6);
    let mut out = Line::new();
    banner_line(&mut out, "0.1.0 dev\n", FP, DialectLock::Auto, protocol::feedback::FeedbackMode::Both, "WATCHDOG")
        .unwrap();
    assert!(is_clean_line(&out) && !out.starts_with('<'));
    assert_eq!(
        out.as_str(),
        format!("BOOT PAROL6 fw=0.1.0?dev? protocol=1 config={FP:016X} dialect=AUTO feedback=BOTH reset=WATCHDOG\n")
    );
}
