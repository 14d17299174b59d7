//! `terraslip estimate` as values, for the command and for other front ends
//! (the Python package): the configuration from a preset and TOML, the log
//! as the estimator reads it, the terrain evidence, the run, the content of
//! `summary.json` and the columns of `estimate.csv`.

use std::path::Path;

use anyhow::{bail, Context, Result};
use terraslip_io::{DriveLog, GyroStream, LogError, ParamsFile, PoseStream, Streams, WheelStream};

use crate::config::EstimatorConfig;
use crate::pipeline::{self, EstimateRun, RowSink, RunOptions, TerrainEvidence};

mod columns;
pub mod headline;
mod numbers;
mod recommendation;
mod summary;

pub use columns::{as_written, header, prediction_csv, values, Column, RowWriter, COLUMNS};
pub use recommendation::{controller_json, recommendation_json};
pub use summary::{learning_json, summary_json};

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
