//! What `terraslip report EST_DIR` draws from an estimate and its log: the
//! track against the pose reference, the ICRs and speed factors with 2σ
//! bands and the terrain, the 2 s prediction error over time (the
//! segments `estimate` scored for `summary.json`'s `prediction`), and the
//! dead reckoning through pose outages (`summary.json`'s `outage`).

mod outage;

use std::path::{Path, PathBuf};

use terraslip_calib::prediction::{PredictionScore, PredictionSegment, PredictionSpec};
use terraslip_core::IcrParams;
use terraslip_io::{DriveLog, EstimateRecord, PredictionRecord};
use terraslip_report::{Figure, LinePlot, Section, Series, SeriesStyle};

/// Why a report could not be drawn.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    #[error("{0}")]
    Log(#[from] terraslip_io::LogError),
    #[error("{0}")]
    Plot(#[from] terraslip_report::ReportError),
    #[error("{path}: cannot write: {source}")]
    Write {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{0}: has no rows")]
    Empty(PathBuf),
}

/// The files a report wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct Written {
    pub page: PathBuf,
    pub plots: Vec<PathBuf>,
}

/// Every `stride`-th element and the last one (plots need no 50 Hz).
fn thin<T: Clone>(v: &[T], max: usize) -> Vec<T> {
    let stride = (v.len() / max.max(1)).max(1);
    let mut out: Vec<T> = v.iter().step_by(stride).cloned().collect();
    if let Some(last) = v.last() {
        if v.len() % stride != 1 {
            out.push(last.clone());
        }
    }
    out
}

/// Times where the estimate's terrain changes, with the new name.
fn terrain_changes(rows: &[EstimateRecord]) -> Vec<(f64, String)> {
    rows.windows(2)
        .filter(|w| w[0].terrain != w[1].terrain && !w[1].terrain.is_empty())
        .map(|w| (w[1].t, w[1].terrain.clone()))
        .collect()
}

/// The 2 s prediction errors `estimate` scored (the lines of its
/// `prediction.csv`), as the score `summary.json`'s `prediction` holds:
/// the same segments, the same statistics.
pub fn prediction_score(segments: &[PredictionRecord]) -> Option<PredictionScore> {
    let segments = segments
        .iter()
        .map(|r| PredictionSegment {
            t: r.t,
            error: r.error_m,
            no_slip: r.no_slip_m,
        })
        .collect::<Vec<_>>();
    (!segments.is_empty())
        .then(|| PredictionScore::from_segments(PredictionSpec::default(), segments))
}

/// Draws the report of `rows` (an `estimate.csv`) over `log` (for the pose
/// reference; `None` leaves it out), `prediction` (the estimate's
/// `prediction.csv`; `None` when the estimate directory has none) and
/// `summary` (its `summary.json`: the final ICRs, what was learned, the
/// whole drive's recommendation, the warnings) into `out`: `report.html`
/// and up to four SVG plots.
pub fn write(
    rows: &[EstimateRecord],
    log: Option<&DriveLog>,
    prediction: Option<&[PredictionRecord]>,
    summary: Option<&serde_json::Value>,
    out: &Path,
    title: &str,
) -> Result<Written, ReportError> {
    let final_icr = summary
        .and_then(|s| serde_json::from_value::<IcrParams>(s["icr"].clone()).ok())
        .filter(|_| !nothing_learned(summary));
    let final_icr = final_icr.as_ref();
    if rows.is_empty() {
        return Err(ReportError::Empty(out.join("estimate.csv")));
    }
    std::fs::create_dir_all(out).map_err(|source| ReportError::Write {
        path: out.to_path_buf(),
        source,
    })?;
    let thin_rows = thin(rows, 3000);
    let changes = terrain_changes(rows);
    let mut plots = Vec::new();

    // The track: the estimate, then the reference over it.
    let mut track = LinePlot::new("Track", "east [m]", "north [m]")
        .equal_aspect(true)
        .series(
            Series::line(
                "estimate",
                thin_rows.iter().map(|r| (r.east, r.north)).collect(),
            )
            .color(5),
        );
    let mut track_caption =
        "Track: the estimate (no pose reference to draw against it)".to_string();
    if let Some(log) = log {
        let (name, reference): (&str, Vec<(f64, f64)>) = if log.truth.is_empty() {
            let pose = log.pose.iter().filter_map(|p| p.east.zip(p.north));
            ("pose reference", pose.collect())
        } else {
            (
                "ground truth",
                log.truth.iter().map(|s| (s.east, s.north)).collect(),
            )
        };
        if !reference.is_empty() {
            track = track.series(
                Series::line(name, thin(&reference, 3000))
                    .color(0)
                    .style(SeriesStyle::Dashed),
            );
            track_caption = if log.truth.is_empty() {
                "Track: the estimate against the log's pose reference (dashed, drawn over it)"
            } else {
                "Track: the estimate against the ground truth of a simulated log (dashed, drawn over it)"
            }
            .to_string();
        }
    }
    let path = out.join("track.svg");
    track.write_svg(&path)?;
    plots.push((path, track_caption));

    // The slip parameters with 2σ bands and the terrain.
    let band = |f: &dyn Fn(&EstimateRecord) -> (f64, f64)| -> Vec<(f64, f64, f64)> {
        thin_rows
            .iter()
            .map(|r| {
                let (v, s) = f(r);
                (r.t, v - 2.0 * s, v + 2.0 * s)
            })
            .collect()
    };
    let line = |f: &dyn Fn(&EstimateRecord) -> f64| -> Vec<(f64, f64)> {
        thin_rows.iter().map(|r| (r.t, f(r))).collect()
    };
    let mut spread = LinePlot::new("ICRs in effect (2σ bands)", "t [s]", "[m]")
        .band("y_l 2σ", band(&|r| (r.y_l, r.std_y_l)), Some(1))
        .band("y_r 2σ", band(&|r| (r.y_r, r.std_y_r)), Some(2))
        .series(Series::line("y_l", line(&|r| r.y_l)).color(1))
        .series(Series::line("y_r", line(&|r| r.y_r)).color(2))
        .series(Series::line("x_c", line(&|r| r.x_c)).color(3));
    let mut factors = LinePlot::new("Tread speed factors (2σ bands)", "t [s]", "alpha")
        .band("alpha_l 2σ", band(&|r| (r.alpha_l, r.std_alpha_l)), Some(1))
        .band("alpha_r 2σ", band(&|r| (r.alpha_r, r.std_alpha_r)), Some(2))
        .series(Series::line("alpha_l", line(&|r| r.alpha_l)).color(1))
        .series(Series::line("alpha_r", line(&|r| r.alpha_r)).color(2));
    for (t, name) in &changes {
        spread = spread.marker(*t, name.clone());
        factors = factors.marker(*t, name.clone());
    }
    let path = out.join("slip.svg");
    Figure::new(vec![spread, factors]).write_svg(&path)?;
    plots.push((
        path,
        "ICRs in effect and speed factors, with 2σ bands; vertical lines: terrain changes".into(),
    ));

    // The 2 s prediction error over time: the segments behind
    // summary.json's `prediction`, as `estimate` scored them.
    let prediction_text = match prediction.map(prediction_score) {
        None => "No 2 s prediction error: the estimate directory has no prediction.csv (run `terraslip estimate` again to write it).".to_string(),
        Some(None) => "No 2 s prediction error: the estimate scored none (summary.json's warnings say why).".to_string(),
        Some(Some(p)) => {
            let mut plot =
                LinePlot::new("2 s prediction error", "start t [s]", "position error [m]")
                    .series(
                        Series::line(
                            "no-slip",
                            p.segments.iter().map(|s| (s.t, s.no_slip)).collect(),
                        )
                        .color(6)
                        .style(SeriesStyle::Dashed),
                    )
                    .series(
                        Series::line(
                            "learned ICRs",
                            p.segments.iter().map(|s| (s.t, s.error)).collect(),
                        )
                        .color(5),
                    );
            for (t, name) in &changes {
                plot = plot.marker(*t, name.clone());
            }
            let path = out.join("prediction.svg");
            plot.write_svg(&path)?;
            plots.push((
                path,
                "2 s prediction error per start: learned ICRs against the no-slip model".into(),
            ));
            format!(
                "2 s prediction error against the pose reference (summary.json's prediction: each start predicted with the model the estimator had then, the pose read with the clock offset it had learned) over {} segments: mean {:.3} m, p90 {:.3} m with the learned ICRs; mean {:.3} m, p90 {:.3} m with the no-slip model.",
                p.segments.len(),
                p.stats.mean_m,
                p.stats.p90_m,
                p.no_slip.mean_m,
                p.no_slip.p90_m
            )
        }
    };
    let mut sections = vec![Section::Paragraph(end_values(rows, final_icr))];
    if let Some(s) = summary {
        sections.extend(
            crate::estimate::headline::headline(s)
                .into_iter()
                .filter(|l| !l.starts_with("2 s prediction"))
                .map(Section::Paragraph),
        );
        let warnings: Vec<String> = s["warnings"].as_array().map_or(Vec::new(), |w| {
            w.iter()
                .filter_map(|w| w.as_str().map(|w| format!("Warning: {w}")))
                .collect()
        });
        sections.extend(warnings.into_iter().map(Section::Paragraph));
    }
    sections.push(Section::Paragraph(prediction_text));
    let outage = outage::section(summary.and_then(|s| s.get("outage")), out)?;
    sections.extend(outage.text);
    plots.extend(outage.plot);
    for (p, caption) in &plots {
        sections.push(Section::Image {
            src: p
                .file_name()
                .map_or(String::new(), |n| n.to_string_lossy().into()),
            caption: caption.clone(),
        });
    }
    let page = out.join("report.html");
    let html = terraslip_report::html_page(title, &sections);
    terraslip_io::write_atomic(&page, html.as_bytes())?;
    Ok(Written {
        page,
        plots: plots.into_iter().map(|(p, _)| p).collect(),
    })
}

/// Whether `summary.json` says every slip parameter was held.
fn nothing_learned(summary: Option<&serde_json::Value>) -> bool {
    summary
        .and_then(|s| s["learning"].as_object())
        .is_some_and(|l| {
            !l.is_empty()
                && l.values()
                    .all(|v| v.as_str().is_some_and(|v| v.starts_with("held")))
        })
}

/// The report's first line: the final ICRs as the terminal and
/// `summary.json` give them (straight-line values of the turn law), and
/// the ICRs in effect at the last row's turn rate, each labelled.
fn end_values(rows: &[EstimateRecord], final_icr: Option<&IcrParams>) -> String {
    let first = &rows[0];
    let last = &rows[rows.len() - 1];
    let fmt = |y_l: f64, y_r: f64, x_c: f64, a_l: f64, a_r: f64| {
        format!("y_l = {y_l:.3} m, y_r = {y_r:.3} m, x_c = {x_c:.3} m, alpha_l = {a_l:.3}, alpha_r = {a_r:.3}")
    };
    let in_effect = format!(
        "in effect at the last row's turn rate (the turn law applied, as in estimate.csv): {}",
        fmt(last.y_l, last.y_r, last.x_c, last.alpha_l, last.alpha_r)
    );
    let end = match final_icr {
        Some(p) => format!(
            "Final ICRs (straight-line values of the turn law, as in summary.json): {}; {in_effect}.",
            fmt(p.y_l, p.y_r, p.x_c, p.alpha_l, p.alpha_r)
        ),
        None => format!("ICRs held at their starting values (nothing learned, summary.json's `learning` says why; none is a finding): {in_effect}."),
    };
    format!("{} rows over {:.1} s. {end}", rows.len(), last.t - first.t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_real_logs_report_shows_its_warnings_and_holds_nothing_as_a_finding() {
        let rows: Vec<EstimateRecord> = (0..20)
            .map(|k| EstimateRecord {
                t: k as f64,
                east: 0.1 * k as f64,
                y_l: 0.25,
                y_r: -0.25,
                alpha_l: 1.0,
                alpha_r: 1.0,
                ..Default::default()
            })
            .collect();
        let pose = (0..20)
            .map(|k| terraslip_io::PoseObs {
                t: k as f64,
                east: Some(0.1 * k as f64),
                north: Some(0.0),
                ..Default::default()
            })
            .collect();
        let log = DriveLog {
            pose,
            ..Default::default()
        };
        let held =
            "held (no position, heading or gyro: nothing measures the motion; its starting value)";
        let summary = serde_json::json!({
            "icr": {"y_l": 0.25, "y_r": -0.25, "x_c": 0.0, "alpha_l": 1.0, "alpha_r": 1.0},
            "learning": {"spread": held, "speed_factor": held, "speed_factor_difference": held, "icr_centre_offsets": held},
            "warnings": ["wheels.csv:12: 3 row(s) repeat the previous timestamp"],
        });
        let dir = tempfile::tempdir().unwrap();
        let w = write(&rows, Some(&log), None, Some(&summary), dir.path(), "t").unwrap();
        let page = std::fs::read_to_string(&w.page).unwrap();
        assert!(!page.contains("Final ICRs"), "{page}");
        assert!(page.contains("held at their starting values"));
        assert!(page.contains("Warning: wheels.csv:12: 3 row(s) repeat"));
        assert!(
            page.contains("the log&#x27;s pose reference")
                || page.contains("the log's pose reference"),
            "{page}"
        );
        assert!(!page.contains("simulated"));
        // The reference is drawn after (over) the estimate.
        let svg = std::fs::read_to_string(dir.path().join("track.svg")).unwrap();
        let (e, r) = (svg.find("estimate"), svg.find("pose reference"));
        assert!(e.is_some() && r.is_some() && e < r, "{e:?} {r:?}");
    }

    #[test]
    fn end_values_label_which_icrs_they_are() {
        let row = |t: f64, y_l: f64| EstimateRecord {
            t,
            y_l,
            y_r: -y_l,
            alpha_l: 1.0,
            alpha_r: 1.0,
            ..Default::default()
        };
        let rows = [row(0.0, 0.5), row(10.0, 0.885)];
        let p = IcrParams {
            y_l: 1.767,
            y_r: -1.767,
            x_c: 0.0,
            alpha_l: 1.0,
            alpha_r: 1.0,
        };
        let s = end_values(&rows, Some(&p));
        assert!(
            s.starts_with("2 rows over 10.0 s. Final ICRs (straight-line values of the turn law, as in summary.json): y_l = 1.767 m"),
            "{s}"
        );
        assert!(
            s.contains("in effect at the last row's turn rate (the turn law applied, as in estimate.csv): y_l = 0.885 m"),
            "{s}"
        );
        assert!(end_values(&rows, None).contains("in effect at the last row's turn rate"));
    }

    #[test]
    fn thinning_keeps_the_ends() {
        let v: Vec<usize> = (0..10_001).collect();
        let t = thin(&v, 100);
        assert_eq!(t.first(), Some(&0));
        assert_eq!(t.last(), Some(&10_000));
        assert!(t.len() <= 102);
    }
}
