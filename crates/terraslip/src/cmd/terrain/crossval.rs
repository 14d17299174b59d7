//! `terraslip terrain crossval`: leave-runs-out cross-validation, with the
//! held-out runs also spliced into logs with terrain changes.

use std::path::PathBuf;

use anyhow::{bail, Context};
use terraslip_terrain::{crossval, crossval_manoeuvre, CrossvalReport, Source, TrainOptions};

use super::logs::read_logs;
use super::progress::Progress;
use super::settings::{baseline_options, options, TrainSettings};

#[derive(clap::Args)]
pub(super) struct CrossvalArgs {
    /// Log directories with terrain.csv labels, one run each.
    #[arg(required = true)]
    logs: Vec<PathBuf>,
    /// Number of folds (at least 2); runs of each terrain are dealt
    /// round-robin. Use the number of logs for leave-one-run-out. Folds run
    /// in parallel (TERRASLIP_THREADS caps the threads).
    #[arg(long, default_value_t = 5, value_parser = parse_folds)]
    folds: usize,
    /// Which runs are held out. `runs`: dealt round-robin to --folds folds.
    /// `manoeuvre`: one fold of the runs driven outside the speeds and turn
    /// rates of the other runs of their terrain (each terrain's fastest drive
    /// and slowest spin, by the runs' own mean tread speed and tread
    /// difference; a run spins when |v_r - v_l| / (|v_l| + |v_r|) averages
    /// 0.5 or more), trained on all the others: how the model carries to a
    /// way of driving it has not seen.
    #[arg(long, value_enum, default_value_t = Split::Runs)]
    split: Split,
    #[command(flatten)]
    settings: TrainSettings,
    /// Print one JSON object on stdout.
    #[arg(long)]
    json: bool,
    /// Skip the plain baseline (boosted trees with default settings on the
    /// measured features: no speed normalisation, slip terms or speed
    /// copies) cross-validated on the same folds beside the model.
    #[arg(long)]
    no_baseline: bool,
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Split {
    Runs,
    Manoeuvre,
}

pub(super) fn run(a: CrossvalArgs) -> anyhow::Result<()> {
    let opts = options(&a.settings)?;
    let mut seen: Vec<(PathBuf, &PathBuf)> = Vec::with_capacity(a.logs.len());
    for p in &a.logs {
        let real = std::fs::canonicalize(p).unwrap_or_else(|_| p.clone());
        if let Some((_, first)) = seen.iter().find(|(r, _)| *r == real) {
            bail!(
                "run {} is given twice ({} and {}): it would be trained and tested on; give each run once",
                real.display(),
                first.display(),
                p.display()
            );
        }
        seen.push((real, p));
    }
    let logs = read_logs(&a.logs, a.json)?;
    let folds = match a.split {
        Split::Runs => a.folds.min(logs.len()),
        Split::Manoeuvre => 1,
    };
    let cross = |opts: &TrainOptions, what: &'static str| {
        let mut bar = Progress::new(folds as u64, what, a.json);
        let r = match a.split {
            Split::Runs => crossval(&logs, opts, a.folds, |i, _| bar.set(i as u64))
                .map(|r| (r, Vec::new()))
                .context("cross-validation"),
            Split::Manoeuvre => crossval_manoeuvre(&logs, opts, |i, _| bar.set(i as u64))
                .context("cross-validation by manoeuvre"),
        };
        bar.finish();
        r
    };
    let (rep, held) = cross(&opts, "cross-validating (folds done)")?;
    let baseline = if a.no_baseline {
        None
    } else {
        Some(cross(&baseline_options(&opts), "plain baseline (folds done)")?.0)
    };
    let latency = rep.latency_summary();
    let split = match a.split {
        Split::Runs => format!("{} folds (whole runs left out)", rep.folds),
        Split::Manoeuvre => {
            let mut s = format!(
                "split by manoeuvre: {} runs held out, trained on the other {}\n",
                held.len(),
                logs.len() - held.len()
            );
            for h in &held {
                s += &format!("  {}: {}\n", logs[h.run].name(), h.why);
            }
            s.trim_end().to_string()
        }
    };
    let headline = headline(&rep, baseline.as_ref());
    let text = format!(
        "{} logs, {split}\n{headline}single windows: accuracy {:.1} % (balanced {:.1} %; per fold median {:.1} %, worst {:.1} %)\n{}\nruns filtered one by one: accuracy {:.1} %\nspliced runs (terrain changes): raw {:.1} %, filtered {:.1} % (misclassification {:.2} %)\n{}",
        logs.len(),
        100.0 * rep.raw.accuracy(),
        100.0 * rep.raw.balanced_accuracy(),
        100.0 * rep.fold_summary().0,
        100.0 * rep.fold_summary().1,
        rep.raw.to_table(),
        100.0 * rep.filtered.accuracy(),
        100.0 * rep.spliced_raw.accuracy(),
        100.0 * rep.spliced_filtered.accuracy(),
        100.0 * (1.0 - rep.spliced_filtered.accuracy()),
        rep.spliced_filtered.to_table()
    );
    let text = format!(
        "{text}spliced logs: {} terrain changes; filtered without the windows straddling a change: {:.1} %; \
         a change to a correct filtered label: median {}, worst {}, never {} of {}\n\
         held-out outputs of all folds chained ({} terrain changes), filtered: {:.1} % (misclassification {:.2} %)\n\
         held-out windows driven outside their fold's training envelope: {}\n{}",
        rep.spliced_changes,
        100.0 * rep.spliced_filtered_settled.accuracy(),
        seconds(latency.0),
        seconds(latency.1),
        latency.2,
        rep.change_latency_s.len(),
        rep.chained_changes,
        100.0 * rep.chained_filtered.accuracy(),
        100.0 * (1.0 - rep.chained_filtered.accuracy()),
        rep.outside_envelope_share()
            .map_or_else(|| "-".to_string(), |f| format!("{:.1} %", 100.0 * f)),
        rep.runs_table()
    );
    let text = format!("{text}{}", rep.confidence.to_text());
    let text = if opts.source == Source::Camera {
        format!(
            "{text}change detector: {} of {} changes within one frame, {} false alarms\n",
            rep.change.detected, rep.change.changes, rep.change.false_alarms
        )
    } else {
        text
    };
    if a.json {
        eprintln!("{text}");
        let out = serde_json::json!({
            "folds": rep.folds,
            "split": match a.split { Split::Runs => "runs", Split::Manoeuvre => "manoeuvre" },
            "held_out": held.iter().map(|h| serde_json::json!({
                "log": logs[h.run].name(),
                "mean_tread_speed": h.manoeuvre.speed,
                "mean_tread_diff": h.manoeuvre.tread_diff,
                "spin_share": h.manoeuvre.spin_share,
                "why": h.why,
            })).collect::<Vec<_>>(),
            "windows": rep.raw.total(),
            "accuracy": rep.raw.accuracy(),
            "accuracy_filtered": rep.filtered.accuracy(),
            "spliced_accuracy": rep.spliced_raw.accuracy(),
            "spliced_accuracy_filtered": rep.spliced_filtered.accuracy(),
            "classes": rep.raw.classes,
            "confusion": rep.raw.counts,
            "confusion_spliced_filtered": rep.spliced_filtered.counts,
            "spliced_changes": rep.spliced_changes,
            "spliced_accuracy_filtered_settled": rep.spliced_filtered_settled.accuracy(),
            "chained_changes": rep.chained_changes,
            "chained_accuracy_filtered": rep.chained_filtered.accuracy(),
            "outside_envelope_share": rep.outside_envelope_share(),
            "change_latency_s": rep.change_latency_s,
            "fold_accuracy": rep.fold_accuracy,
            "runs": rep.runs,
            "change_detection": rep.change,
            "confidence": rep.confidence,
            "baseline": baseline.as_ref().map(|b| serde_json::json!({
                "accuracy": b.raw.accuracy(),
                "accuracy_filtered": b.filtered.accuracy(),
                "spliced_accuracy_filtered": b.spliced_filtered.accuracy(),
                "chained_accuracy_filtered": b.chained_filtered.accuracy(),
                "fold_accuracy": b.fold_accuracy,
                "confidence": b.confidence,
            })),
        });
        println!("{out}");
    } else {
        println!("{text}");
    }
    Ok(())
}

/// `--folds`: a number of folds, at least 2.
fn parse_folds(s: &str) -> Result<usize, String> {
    match s.parse::<usize>() {
        Ok(k) if k >= 2 => Ok(k),
        _ => Err(format!(
            "need at least 2 folds (whole runs left out per fold), got `{s}`; \
             the number of logs gives leave-one-run-out"
        )),
    }
}

/// `1.5 s`, or `-` when there is no value.
fn seconds(v: Option<f64>) -> String {
    v.map_or_else(|| "-".into(), |v| format!("{v:.1} s"))
}

/// The outer-fold figures (no choice of the model was made on the runs
/// they score), beside the plain baseline's on the same folds.
fn headline(rep: &CrossvalReport, baseline: Option<&CrossvalReport>) -> String {
    let pct = |v: f64| format!("{:.1} %", 100.0 * v);
    let acc80 = |r: &CrossvalReport| r.confidence.accuracy_at_80.map_or("-".into(), pct);
    let row = |name: &str, r: &CrossvalReport| {
        format!(
            "  {name:<15} {:>8} {:>9} {:>9} {:>13} {:>6.3}\n",
            pct(r.raw.accuracy()),
            pct(r.filtered.accuracy()),
            pct(r.chained_filtered.accuracy()),
            acc80(r),
            r.confidence.ece
        )
    };
    let mut s = format!(
        "outer folds (held-out runs; every choice made on the training runs only):\n  {:<15} {:>8} {:>9} {:>9} {:>13} {:>6}\n",
        "", "windows", "filtered", "chained", "80 % surest", "ECE"
    );
    s += &row("model", rep);
    match baseline {
        Some(b) => s += &row("plain baseline", b),
        None => s += "  (plain baseline skipped: --no-baseline)\n",
    }
    s
}
