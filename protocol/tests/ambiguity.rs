//! Ambiguity and strictness tests: the cases where a lenient parser would
//! guess, and the sequence rule's resynchronisation cases.

use kernel::config::PAROL6_VALIDATED;
use kernel::{Fx, Scalar};
use protocol::receiver::{Received, Receiver};
use protocol::seq::{ResyncReason, StaleReason};
use protocol::{Command, Dialect, DialectLock, ParseError, Parser, ProtocolConfig};

fn parse<S: Scalar>(line: &str) -> Result<Command<S>, ParseError> {
    Parser::<S>::new(&PAROL6_VALIDATED, DialectLock::Auto).parse(line.as_bytes())
}

fn both(line: &str) -> Result<Command<f32>, ParseError> {
    let f = parse::<f32>(line);
    let x = parse::<Fx>(line);
    // same verdict for both scalar types
    match (&f, &x) {
        (Ok(Command::Motion { seq: a, dialect: da, .. }), Ok(Command::Motion { seq: b, dialect: db, .. })) => {
            assert_eq!((a, da), (b, db), "{line}")
        }
        _ => assert_eq!(f.map(|_| ()), x.map(|_| ()), "{line}"),
    }
    f
}

fn frame(seq: &str, nums: &[&str]) -> String {
    format!("<{seq},{}>", nums.join(","))
}

fn positions(c: Result<Command<f32>, ParseError>) -> ([f32; 6], [f32; 6], Dialect) {
    match c {
        Ok(Command::Motion { target, dialect, .. }) => (target.position, target.velocity, dialect),
        other => panic!("{other:?}"),
    }
}

#[test]
fn same_digits_read_as_either_dialect_only_by_decimals() {
    // Twelve small values valid in both layouts: the decimals decide, never a guess.
    let vals =
        ["0.100", "0.200", "0.300", "0.400", "0.500", "0.600", "0.700", "0.800", "0.900", "1.000", "0.010", "0.020"];
    let (p, v, d) = positions(both(&frame("1", &vals)));
    assert_eq!(d, Dialect::Driver);
    assert_eq!(p, [0.1, 0.3, 0.5, 0.7, 0.9, 0.01]); // interleaved
    assert_eq!(v, [0.2, 0.4, 0.6, 0.8, 1.0, 0.02]);
    let vals4: Vec<String> = vals.iter().map(|s| format!("{s}0")).collect();
    let vals4: Vec<&str> = vals4.iter().map(String::as_str).collect();
    let (p, v, d) = positions(both(&frame("1", &vals4)));
    assert_eq!(d, Dialect::Configurator);
    assert_eq!(p, [0.1, 0.2, 0.3, 0.4, 0.5, 0.6]); // grouped
    assert_eq!(v, [0.7, 0.8, 0.9, 1.0, 0.01, 0.02]);
}

#[test]
fn mixed_decimals_are_rejected_whole_in_every_position() {
    for odd in 0..12 {
        let mut v = vec!["0.000"; 12];
        v[odd] = "0.0000";
        assert_eq!(both(&frame("1", &v)), Err(ParseError::MixedDialect), "odd {odd}");
        let mut v = vec!["0.0000"; 12];
        v[odd] = "0.000";
        assert_eq!(both(&frame("1", &v)), Err(ParseError::MixedDialect), "odd {odd}");
        // half and half
        let v: Vec<&str> = (0..12).map(|i| if i < odd { "0.000" } else { "0.0000" }).collect();
        if odd > 0 {
            assert_eq!(both(&frame("1", &v)), Err(ParseError::MixedDialect));
        }
    }
}

#[test]
fn two_five_and_zero_decimals_are_rejected() {
    for (text, dec) in [("0.00", 2), ("0.00000", 5), ("0", 0), ("0.", 0), ("1.5", 1)] {
        for odd in [0usize, 5, 11] {
            let mut v = vec!["0.000"; 12];
            v[odd] = text;
            assert_eq!(
                both(&frame("1", &v)),
                Err(ParseError::BadDecimals { field: odd as u8 + 1, decimals: dec }),
                "{text} at {odd}"
            );
        }
        assert!(matches!(both(&frame("1", &[text; 12])), Err(ParseError::BadDecimals { field: 1, .. })));
    }
}

#[test]
fn negative_zero_is_accepted_as_zero() {
    let (p, v, _) = positions(both(&frame("1", &["-0.000"; 12])));
    assert!(p.iter().chain(&v).all(|x| *x == 0.0));
    let (p, _, d) = positions(both(&frame("1", &["-0.0000"; 12])));
    assert_eq!((p[0], d), (0.0, Dialect::Configurator));
    match parse::<Fx>(&frame("1", &["-0.000"; 12])) {
        Ok(Command::Motion { target, .. }) => assert_eq!(target.position[0], Fx::ZERO),
        other => panic!("{other:?}"),
    }
}

#[test]
fn non_decimal_spellings_are_non_numeric() {
    for bad in [
        "+1.000", "1e3", "1.0e3", "1.000e0", "nan", "NaN", "inf", "-inf", "infinity", " 0.000", "0.000 ", "0x1.000",
        "0,000", "0..000", "--0.000", "-", ".000", "0.-000", "١.000",
    ] {
        let mut v = vec!["0.000"; 12];
        v[3] = bad;
        let line = frame("1", &v);
        let got = both(&line);
        // a comma inside changes the field count instead
        if bad.contains(',') {
            assert_eq!(got, Err(ParseError::WrongFieldCount { found: 14 }), "{line}");
        } else {
            assert_eq!(got, Err(ParseError::NonNumeric { field: 4 }), "{line}");
        }
    }
}

#[test]
fn wrong_number_counts() {
    assert_eq!(both(&frame("1", &["0.000"; 11])), Err(ParseError::WrongFieldCount { found: 12 }));
    assert_eq!(both(&frame("1", &["0.000"; 13])), Err(ParseError::WrongFieldCount { found: 14 }));
    assert_eq!(both("<1>"), Err(ParseError::WrongFieldCount { found: 1 }));
    let many = format!("<{}>", vec!["0"; 300].join(","));
    assert_eq!(both(&many), Err(ParseError::WrongFieldCount { found: 255 }));
}

#[test]
fn sequence_number_edges() {
    let z = ["0.000"; 12];
    assert!(matches!(both(&frame("4294967295", &z)), Ok(Command::Motion { seq: u32::MAX, .. })));
    assert!(matches!(both(&frame("0000000007", &z)), Ok(Command::Motion { seq: 7, .. })));
    assert_eq!(both(&frame("4294967296", &z)), Err(ParseError::SeqOverflow));
    assert_eq!(both(&frame("99999999999999999999999", &z)), Err(ParseError::SeqOverflow));
    assert_eq!(both(&frame("-1", &z)), Err(ParseError::BadSeq));
    assert_eq!(both(&frame("+1", &z)), Err(ParseError::BadSeq));
    assert_eq!(both(&frame("1.000", &z)), Err(ParseError::BadSeq));
    assert_eq!(both(&frame(" 1", &z)), Err(ParseError::BadSeq));
}

#[test]
fn empty_fields_and_spaces() {
    let mut v = vec!["0.000"; 12];
    v[6] = "";
    assert_eq!(both(&frame("1", &v)), Err(ParseError::EmptyField { field: 7 }));
    assert_eq!(both(&frame("", &["0.000"; 12])), Err(ParseError::EmptyField { field: 0 }));
    assert_eq!(
        both(&format!("{},>", &frame("1", &["0.000"; 12]).trim_end_matches('>'))),
        Err(ParseError::WrongFieldCount { found: 14 })
    );
    assert_eq!(
        both(&frame("1", &["0.000"; 12]).replacen(",0.000,", ", 0.000,", 1)),
        Err(ParseError::NonNumeric { field: 1 })
    );
    assert_eq!(both("< HOME>"), Err(ParseError::WrongFieldCount { found: 1 }));
    assert_eq!(both("<HOME >"), Err(ParseError::UnknownKeyword));
    assert_eq!(both("<HOME> "), Err(ParseError::TrailingText));
    assert_eq!(both(" <HOME>"), Err(ParseError::MissingStart));
}

#[test]
fn keywords_are_case_sensitive_and_exact() {
    for bad in [
        "<home>",
        "<Home>",
        "<enable>",
        "<Enable>",
        "<home3>",
        "<HOME0>",
        "<HOME7>",
        "<HOMEALL>",
        "<ENABLED>",
        "<STOP>",
    ] {
        assert_eq!(both(bad), Err(ParseError::UnknownKeyword), "{bad}");
    }
    for (i, k) in ["<HOME1>", "<HOME2>", "<HOME3>", "<HOME4>", "<HOME5>", "<HOME6>"].iter().enumerate() {
        assert_eq!(both(k), Ok(Command::HomeJoint(i as u8)));
    }
}

#[test]
fn limits_are_checked_per_dialect_layout() {
    // J1 limits +-1.7, J2 [-0.802, 1.0], J1 max velocity 3.0
    let mut v = vec!["0.000"; 12];
    v[0] = "1.700";
    assert!(both(&frame("1", &v)).is_ok());
    v[0] = "1.701";
    assert_eq!(both(&frame("1", &v)), Err(ParseError::PositionOutOfLimits { axis: 0 }));
    let mut v = vec!["0.000"; 12];
    v[1] = "3.000"; // driver: v1
    assert!(both(&frame("1", &v)).is_ok());
    v[1] = "-3.001";
    assert_eq!(both(&frame("1", &v)), Err(ParseError::VelocityTooHigh { axis: 0 }));
    // the same text as configurator: field 2 is p2 (J2 max 1.0)
    let mut v = vec!["0.0000"; 12];
    v[1] = "1.5000";
    assert_eq!(both(&frame("1", &v)), Err(ParseError::PositionOutOfLimits { axis: 1 }));
    // huge numbers: f32 parses and the limit rejects, Fx does not fit
    let mut v = vec!["0.000"; 12];
    v[0] = "99999999999999999999999999999999999999999.000";
    assert_eq!(parse::<f32>(&frame("1", &v)), Err(ParseError::OutOfRange { field: 1 }));
    v[0] = "200.000";
    assert_eq!(parse::<f32>(&frame("1", &v)), Err(ParseError::PositionOutOfLimits { axis: 0 }));
    assert_eq!(parse::<Fx>(&frame("1", &v)), Err(ParseError::OutOfRange { field: 1 }));
}

#[test]
fn dialect_lock() {
    let d = frame("1", &["0.000"; 12]);
    let c = frame("1", &["0.0000"; 12]);
    let only_driver: Parser<f32> = Parser::new(&PAROL6_VALIDATED, DialectLock::DriverOnly);
    let only_conf: Parser<f32> = Parser::new(&PAROL6_VALIDATED, DialectLock::ConfiguratorOnly);
    assert!(only_driver.parse(d.as_bytes()).is_ok());
    assert_eq!(only_driver.parse(c.as_bytes()), Err(ParseError::DialectLocked { found: Dialect::Configurator }));
    assert!(only_conf.parse(c.as_bytes()).is_ok());
    assert_eq!(only_conf.parse(d.as_bytes()), Err(ParseError::DialectLocked { found: Dialect::Driver }));
    // the lock never makes a mixed frame acceptable, and keywords pass in every mode
    let mut m = vec!["0.000"; 12];
    m[11] = "0.0000";
    assert_eq!(only_driver.parse(frame("1", &m).as_bytes()), Err(ParseError::MixedDialect));
    for p in [only_driver, only_conf] {
        assert_eq!(p.parse(b"<ENABLE>"), Ok(Command::Enable));
        assert_eq!(p.parse(b"<HOME2>"), Ok(Command::HomeJoint(1)));
    }
}

fn run(rx: &mut Receiver<f32>, line: &str, now: u32) -> Received<f32> {
    let mut got = None;
    for b in line.bytes().chain(std::iter::once(b'\n')) {
        if let Some(r) = rx.push(b, now) {
            assert!(got.is_none());
            got = Some(r);
        }
    }
    got.unwrap()
}

#[test]
fn restarted_driver_is_resynchronised() {
    let mut rx: Receiver<f32> = Receiver::new(&PAROL6_VALIDATED, ProtocolConfig::DEFAULT);
    let z = ["0.000"; 12];
    // an hour at 100 Hz
    assert!(matches!(run(&mut rx, &frame("360000", &z), 0), Received::Accepted { resync: None, .. }));
    // restart, same millisecond: large backward jump
    match run(&mut rx, &frame("0", &z), 1) {
        Received::Accepted { resync: Some(r), .. } => assert_eq!(r.reason, ResyncReason::BackwardJump),
        other => panic!("{other:?}"),
    }
    // a short backward jump is stale until the gap expires
    assert!(matches!(run(&mut rx, &frame("100", &z), 2), Received::Accepted { resync: None, .. }));
    match run(&mut rx, &frame("50", &z), 3) {
        Received::Dropped(s) => assert_eq!((s.seq, s.last, s.reason), (50, 100, StaleReason::Behind)),
        other => panic!("{other:?}"),
    }
    match run(&mut rx, &frame("51", &z), 600) {
        Received::Accepted { resync: Some(r), .. } => assert_eq!(r.reason, ResyncReason::Gap { ms: 598 }),
        other => panic!("{other:?}"),
    }
    // <HOME> resynchronises at once (the driver sends it on every activation)
    assert!(matches!(run(&mut rx, &frame("60", &z), 601), Received::Accepted { .. }));
    assert!(matches!(run(&mut rx, "<HOME>", 602), Received::Accepted { command: Command::Home, .. }));
    assert!(matches!(run(&mut rx, &frame("3", &z), 603), Received::Accepted { resync: None, .. }));
    // and <ENABLE>
    assert!(matches!(run(&mut rx, &frame("3", &z), 604), Received::Dropped(_)));
    assert!(matches!(run(&mut rx, "<ENABLE>", 605), Received::Accepted { command: Command::Enable, .. }));
    assert!(matches!(run(&mut rx, &frame("0", &z), 606), Received::Accepted { resync: None, .. }));
    let c = rx.counters();
    assert_eq!((c.seq.behind, c.seq.duplicates, c.seq.gap_resyncs, c.seq.jump_resyncs, c.seq.resets), (1, 1, 1, 1, 2));
}

/// A frame exactly at a joint limit is accepted by both numeric variants,
/// and the kernel agrees (its `TargetLimits` widen each f32 limit by one f32
/// ulp before converting; `Fx(2.1f32)` alone would lie 2 LSB inside 2.1).
#[test]
fn frames_exactly_at_the_limits_are_accepted_by_both_variants() {
    let (k, _) = kernel::KernelFx::new(&PAROL6_VALIDATED);
    for (field, text) in [(8, "-2.100"), (8, "2.100"), (4, "1.290"), (4, "-2.000"), (0, "-1.700"), (6, "-2.529")] {
        let mut v = vec!["0.000"; 12];
        v[field] = text;
        let line = frame("1", &v);
        assert!(parse::<f32>(&line).is_ok(), "{text}");
        match parse::<Fx>(&line) {
            Ok(Command::Motion { target, .. }) => assert!(k.validate(&target).is_ok(), "{text}"),
            other => panic!("{text}: {other:?}"),
        }
    }
    // One printed step beyond is still rejected.
    let mut v = vec!["0.000"; 12];
    v[8] = "-2.101";
    assert_eq!(parse::<Fx>(&frame("1", &v)), Err(ParseError::PositionOutOfLimits { axis: 4 }));
    assert_eq!(parse::<f32>(&frame("1", &v)), Err(ParseError::PositionOutOfLimits { axis: 4 }));
}
