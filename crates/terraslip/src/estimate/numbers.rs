//! The text of the numbers in `estimate.csv`: times as the shortest text
//! that reads back as the same number, the other columns rounded to a fixed
//! number of decimals. Written by hand into bytes: with `format!` the text
//! was the largest single cost of `estimate` on a long log.

use std::io::Write as _;

/// `10^d` for the decimals a column can have.
const POW10: [u64; 10] = [
    1,
    10,
    100,
    1_000,
    10_000,
    100_000,
    1_000_000,
    10_000_000,
    100_000_000,
    1_000_000_000,
];

/// The two-digit groups `00` to `99`.
const PAIRS: &[u8; 200] = b"0001020304050607080910111213141516171819\
2021222324252627282930313233343536373839\
4041424344454647484950515253545556575859\
6061626364656667686970717273747576777879\
8081828384858687888990919293949596979899";

/// Above this, `|v| 10^digits` leaves integer arithmetic to `format!`.
const MAX_SCALED: f64 = 9.0e15;

/// `|v|` in units of the last of `digits` decimals, rounded half away from
/// zero (as `f64::round`), the scale and whether the text has a minus
/// sign; `None` where it is too large for integer arithmetic or not finite.
#[inline(always)]
pub(super) fn fixed(v: f64, digits: u32) -> Option<(u64, u64, bool)> {
    let scale = POW10
        .get(digits as usize)
        .copied()
        .unwrap_or_else(|| 10u64.pow(digits));
    let s = v.abs() * scale as f64;
    if s.is_nan() || s >= MAX_SCALED {
        return None;
    }
    // `s` is below 2^53, so its fraction `s - trunc(s)` is exact: rounding
    // without `f64::round` (a call into libm on baseline x86-64). Signed
    // conversions are single instructions there, unsigned ones are not.
    let mut n = s as i64;
    if s - n as f64 >= 0.5 {
        n += 1;
    }
    if n as f64 >= MAX_SCALED {
        return None;
    }
    Some((n as u64, scale, v < 0.0 && n != 0))
}

/// Room of a [`Text`]: 16 digits, the point and the sign fit.
const TEXT: usize = 24;

/// The text of one number, left-aligned in a buffer of constant size, so
/// that it is appended by a copy of constant length (no call to `memcpy`)
/// and a truncation.
#[derive(Debug, Clone, Copy)]
pub(super) struct Text {
    bytes: [u8; TEXT],
    len: u8,
}

impl Text {
    /// Appends the text to `buf`.
    #[inline(always)]
    pub(super) fn push_to(&self, buf: &mut Vec<u8>) {
        let n = buf.len();
        buf.extend_from_slice(&self.bytes);
        buf.truncate(n + self.len as usize);
    }
}

/// How many decimal digits `m` has (1 for 0).
#[inline(always)]
fn digit_count(m: u64) -> usize {
    let (mut count, mut limit) = (1, 10u64);
    while count < 20 && m >= limit {
        count += 1;
        limit = limit.saturating_mul(10);
    }
    count
}

/// `v` with `D` decimals, as `format!("{v:.D$}")` writes it (without the
/// minus sign of a value that rounds to zero); `None` where `format!` must
/// write it ([`fixed`]).
#[inline(always)]
fn decimals<const D: usize>(v: f64) -> Option<Text> {
    let (n, scale, negative) = fixed(v, D as u32)?;
    let (int, mut frac) = (n / scale, n % scale);
    // n < 9e15: at most 16 digits, the point and the sign.
    let sign = usize::from(negative);
    let point = sign + digit_count(int);
    let len = point + 1 + D;
    let mut bytes = [b'-'; TEXT];
    let mut i = len;
    while i > point + 2 {
        let r = (frac % 100) as usize * 2;
        frac /= 100;
        i -= 2;
        bytes[i..i + 2].copy_from_slice(&PAIRS[r..r + 2]);
    }
    if i > point + 1 {
        bytes[point + 1] = b'0' + frac as u8;
    }
    bytes[point] = b'.';
    integer(&mut bytes[sign..point], int);
    Some(Text {
        bytes,
        len: len as u8,
    })
}

/// Writes the digits of `m` right-aligned into `text` (at least one digit);
/// returns where they start.
#[inline(always)]
fn integer(text: &mut [u8], mut m: u64) -> usize {
    let mut i = text.len();
    while m >= 100 {
        let r = (m % 100) as usize * 2;
        m /= 100;
        i -= 2;
        text[i..i + 2].copy_from_slice(&PAIRS[r..r + 2]);
    }
    if m >= 10 {
        let r = m as usize * 2;
        i -= 2;
        text[i..i + 2].copy_from_slice(&PAIRS[r..r + 2]);
    } else {
        i -= 1;
        text[i] = b'0' + m as u8;
    }
    i
}

/// `v` with `digits` decimals as [`push_fixed`] writes it, where it fits a
/// [`Text`]. The decimals of estimate.csv's columns are constants here:
/// the digit arithmetic then needs no division instruction.
pub(super) fn fixed_text(v: f64, digits: u32) -> Option<Text> {
    match digits {
        3 => decimals::<3>(v),
        4 => decimals::<4>(v),
        5 => decimals::<5>(v),
        6 => decimals::<6>(v),
        _ => None,
    }
}

/// Appends `v` with `digits` decimals, as `format!("{v:.digits$}")` writes
/// it (without the minus sign of a value that rounds to zero).
pub(super) fn push_fixed(buf: &mut Vec<u8>, v: f64, digits: u32) {
    if let Some(t) = fixed_text(v, digits) {
        t.push_to(buf);
        return;
    }
    let Some((n, _, negative)) = fixed(v, digits) else {
        let _ = write!(buf, "{v:.*}", digits as usize);
        return;
    };
    if negative {
        buf.push(b'-');
    }
    let mut text = [b'0'; 40];
    let start = integer(&mut text, n);
    let point = text.len() - digits as usize;
    buf.extend_from_slice(&text[start.min(point - 1)..point]);
    if digits > 0 {
        buf.push(b'.');
        buf.extend_from_slice(&text[point..]);
    }
}

/// Appends `v` as `format!("{v}")` writes it: the shortest text that reads
/// back as `v`, never in exponent form. Ryu finds the same shortest digits
/// faster; its `.0` of whole numbers is dropped, and `format!` writes what
/// the two could write differently: the exponent forms Ryu uses for very
/// large or small numbers, and texts of 16 or more significant digits,
/// the only ones where two candidates can be equally close to `v` (Ryu
/// and `format!` break such ties differently).
pub(super) fn push_time(buf: &mut Vec<u8>, v: f64) {
    if v.is_finite() {
        let mut b = ryu::Buffer::new();
        let s = b.format_finite(v);
        if !s.contains('e') && significant_digits(s) < 16 {
            let s = s.strip_suffix(".0").unwrap_or(s);
            buf.extend_from_slice(s.as_bytes());
            return;
        }
    }
    let _ = write!(buf, "{v}");
}

/// Significant digits of a plain decimal text (`-0.00120` has 3).
fn significant_digits(s: &str) -> usize {
    let digits = s.bytes().filter(u8::is_ascii_digit);
    let leading = s
        .bytes()
        .take_while(|c| matches!(c, b'-' | b'0' | b'.'))
        .filter(|&c| c == b'0')
        .count();
    digits.count() - leading
}

#[cfg(test)]
mod tests {
    use super::super::{as_written, Column};
    use super::{fixed, push_fixed, push_time};

    #[test]
    fn fixed_formatting_matches_format_and_reads_back_as_written() {
        let mut values = vec![
            0.0,
            -0.0,
            1.5,
            -2.25,
            0.123456789,
            -0.00004,
            123456.7,
            1e300,
            f64::NAN,
            f64::INFINITY,
            -1e-9,
            -2.765432,
            0.00015,
            0.5,
            2.5,
            -0.5,
            0.00049999999999999,
            8.999999999e9,
            9.1e9,
            4503599627370495.5,
        ];
        // Halves at the last decimal, and a spread of magnitudes.
        let mut x = 0.000123456789f64;
        while x < 1e12 {
            values.extend([x, -x, x * 1.0000001, (x * 1e3).round() / 1e3 + 0.0005]);
            x *= 3.7;
        }
        for v in values {
            for d in [0, 1, 2, 3, 4, 5, 6, 9] {
                // Rounded as f64::round rounds the scaled value (halves
                // away from zero).
                let scaled = v.abs() * 10f64.powi(d as i32);
                if let Some((n, _, _)) = fixed(v, d) {
                    assert_eq!(n as f64, scaled.round(), "{v} {d}");
                }
                let mut b = Vec::new();
                push_fixed(&mut b, v, d);
                let s = String::from_utf8(b).unwrap();
                if scaled.fract() == 0.5 {
                    // `format!` rounds exact halves to even.
                    continue;
                }
                let want = format!("{v:.*}", d as usize);
                let want =
                    if want.starts_with('-') && want[1..].chars().all(|c| c == '0' || c == '.') {
                        want[1..].to_string()
                    } else {
                        want
                    };
                assert_eq!(s, want, "{v} {d}");
                let read: f64 = s.parse().unwrap();
                let got = as_written(v, Column::Fixed(d));
                assert!(
                    read == got || (read.is_nan() && got.is_nan()),
                    "{v} {d}: {read} != {got}"
                );
            }
        }
    }

    #[test]
    fn times_are_written_as_format_writes_them() {
        let mut values = vec![
            0.0, -0.0, 1.0, 0.02, 17302.98, 1e15, 1e16, 1e17, 1e-5, 1e-7, 123e-20, 0.1,
        ];
        values.extend([
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MAX,
            f64::MIN_POSITIVE,
        ]);
        // Times of a 50 Hz log, and numbers of every magnitude and pattern.
        values.extend((0..20_000).map(|k| k as f64 * 0.02));
        values.extend((0..20_000).map(|k| 1.7e9 + k as f64 * 0.001));
        // Exactly halfway between two texts of the shortest length (the
        // digits past f64's precision are the point).
        #[allow(clippy::excessive_precision)]
        values.extend([1658206780088562.2, 10000000000000.0625, 68719476736.0078125]);
        for f in 1..12 {
            let q = 0.5f64.powi(f);
            values.extend((0..2000).map(|k| (1u64 << (40 + f % 13)) as f64 + k as f64 * q));
        }
        let mut bits = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..200_000 {
            bits ^= bits << 13;
            bits ^= bits >> 7;
            bits ^= bits << 17;
            values.push(f64::from_bits(bits));
        }
        for v in values {
            let mut b = Vec::new();
            push_time(&mut b, v);
            assert_eq!(String::from_utf8(b).unwrap(), format!("{v}"), "{v:e}");
        }
    }
}
