//! Integer-to-text helpers writing into a fixed [`Line`]. No floating point
//! is formatted anywhere in this crate: numbers arrive as scaled integers
//! from [`kernel::Scalar::to_scaled_int`].

/// Capacity of one output line. The longest line this crate can produce is
/// the configurator feedback line with every number saturated to `i64`
/// (checked by a test): `<ACK,` + 10 + 12 x 22 + 4 + 2 + 11 + `>\n` = 298.
pub const LINE_CAP: usize = 320;

/// One output line (terminator included).
pub type Line = heapless::String<LINE_CAP>;

/// The line buffer was too small (never expected: capacities are sized for
/// the worst case and tested; reported rather than truncated silently).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Full;

pub(crate) fn push_str<const N: usize>(out: &mut heapless::String<N>, s: &str) -> Result<(), Full> {
    out.push_str(s).map_err(|_| Full)
}

pub(crate) fn push_byte<const N: usize>(out: &mut heapless::String<N>, b: u8) -> Result<(), Full> {
    out.push(char::from(b)).map_err(|_| Full)
}

/// Writes the decimal digits of `n` (at least `min_digits` digits, zero
/// padded, `min_digits <= 20`) into the tail of `buf`; returns where they start.
fn digits(mut n: u64, min_digits: usize, buf: &mut [u8; 20]) -> usize {
    const LEN: usize = 20;
    let mut start = LEN;
    for (i, slot) in buf.iter_mut().enumerate().rev() {
        // `n % 10` is in 0..=9, so `b'0' | d` is the ASCII digit.
        *slot = b'0' | (n % 10) as u8;
        n /= 10;
        start = i;
        let written = LEN.saturating_sub(i);
        if n == 0 && written >= min_digits {
            break;
        }
    }
    start
}

pub(crate) fn push_u64<const N: usize>(out: &mut heapless::String<N>, n: u64) -> Result<(), Full> {
    let mut buf = [0u8; 20];
    let start = digits(n, 1, &mut buf);
    for &b in buf.get(start..).unwrap_or(&[]) {
        push_byte(out, b)?;
    }
    Ok(())
}

pub(crate) fn push_u32<const N: usize>(out: &mut heapless::String<N>, n: u32) -> Result<(), Full> {
    push_u64(out, u64::from(n))
}

pub(crate) fn push_i64<const N: usize>(out: &mut heapless::String<N>, n: i64) -> Result<(), Full> {
    if n < 0 {
        push_byte(out, b'-')?;
    }
    push_u64(out, n.unsigned_abs())
}

/// `0x` and two hex digits.
pub(crate) fn push_hex8<const N: usize>(out: &mut heapless::String<N>, n: u8) -> Result<(), Full> {
    const HEX: &[u8; 16] = b"0123456789ABCDEF";
    push_str(out, "0x")?;
    push_byte(out, HEX.get(usize::from(n >> 4)).copied().unwrap_or(b'?'))?;
    push_byte(out, HEX.get(usize::from(n & 0xF)).copied().unwrap_or(b'?'))
}

/// Sixteen hex digits.
pub(crate) fn push_hex64<const N: usize>(out: &mut heapless::String<N>, n: u64) -> Result<(), Full> {
    for b in n.to_be_bytes() {
        let s = &mut heapless::String::<4>::new();
        push_hex8(s, b)?;
        push_str(out, s.get(2..).unwrap_or("??"))?;
    }
    Ok(())
}

/// Prints `scaled / 10^decimals` exactly (`decimals` in 1..=19), e.g.
/// `-1234, 3` as `-1.234`. The sign comes from the integer, so a value that
/// rounds to zero prints as `0.000`, never `-0.000`.
pub(crate) fn push_scaled<const N: usize>(
    out: &mut heapless::String<N>,
    scaled: i64,
    decimals: usize,
) -> Result<(), Full> {
    let decimals = decimals.clamp(1, 19);
    if scaled < 0 {
        push_byte(out, b'-')?;
    }
    let mut buf = [0u8; 20];
    let start = digits(scaled.unsigned_abs(), decimals.saturating_add(1), &mut buf);
    let point = buf.len().saturating_sub(decimals);
    for (i, &b) in buf.iter().enumerate().skip(start) {
        if i == point {
            push_byte(out, b'.')?;
        }
        push_byte(out, b)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(f: impl Fn(&mut Line) -> Result<(), Full>) -> Line {
        let mut l = Line::new();
        f(&mut l).unwrap();
        l
    }

    #[test]
    fn integers_and_scaled_values() {
        assert_eq!(s(|l| push_u64(l, 0)), "0");
        assert_eq!(s(|l| push_u64(l, u64::MAX)), "18446744073709551615");
        assert_eq!(s(|l| push_i64(l, i64::MIN)), "-9223372036854775808");
        assert_eq!(s(|l| push_scaled(l, 0, 3)), "0.000");
        assert_eq!(s(|l| push_scaled(l, -1, 3)), "-0.001");
        assert_eq!(s(|l| push_scaled(l, 1234, 4)), "0.1234");
        assert_eq!(s(|l| push_scaled(l, -31416, 4)), "-3.1416");
        assert_eq!(s(|l| push_scaled(l, 123_456, 3)), "123.456");
        assert_eq!(s(|l| push_scaled(l, i64::MIN, 4)), "-922337203685477.5808");
        assert_eq!(s(|l| push_scaled(l, i64::MAX, 3)), "9223372036854775.807");
        assert_eq!(s(|l| push_hex8(l, 0x3f)), "0x3F");
        assert_eq!(s(|l| push_hex64(l, 0x0123_4567_89ab_cdef)), "0123456789ABCDEF");
    }
}
