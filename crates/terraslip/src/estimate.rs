//! `terraslip estimate` as values, for the command and for other front ends
//! (the Python package): the configuration from a preset and TOML, the log
//! as the estimator reads it, the terrain evidence, the run, the content of
//! `summary.json` and the columns of `estimate.csv`.

use std::path::Path;

use anyhow::{bail, Context, Result};
use terraslip_io::{DriveLog, GyroStream, LogError, ParamsFile, PoseStream, Streams, WheelStream};

use crate::config::EstimatorConfig;
use crate::pipeline::{self, EstimateRow, EstimateRun, RowSink, RunOptions, TerrainEvidence};
use terraslip_core::filter::{FilterConfig, SlipHold};
use terraslip_core::slip::Chart;

pub mod headline;
mod numbers;
mod recommendation;

pub use recommendation::{controller_json, recommendation_json};

/// Reads only what the estimator uses: wheels, pose, imu, meta and
/// terrain (truth is for scoring, not estimating).
pub fn read_log(dir: &Path) -> Result<DriveLog, LogError> {
    DriveLog::read_streams(dir, Streams::ESTIMATOR)
}

/// The configuration in effect: the preset `preset` (else the default),
/// the keys of the TOML file `path` on top, validated.
pub fn load_config(preset: Option<&str>, path: Option<&Path>) -> Result<EstimatorConfig> {
    let text = match path {
        Some(p) => Some((
            std::fs::read_to_string(p).with_context(|| format!("{}: cannot read", p.display()))?,
            p.display().to_string(),
        )),
        None => None,
    };
    config_from(preset, text.as_ref().map(|(t, n)| (t.as_str(), n.as_str())))
}

/// [`load_config`] with the TOML given as `(text, name)`; `name` prefixes
/// the errors.
pub fn config_from(
    preset: Option<&str>,
    toml_text: Option<(&str, &str)>,
) -> Result<EstimatorConfig> {
    let mut cfg = match preset {
        Some(name) => EstimatorConfig::preset(name).with_context(|| {
            let names: Vec<&str> = EstimatorConfig::presets().iter().map(|p| p.0).collect();
            format!("unknown preset `{name}` (known: {})", names.join(", "))
        })?,
        None => EstimatorConfig::default(),
    };
    if let Some((text, name)) = toml_text {
        cfg = overlay(cfg, text, name)?;
    }
    cfg.validate()?;
    Ok(cfg)
}

/// `cfg` with the keys of TOML `text` over it (checked alone first, so
/// errors point at the user's own lines); `name` prefixes the errors.
pub fn overlay(cfg: EstimatorConfig, text: &str, name: &str) -> Result<EstimatorConfig> {
    toml::from_str::<EstimatorConfig>(text)
        .map_err(|e| crate::config::toml_error(text, &e))
        .with_context(|| name.to_string())?;
    // The base is the preset; the text's keys override it.
    let base = toml::Value::try_from(&cfg).context("serialising the base configuration")?;
    let over: toml::Value = toml::from_str(text)
        .map_err(|e| crate::config::toml_error(text, &e))
        .with_context(|| name.to_string())?;
    let merged = merge(base, over);
    EstimatorConfig::from_toml(&toml::to_string(&merged).unwrap_or_default())
        .with_context(|| name.to_string())
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

/// What a run uses besides the log and the configuration.
#[derive(Debug, Clone, Copy, Default)]
pub struct Inputs<'a> {
    /// Starting ICRs (`--init`).
    pub init: Option<&'a ParamsFile>,
    /// The log's own terrain.csv as terrain evidence (`--terrain-labels`).
    pub terrain_labels: bool,
    /// A terrain model classifying the log's imu or camera stream
    /// (`--terrain-model`); the log must hold that stream.
    pub terrain_model: Option<&'a Path>,
    /// Drop every pose fix in `[t0, t1)` s (`--outage`).
    pub outage: Option<(f64, f64)>,
}

/// A finished run: the rows of `estimate.csv` and `summary.json`.
#[derive(Debug, Clone)]
pub struct Estimate {
    pub run: EstimateRun,
    pub summary: serde_json::Value,
    /// What the command prints about its inputs (the terrain model used).
    pub notes: Vec<String>,
}

/// Runs the estimator over `log` as `terraslip estimate` does;
/// `progress(done, total)` is called every few thousand wheels rows.
pub fn estimate(
    log: &DriveLog,
    mut cfg: EstimatorConfig,
    inputs: &Inputs,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Estimate> {
    let (evidence, evidence_name, notes) = terrain_evidence(log, &mut cfg, inputs)?;
    let opts = RunOptions {
        outage: inputs.outage,
    };
    let run = pipeline::run_with(log, &cfg, &evidence, inputs.init, opts, progress)?;
    Ok(finish(log, run, &cfg, evidence_name, notes))
}

/// A log directory open for [`estimate_streamed`]: `meta.toml` and
/// `terrain.csv` read, `wheels.csv`, `pose.csv` and `imu.csv` open with
/// their headers checked.
pub struct OpenLog {
    /// The log without its wheels, pose and imu rows.
    pub log: DriveLog,
    wheels: WheelStream,
    pose: Option<PoseStream>,
    gyro: Option<GyroStream>,
    /// Size of wheels.csv, bytes.
    size: u64,
}

impl OpenLog {
    pub fn open(dir: &Path) -> Result<Self, LogError> {
        let log = DriveLog::read_streams(dir, Streams::HEADER)?;
        let wheels_path = dir.join("wheels.csv");
        let wheels = WheelStream::open(&wheels_path)?;
        let pose = match dir.join("pose.csv") {
            p if p.exists() => Some(PoseStream::open(&p)?),
            _ => None,
        };
        let gyro = match dir.join("imu.csv") {
            p if p.exists() => Some(GyroStream::open(&p)?),
            _ => None,
        };
        Ok(Self {
            log,
            wheels,
            pose,
            gyro,
            size: std::fs::metadata(&wheels_path).map_or(0, |m| m.len()),
        })
    }

    /// Size of wheels.csv, bytes.
    pub fn wheels_bytes(&self) -> u64 {
        self.size
    }
}

/// [`estimate`] reading the log's wheels.csv and pose.csv row by row, each
/// row of `estimate.csv` handed to `sink` as it is made, so memory does not
/// grow with the log (the result's `rows` stay empty).
/// `progress(bytes, total)` follows the reading of wheels.csv. A terrain
/// model needs the whole log: use [`estimate`] for it. Returns the log
/// (without its wheels and pose) with the reading's warnings.
pub fn estimate_streamed(
    open: OpenLog,
    mut cfg: EstimatorConfig,
    inputs: &Inputs,
    sink: &mut dyn RowSink,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<(DriveLog, Estimate)> {
    if inputs.terrain_model.is_some() {
        bail!("--terrain-model reads the whole log; run it without streaming");
    }
    let OpenLog {
        mut log,
        mut wheels,
        mut pose,
        mut gyro,
        size,
    } = open;
    let (evidence, evidence_name, notes) = terrain_evidence(&log, &mut cfg, inputs)?;
    let opts = RunOptions {
        outage: inputs.outage,
    };
    let mut no_pose = std::iter::empty();
    let mut no_gyro = std::iter::empty();
    // The gyro's clock against the wheels', from the first minutes.
    let fuse = gyro.as_ref().is_some_and(|g| g.has_gyro()) && cfg.measurement.std_gyro > 0.0;
    let clock = fuse.then(|| pipeline::gyro_delay_in(&log.dir));
    let clock = clock.unwrap_or(pipeline::GyroClock::Unknown);
    let run = {
        let mut counted = Counted {
            inner: &mut wheels,
            rows: 0,
            size,
            progress,
        };
        let streams = pipeline::Streams {
            wheels: &mut counted,
            pose: match pose.as_mut() {
                Some(p) => p,
                None => &mut no_pose,
            },
            gyro: match gyro.as_mut() {
                Some(g) => g,
                None => &mut no_gyro,
            },
            gyro_clock: clock,
        };
        pipeline::run_streams(
            &log,
            streams,
            &cfg,
            &evidence,
            inputs.init,
            opts,
            sink,
            &mut |_| {},
        )
        .map_err(|e| match e {
            // A row that cannot be read is reported as the whole-log read
            // reports it.
            pipeline::PipelineError::Read(e) => {
                anyhow::Error::new(e).context(format!("reading log {}", log.dir.display()))
            }
            e => e.into(),
        })?
    };
    log.warnings.extend(wheels.warnings());
    log.warnings.extend(pose.iter().flat_map(|p| p.warnings()));
    log.warnings.extend(gyro.iter().flat_map(|g| g.warnings()));
    let est = finish(&log, run, &cfg, evidence_name, notes);
    Ok((log, est))
}

/// Wheels rows with the reading's progress in bytes.
struct Counted<'a> {
    inner: &'a mut WheelStream,
    rows: usize,
    size: u64,
    progress: &'a mut dyn FnMut(u64, u64),
}

impl Iterator for Counted<'_> {
    type Item = Result<terraslip_io::WheelSample, LogError>;

    fn next(&mut self) -> Option<Self::Item> {
        let item = self.inner.next();
        self.rows += 1;
        if self.rows.is_multiple_of(4096) || item.is_none() {
            (self.progress)(self.inner.bytes_read(), self.size);
        }
        item
    }
}

/// What summary.json says of the terrain evidence.
struct EvidenceInfo {
    name: String,
    /// Share of a terrain model's windows driven outside its training
    /// envelope (`None` without a model, or for a model without envelope).
    outside_envelope_share: Option<f64>,
}

impl From<String> for EvidenceInfo {
    fn from(name: String) -> Self {
        Self {
            name,
            outside_envelope_share: None,
        }
    }
}

/// How a note that is a warning starts.
const WARNING: &str = "warning: ";

/// Why a vibration model gave the estimator no window of `log`.
fn slow_drive(log: &DriveLog, model: &Path) -> String {
    let speeds: Vec<f64> = log
        .wheels
        .iter()
        .map(|s| 0.5 * (s.v_left.abs() + s.v_right.abs()))
        .collect();
    let mean = speeds.iter().sum::<f64>() / speeds.len().max(1) as f64;
    format!(
        "--terrain-model {}: no window was used, the terrain stays unknown: the estimator takes a vibration window only where the mean tread speed reaches {} m/s (slower, vibration tells grounds apart poorly), and this drive's is {mean:.2} m/s (`terrain eval` scores every window)",
        model.display(),
        terraslip_terrain::MIN_INFORMATIVE_SPEED
    )
}

/// The terrain evidence `inputs` ask for (the model's smoothing put into
/// `cfg`), its name in summary.json, and what the command prints about it.
fn terrain_evidence(
    log: &DriveLog,
    cfg: &mut EstimatorConfig,
    inputs: &Inputs,
) -> Result<(TerrainEvidence, EvidenceInfo, Vec<String>)> {
    let mut notes = Vec::new();
    if inputs.terrain_labels {
        if log.terrain.is_empty() {
            bail!("--terrain-labels: {} has no terrain.csv", log.dir.display());
        }
        return Ok((
            TerrainEvidence::Labels(log.terrain.clone()),
            "labels (terrain.csv)".to_string().into(),
            notes,
        ));
    }
    let Some(path) = inputs.terrain_model else {
        return Ok((TerrainEvidence::None, "none".to_string().into(), notes));
    };
    let ctx = || format!("--terrain-model {}", path.display());
    let model = terraslip_terrain::TerrainModel::load(path).with_context(ctx)?;
    let timeline = model.estimator_evidence(log).with_context(ctx)?;
    if timeline.frames.is_empty() && model.source == terraslip_terrain::Source::Imu {
        notes.push(format!("{WARNING}{}", slow_drive(log, path)));
    }
    // The model carries the smoothing it was validated with (λ chosen
    // from its own accuracy, wang2018 eq. 14): use it, not the defaults.
    cfg.belief.stay_prob = model.belief.stay_prob;
    cfg.belief.stay_prob_on_jump = model.belief.stay_prob_on_jump;
    cfg.belief.vote_lambda = model.belief.vote_lambda;
    notes.push(format!(
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
    ));
    let outside = timeline.outside_envelope_share();
    if let Some(f) = outside.filter(|&f| f > 0.0) {
        notes.push(format!(
            "terrain: {:.1} % of the windows were driven at a speed or turn that no training run \
             of the terrain they were read as has (their confidence was lowered); record such \
             driving on every terrain and retrain",
            100.0 * f
        ));
    }
    Ok((
        TerrainEvidence::from(timeline),
        EvidenceInfo {
            name: format!("model {} ({:?})", path.display(), model.source),
            outside_envelope_share: outside,
        },
        notes,
    ))
}

/// The estimate's summary; notes that are warnings (`warning: ...`) join
/// the run's warnings, so summary.json lists them too.
fn finish(
    log: &DriveLog,
    mut run: EstimateRun,
    cfg: &EstimatorConfig,
    evidence: EvidenceInfo,
    notes: Vec<String>,
) -> Estimate {
    let (warnings, notes): (Vec<String>, Vec<String>) =
        notes.into_iter().partition(|n| n.starts_with(WARNING));
    run.warnings
        .extend(warnings.iter().map(|w| w[WARNING.len()..].to_string()));
    let mut summary = summary_json(log, &run, cfg);
    summary["terrain_evidence"] = serde_json::Value::String(evidence.name);
    if let Some(f) = evidence.outside_envelope_share {
        summary["terrain_outside_envelope_share"] = serde_json::json!(f);
    }
    Estimate {
        run,
        summary,
        notes,
    }
}

/// The content of `summary.json` (without `terrain_evidence`).
pub fn summary_json(log: &DriveLog, est: &EstimateRun, cfg: &EstimatorConfig) -> serde_json::Value {
    let icr = est.final_icr;
    let last = est.last_row;
    let learning = learning_json(est.hold, &cfg.filter);
    serde_json::json!({
        "log": log.dir.display().to_string(),
        "rows": est.row_count,
        "duration_s": est.duration(),
        // The final ICRs: the turn law's straight-line values (a tread speed
        // difference of 0); estimate.csv's rows hold those in effect at each
        // row's turn rate.
        "icr": {
            "y_l": icr.y_l, "y_r": icr.y_r, "x_c": icr.x_c,
            "alpha_l": icr.alpha_l, "alpha_r": icr.alpha_r,
        },
        "icr_holds_at": "straight line (tread speed difference 0)",
        "icr_is": "final state: the estimator's last state; `recommendation` holds the whole drive's figures",
        // Per group of slip parameters: "learned" or "held (why)"; a held
        // group's values in "icr" are its starting values.
        "learning": learning,
        // The whole drive's figures with their 1-sigma (null where held).
        "recommendation": recommendation_json(est.drive.as_ref(), &learning),
        "icr_std": last.map(|r| serde_json::json!({
            "y_l": r.std[3], "y_r": r.std[4], "x_c": r.std[5], "spread": r.std_spread,
        })),
        "track_width": est.track_width,
        "controller": controller_json(&log.meta, &icr, est.drive.as_ref(), &learning),
        "variant": cfg.filter.variant,
        "init": est.init_source,
        "clock_offset_s": {"value": est.clock_offset.0, "std": est.clock_offset.1},
        // Where the pose reference sits on the robot (body frame, m), apart
        // from x_c: "stated" (meta.toml's [pose]) or "config".
        "pose_lever_arm_m": {
            "x": est.lever_arm.x, "y": est.lever_arm.y,
            "source": est.lever_arm.source,
        },
        // The spread in effect is (1 + slope |v_r - v_l|) times "icr"'s.
        "turn_law_s_per_m": {"slope": est.turn_law.0, "std": est.turn_law.1},
        // Both speed factors in effect are (1 + slope |v_r - v_l|) times "icr"'s.
        "speed_law_s_per_m": {"slope": est.speed_law.0, "std": est.speed_law.1},
        // At mean tread speed v (m/s): x_c moves by k_x_speed v, the spread
        // scales by 1 + k_spread_speed |v| (on top of the turn law).
        "centripetal": {
            "k_x_speed": est.centripetal.0.k_x_speed,
            "k_spread_speed": est.centripetal.0.k_spread_speed,
            "std_k_x_speed": est.centripetal.1.k_x_speed,
            "std_k_spread_speed": est.centripetal.1.k_spread_speed,
            "learned": est.centripetal.2,
        },
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
        // The yaw-rate gyro (imu.csv's gyro_z), null without one.
        "gyro": (est.gyro.fused > 0).then(|| serde_json::json!({
            "std_rad_s": est.gyro.std,
            "bias_rad_s": est.gyro.bias,
            "bias_std_rad_s": est.gyro.bias_std,
            // It reads `scale` times the true yaw rate.
            "scale": est.gyro.scale,
            "scale_std": est.gyro.scale_std,
            "scale_learning": if est.gyro.scale_learned {
                "learned"
            } else {
                "held (no position or heading reference: only they show the true turn; its starting value)"
            },
            "windows_fused": est.gyro.fused,
            "windows_widened": est.gyro.widened,
            "wheels_late_by_s": est.gyro_delay,
        })),
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
        "prediction": est.prediction.as_ref().map(|p| p.to_json()),
        "outage": est.outage.as_ref().map(|o| o.to_json()),
    })
}

/// The `learning` object of `summary.json`: for the spread, the speed
/// factor difference, the common speed factor and the ICR centre offsets,
/// `"learned"` or `"held (why)"`.
pub fn learning_json(hold: SlipHold, filter: &FilterConfig) -> serde_json::Value {
    const NO_POSITIONS: &str =
        "held (no position reference: only positions show it; its starting value)";
    const NOTHING: &str =
        "held (no position, heading or gyro: nothing measures the motion; its starting value)";
    let filter = FilterConfig { hold, ..*filter };
    let held = filter.held_slots();
    let (spread, difference, speed, offsets) = match filter.chart {
        Chart::Gain => (held[0], held[1], held[2], held[3] || held[4]),
        Chart::Tread => (held[0] || held[1], held[3], held[3], held[2]),
    };
    let state = |is_held: bool, factor: bool| {
        if !filter.learn_icr {
            "held (filter.learn_icr = false)"
        } else if factor && !filter.learn_alpha {
            "held (filter.learn_alpha = false)"
        } else if !is_held {
            "learned"
        } else if hold == SlipHold::All {
            NOTHING
        } else if factor && filter.chart == Chart::Tread {
            "held (no position reference: the tread chart holds both speed factors)"
        } else {
            NO_POSITIONS
        }
    };
    serde_json::json!({
        "spread": state(spread, false),
        "speed_factor_difference": state(difference, true),
        "speed_factor": state(speed, true),
        "icr_centre_offsets": state(offsets, false),
    })
}

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
