//! The parser equals the pre-issue-14 reference (`tests/reference`) on
//! frames near the well-formed ones: same verdict, same error, bit-identical
//! values, for both scalar types and every dialect lock (sampled evidence).
//!
//! The parser reads a well-formed motion frame on a fast path and anything
//! else on the general path; the frames here are built to sit on both
//! sides of that boundary: well-formed frames of both dialects with values
//! in and out of the limits, leading zeros, long SEQs and numbers, `-0`,
//! then edited (a byte replaced, inserted or deleted, the line cut short,
//! a number's decimals changed) so every rule of the grammar is broken
//! somewhere.

mod reference;

use kernel::config::PAROL6_VALIDATED;
use kernel::Fx;
use proptest::prelude::*;
use protocol::{DialectLock, Parser};
use reference::{same, Bits};

/// A number with `decimals` decimals: `int` and `frac` as given, zero padded
/// to `pad` integer digits.
fn number(negative: bool, int: u64, frac: u64, decimals: usize, pad: usize) -> String {
    let frac = frac % 10u64.pow(decimals as u32);
    let sign = if negative { "-" } else { "" };
    if decimals == 0 {
        format!("{sign}{int:0pad$}")
    } else {
        format!("{sign}{int:0pad$}.{frac:0decimals$}")
    }
}

/// One number: mostly small values of the frame's decimals, sometimes
/// large, padded, or with other decimals.
fn any_number(decimals: usize) -> impl Strategy<Value = String> {
    let int = prop_oneof![8 => 0u64..4, 3 => 0u64..20, 1 => 0u64..1_000_000, 1 => any::<u64>()];
    let decimals = prop_oneof![20 => Just(decimals), 1 => 0usize..6];
    let pad = prop_oneof![20 => Just(1usize), 1 => 0usize..14];
    (any::<bool>(), int, any::<u64>(), decimals, pad).prop_map(|(n, i, f, d, p)| number(n, i, f, d, p))
}

/// A motion frame, well formed most of the time.
fn frame() -> impl Strategy<Value = Vec<u8>> {
    let seq = prop_oneof![8 => (0u64..100_000).prop_map(|s| s.to_string()), 1 => any::<u64>().prop_map(|s| s.to_string()),
        1 => (0u64..100, 0usize..12).prop_map(|(s, p)| format!("{s:0p$}"))];
    (seq, prop_oneof![Just(3usize), Just(4usize)])
        .prop_flat_map(|(seq, d)| (Just(seq), proptest::collection::vec(any_number(d), 10..=14)))
        .prop_map(|(seq, nums)| format!("<{seq},{}>", nums.join(",")).into_bytes())
}

/// An edit of a frame.
#[derive(Clone, Debug)]
enum Edit {
    None,
    Replace(usize, u8),
    Insert(usize, u8),
    Delete(usize),
    Truncate(usize),
}

fn edit() -> impl Strategy<Value = Edit> {
    let byte = prop_oneof![proptest::sample::select(b"0123456789-.,<>+e x\n".to_vec()), any::<u8>(),];
    prop_oneof![
        4 => Just(Edit::None),
        2 => (any::<usize>(), byte.clone()).prop_map(|(i, b)| Edit::Replace(i, b)),
        2 => (any::<usize>(), byte).prop_map(|(i, b)| Edit::Insert(i, b)),
        2 => any::<usize>().prop_map(Edit::Delete),
        1 => any::<usize>().prop_map(Edit::Truncate),
    ]
}

fn apply(mut line: Vec<u8>, e: &Edit) -> Vec<u8> {
    let n = line.len();
    match *e {
        Edit::None => {}
        Edit::Replace(_, _) | Edit::Delete(_) if n == 0 => {}
        Edit::Replace(i, b) => line[i % n] = b,
        Edit::Insert(i, b) => line.insert(i % (n + 1), b),
        Edit::Delete(i) => {
            line.remove(i % n);
        }
        Edit::Truncate(i) => line.truncate(i % (n + 1)),
    }
    line
}

fn check<S: Bits>(line: &[u8]) {
    for lock in [DialectLock::Auto, DialectLock::DriverOnly, DialectLock::ConfiguratorOnly] {
        let p: Parser<S> = Parser::new(&PAROL6_VALIDATED, lock);
        let got = p.parse(line);
        let want = reference::parse(&p, line);
        assert!(same(&got, &want), "{:?} ({lock:?}): {got:?} vs {want:?}", String::from_utf8_lossy(line));
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 20_000, ..ProptestConfig::default() })]

    #[test]
    fn near_well_formed_frames_parse_as_the_reference(line in frame(), edits in proptest::collection::vec(edit(), 0..3)) {
        let line = edits.iter().fold(line, apply);
        check::<f32>(&line);
        check::<Fx>(&line);
    }
}

/// Hand-picked frames at the fast path's edges.
#[test]
fn edges_parse_as_the_reference() {
    let zeros = |d: usize| vec![number(false, 0, 0, d, 1); 12];
    let mut lines: Vec<String> = Vec::new();
    for d in [3, 4] {
        for (i, n) in [
            "-0.000",
            "0000000.000",
            "999999.999",
            "9999999.999",
            "99999.9999",
            "999999.9999",
            "12.000",
            "-15.9999",
            "4294967.296",
            "0000000000000000001.000",
            "-00000000000000000000.0000",
            "000099999.9999",
            "1234567890.000",
            "100000.0000",
            "-18446744073709551616.000",
            "340282346638528859811704183484516925440.000",
            "340282356779733661637539395458142568447.9999",
            "-340282356779733661637539395458142568448.000",
            "340282356779733661637539395458142568449.000",
            "999999999999999999999999999999999999999.000",
            "1000000000000000000000000000000000000000.000",
            "-429496.7297",
            "127.999",
            "128.000",
            "-128.000",
            "200.0000",
            "1.00",
            "1.00000",
            "1.",
            "-.500",
            "+1.000",
        ]
        .iter()
        .enumerate()
        {
            // in field 1 (which decides the decimals) and in another field
            for f in [0, 1 + i % 11] {
                let mut nums = zeros(d);
                nums[f] = n.to_string();
                lines.push(format!("<7,{}>", nums.join(",")));
            }
        }
        for seq in ["0", "999999999", "1000000000", "4294967295", "4294967296", "0000000000001", ""] {
            lines.push(format!("<{seq},{}>", zeros(d).join(",")));
        }
        lines.push(format!("<1,{}>x", zeros(d).join(",")));
        lines.push(format!("<1,{},>", zeros(d).join(",")));
        lines.push(format!("<1,{}", zeros(d).join(",")));
        lines.push(format!("<1,{}>", zeros(d)[1..].join(",")));
    }
    for line in &lines {
        check::<f32>(line.as_bytes());
        check::<Fx>(line.as_bytes());
    }
}
