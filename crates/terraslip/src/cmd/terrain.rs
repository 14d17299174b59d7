//! `terraslip terrain train|eval|crossval`: terrain classifiers from
//! vibration (IMU) or ground-camera frames.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::{bail, Context};
use clap::{Subcommand, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use terraslip_io::DriveLog;
use terraslip_report::{Heatmap, LinePlot, Series, SeriesStyle};
use terraslip_terrain::{
    crossval, score_log, ChangeScore, ChannelSet, ClassifierKind, Confusion, LogScore, RoiConfig,
    Source, TerrainModel, TrainOptions, VibrationConfig, VibrationFeatureSet, VisionFeatureSet,
};

/// Train and evaluate terrain classifiers.
///
/// A model reads one source: `imu` (vibration windows of imu.csv plus tread
/// speeds from wheels.csv) or `camera` (frames listed in images.csv). Training
/// logs need terrain.csv labels. Evaluate on runs the model was not trained
/// on; `crossval` does that for you by leaving whole runs out.
///
/// Example:
///   terraslip terrain train data/borealtc/* --out husky.json
///   terraslip terrain eval other-run/ --model husky.json --plots eval/
#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Train a classifier from labelled logs and save it as a JSON model.
    Train(TrainArgs),
    /// Classify labelled logs with a model: confusion matrix, raw and filtered
    /// accuracy, plots of the confusion matrix and of the terrain timeline.
    Eval(EvalArgs),
    /// Leave-runs-out cross-validation: train without some runs, test on
    /// them, also spliced into logs with terrain changes for the Bayesian filter.
    Crossval(CrossvalArgs),
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum SourceArg {
    Imu,
    Camera,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum ClassifierArg {
    /// wang2018: entropy decision tree with cost-complexity pruning.
    Tree,
    /// chen2023: k-nearest neighbours on standardised features.
    Knn,
    /// Gradient-boosted trees (default; softmax loss, depth-4 trees).
    Boost,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum FeaturesArg {
    /// imu: the paper's sign changes, mean, variance of accel_z (1 s windows unless --window).
    Paper,
    /// imu: moments, Welch band powers of every channel, tread speed and slip terms.
    Full,
    /// camera: lv2019's RGB histograms + uniform LBP.
    HistLbp,
    /// camera: chen2023's SFTA.
    Sfta,
    /// camera: both.
    Both,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum ChannelsArg {
    /// All six IMU channels (accel x/y/z, gyro x/y/z).
    All,
    /// Vertical acceleration only.
    AccelZ,
}

/// Training settings shared by `train` and `crossval`.
#[derive(clap::Args, Clone)]
struct TrainSettings {
    /// Sensor the model reads.
    #[arg(long, value_enum, default_value = "imu")]
    source: SourceArg,
    /// Classifier to train.
    #[arg(long, value_enum, default_value = "boost")]
    classifier: ClassifierArg,
    /// Feature set [default: full for imu, both for camera].
    #[arg(long, value_enum)]
    features: Option<FeaturesArg>,
    /// IMU window length, s [default: 6 (full), 1 (paper)]. Longer windows
    /// classify better (BorealTC leave-run-out: 1 s 75 %, 4 s 82 %, 6 s 86 %)
    /// but see a terrain change up to a window later.
    #[arg(long)]
    window: Option<f64>,
    /// Time between consecutive IMU windows, s.
    #[arg(long, default_value_t = 0.5)]
    hop: f64,
    /// IMU channels of the full feature set [default: all six when every
    /// training log has them, else accel-z].
    #[arg(long, value_enum)]
    channels: Option<ChannelsArg>,
    /// imu, full features: leave out the drive-motor current features
    /// (read by default when every training log has current_left,current_right).
    #[arg(long)]
    no_currents: bool,
    /// imu, full features: speed floor of the speed normalisation, m/s
    /// [default: chosen among 0.05, 0.1, 0.2 by cross-validation over the
    /// training runs].
    #[arg(long)]
    speed_floor: Option<f64>,
    /// Neighbours of the KNN classifier.
    #[arg(long, default_value_t = 5)]
    k: usize,
    /// Boosting rounds of the boosted trees (one tree per class each).
    #[arg(long, default_value_t = 150)]
    rounds: usize,
    /// Seed of the boosted trees (row samples and feature subsets).
    /// Leave-run-out figures on BorealTC move by about ±1 point with it.
    #[arg(long, default_value_t = 7)]
    seed: u64,
    /// imu, full features: leave out the slip terms (steering efficiency
    /// from gyro vs commanded yaw rate, spin share), as in model format 1.
    #[arg(long)]
    no_slip: bool,
    /// imu, full features: feed the classifier the raw log powers instead
    /// of mapping them to 0.5 m/s with speed slopes learnt from the training runs.
    #[arg(long)]
    no_speed_norm: bool,
    /// Pruning weight α of the decision tree (0 = no pruning).
    #[arg(long, default_value_t = 4.0)]
    prune_alpha: f64,
    /// camera: TOML file with chen2023's region of interest (a `[camera]`
    /// pinhole model plus horizon_s, length, width, margin); whole frames otherwise.
    #[arg(long)]
    roi: Option<PathBuf>,
}

#[derive(clap::Args)]
struct TrainArgs {
    /// Log directories with terrain.csv labels.
    #[arg(required = true)]
    logs: Vec<PathBuf>,
    /// Model file to write (JSON).
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    settings: TrainSettings,
}

#[derive(clap::Args)]
struct EvalArgs {
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
    /// classes, confusion (rows = true class), confusion_filtered, per-log scores.
    #[arg(long)]
    json: bool,
}

#[derive(clap::Args)]
struct CrossvalArgs {
    /// Log directories with terrain.csv labels, one run each.
    #[arg(required = true)]
    logs: Vec<PathBuf>,
    /// Number of folds (at least 2); runs of each terrain are dealt
    /// round-robin. Use the number of logs for leave-one-run-out. Folds run
    /// in parallel (TERRASLIP_THREADS caps the threads).
    #[arg(long, default_value_t = 5, value_parser = parse_folds)]
    folds: usize,
    #[command(flatten)]
    settings: TrainSettings,
    /// Print one JSON object on stdout.
    #[arg(long)]
    json: bool,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    match args.command {
        Command::Train(a) => train(a),
        Command::Eval(a) => eval(a),
        Command::Crossval(a) => run_crossval(a),
    }
}

fn read_logs(paths: &[PathBuf], quiet: bool) -> anyhow::Result<Vec<DriveLog>> {
    let mut bar = Progress::new(paths.len() as u64, "reading logs", quiet);
    let mut logs = Vec::with_capacity(paths.len());
    for p in paths {
        let log = super::bag::read_full(p)?;
        logs.push(log);
        bar.inc();
    }
    bar.finish();
    Ok(logs)
}

/// Progress on stderr: a bar on a terminal; elsewhere (logs, CI) one line
/// `what: done/total (elapsed)` at most every TERRASLIP_PROGRESS_SECS
/// seconds (10 by default) and at the end of a step that took that long;
/// nothing when `quiet`.
struct Progress {
    bar: Option<ProgressBar>,
    what: &'static str,
    n: u64,
    done: u64,
    plain: bool,
    every: Duration,
    start: Instant,
    last: Instant,
}

impl Progress {
    fn new(n: u64, what: &'static str, quiet: bool) -> Self {
        let plain = !quiet && !std::io::stderr().is_terminal();
        let bar = (!quiet && !plain).then(|| {
            let bar = ProgressBar::new(n);
            bar.set_style(
                ProgressStyle::with_template("{msg} [{bar:30}] {pos}/{len} {elapsed}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            bar.set_message(what);
            bar
        });
        let every = std::env::var("TERRASLIP_PROGRESS_SECS")
            .ok()
            .and_then(|v| v.parse::<f64>().ok())
            .filter(|v| v.is_finite() && *v >= 0.0)
            .map_or(Duration::from_secs(10), Duration::from_secs_f64);
        let now = Instant::now();
        Self {
            bar,
            what,
            n,
            done: 0,
            plain,
            every,
            start: now,
            last: now,
        }
    }

    fn set(&mut self, done: u64) {
        self.done = done;
        if let Some(bar) = &self.bar {
            bar.set_position(done);
        } else if self.plain && self.last.elapsed() >= self.every {
            self.last = Instant::now();
            eprintln!(
                "{}: {done}/{} ({:.0} s)",
                self.what,
                self.n,
                self.start.elapsed().as_secs_f64()
            );
        }
    }

    fn inc(&mut self) {
        self.set(self.done + 1);
    }

    fn finish(self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}

fn options(s: &TrainSettings) -> anyhow::Result<TrainOptions> {
    let mut o = TrainOptions {
        source: match s.source {
            SourceArg::Imu => Source::Imu,
            SourceArg::Camera => Source::Camera,
        },
        ..TrainOptions::default()
    };
    o.classifier.kind = match s.classifier {
        ClassifierArg::Tree => ClassifierKind::Tree,
        ClassifierArg::Knn => ClassifierKind::Knn,
        ClassifierArg::Boost => ClassifierKind::Boost,
    };
    o.classifier.knn_k = s.k;
    o.classifier.boost.rounds = s.rounds;
    o.classifier.boost.seed = s.seed;
    o.classifier.tree.prune_alpha = s.prune_alpha;
    match (s.source, s.features) {
        (SourceArg::Imu, Some(FeaturesArg::Paper)) => o.vibration = VibrationConfig::paper(),
        (SourceArg::Imu, None | Some(FeaturesArg::Full)) => {}
        (SourceArg::Camera, None | Some(FeaturesArg::Both)) => {
            o.vision.features = VisionFeatureSet::Both
        }
        (SourceArg::Camera, Some(FeaturesArg::HistLbp)) => {
            o.vision.features = VisionFeatureSet::HistLbp
        }
        (SourceArg::Camera, Some(FeaturesArg::Sfta)) => o.vision.features = VisionFeatureSet::Sfta,
        (SourceArg::Imu, Some(_)) => bail!("--source imu takes --features paper or full"),
        (SourceArg::Camera, Some(_)) => {
            bail!("--source camera takes --features hist-lbp, sfta or both")
        }
    }
    if let Some(w) = s.window {
        if !(w.is_finite() && w > 0.0) {
            bail!("--window must be a positive number of seconds, got {w}");
        }
        o.vibration.window_s = w;
    }
    if !(s.hop.is_finite() && s.hop > 0.0) {
        bail!("--hop must be a positive number of seconds, got {}", s.hop);
    }
    o.vibration.hop_s = s.hop;
    if s.no_slip {
        o.vibration.slip = false;
    }
    if s.no_speed_norm {
        o.vibration.speed_norm = false;
    }
    if o.vibration.feature_set == VibrationFeatureSet::Full {
        o.imu_channels = s.channels.map(|c| match c {
            ChannelsArg::All => ChannelSet::All,
            ChannelsArg::AccelZ => ChannelSet::AccelZ,
        });
    }
    if s.no_currents {
        o.currents = Some(false);
    }
    if let Some(v) = s.speed_floor {
        if !(v.is_finite() && v > 0.0) {
            bail!("--speed-floor must be a positive speed in m/s, got {v}");
        }
        o.speed_floor = Some(v);
    }
    if let Some(p) = &s.roi {
        let text =
            std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
        // toml's own message spans several lines (a source excerpt); the CLI
        // contract wants one.
        let roi: RoiConfig = toml::from_str(&text).map_err(|e| {
            let line = e
                .span()
                .map(|r| text[..r.start.min(text.len())].lines().count().max(1));
            anyhow::anyhow!(
                "{}:{}: bad region of interest: {}",
                p.display(),
                line.unwrap_or(0),
                e.message()
            )
        })?;
        o.vision.roi = Some(roi);
    }
    Ok(o)
}

fn train(a: TrainArgs) -> anyhow::Result<()> {
    let opts = options(&a.settings)?;
    let logs = read_logs(&a.logs, false)?;
    let spinner = std::io::stderr().is_terminal().then(|| {
        let spinner = ProgressBar::new_spinner();
        spinner.set_message("extracting features and training");
        spinner.enable_steady_tick(Duration::from_millis(200));
        spinner
    });
    let t0 = Instant::now();
    let model = TerrainModel::train(&logs, &opts);
    if let Some(s) = spinner {
        s.finish_and_clear();
    }
    let model = model.context("training the terrain model")?;
    model
        .save(&a.out)
        .with_context(|| format!("writing model {}", a.out.display()))?;
    eprintln!(
        "trained the {} model on {} log{}: {} classes, {} features, samples per class {}",
        model.source.name(),
        logs.len(),
        if logs.len() == 1 { "" } else { "s" },
        model.classes.len(),
        model.feature_names.len(),
        model
            .classes
            .iter()
            .zip(&model.training.samples_per_class)
            .map(|(c, n)| format!("{c}={n}"))
            .collect::<Vec<_>>()
            .join(" ")
    );
    eprintln!(
        "reads {}; wrote {} ({:.0} s)",
        model.channels_description(),
        a.out.display(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}

fn eval(a: EvalArgs) -> anyhow::Result<()> {
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
    for log in &logs {
        let s =
            score_log(&model, log).with_context(|| format!("classifying {}", log.dir.display()))?;
        raw.merge(&s.raw);
        filtered.merge(&s.filtered);
        change.merge(&s.change);
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
    let text = format!(
        "{} windows from {} logs\nsingle windows: accuracy {:.1} % (balanced {:.1} %)\n{}\nafter the Bayesian filter: accuracy {:.1} % (balanced {:.1} %)\n{}{change_text}plots in {}",
        raw.total(),
        logs.len(),
        100.0 * raw.accuracy(),
        100.0 * raw.balanced_accuracy(),
        raw.to_table(),
        100.0 * filtered.accuracy(),
        100.0 * filtered.balanced_accuracy(),
        filtered.to_table(),
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
            "logs": per_log,
            "plots": plots,
        });
        println!("{out}");
    } else {
        println!("{text}");
    }
    Ok(())
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

fn run_crossval(a: CrossvalArgs) -> anyhow::Result<()> {
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
    let folds = a.folds;
    let mut bar = Progress::new(
        folds.min(logs.len()) as u64,
        "cross-validating (folds done)",
        a.json,
    );
    let rep =
        crossval(&logs, &opts, folds, |i, _| bar.set(i as u64)).context("cross-validation")?;
    bar.finish();
    let latency = rep.latency_summary();
    let text = format!(
        "{} logs, {} folds (whole runs left out)\nsingle windows: accuracy {:.1} % (balanced {:.1} %; per fold median {:.1} %, worst {:.1} %)\n{}\nruns filtered one by one: accuracy {:.1} %\nspliced runs (terrain changes): raw {:.1} %, filtered {:.1} % (misclassification {:.2} %)\n{}",
        logs.len(),
        rep.folds,
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
         held-out outputs of all folds chained ({} terrain changes), filtered: {:.1} % (misclassification {:.2} %)\n{}",
        rep.spliced_changes,
        100.0 * rep.spliced_filtered_settled.accuracy(),
        seconds(latency.0),
        seconds(latency.1),
        latency.2,
        rep.change_latency_s.len(),
        rep.chained_changes,
        100.0 * rep.chained_filtered.accuracy(),
        100.0 * (1.0 - rep.chained_filtered.accuracy()),
        rep.runs_table()
    );
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
            "change_latency_s": rep.change_latency_s,
            "fold_accuracy": rep.fold_accuracy,
            "runs": rep.runs,
            "change_detection": rep.change,
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
