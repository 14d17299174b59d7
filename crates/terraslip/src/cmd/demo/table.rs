//! The demo's comparison table: one row per variant, as markdown and as
//! aligned text for the terminal.

use terraslip_report::markdown_table;

use super::outcome::Outcome;

pub(super) fn cm(v: f64) -> String {
    if v.is_finite() {
        format!("{:.1}", 100.0 * v)
    } else {
        "-".into()
    }
}

/// The comparison table: one row per variant.
pub(super) struct Table {
    pub headers: Vec<String>,
    pub rows: Vec<Vec<String>>,
    pub markdown: String,
}

impl Table {
    pub(super) fn new(outcomes: &[Outcome], changes: &[(f64, String)]) -> Self {
        let (headers, rows) = cells(outcomes, changes);
        let header_refs: Vec<&str> = headers.iter().map(String::as_str).collect();
        let markdown = markdown_table(&header_refs, &rows);
        Self {
            headers,
            rows,
            markdown,
        }
    }

    /// The table with aligned columns, for the terminal.
    pub(super) fn text(&self) -> String {
        text_table(&self.headers, &self.rows)
    }
}

pub(super) fn cells(
    outcomes: &[Outcome],
    changes: &[(f64, String)],
) -> (Vec<String>, Vec<Vec<String>>) {
    let mut headers = vec!["variant".to_string()];
    for (t, name) in changes {
        headers.push(format!("re-conv. to {name} @{t:.0}s [s]"));
    }
    for h in [
        "RMS d [cm]",
        "RMS y_l [cm]",
        "RMS y_r [cm]",
        "RMS x_c [cm]",
        "outage drift [%]",
    ] {
        headers.push(h.to_string());
    }
    let rows = outcomes
        .iter()
        .map(|o| {
            let mut r = vec![o.name.clone()];
            for (t, _) in changes {
                let rec = o
                    .card
                    .reconvergence
                    .iter()
                    .find(|c| (c.t_change - t).abs() < 1e-6);
                r.push(match rec {
                    Some(c) => match c.seconds {
                        Some(s) => format!("{s:.1}"),
                        None => format!("> {:.0}", c.segment),
                    },
                    None => "-".into(),
                });
            }
            let rms = &o.card.rms;
            r.extend([cm(rms.d), cm(rms.y_l), cm(rms.y_r), cm(rms.x_c)]);
            r.push(match &o.card.drift {
                Some(d) => format!("{:.2} ({:.2} m of {:.1} m)", d.percent, d.error, d.distance),
                None => "-".into(),
            });
            r
        })
        .collect();
    (headers, rows)
}

/// The table with aligned columns, for the terminal.
pub(super) fn text_table(headers: &[String], rows: &[Vec<String>]) -> String {
    let mut width: Vec<usize> = headers.iter().map(|h| h.chars().count()).collect();
    for r in rows {
        for (w, c) in width.iter_mut().zip(r) {
            *w = (*w).max(c.chars().count());
        }
    }
    let line = |cells: &[String]| {
        cells
            .iter()
            .zip(&width)
            .enumerate()
            .map(|(i, (c, w))| {
                if i == 0 {
                    format!("{c:<w$}")
                } else {
                    format!("{c:>w$}")
                }
            })
            .collect::<Vec<_>>()
            .join("  ")
    };
    let mut out = line(headers);
    out.push('\n');
    out.push_str(&"-".repeat(out.chars().count().saturating_sub(1)));
    for r in rows {
        out.push('\n');
        out.push_str(&line(r));
    }
    out
}
