//! The text of one CSV cell: trimmed, and read as a number. Both are done
//! for every cell of a log (millions on a long drive), so the common case
//! (a plain decimal without surrounding blanks) takes a short path that
//! gives exactly what the general one gives.

/// `cell` without leading and trailing whitespace, as `str::trim` gives it.
#[inline]
pub(crate) fn trim(cell: &str) -> &str {
    let b = cell.as_bytes();
    match (b.first(), b.last()) {
        // Visible ASCII at both ends: nothing to trim.
        (Some(f), Some(l)) if f.is_ascii_graphic() && l.is_ascii_graphic() => cell,
        _ => cell.trim(),
    }
}

/// Powers of ten that are exact in `f64`.
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// `cell` read as `str::parse::<f64>` reads it.
#[inline]
pub(crate) fn parse_f64(cell: &str) -> Option<f64> {
    plain_decimal(cell.as_bytes()).or_else(|| cell.parse().ok())
}

/// A plain decimal (`[+-]digits[.digits]`) whose digits, as an integer,
/// are exact in `f64` (at most 2^53) with at most 22 decimals: that
/// integer over a power of ten, both exact, so the one division rounds
/// correctly and gives the nearest `f64`, as parsing does (Clinger's fast
/// path). `None` for anything else.
fn plain_decimal(b: &[u8]) -> Option<f64> {
    let (negative, digits) = match b.first()? {
        b'-' => (true, &b[1..]),
        b'+' => (false, &b[1..]),
        _ => (false, b),
    };
    let (mut m, mut count, mut decimals) = (0u64, 0usize, None::<usize>);
    for &c in digits {
        match c {
            b'0'..=b'9' => {
                count += 1;
                // 19 digits cannot overflow a u64.
                if count > 19 {
                    return None;
                }
                m = m * 10 + u64::from(c - b'0');
                if let Some(d) = decimals.as_mut() {
                    *d += 1;
                }
            }
            b'.' if decimals.is_none() => decimals = Some(0),
            _ => return None,
        }
    }
    let decimals = decimals.unwrap_or(0);
    if count == 0 || m > 1 << 53 || decimals >= POW10.len() {
        return None;
    }
    let v = m as f64 / POW10[decimals];
    Some(if negative { -v } else { v })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_read_as_str_parse_reads_them() {
        let mut cells: Vec<String> = [
            "0",
            "-0",
            "+0",
            "0.0",
            "-0.0",
            "1",
            "1.",
            ".5",
            "-.5",
            "+.5",
            ".",
            "-",
            "+",
            "",
            "1.2.3",
            "1e5",
            "1E-3",
            "inf",
            "NaN",
            "-inf",
            "0x10",
            "1_000",
            " 1",
            "1 ",
            "--1",
            "0.1",
            "0.2",
            "0.3",
            "17302.98",
            "9007199254740992",
            "9007199254740993",
            "9007199254740993.5",
            "0.00000000000000000000001",
            "1234567890123456789",
            "12345678901234567890",
            "00000000000000000001",
            "0.5487802414400826",
            "-0.951719758476584",
            "1.7976931348623157",
            "4503599627370497.5",
        ]
        .map(String::from)
        .to_vec();
        // Decimals of every length around the limits of the short path.
        let mut bits = 0x243f_6a88_85a3_08d3u64;
        for _ in 0..100_000 {
            bits ^= bits << 13;
            bits ^= bits >> 7;
            bits ^= bits << 17;
            let digits = (bits % 10_u64.pow((bits >> 56) as u32 % 19 + 1)).to_string();
            let point = (bits >> 40) as usize % (digits.len() + 1);
            let sign = ["", "-", "+"][(bits >> 20) as usize % 3];
            cells.push(format!("{sign}{}.{}", &digits[..point], &digits[point..]));
            cells.push(format!("{sign}{digits}"));
        }
        for c in &cells {
            let want = c.parse::<f64>().ok();
            let got = parse_f64(c);
            assert!(
                want.map(f64::to_bits) == got.map(f64::to_bits),
                "{c:?}: {got:?} != {want:?}"
            );
            assert_eq!(trim(c), c.trim(), "{c:?}");
        }
        for c in [
            " 1",
            "1\t",
            "\u{a0}1\u{a0}",
            "\u{2003}x",
            "",
            " ",
            "é",
            "x\u{3000}",
        ] {
            assert_eq!(trim(c), c.trim(), "{c:?}");
        }
    }
}
