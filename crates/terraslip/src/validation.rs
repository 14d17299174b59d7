//! `terraslip calibrate validate` as values: the 2 s prediction score of a
//! parameters file and the JSON object `--json` prints.

use anyhow::Context;
use terraslip_calib::prediction::{score_timed, PredictionScore, Timed};
use terraslip_calib::validate::{model_for, stored_offset, OffsetChoice};
use terraslip_calib::{ModelChoice, Mse, ValidateConfig, Validation};
use terraslip_io::{DriveLog, ParamsFile};

/// What `calibrate validate` scores on a set of logs.
#[derive(Debug, Clone)]
pub enum Scores {
    /// Logs with a heading reference: the segment scores, and the 2 s
    /// prediction with the same time offsets (`None` when a log lacks a
    /// track width or a pose reference).
    Segments {
        validation: Box<Validation>,
        prediction: Option<PredictionScore>,
    },
    /// Logs whose reference is position-only (GNSS fixes, no heading):
    /// the 2 s prediction alone ([`position_only`]).
    PositionOnly(PositionOnlyScore),
}

impl Scores {
    /// What `calibrate validate --json` prints.
    pub fn to_json(&self) -> serde_json::Value {
        match self {
            Scores::Segments {
                validation,
                prediction,
            } => to_json(validation, prediction.as_ref()),
            Scores::PositionOnly(s) => s.to_json(),
        }
    }
}

/// `calibrate validate`: scores `params` on `logs` as `cfg` asks. When
/// every log's reference is position-only the segment scores are not
/// made (they need headings) and the 2 s prediction is scored with the
/// start heading profiled out; `cfg.time_offset` must then be the file's
/// offset or a fixed one (`auto` regresses heading changes).
pub fn score(
    logs: &[DriveLog],
    params: &ParamsFile,
    cfg: &ValidateConfig,
) -> anyhow::Result<Scores> {
    if !logs.is_empty() && logs.iter().all(terraslip_calib::track::position_only) {
        let offset = match cfg.time_offset {
            OffsetChoice::FromParams => stored_offset(params).unwrap_or(0.0),
            OffsetChoice::Fixed(o) => o,
            OffsetChoice::Auto { .. } => anyhow::bail!(
                "--time-offset auto regresses heading changes, which a position-only reference \
                 (no heading) does not have: give `params` (the offset calibrate found) or seconds"
            ),
        };
        return Ok(Scores::PositionOnly(position_only(
            logs,
            params,
            &vec![offset; logs.len()],
        )?));
    }
    let v = terraslip_calib::validate(logs, params, cfg).context("validation failed")?;
    let prediction = prediction_at(logs, params, &v.offsets);
    Ok(Scores::Segments {
        validation: Box::new(v),
        prediction,
    })
}

/// The 2 s prediction score of `params` over all `logs` together, each log
/// read with the file's `time_offset_s` (0 without one); `None` when a log
/// lacks a track width or a pose reference. See [`prediction_at`].
pub fn prediction(logs: &[DriveLog], params: &ParamsFile) -> Option<PredictionScore> {
    let offset = stored_offset(params).unwrap_or(0.0);
    prediction_at(logs, params, &vec![offset; logs.len()])
}

/// The 2 s prediction score of `params` over all `logs` together: the
/// model of the terrain in effect (or of the pooled set) over each 2 s,
/// the selected turn-rate and centripetal model where calibration
/// selected one, else the constant ICRs, the pose of log `i` read
/// `offsets[i]` s later than its stamps (the pose stamped late by that
/// much); `None` when a log lacks a track width or a pose reference.
pub fn prediction_at(
    logs: &[DriveLog],
    params: &ParamsFile,
    offsets: &[f64],
) -> Option<PredictionScore> {
    let mut all: Option<PredictionScore> = None;
    for (log, &offset) in logs.iter().zip(offsets) {
        let w = log.meta.track_width.filter(|w| w.is_finite() && *w > 0.0)?;
        let set_at = |t: f64| {
            let k = log.terrain.partition_point(|l| l.t <= t);
            let name = k.checked_sub(1).map(|k| log.terrain[k].terrain.as_str());
            timed(params, name, offset)
        };
        if let Some(s) = score_timed(&log.wheels, &log.pose, w, &set_at, Default::default()) {
            match all.as_mut() {
                Some(a) => a.segments.extend(s.segments),
                None => all = Some(s),
            }
        }
    }
    all.map(|a| PredictionScore::from_segments(a.spec, a.segments))
}

/// The model of `terrain`'s set (or the pooled set) of `params` as the 2 s
/// prediction scores it: the selected turn-rate and centripetal model, else
/// the constant ICRs, the pose read `offset` s later. A malformed
/// `rate_model` counts as absent here (`validate` names it).
pub fn timed(params: &ParamsFile, terrain: Option<&str>, offset: f64) -> Option<Timed> {
    let (p, slopes) = model_for(params, terrain, ModelChoice::FromParams)
        .ok()
        .flatten()?;
    Some(Timed {
        slopes,
        ..Timed::new(p, offset)
    })
}

/// What `calibrate validate --json` prints: mean squared errors (dx, dy in
/// m^2, dyaw in rad^2) of the calibrated, constant and no-slip models, per
/// terrain, the time offsets used and the 2 s prediction score.
pub fn to_json(v: &Validation, prediction: Option<&PredictionScore>) -> serde_json::Value {
    let ratio = |n: f64, c: f64| if c > 0.0 { n / c } else { f64::INFINITY };
    let mse = |m: &Mse| serde_json::json!({"dx": m.dx, "dy": m.dy, "dyaw": m.dyaw});
    let per: serde_json::Map<String, serde_json::Value> = v
        .per_terrain
        .iter()
        .map(|(k, (n, m, nm))| {
            (
                k.clone(),
                serde_json::json!({"segments": n, "mse": mse(m), "nominal_mse": mse(nm)}),
            )
        })
        .collect();
    serde_json::json!({
        "segments": v.segments.len(),
        "mse": mse(&v.mse),
        "nominal_mse": mse(&v.nominal_mse),
        "position_mse_ratio": ratio(v.nominal_mse.position(), v.mse.position()),
        "constant_mse": mse(&v.constant_mse),
        "constant_position_mse_ratio": ratio(v.nominal_mse.position(), v.constant_mse.position()),
        "rate_model_segments": v.rate_segments,
        "time_offsets_s": v.offsets,
        "stationary_skipped": v.stats.stationary,
        "implausible_dropped": v.stats.implausible,
        "mistimed_poses_dropped": v.stats.mistimed_poses,
        "held_poses_dropped": v.stats.stale_poses,
        "terrains": per,
        "prediction": prediction.map(|p| p.to_json()),
    })
}

/// `calibrate validate` on position-only references (GNSS fixes, no
/// heading, [`terraslip_calib::track::position_only`]): the segment scores
/// need headings, so only the 2 s prediction is made, each model's start
/// heading and position profiled out over the fixes before each start
/// ([`terraslip_calib::position_prediction`]). The model is the file's
/// pooled set (a position-only calibration fits constant ICRs); the
/// no-slip model is that of each log's track width, else of the separation
/// its tread speeds were made with (`meta.toml`'s `separation`). `offsets`:
/// the pose read that much later than its stamps, per log.
pub fn position_only(
    logs: &[DriveLog],
    params: &ParamsFile,
    offsets: &[f64],
) -> anyhow::Result<PositionOnlyScore> {
    let p = params.for_terrain(None).context(
        "a position-only reference is scored with the file's pooled parameter set \
         (`params`), and this file has only terrain sets",
    )?;
    let spec = terraslip_calib::position_prediction::PositionOnlySpec::default();
    let mut all: Option<PredictionScore> = None;
    let mut widths = Vec::with_capacity(logs.len());
    for (log, &offset) in logs.iter().zip(offsets) {
        let width = log
            .meta
            .track_width
            .or(log.meta.separation)
            .filter(|w| w.is_finite() && *w > 0.0)
            .with_context(|| {
                format!(
                    "{}: meta.toml has neither track_width nor separation, so the no-slip \
                     model to compare against is undefined",
                    log.dir.display()
                )
            })?;
        widths.push(width);
        let s = terraslip_calib::position_prediction::score(log, &p, width, offset, &spec);
        if let Some(s) = s {
            match all.as_mut() {
                Some(a) => a.segments.extend(s.segments),
                None => all = Some(s),
            }
        }
    }
    let prediction = all
        .map(|a| {
            let mut s = PredictionScore::from_segments(a.spec, a.segments);
            s.profiled_window_s = a.profiled_window_s;
            s
        })
        .with_context(|| {
            format!(
                "no 2 s prediction could be made: each start needs {} fixes over the {} s \
                 before it, no gap over {} s between fixes nor over {} s between wheel samples",
                spec.min_fixes, spec.window, spec.max_fix_gap, spec.prediction.max_gap
            )
        })?;
    Ok(PositionOnlyScore {
        prediction,
        offsets: offsets.to_vec(),
        no_slip_widths: widths,
    })
}

/// What [`position_only`] scores.
#[derive(Debug, Clone)]
pub struct PositionOnlyScore {
    pub prediction: PredictionScore,
    /// Time offset per log, s.
    pub offsets: Vec<f64>,
    /// The no-slip model's separation per log, m.
    pub no_slip_widths: Vec<f64>,
}

impl PositionOnlyScore {
    /// What `calibrate validate --json` prints for position-only logs.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "reference": "position-only",
            "segments": null,
            "time_offsets_s": self.offsets,
            "no_slip_width_m": self.no_slip_widths,
            "prediction": self.prediction.to_json(),
        })
    }
}
