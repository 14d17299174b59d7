//! `terraslip estimate LOG --out DIR`: the online ICR estimator over a log.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use terraslip::config::EstimatorConfig;
use terraslip::pipeline::{self, EstimateRun, RunOptions, TerrainEvidence};
use terraslip_io::{AtomicFile, DriveLog, ParamsFile};

use crate::progress::Progress;

/// Run the online ICR estimator over a drive log.
///
/// Reads LOG (docs/log-format.md: wheels.csv required, pose.csv for
/// the fixes), runs the filter event by event on the log's timestamps and
/// writes DIR/estimate.csv (one row per wheels row: pose, ICRs y_l, y_r,
/// x_c in m in the body frame, their standard deviations, the terrain) and
/// DIR/summary.json (rows, duration_s, final icr, counters, warnings).
///
/// Examples:
///   terraslip estimate drive/ --out est/
///   terraslip estimate drive/ --out est/ --terrain-labels --init params.json
///   terraslip estimate drive/ --out est/ --preset ta-iekf --json
///   terraslip estimate --print-config > estimator.toml
#[derive(clap::Args, Debug)]
#[command(after_help = after_help())]
pub struct Args {
    /// Log directory to read.
    #[arg(required_unless_present = "print_config")]
    pub log: Option<PathBuf>,
    /// Output directory (created if missing); estimate.csv and summary.json
    /// appear there only when complete.
    #[arg(long, required_unless_present = "print_config")]
    pub out: Option<PathBuf>,
    /// TOML configuration (see --print-config for every key and its default).
    #[arg(long, value_name = "FILE")]
    pub config: Option<PathBuf>,
    /// Start from a named variant instead of the default: no-slip, ekf-qmin,
    /// ekf-qmax, ta-ekf-boost, ta-iekf, ekf-reset, terraslip (each explained
    /// below). Applied before --config.
    #[arg(long, value_name = "NAME")]
    pub preset: Option<String>,
    /// Starting ICRs from `terraslip calibrate` (pooled set and/or one set per
    /// terrain; per-terrain sets are recalled when the robot enters that terrain).
    #[arg(long, value_name = "PARAMS")]
    pub init: Option<PathBuf>,
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
warnings). Both appear only when complete.

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

fn load_config(args: &Args) -> Result<EstimatorConfig> {
    let mut cfg = match &args.preset {
        Some(name) => EstimatorConfig::preset(name).with_context(|| {
            let names: Vec<&str> = EstimatorConfig::presets().iter().map(|p| p.0).collect();
            format!("unknown preset `{name}` (known: {})", names.join(", "))
        })?,
        None => EstimatorConfig::default(),
    };
    if let Some(path) = &args.config {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("{}: cannot read", path.display()))?;
        // Checked alone first, so errors point at the user's own lines.
        toml::from_str::<EstimatorConfig>(&text)
            .map_err(|e| terraslip::config::toml_error(&text, &e))
            .with_context(|| format!("{}", path.display()))?;
        // A preset is the base; the file's keys override it.
        let base = toml::Value::try_from(&cfg).context("serialising the base configuration")?;
        let over: toml::Value = toml::from_str(&text)
            .map_err(|e| terraslip::config::toml_error(&text, &e))
            .with_context(|| format!("{}", path.display()))?;
        let merged = merge(base, over);
        cfg = EstimatorConfig::from_toml(&toml::to_string(&merged).unwrap_or_default())
            .with_context(|| format!("{}", path.display()))?;
    }
    cfg.validate()?;
    Ok(cfg)
}

fn merge(base: toml::Value, over: toml::Value) -> toml::Value {
    match (base, over) {
        (toml::Value::Table(mut b), toml::Value::Table(o)) => {
            for (k, v) in o {
                let nv = match b.remove(&k) {
                    Some(bv) => merge(bv, v),
                    None => v,
                };
                b.insert(k, nv);
            }
            toml::Value::Table(b)
        }
        (_, o) => o,
    }
}

pub fn run(args: Args) -> Result<()> {
    let mut cfg = load_config(&args)?;
    if args.print_config {
        print!("{}", cfg.to_commented_toml());
        return Ok(());
    }
    let (Some(log_dir), Some(out)) = (args.log.as_ref(), args.out.as_ref()) else {
        bail!("LOG and --out are required");
    };
    // A terrain model needs the sensor streams it classifies (imu or images).
    let log = if args.terrain_model.is_some() {
        super::bag::read_full(log_dir)
    } else {
        super::bag::read_with(log_dir, super::read_log)
    }?;
    let inputs: Vec<&Path> = [&args.init, &args.config, &args.terrain_model]
        .into_iter()
        .flatten()
        .map(|p| p.as_path())
        .collect();
    for name in OUTPUTS {
        super::refuse_overwrite(&out.join(name), &inputs, &[log_dir])?;
    }
    let init = match &args.init {
        Some(p) => Some(ParamsFile::read(p).with_context(|| "--init")?),
        None => None,
    };
    let (evidence, evidence_name) = if args.terrain_labels {
        if log.terrain.is_empty() {
            bail!("--terrain-labels: {} has no terrain.csv", log_dir.display());
        }
        (
            TerrainEvidence::Labels(log.terrain.clone()),
            "labels (terrain.csv)".to_string(),
        )
    } else if let Some(path) = &args.terrain_model {
        let ctx = || format!("--terrain-model {}", path.display());
        let model = terraslip_terrain::TerrainModel::load(path).with_context(ctx)?;
        let timeline = model.estimator_evidence(&log).with_context(ctx)?;
        // The model carries the smoothing it was validated with (λ chosen
        // from its own accuracy, wang2018 eq. 14): use it, not the defaults.
        cfg.belief.stay_prob = model.belief.stay_prob;
        cfg.belief.stay_prob_on_jump = model.belief.stay_prob_on_jump;
        cfg.belief.vote_lambda = model.belief.vote_lambda;
        eprintln!(
            "terrain: {} {:?} classifier, {} windows{} over classes {}",
            path.display(),
            model.source,
            timeline.frames.len(),
            if timeline.changes.is_empty() {
                String::new()
            } else {
                format!(", {} camera change detections", timeline.changes.len())
            },
            timeline.classes.join(", ")
        );
        (
            TerrainEvidence::from(timeline),
            format!("model {} ({:?})", path.display(), model.source),
        )
    } else {
        (TerrainEvidence::None, "none".to_string())
    };

    // Held from here until both files are in place: a second run into the
    // same directory is told so instead of mixing its files with ours.
    let lock = terraslip_io::DirLock::acquire(out)?;
    lock.remove_stale_temps(&OUTPUTS);
    let bar = progress(log.wheels.len());
    let opts = RunOptions {
        outage: args.outage,
    };
    let result = pipeline::run_with(
        &log,
        &cfg,
        &evidence,
        init.as_ref(),
        opts,
        &mut |done, _| bar.set_position(done as u64),
    );
    bar.finish();
    let est = result?;

    let mut summary = summary_json(&log, &est, &cfg);
    summary["terrain_evidence"] = serde_json::Value::String(evidence_name);
    write_outputs(out, &est, &summary)?;
    drop(lock);
    #[cfg(feature = "ros2")]
    if let Some(p) = &args.mcap {
        super::ros2out::write_mcap(p, log_dir, &log, &est)?;
    }

    for w in log.warnings.iter().chain(&est.warnings) {
        eprintln!("warning: {w}");
    }
    let icr = est.final_icr;
    eprintln!(
        "estimate: {} rows over {:.1} s, {} fixes ({} position / {} heading gated), final ICRs y_l = {:.4} m, y_r = {:.4} m, x_c = {:.4} m -> {}",
        est.rows.len(),
        est.duration(),
        est.stats.fixes_used,
        est.stats.fixes.position_gated,
        est.stats.fixes.yaw_gated,
        icr.y_l,
        icr.y_r,
        icr.x_c,
        out.display()
    );
    if args.json {
        println!("{}", serde_json::to_string(&summary)?);
    }
    Ok(())
}

fn progress(total: usize) -> Progress {
    // Short logs finish before progress is worth showing.
    if total < 200_000 {
        return Progress::hidden();
    }
    let p = Progress::new(total as u64, "wheels rows");
    p.set_message("estimate");
    p
}

fn summary_json(log: &DriveLog, est: &EstimateRun, cfg: &EstimatorConfig) -> serde_json::Value {
    let icr = est.final_icr;
    let last = est.rows.last();
    serde_json::json!({
        "log": log.dir.display().to_string(),
        "rows": est.rows.len(),
        "duration_s": est.duration(),
        "icr": {
            "y_l": icr.y_l, "y_r": icr.y_r, "x_c": icr.x_c,
            "alpha_l": icr.alpha_l, "alpha_r": icr.alpha_r,
        },
        "icr_std": last.map(|r| serde_json::json!({
            "y_l": r.std[3], "y_r": r.std[4], "x_c": r.std[5], "spread": r.std_spread,
        })),
        "track_width": est.track_width,
        "variant": cfg.filter.variant,
        "init": est.init_source,
        "clock_offset_s": {"value": est.clock_offset.0, "std": est.clock_offset.1},
        // The spread in effect is (1 + slope |v_r - v_l|) times "icr"'s.
        "turn_law_s_per_m": {"slope": est.turn_law.0, "std": est.turn_law.1},
        // The pose noise the filter ended with, and whether pose.csv stated it.
        "pose_noise": {
            "std_xy_m": est.noise.std_xy,
            "std_yaw_rad": est.noise.std_yaw,
            "correlated_std_m": est.noise.correlated_std,
            "model_speed_rel_per_sqrt_s": est.noise.model.0.sqrt(),
            "model_yaw_rate_rel_per_sqrt_s": est.noise.model.1.sqrt(),
            "stated_in_log": est.noise.stated,
            "learned": est.noise.learned,
        },
        "terrain_changes": est.changes.iter().map(|c| serde_json::json!({
            "t": c.t,
            "terrain": est.terrains.get(c.terrain),
            "action": format!("{:?}", c.action).to_lowercase(),
        })).collect::<Vec<_>>(),
        "stats": {
            "predictions": est.stats.fixes.predictions,
            "fixes": est.stats.fixes_used,
            "position_fused": est.stats.fixes.position_fused,
            "position_gated": est.stats.fixes.position_gated,
            "yaw_fused": est.stats.fixes.yaw_fused,
            "yaw_gated": est.stats.fixes.yaw_gated,
            "anchored": est.stats.fixes.anchored,
            "changes_detected": est.stats.fixes.changes_detected,
            "refused_updates": est.stats.fixes.refused,
            "dropped_fixes": est.stats.dropped_fixes,
        },
        "warnings": log.warnings.iter().chain(&est.warnings).collect::<Vec<_>>(),
        // How well the parameters the filter reported at each time predict
        // the next 2 s of motion against the pose reference (absent without one).
        "prediction": terraslip::prediction_score(log, est).map(|p| p.to_json()),
    })
}

/// CSV header of estimate.csv: log-format.md's columns, then extras.
pub const HEADER: &str = "t,east,north,yaw,y_l,y_r,x_c,std_east,std_north,std_yaw,std_y_l,std_y_r,std_x_c,terrain,alpha_l,alpha_r,std_alpha_l,std_alpha_r,std_spread,fused,gated,nis,q_scale,change,clock_offset";

/// The files `estimate` writes into its output directory.
const OUTPUTS: [&str; 2] = ["estimate.csv", "summary.json"];

/// Writes both files as a pair (the caller holds the directory's lock):
/// neither appears unless both are complete, and summary.json is removed
/// first and renamed into place last, so a summary.json always describes
/// the estimate.csv beside it.
fn write_outputs(out: &Path, est: &EstimateRun, summary: &serde_json::Value) -> Result<()> {
    let csv_path = out.join(OUTPUTS[0]);
    let json_path = out.join(OUTPUTS[1]);
    let mut csv = AtomicFile::create(&csv_path)?;
    let mut buf = String::with_capacity(1 << 16);
    buf.push_str(HEADER);
    buf.push('\n');
    for r in &est.rows {
        let _ = write!(buf, "{}", r.t);
        for (v, digits) in [
            (r.east, 4),
            (r.north, 4),
            (r.yaw, 6),
            (r.y_l, 6),
            (r.y_r, 6),
            (r.x_c, 6),
            (r.std[0], 4),
            (r.std[1], 4),
            (r.std[2], 6),
            (r.std[3], 6),
            (r.std[4], 6),
            (r.std[5], 6),
        ] {
            buf.push(',');
            push_fixed(&mut buf, v, digits);
        }
        buf.push(',');
        buf.push_str(est.terrain_name(r).unwrap_or(""));
        for (v, digits) in [
            (r.alpha_l, 5),
            (r.alpha_r, 5),
            (r.std[6], 5),
            (r.std[7], 5),
            (r.std_spread, 6),
        ] {
            buf.push(',');
            push_fixed(&mut buf, v, digits);
        }
        let _ = write!(buf, ",{},{}", r.fused as u8, r.gated as u8);
        for (v, digits) in [(r.nis, 3), (r.q_scale, 3)] {
            buf.push(',');
            push_fixed(&mut buf, v, digits);
        }
        let _ = write!(buf, ",{},", r.change as u8);
        push_fixed(&mut buf, r.clock_offset, 4);
        buf.push('\n');
        if buf.len() > 60_000 {
            csv.write_all(buf.as_bytes())
                .with_context(|| format!("{}: write failed", csv_path.display()))?;
            buf.clear();
        }
    }
    csv.write_all(buf.as_bytes())
        .with_context(|| format!("{}: write failed", csv_path.display()))?;
    let mut js = AtomicFile::create(&json_path)?;
    js.write_all(serde_json::to_string_pretty(summary)?.as_bytes())
        .with_context(|| format!("{}: write failed", json_path.display()))?;
    match std::fs::remove_file(&json_path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            return Err(e).with_context(|| format!("{}: cannot replace", json_path.display()));
        }
        _ => {}
    }
    csv.commit()?;
    js.commit()?;
    Ok(())
}

/// Appends `v` with `digits` decimals. Integer arithmetic: `format!` with a
/// precision costs ~1 s per hour of 50 Hz rows, this a tenth of it.
fn push_fixed(buf: &mut String, v: f64, digits: u32) {
    let scale = 10u64.pow(digits);
    let scaled = (v.abs() * scale as f64).round();
    if !v.is_finite() || scaled >= 9.0e15 {
        let _ = write!(buf, "{v:.*}", digits as usize);
        return;
    }
    let n = scaled as u64;
    if v < 0.0 && n != 0 {
        buf.push('-');
    }
    let _ = write!(
        buf,
        "{}.{:0width$}",
        n / scale,
        n % scale,
        width = digits as usize
    );
}

#[cfg(test)]
mod tests {
    use super::push_fixed;

    #[test]
    fn fixed_formatting_matches_format() {
        for v in [
            0.0,
            -0.0,
            1.5,
            -2.25,
            0.123456789,
            -0.00004,
            123456.7,
            1e300,
            f64::NAN,
            -1e-9,
        ] {
            for d in [3, 4, 6] {
                let mut s = String::new();
                push_fixed(&mut s, v, d);
                let want = format!("{v:.*}", d as usize);
                let want =
                    if want.starts_with('-') && want[1..].chars().all(|c| c == '0' || c == '.') {
                        want[1..].to_string()
                    } else {
                        want
                    };
                assert_eq!(s, want, "{v} {d}");
            }
        }
    }
}
