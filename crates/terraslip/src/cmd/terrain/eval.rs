//! `terraslip terrain eval`: a model on labelled logs: confusion matrices,
//! raw and filtered accuracy, plots of the confusion and of each log's
//! terrain timeline.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use terraslip_io::DriveLog;
use terraslip_report::{Heatmap, LinePlot, Series, SeriesStyle};
use terraslip_terrain::confidence::{ConfidenceScore, ScoredWindow, UNKNOWN_BELOW};
use terraslip_terrain::{score_log, ChangeScore, Confusion, LogScore, Source, TerrainModel};

use super::logs::read_logs;
use super::progress::Progress;

#[derive(clap::Args)]
pub(super) struct EvalArgs {
    /// Log directories with terrain.csv labels.
    #[arg(required = true)]
    logs: Vec<PathBuf>,
    /// Model file written by `terrain train`.
    #[arg(long)]
    model: PathBuf,
    /// Directory for the plots (confusion matrix, one timeline per log).
    #[arg(long, default_value = "out/terrain-eval")]
    plots: PathBuf,
    /// Print one JSON object on stdout: windows, accuracy, accuracy_filtered,
    /// classes, confusion (rows = true class), confusion_filtered,
    /// outside_envelope_share (share of windows driven at a speed or turn no
    /// training run of the terrain they were read as has; null for models
    /// without an envelope), per-log scores.
    #[arg(long)]
    json: bool,
    /// Write one CSV row per scored window: log,t,truth,predicted,confidence
    /// (t the window's end, s; predicted `unknown` when the confidence is
    /// below 0.5). Written atomically.
    #[arg(long, value_name = "FILE.csv")]
    windows: Option<PathBuf>,
}

pub(super) fn run(a: EvalArgs) -> anyhow::Result<()> {
    let inputs = super::super::inputs_with(&a.logs, &[("--model", Some(&a.model))]);
    inputs.check_dir(
        "--plots",
        &a.plots,
        &["confusion.svg", "confusion_filtered.svg"],
    )?;
    if let Some(w) = &a.windows {
        inputs.check("--windows", w)?;
    }
    let model = TerrainModel::load(&a.model).context("loading the terrain model")?;
    let logs = read_logs(&a.logs, a.json)?;
    for log in &logs {
        if let Some(unknown) = log
            .terrain_names()
            .into_iter()
            .find(|n| !model.classes.contains(n))
        {
            bail!(
                "{}: terrain `{unknown}` is not one of the model's classes {:?}",
                log.dir.display(),
                model.classes
            );
        }
    }
    let mut bar = Progress::new(logs.len() as u64, "classifying", a.json);
    let mut raw = Confusion::new(&model.classes);
    let mut filtered = Confusion::new(&model.classes);
    let mut scores = Vec::new();
    let mut change = ChangeScore::default();
    let mut outside = model.envelope.as_ref().map(|_| 0usize);
    for log in &logs {
        let s =
            score_log(&model, log).with_context(|| format!("classifying {}", log.dir.display()))?;
        raw.merge(&s.raw);
        filtered.merge(&s.filtered);
        change.merge(&s.change);
        if let (Some(o), Some(n)) = (outside.as_mut(), s.outside_envelope) {
            *o += n;
        }
        scores.push(s);
        bar.inc();
    }
    bar.finish();
    if raw.total() == 0 {
        let window = model.window_s();
        let why: Vec<String> = logs
            .iter()
            .map(|log| format!("{}: {}", log.name(), no_window_reason(log, window)))
            .collect();
        bail!(
            "scored 0 windows: {}; give logs with labelled data longer than the model's window",
            why.join("; ")
        );
    }
    for (log, s) in logs.iter().zip(&scores) {
        if s.raw.total() == 0 {
            eprintln!(
                "note: {}: no window scored ({})",
                log.name(),
                no_window_reason(log, model.window_s())
            );
        }
    }
    std::fs::create_dir_all(&a.plots)
        .with_context(|| format!("creating plot directory {}", a.plots.display()))?;
    let mut plots = vec![
        a.plots.join("confusion.svg"),
        a.plots.join("confusion_filtered.svg"),
    ];
    Heatmap::confusion("Confusion (single windows)", &raw.classes, &raw.counts)
        .write_svg(&plots[0])
        .context("drawing the confusion matrix")?;
    Heatmap::confusion(
        "Confusion (after the Bayesian filter)",
        &filtered.classes,
        &filtered.counts,
    )
    .write_svg(&plots[1])
    .context("drawing the confusion matrix")?;
    for (i, s) in scores.iter().enumerate() {
        let p = a
            .plots
            .join(format!("timeline_{:02}_{}.svg", i, sanitize(&s.log)));
        timeline_plot(s, &model.classes)
            .write_svg(&p)
            .context("drawing the terrain timeline")?;
        plots.push(p);
    }
    let change_text = if model.source == Source::Camera {
        format!(
            "change detector (lv2019): {} of {} terrain changes flagged within one frame, {} false alarms\n",
            change.detected, change.changes, change.false_alarms
        )
    } else {
        String::new()
    };
    let outside_share = outside.map(|o| o as f64 / raw.total().max(1) as f64);
    let envelope_text = match outside_share {
        Some(f) if f > 0.0 => format!(
            "driven outside the training envelope: {:.1} % of the windows (a speed or turn that no \
             training run of the terrain they were read as has; their confidence was lowered; \
             record such driving on every terrain and retrain)\n",
            100.0 * f
        ),
        Some(_) => "driven outside the training envelope: none of the windows\n".into(),
        None => String::new(),
    };
    let windows: Vec<ScoredWindow> = scores.iter().flat_map(|s| s.windows.clone()).collect();
    let confidence = ConfidenceScore::of(&windows);
    if let Some(path) = &a.windows {
        write_windows(path, &scores, &model.classes)?;
    }
    let unknown_text = format!("unknown: confidence below {UNKNOWN_BELOW}\n");
    let text = format!(
        "{} windows from {} logs\nsingle windows: accuracy {:.1} % (balanced {:.1} %)\n{}\nafter the Bayesian filter: accuracy {:.1} % (balanced {:.1} %)\n{}{change_text}{envelope_text}{unknown_text}{}plots in {}",
        raw.total(),
        logs.len(),
        100.0 * raw.accuracy(),
        100.0 * raw.balanced_accuracy(),
        raw.to_table(),
        100.0 * filtered.accuracy(),
        100.0 * filtered.balanced_accuracy(),
        filtered.to_table(),
        confidence.to_text(),
        a.plots.display()
    );
    if a.json {
        eprintln!("{text}");
        let per_log: Vec<_> = scores
            .iter()
            .map(|s| {
                serde_json::json!({
                    "log": s.log, "windows": s.raw.total(),
                    "accuracy": s.raw.accuracy(), "accuracy_filtered": s.filtered.accuracy(),
                    "outside_envelope_share": s.outside_envelope
                        .map(|o| o as f64 / s.raw.total().max(1) as f64),
                })
            })
            .collect();
        let out = serde_json::json!({
            "windows": raw.total(),
            "accuracy": raw.accuracy(),
            "accuracy_filtered": filtered.accuracy(),
            "balanced_accuracy": raw.balanced_accuracy(),
            "classes": raw.classes,
            "confusion": raw.counts,
            "confusion_filtered": filtered.counts,
            "source": model.source.name(),
            "change_detection": change,
            "outside_envelope_share": outside_share,
            "confidence": confidence,
            "unknown_below": UNKNOWN_BELOW,
            "logs": per_log,
            "plots": plots,
        });
        println!("{out}");
    } else {
        println!("{text}");
    }
    Ok(())
}

/// `--windows`: one row per scored window, written atomically.
fn write_windows(path: &Path, scores: &[LogScore], classes: &[String]) -> anyhow::Result<()> {
    let mut out = String::from("log,t,truth,predicted,confidence\n");
    for s in scores {
        for w in &s.windows {
            let predicted = if w.unknown {
                "unknown"
            } else {
                classes[w.predicted].as_str()
            };
            out += &format!(
                "{},{:.3},{},{predicted},{:.4}\n",
                csv_field(&s.log),
                w.t,
                classes[w.truth],
                w.confidence
            );
        }
    }
    terraslip_io::write_atomic(path, out.as_bytes())
        .with_context(|| format!("writing --windows {}", path.display()))
}

/// A CSV field, quoted when it holds a comma, quote or line break.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// Why a log gave no scored window: too short for the window, or no label
/// in force at any window's end.
fn no_window_reason(log: &DriveLog, window_s: f64) -> String {
    let span = |t: &mut dyn Iterator<Item = f64>| {
        let v: Vec<f64> = t.collect();
        match (v.first(), v.last()) {
            (Some(a), Some(b)) => b - a,
            _ => 0.0,
        }
    };
    let imu = span(&mut log.imu.iter().map(|s| s.t));
    if !log.images.is_empty() {
        return "no frame has a terrain label in force".into();
    }
    if imu < window_s {
        format!("imu.csv covers {imu:.1} s, shorter than the model's {window_s} s window")
    } else {
        "no window ends where a terrain label is in force".into()
    }
}

fn sanitize(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// True, raw and filtered terrain (class index) against time.
fn timeline_plot(s: &LogScore, classes: &[String]) -> LinePlot {
    let truth: Vec<(f64, f64)> = s
        .frames
        .iter()
        .zip(&s.truth)
        .filter_map(|(f, t)| t.map(|t| (f.t, t as f64)))
        .collect();
    let raw: Vec<(f64, f64)> = s
        .frames
        .iter()
        .map(|f| (f.t, f.raw as f64 + 0.08))
        .collect();
    let filt: Vec<(f64, f64)> = s
        .frames
        .iter()
        .map(|f| (f.t, f.filtered as f64 - 0.08))
        .collect();
    let legend: Vec<String> = classes
        .iter()
        .enumerate()
        .map(|(i, c)| format!("{i}={c}"))
        .collect();
    LinePlot::new(
        format!(
            "{}: raw {:.1} %, filtered {:.1} %",
            s.log,
            100.0 * s.raw.accuracy(),
            100.0 * s.filtered.accuracy()
        ),
        "time [s]",
        format!("terrain ({})", legend.join(", ")),
    )
    .y_range(-0.5, classes.len() as f64 - 0.5)
    .series(
        Series::line("true", truth)
            .style(SeriesStyle::Bold)
            .color(0),
    )
    .series(Series::points("classifier", raw).color(4))
    .series(Series::line("Bayesian filter", filt).color(5))
}
