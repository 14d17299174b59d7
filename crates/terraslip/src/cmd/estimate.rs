//! `terraslip estimate LOG --out DIR`: the online ICR estimator over a log.

use std::io::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use terraslip::estimate::{Estimate, Inputs};
use terraslip::pipeline::{EstimateRow, PipelineError, RowSink};
use terraslip_io::{AtomicFile, ParamsFile};

use crate::progress::Progress;

/// Run the online ICR estimator over a drive log.
///
/// Reads LOG (docs/log-format.md: wheels.csv required, pose.csv for
/// the fixes), runs the filter event by event on the log's timestamps and
/// writes DIR/estimate.csv (one row per wheels row: pose, ICRs y_l, y_r,
/// x_c in m in the body frame, their standard deviations, the terrain),
/// DIR/summary.json (rows, duration_s, final icr, counters, warnings, the
/// 2 s prediction error) and DIR/prediction.csv (that prediction's error
/// per start, which `terraslip report` plots).
///
/// Examples:
///   terraslip estimate drive/ --out est/
///   terraslip estimate drive/ --out est/ --terrain-labels --init params.json
///   terraslip estimate drive/ --out est/ --preset ta-iekf --json
///   terraslip estimate --print-config > estimator.toml
#[derive(clap::Args, Debug)]
#[command(after_help = after_help())]
pub struct Args {
    #[arg(required_unless_present = "print_config", help = log_help!())]
    pub log: Option<PathBuf>,
    /// Output directory (created if missing); estimate.csv, summary.json and
    /// prediction.csv appear there only when complete.
    #[arg(long, required_unless_present = "print_config")]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub estimator: EstimatorArgs,
    /// Use the log's own terrain.csv as terrain evidence (a perfect classifier).
    #[arg(long)]
    pub terrain_labels: bool,
    /// Classify terrain online from the log's imu or camera stream with a model
    /// from `terraslip terrain train`; its smoothed, λ-voted terrain fills the
    /// `terrain` column and drives the noise schedule (boost / reset / recall).
    #[arg(long, value_name = "MODEL", conflicts_with = "terrain_labels")]
    pub terrain_model: Option<PathBuf>,
    /// Drop every pose fix in [T0, T1) s (simulate a GNSS + compass outage).
    #[arg(long, value_name = "T0,T1", value_parser = parse_window)]
    pub outage: Option<(f64, f64)>,
    /// Print the configuration in effect as TOML, every table and key with
    /// its documentation and unit as comments, and exit.
    #[arg(long)]
    pub print_config: bool,
    /// Print the summary as one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
    /// Also write the estimate as ROS 2 messages (Odometry, TF, ICRs,
    /// terrain, innovations; a bag's input topics copied through) to this MCAP file.
    #[cfg(feature = "ros2")]
    #[arg(long, value_name = "OUT.mcap")]
    pub mcap: Option<PathBuf>,
}

const AFTER_HELP: &str = "\
Writes DIR/estimate.csv (one row per wheels row: t, east, north, yaw, y_l, y_r,
x_c, their standard deviations, terrain, then alpha_l, alpha_r, std_spread,
fused, gated, nis, q_scale, change, clock_offset; metres, radians, REP-103
frames) and
DIR/summary.json (rows, duration_s, final icr, terrain changes, counters,
warnings, the 2 s prediction error) and DIR/prediction.csv (t, error_m,
no_slip_m: that prediction's error per start, what `terraslip report`
plots). All three appear only when complete.

Examples:
  terraslip estimate drive/ --out est/
  terraslip estimate drive/ --out est/ --terrain-labels --init params.json
  terraslip estimate drive/ --out est/ --preset ta-iekf --json
  terraslip estimate drive/ --out est/ --outage 300,330   # dead reckoning test
  terraslip estimate --print-config > estimator.toml      # every constant, with its documentation";

/// The examples, then the presets' and the papers' names explained.
fn after_help() -> String {
    format!("{AFTER_HELP}\n\n{}", terraslip::glossary::help_text(80))
}

fn parse_window(s: &str) -> Result<(f64, f64), String> {
    let (a, b) = s
        .split_once(',')
        .ok_or_else(|| format!("`{s}`: expected T0,T1"))?;
    let a: f64 = a.trim().parse().map_err(|e| format!("`{a}`: {e}"))?;
    let b: f64 = b.trim().parse().map_err(|e| format!("`{b}`: {e}"))?;
    if !(a.is_finite() && b.is_finite() && a < b) {
        return Err(format!("`{s}`: need finite T0 < T1"));
    }
    Ok((a, b))
}

/// The estimator's options, as `estimate` and `node` take them (the global
/// `--topics` aside); the Python package's `terraslip.estimate` takes the
/// same as keywords (checked by a test below).
#[derive(clap::Args, Debug, Clone)]
pub struct EstimatorArgs {
    /// TOML configuration (see `terraslip estimate --print-config` for every
    /// key and its default).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Start from a named variant instead of the default: no-slip, ekf-qmin,
    /// ekf-qmax, ta-ekf-boost, ta-iekf, ekf-reset, terraslip (each explained
    /// at the end of `terraslip estimate --help`). Applied before --config.
    #[arg(long, value_name = "NAME")]
    pub preset: Option<String>,
    /// Starting ICRs from `terraslip calibrate` or a node's parameters file,
    /// read only (pooled set and/or one set per terrain; per-terrain sets
    /// are recalled when the robot enters that terrain).
    #[arg(long, value_name = "PARAMS")]
    pub init: Option<PathBuf>,
}

impl EstimatorArgs {
    /// The preset, then the configuration file over it.
    pub fn load(&self) -> Result<terraslip::config::EstimatorConfig> {
        terraslip::estimate::load_config(self.preset.as_deref(), self.config.as_deref())
    }

    /// The configuration file as an input no output may overwrite.
    pub fn input(&self) -> (&'static str, Option<&std::path::Path>) {
        ("--config", self.config.as_deref())
    }
}

pub fn run(args: Args) -> Result<()> {
    let load = || args.estimator.load();
    if args.print_config {
        print!("{}", load()?.to_commented_toml());
        return Ok(());
    }
    let (Some(log_dir), Some(out)) = (args.log.as_ref(), args.out.as_ref()) else {
        bail!("LOG and --out are required");
    };
    let inputs = super::inputs_with(
        std::slice::from_ref(log_dir),
        &[
            ("--init", args.estimator.init.as_deref()),
            args.estimator.input(),
            ("--terrain-model", args.terrain_model.as_deref()),
        ],
    );
    inputs.check_dir("--out", out, &OUTPUTS)?;
    let mut outputs = terraslip_io::Outputs::new();
    outputs.dir("--out", out, &OUTPUTS)?;
    #[cfg(feature = "ros2")]
    if let Some(m) = &args.mcap {
        inputs.check("--mcap", m)?;
        outputs.file("--mcap", m)?;
    }
    let cfg = load()?;
    // A plain log directory is streamed row by row; a terrain model needs
    // the sensor streams it classifies (imu or images), a bag is imported
    // first, and an MCAP output needs every row: those read the whole log.
    #[cfg(feature = "ros2")]
    let mcap = args.mcap.is_some();
    #[cfg(not(feature = "ros2"))]
    let mcap = false;
    let streamed = !(terraslip::bag::is_bag(log_dir) || args.terrain_model.is_some() || mcap);
    let source = if streamed {
        if super::bag::topics().is_given() && !log_dir.is_dir() {
            bail!("{}: --topics is for ROS 2 bags", log_dir.display());
        }
        let open = terraslip::estimate::OpenLog::open(log_dir)
            .with_context(|| format!("reading log {}", log_dir.display()))?;
        Source::Open(Box::new(open))
    } else if args.terrain_model.is_some() {
        Source::Read(Box::new(super::bag::read_full(log_dir)?))
    } else {
        Source::Read(Box::new(super::bag::read_with(log_dir, super::read_log)?))
    };
    let init = match &args.estimator.init {
        Some(p) => Some(ParamsFile::read(p).with_context(|| "--init")?),
        None => None,
    };
    // Held from here until the files are in place: a second run into the
    // same directory is told so instead of mixing its files with ours.
    let lock = terraslip_io::DirLock::acquire(out)?;
    lock.remove_stale_temps(&OUTPUTS);
    let inputs = Inputs {
        init: init.as_ref(),
        terrain_labels: args.terrain_labels,
        terrain_model: args.terrain_model.as_deref(),
        outage: args.outage,
    };
    let mut csv = CsvSink::create(&out.join(OUTPUTS[0]))?;
    let (log, result) = match source {
        Source::Open(open) => {
            let bar = progress(open.wheels_bytes(), "bytes of wheels.csv");
            let result = terraslip::estimate::estimate_streamed(
                *open,
                cfg,
                &inputs,
                &mut csv,
                &mut |done, _| bar.set_position(done),
            );
            bar.finish();
            result?
        }
        Source::Read(log) => {
            let bar = progress(log.wheels.len() as u64, "wheels rows");
            let result = terraslip::estimate::estimate(&log, cfg, &inputs, &mut |done, _| {
                bar.set_position(done as u64)
            });
            bar.finish();
            let est = result?;
            for r in &est.run.rows {
                csv.row(&est.run.terrains, r)?;
            }
            (*log, est)
        }
    };
    let Estimate {
        run: est,
        mut summary,
        notes,
    } = result;
    // The input, absolute so that `report` finds it from any directory (a
    // bag's log lives in a temporary directory), and for a bag the topics
    // it was read with: what `report` reads again.
    let recorded = std::path::absolute(log_dir).unwrap_or_else(|_| log_dir.clone());
    summary["log"] = recorded.display().to_string().into();
    if terraslip::bag::is_bag(log_dir) {
        summary["bag_topics"] = super::bag::topics_record()?;
        let revisited = super::bag::revisited(log_dir);
        if !revisited.is_empty() {
            summary["revisited"] = revisited.into();
        }
    }
    for n in &notes {
        eprintln!("{n}");
    }
    let prediction = terraslip::estimate::prediction_csv(est.prediction.as_ref());
    write_outputs(out, csv, &prediction, &summary)?;
    drop(lock);
    #[cfg(feature = "ros2")]
    if let Some(p) = &args.mcap {
        super::ros2out::write_mcap(p, log_dir, &log, &est)?;
    }

    // What the run decided before its first row, as the node says it.
    for line in est.decided.lines() {
        eprintln!("{}: decided: {line}", log_dir.display());
    }
    for w in log.warnings.iter().chain(&est.warnings) {
        eprintln!("warning: {w}");
    }
    let icr = est.final_icr;
    let nothing_learned = est.hold == terraslip_core::filter::SlipHold::All;
    eprintln!(
        "estimate: {} rows over {:.1} s, {} fixes ({} position / {} heading gated), {} y_l = {:.4} m, y_r = {:.4} m, x_c = {:.4} m -> {}",
        est.row_count,
        est.duration(),
        est.stats.fixes_used,
        est.stats.fixes.position_gated,
        est.stats.fixes.yaw_gated,
        if nothing_learned {
            "ICRs held at their starting values (nothing learned)"
        } else {
            "final ICRs (straight line)"
        },
        icr.y_l,
        icr.y_r,
        icr.x_c,
        out.display()
    );
    for line in terraslip::estimate::headline::headline(&summary) {
        eprintln!("{line}");
    }
    if args.json {
        println!("{}", serde_json::to_string(&summary)?);
    }
    Ok(())
}

/// Where the log's rows come from.
enum Source {
    /// Streamed from the log directory.
    Open(Box<terraslip::estimate::OpenLog>),
    /// Read whole.
    Read(Box<terraslip_io::DriveLog>),
}

fn progress(total: u64, unit: &str) -> Progress {
    // Short logs finish before progress is worth showing (200 000 rows,
    // about 10 MB).
    let short = if unit == "wheels rows" {
        200_000
    } else {
        10_000_000
    };
    if total < short {
        return Progress::hidden();
    }
    let p = Progress::new(total, unit);
    p.set_message("estimate");
    p
}

/// The files `estimate` writes into its output directory.
const OUTPUTS: [&str; 3] = ["estimate.csv", "summary.json", "prediction.csv"];

/// Bytes of `estimate.csv` gathered before each write.
const CSV_CHUNK: usize = 1 << 18;

/// `estimate.csv` being written, row by row, under a temporary name.
struct CsvSink {
    file: AtomicFile,
    buf: Vec<u8>,
    rows: terraslip::estimate::RowWriter,
}

impl CsvSink {
    fn create(path: &Path) -> Result<Self> {
        let mut buf = Vec::with_capacity(CSV_CHUNK + 4096);
        buf.extend_from_slice(terraslip::estimate::header().as_bytes());
        buf.push(b'\n');
        Ok(Self {
            file: AtomicFile::create(path)?,
            buf,
            rows: Default::default(),
        })
    }

    fn flush_buf(&mut self) -> Result<(), PipelineError> {
        self.file
            .write_all(&self.buf)
            .map_err(|source| PipelineError::Write {
                path: self.file.path().display().to_string(),
                source,
            })?;
        self.buf.clear();
        Ok(())
    }
}

impl RowSink for CsvSink {
    fn row(&mut self, terrains: &[String], r: &EstimateRow) -> Result<(), PipelineError> {
        self.rows.write(&mut self.buf, terrains, r);
        if self.buf.len() > CSV_CHUNK {
            self.flush_buf()?;
        }
        Ok(())
    }
}

/// Finishes the files as a set (the caller holds the directory's lock):
/// none appears unless all are complete, and summary.json is removed
/// first and renamed into place last, so a summary.json always describes
/// the estimate.csv and the prediction.csv (text `prediction`) beside it.
fn write_outputs(
    out: &Path,
    mut csv: CsvSink,
    prediction: &str,
    summary: &serde_json::Value,
) -> Result<()> {
    let json_path = out.join(OUTPUTS[1]);
    let prediction_path = out.join(OUTPUTS[2]);
    csv.flush_buf()?;
    let mut pred = AtomicFile::create(&prediction_path)?;
    pred.write_all(prediction.as_bytes())
        .with_context(|| format!("{}: write failed", prediction_path.display()))?;
    let mut js = AtomicFile::create(&json_path)?;
    js.write_all(serde_json::to_string_pretty(summary)?.as_bytes())
        .with_context(|| format!("{}: write failed", json_path.display()))?;
    match std::fs::remove_file(&json_path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            return Err(e).with_context(|| format!("{}: cannot replace", json_path.display()));
        }
        _ => {}
    }
    csv.file.commit()?;
    pred.commit()?;
    js.commit()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use clap::{Args as _, CommandFactory as _};

    /// Long names of a command's options (the positional ones by id).
    fn options(cmd: &clap::Command) -> Vec<String> {
        cmd.get_arguments()
            .filter(|a| !["help", "version"].contains(&a.get_id().as_str()))
            .map(|a| {
                a.get_long()
                    .unwrap_or(a.get_id().as_str())
                    .replace('-', "_")
            })
            .collect()
    }

    /// The keywords of `terraslip.estimate` in the Python package
    /// (crates/terraslip-py/src/estimate.rs, its `#[pyo3(signature)]`).
    fn python_keywords() -> Vec<String> {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../terraslip-py/src/estimate.rs"
        );
        let src = std::fs::read_to_string(path).expect(path);
        let sig = src
            .split("#[pyo3(signature = (")
            .nth(1)
            .and_then(|s| s.split("))]").next())
            .expect("the signature of terraslip.estimate");
        sig.split(',')
            .map(|k| k.split('=').next().unwrap_or("").trim().to_string())
            .filter(|k| !k.is_empty() && k != "*")
            .collect()
    }

    /// Options of `estimate` that are for the command line only: where
    /// the files go and what is printed (Python returns the arrays and the
    /// summary), the dead-reckoning test window, the bag reading mode.
    const CLI_ONLY: [&str; 6] = ["out", "outage", "print_config", "json", "mcap", "strict"];

    #[test]
    fn the_estimators_options_are_pythons_keywords() {
        let cli = crate::Cli::command();
        let estimate = cli.find_subcommand("estimate").expect("estimate");
        let mut cli_opts = options(estimate);
        cli_opts.extend(options(&cli));
        cli_opts.sort();
        cli_opts.dedup();
        let py = python_keywords();
        for o in &cli_opts {
            assert!(
                py.contains(o) || CLI_ONLY.contains(&o.as_str()),
                "`terraslip estimate --{o}` has no keyword in terraslip.estimate (add it, or to CLI_ONLY)"
            );
        }
        for k in &py {
            assert!(
                cli_opts.contains(k),
                "terraslip.estimate's keyword `{k}` is no option of `terraslip estimate`"
            );
        }
        // The shared options are declared once, and `node` takes them.
        let shared = options(&super::EstimatorArgs::augment_args(clap::Command::new("x")));
        assert_eq!(shared, ["config", "preset", "init"]);
        #[cfg(any(feature = "node", feature = "node-humble"))]
        {
            let node = options(cli.find_subcommand("node").expect("node"));
            assert!(shared.iter().all(|o| node.contains(o)), "{node:?}");
        }
    }
}
