//! Framer + parser + sequence filter on arbitrary bytes, for both scalar
//! types and every dialect lock. Panics (the fuzzer's findings) on: any
//! panic inside the crate, an accepted motion frame outside the joint
//! limits, a report line that is not clean printable text, or a line the
//! parser reads differently from the pre-issue-14 parser (numbers converted
//! from their text, `protocol/tests/reference`): a different verdict, error
//! or any value not bit-identical.
#![no_main]

#[path = "../../tests/reference/mod.rs"]
mod reference;

use kernel::config::{ArmConfig, PAROL6, PAROL6_VALIDATED};
use kernel::{Fx, MotionTarget, Scalar};
use libfuzzer_sys::fuzz_target;
use protocol::framer::Framer;
use protocol::receiver::{Received, Receiver};
use protocol::{Command, DialectLock, Line, Parser, ProtocolConfig, INPUT_LINE_CAP};
use reference::Bits;

fn within_limits<S: Scalar>(c: &ArmConfig, t: &MotionTarget<S>) -> bool {
    let tol = 1e-7;
    c.joints.iter().zip(t.position.iter().zip(&t.velocity)).all(|(j, (p, v))| {
        let (p, v) = (p.to_f32() as f64, v.to_f32() as f64);
        p.is_finite()
            && v.is_finite()
            && p >= j.limit_min as f64 - tol
            && p <= j.limit_max as f64 + tol
            && v.abs() <= j.max_velocity as f64 + tol
    })
}

fn run<S: Bits>(data: &[u8], lock: DialectLock) {
    let cfg = ProtocolConfig { lock, ..ProtocolConfig::DEFAULT };
    let mut rx: Receiver<S> = Receiver::new(&PAROL6_VALIDATED, cfg);
    let mut out = Line::new();
    for (i, &b) in data.iter().enumerate() {
        if let Some(r) = rx.push(b, (i as u32).wrapping_mul(7)) {
            if let Received::Accepted { command: Command::Motion { target, .. }, .. } = &r {
                assert!(within_limits(&PAROL6, target), "{target:?}");
            }
            if r.report(&mut out).expect("line fits") {
                let body = out.strip_suffix('\n').expect("terminated");
                assert!(!body.starts_with('<'));
                assert!(body.bytes().all(|b| (0x20..=0x7E).contains(&b)));
            }
        }
    }
    // The same lines through the parser and the reference parser.
    let parser: Parser<S> = Parser::new(&PAROL6_VALIDATED, lock);
    let mut framer: Framer<INPUT_LINE_CAP> = Framer::new();
    for &b in data {
        if let Some(Ok(line)) = framer.push(b) {
            let got = parser.parse(line);
            let want = reference::parse(&parser, line);
            assert!(reference::same(&got, &want), "{:?}: {got:?} vs {want:?}", String::from_utf8_lossy(line));
        }
    }
}

fuzz_target!(|data: &[u8]| {
    // The first byte picks the lock, so the fuzzer explores all three.
    let (lock, rest) = match data.split_first() {
        Some((b, rest)) => (
            match b % 3 {
                0 => DialectLock::Auto,
                1 => DialectLock::DriverOnly,
                _ => DialectLock::ConfiguratorOnly,
            },
            rest,
        ),
        None => (DialectLock::Auto, data),
    };
    run::<f32>(rest, lock);
    run::<Fx>(rest, lock);
});
