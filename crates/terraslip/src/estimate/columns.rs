//! `estimate.csv`'s columns, how each value is written, and `prediction.csv`.

use super::numbers;
use crate::pipeline::EstimateRow;

/// How a column of `estimate.csv` is written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Column {
    /// Seconds, shortest text that reads back as the same number.
    Time,
    /// Rounded to this many decimals.
    Fixed(u32),
    /// 0 or 1.
    Flag,
    /// The terrain's name (empty when unknown).
    Terrain,
}

/// The columns of `estimate.csv` (log-format.md's, then extras) and how
/// each is written; [`values`] gives a row's numbers in this order.
pub const COLUMNS: [(&str, Column); 25] = [
    ("t", Column::Time),
    ("east", Column::Fixed(4)),
    ("north", Column::Fixed(4)),
    ("yaw", Column::Fixed(6)),
    ("y_l", Column::Fixed(6)),
    ("y_r", Column::Fixed(6)),
    ("x_c", Column::Fixed(6)),
    ("std_east", Column::Fixed(4)),
    ("std_north", Column::Fixed(4)),
    ("std_yaw", Column::Fixed(6)),
    ("std_y_l", Column::Fixed(6)),
    ("std_y_r", Column::Fixed(6)),
    ("std_x_c", Column::Fixed(6)),
    ("terrain", Column::Terrain),
    ("alpha_l", Column::Fixed(5)),
    ("alpha_r", Column::Fixed(5)),
    ("std_alpha_l", Column::Fixed(5)),
    ("std_alpha_r", Column::Fixed(5)),
    ("std_spread", Column::Fixed(6)),
    ("fused", Column::Flag),
    ("gated", Column::Flag),
    ("nis", Column::Fixed(3)),
    ("q_scale", Column::Fixed(3)),
    ("change", Column::Flag),
    ("clock_offset", Column::Fixed(4)),
];

/// The header line of `estimate.csv` (without the newline).
pub fn header() -> String {
    COLUMNS.map(|c| c.0).join(",")
}

/// A row's numbers in the order of [`COLUMNS`], unrounded; flags are 0 or
/// 1, the terrain column is the index into [`EstimateRun::terrains`] (NaN
/// when unknown).
pub fn values(r: &EstimateRow) -> [f64; 25] {
    let flag = |b: bool| if b { 1.0 } else { 0.0 };
    [
        r.t,
        r.east,
        r.north,
        r.yaw,
        r.y_l,
        r.y_r,
        r.x_c,
        r.std[0],
        r.std[1],
        r.std[2],
        r.std[3],
        r.std[4],
        r.std[5],
        r.terrain.map_or(f64::NAN, |k| k as f64),
        r.alpha_l,
        r.alpha_r,
        r.std[6],
        r.std[7],
        r.std_spread,
        flag(r.fused),
        flag(r.gated),
        r.nis,
        r.q_scale,
        flag(r.change),
        r.clock_offset,
    ]
}

/// Writes the lines of `estimate.csv`. Each column's last text is kept:
/// many columns (the speed factors, `x_c`, the clock offset, `nis`) repeat
/// from row to row, and a repeated number is copied, not written again.
#[derive(Debug, Default)]
pub struct RowWriter {
    last: [Option<(u64, numbers::Text)>; 25],
}

impl RowWriter {
    /// Appends one line (UTF-8 text) for `r`; `terrains` names its terrain
    /// index ([`EstimateRun::terrains`]).
    pub fn write(&mut self, buf: &mut Vec<u8>, terrains: &[String], r: &EstimateRow) {
        for (k, (v, (_, col))) in values(r).into_iter().zip(COLUMNS).enumerate() {
            if k > 0 {
                buf.push(b',');
            }
            match col {
                Column::Time => numbers::push_time(buf, v),
                Column::Fixed(digits) => {
                    let bits = v.to_bits();
                    match &self.last[k] {
                        Some((b, text)) if *b == bits => text.push_to(buf),
                        _ => match numbers::fixed_text(v, digits) {
                            Some(text) => {
                                text.push_to(buf);
                                self.last[k] = Some((bits, text));
                            }
                            None => numbers::push_fixed(buf, v, digits),
                        },
                    }
                }
                Column::Flag => buf.push(if v != 0.0 { b'1' } else { b'0' }),
                Column::Terrain => buf.extend_from_slice(
                    r.terrain
                        .and_then(|k| terrains.get(k))
                        .map_or("", |s| s)
                        .as_bytes(),
                ),
            }
        }
        buf.push(b'\n');
    }
}

/// The text of `prediction.csv`: one line per start of the 2 s prediction
/// behind `summary.json`'s `prediction` (`t` s on the wheels' clock, the
/// learned model's and the no-slip model's position errors in m), each
/// number as the shortest text that reads back as the same number; a
/// header alone without a score. `terraslip report` plots these lines.
pub fn prediction_csv(score: Option<&terraslip_calib::prediction::PredictionScore>) -> String {
    use std::fmt::Write as _;
    let segments = score.map_or(&[][..], |s| &s.segments[..]);
    let mut text = String::with_capacity(48 * (segments.len() + 1));
    text.push_str("t,error_m,no_slip_m\n");
    for s in segments {
        let _ = writeln!(text, "{},{},{}", s.t, s.error, s.no_slip);
    }
    text
}

/// `v` as `estimate.csv` holds it: the number its text reads back as
/// ([`Column::Fixed`] columns rounded to their decimals).
pub fn as_written(v: f64, col: Column) -> f64 {
    match col {
        Column::Fixed(digits) => match numbers::fixed(v, digits) {
            // Both exact in f64 and the division correctly rounded: the
            // nearest double to the decimal text, as parsing gives.
            Some((n, scale, negative)) => {
                let x = n as f64 / scale as f64;
                if negative {
                    -x
                } else {
                    x
                }
            }
            None => v,
        },
        _ => v,
    }
}
