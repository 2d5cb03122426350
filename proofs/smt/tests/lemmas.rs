//! The facts `ctx::product_lemmas` asserts about abstracted products,
//! checked on the concrete types (no z3): boundary values, every pair, and
//! random pairs. Sampled, not exhaustive: the README states the argument
//! for each (monotone rounding, integer floors).

use fixed::types::I8F24;

fn xorshift(seed: &mut u64) -> u64 {
    *seed ^= *seed << 13;
    *seed ^= *seed >> 7;
    *seed ^= *seed << 17;
    *seed
}

/// `a => b`.
fn implies(a: bool, b: bool) -> bool {
    !a || b
}

fn f32_values() -> Vec<f32> {
    let mut v = vec![
        0.0,
        -0.0,
        1.0,
        -1.0,
        0.5,
        f32::from_bits(0x3f7f_ffff),
        f32::from_bits(0x3f80_0001),
        f32::MIN_POSITIVE,
        f32::from_bits(1),
        -f32::from_bits(1),
        f32::MAX,
        f32::MIN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        1.8e19,
        -1.9e19,
        3.0,
        6.0,
        0.03,
    ];
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    for _ in 0..3000 {
        v.push(f32::from_bits(xorshift(&mut seed) as u32));
        v.push((xorshift(&mut seed) % 2_000_001) as f32 / 100_000.0 - 10.0);
    }
    v
}

#[test]
fn f32_product_facts_hold() {
    let v = f32_values();
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    let mut pairs: Vec<(f32, f32)> = v.iter().take(20).flat_map(|&x| v.iter().take(20).map(move |&y| (x, y))).collect();
    for _ in 0..400_000 {
        let i = (xorshift(&mut seed) % v.len() as u64) as usize;
        let j = (xorshift(&mut seed) % v.len() as u64) as usize;
        pairs.push((v[i], v[j]));
    }
    for (x, y) in pairs {
        let p = x * y;
        for (a, b) in [(x, y), (y, x)] {
            assert!(implies(a.is_nan(), p.is_nan()), "NaN factor {a} * {b} = {p}");
            let small = b.abs() <= 1.0 && !p.is_nan();
            assert!(implies(small, p.abs() <= a.abs()), "|{a} * {b}| = {p} > |{a}|");
        }
        assert!(implies(x.is_finite() && y.is_finite(), !p.is_nan()), "{x} * {y} is NaN");
        let (sx, sy) = (x * x, y * y);
        assert_eq!(x.is_nan(), sx.is_nan());
        assert!(x.is_nan() || sx >= 0.0);
        assert!(implies(x.is_infinite(), sx.is_infinite()));
        assert!(implies(x == 0.0, sx == 0.0));
        assert!(implies(x.abs() <= y.abs(), sx <= sy), "{x}^2 = {sx} > {y}^2 = {sy}");
    }
}

#[test]
fn i8f24_product_facts_hold() {
    let mut v: Vec<i32> =
        vec![0, 1, -1, i32::MIN, i32::MAX, i32::MIN + 1, i32::MAX - 1, 1 << 24, -(1 << 24), (1 << 24) - 1];
    v.extend([-(1 << 24) + 1, 1 << 23, 46_341 << 12, -(46_341 << 12)]);
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    for _ in 0..3000 {
        v.push(xorshift(&mut seed) as i32);
        v.push((xorshift(&mut seed) % (1 << 26)) as i32 - (1 << 25));
    }
    let one = I8F24::ONE;
    let mut pairs: Vec<(i32, i32)> = v.iter().take(14).flat_map(|&x| v.iter().take(14).map(move |&y| (x, y))).collect();
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    for _ in 0..400_000 {
        let i = (xorshift(&mut seed) % v.len() as u64) as usize;
        let j = (xorshift(&mut seed) % v.len() as u64) as usize;
        pairs.push((v[i], v[j]));
    }
    for (x, y) in pairs {
        let (x, y) = (I8F24::from_bits(x), I8F24::from_bits(y));
        let p = x.saturating_mul(y);
        for (a, b) in [(x, y), (y, x)] {
            assert!(implies(b.saturating_abs() <= one, p.saturating_abs() <= a.saturating_abs()), "|{a} * {b}| = {p}");
        }
        let (sx, sy) = (x.saturating_mul(x), y.saturating_mul(y));
        assert!(sx >= I8F24::ZERO);
        assert!(implies(x.saturating_abs() <= y.saturating_abs(), sx <= sy), "{x}^2 = {sx} > {y}^2 = {sy}");
    }
}
