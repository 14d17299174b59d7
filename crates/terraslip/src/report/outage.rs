//! The report's dead reckoning through pose outages: `summary.json`'s
//! `outage` (each model dead-reckoning from the estimate's pose with the
//! pose withheld, its end read against the reference at 10, 30 and 60 s)
//! as a table, and a plot of the mean error against the outage's length.

use std::path::{Path, PathBuf};

use terraslip_report::{LegendPosition, LinePlot, ReportError, Section, Series, SeriesStyle};

/// The models as `summary.json` names them, in the order shown, with the
/// label shown, the plot's colour and whether its line is dashed.
const MODELS: [(&str, &str, usize, bool); 3] = [
    (
        crate::pipeline::outage::ONLINE,
        "learned (the estimator)",
        5,
        false,
    ),
    (
        crate::pipeline::outage::ODOMETRY_GYRO,
        "odometry + gyro",
        3,
        true,
    ),
    (crate::pipeline::outage::NO_SLIP, "no-slip", 6, true),
];

/// What the section adds: its text, and its plot with the caption.
pub(super) struct OutageSection {
    pub text: Vec<Section>,
    pub plot: Option<(PathBuf, String)>,
}

/// One horizon's figures of one model.
#[derive(serde::Deserialize)]
struct AtHorizon {
    horizon_s: f64,
    mean_m: f64,
    m_per_km: f64,
    along_rms_m: f64,
    cross_rms_m: f64,
    nees_median: Option<f64>,
    segments: usize,
}

/// The section for `outage` (`summary.json`'s, `None` or null when the
/// estimate has none), its plot written into `out`.
pub(super) fn section(
    outage: Option<&serde_json::Value>,
    out: &Path,
) -> Result<OutageSection, ReportError> {
    let models = outage.and_then(|o| o.get("models")).map(|m| {
        MODELS
            .iter()
            .filter_map(|&(key, label, color, dashed)| {
                let rows: Vec<AtHorizon> = serde_json::from_value(m.get(key)?.clone()).ok()?;
                (!rows.is_empty()).then_some((label, color, dashed, rows))
            })
            .collect::<Vec<_>>()
    });
    let Some(models) = models.filter(|m| !m.is_empty()) else {
        return Ok(OutageSection {
            text: vec![Section::Paragraph(
                "No dead reckoning through outages: summary.json's outage is empty (it needs a pose reference, and starts after the drive's first minute with the reference still there 10 s on).".into(),
            )],
            plot: None,
        });
    };
    let horizons: Vec<f64> = {
        let mut h: Vec<f64> = models
            .iter()
            .flat_map(|m| m.3.iter().map(|r| r.horizon_s))
            .collect();
        h.sort_by(f64::total_cmp);
        h.dedup();
        h
    };
    let mut headers = vec!["model".to_string()];
    headers.extend(horizons.iter().map(|h| format!("{h:.0} s")));
    headers.push("along / cross rms at 30 s".into());
    let rows = models
        .iter()
        .map(|(label, _, _, at)| {
            let mut row = vec![label.to_string()];
            for h in &horizons {
                row.push(
                    at.iter()
                        .find(|r| r.horizon_s == *h)
                        .map_or("-".into(), cell),
                );
            }
            row.push(
                at.iter()
                    .find(|r| r.horizon_s == 30.0)
                    .map_or("-".into(), |r| {
                        format!("{:.2} / {:.2} m", r.along_rms_m, r.cross_rms_m)
                    }),
            );
            row
        })
        .collect();
    let top = models
        .iter()
        .flat_map(|m| m.3.iter().map(|r| r.mean_m))
        .filter(|m| m.is_finite())
        .fold(0.0, f64::max);
    let mut plot = LinePlot::new(
        "Dead reckoning through a pose outage",
        "outage length [s]",
        "mean position error [m]",
    )
    .y_range(0.0, 1.1 * top.max(1e-3))
    .legend(LegendPosition::UpperLeft);
    for (label, color, dashed, at) in &models {
        let ends: Vec<(f64, f64)> = at.iter().map(|r| (r.horizon_s, r.mean_m)).collect();
        let line = Series::line(*label, ends).color(*color);
        plot = plot.series(if *dashed {
            line.style(SeriesStyle::Dashed)
        } else {
            line
        });
    }
    let path = out.join("outage.svg");
    plot.write_svg(&path)?;
    Ok(OutageSection {
        text: vec![
            Section::Paragraph(
                "Dead reckoning through a pose outage (summary.json's outage): from starts every 10 s after the first minute, each model dead-reckons with the pose withheld, setting out from the estimate's pose and heading, and its end is read against the reference. Mean end error, in m and per km driven; NEES: the median over the ends of the error squared over the estimator's own stated covariance, per degree of freedom (1 is right, over 2 over-confident); n: the ends scored. Along / cross: the error along and across the reference's track.".into(),
            ),
            Section::Table { headers, rows },
        ],
        plot: Some((
            path,
            "Mean position error at the end of a pose outage against its length: the learned model against the plain baselines".into(),
        )),
    })
}

/// A table cell: mean m (m/km; NEES; n).
fn cell(r: &AtHorizon) -> String {
    let nees = r
        .nees_median
        .map_or(String::new(), |n| format!("; NEES {n:.2}"));
    format!(
        "{:.2} m ({:.0} m/km{nees}; n {})",
        r.mean_m, r.m_per_km, r.segments
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_outage_figures_are_a_table_and_a_plot_or_say_why_not() {
        let at = |h: f64, m: f64, nees: Option<f64>| {
            serde_json::json!({"horizon_s": h, "mean_m": m, "median_m": m, "m_per_km": 10.0 * m,
                "along_rms_m": 0.5 * m, "cross_rms_m": 0.6 * m, "nees_median": nees, "segments": 7})
        };
        let outage = serde_json::json!({"horizons_s": [10.0, 30.0, 60.0], "models": {
            "online": [at(10.0, 1.0, Some(0.9)), at(30.0, 3.0, Some(1.1)), at(60.0, 6.0, Some(1.3))],
            "no-slip": [at(10.0, 2.0, None), at(30.0, 9.0, None), at(60.0, 20.0, None)],
        }});
        let dir = tempfile::tempdir().unwrap();
        let s = section(Some(&outage), dir.path()).unwrap();
        let Some(Section::Table { headers, rows }) = s.text.get(1) else {
            panic!("no table");
        };
        assert_eq!(headers[1..4], ["10 s", "30 s", "60 s"]);
        assert_eq!(rows.len(), 2, "{rows:?}");
        assert_eq!(rows[0][0], "learned (the estimator)");
        assert_eq!(rows[0][2], "3.00 m (30 m/km; NEES 1.10; n 7)");
        assert_eq!(rows[1][2], "9.00 m (90 m/km; n 7)");
        assert_eq!(rows[0][4], "1.50 / 1.80 m");
        let (path, _) = s.plot.expect("a plot");
        let svg = std::fs::read_to_string(path).unwrap();
        assert!(svg.contains("no-slip") && svg.contains("learned"));
        // No outage figures: said, nothing drawn.
        for none in [None, Some(serde_json::Value::Null)] {
            let s = section(none.as_ref(), dir.path()).unwrap();
            assert!(s.plot.is_none());
            assert!(
                matches!(&s.text[..], [Section::Paragraph(p)] if p.contains("outage is empty"))
            );
        }
    }
}
