//! `calibrate validate`: scores parameters on other drives, segment by
//! segment, against the no-slip model (Mandow Table III).

use std::collections::BTreeMap;

use terraslip_core::IcrParams;
use terraslip_io::{DriveLog, ParamsFile, RateModelEntry};

use crate::model::{integrate, integrate_rate, RateSlopes};
use crate::offset::estimate_offset;
use crate::segment::{Increment, SegmentConfig, SegmentStats, Segments};
use crate::CalibError;
use terraslip_core::angle;

/// Mean squared increment errors over segments: m^2, m^2, rad^2.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Mse {
    pub dx: f64,
    pub dy: f64,
    pub dyaw: f64,
}

impl Mse {
    /// Mean squared position error `dx + dy`, m^2.
    pub fn position(&self) -> f64 {
        self.dx + self.dy
    }

    fn of(errs: &[[f64; 3]]) -> Self {
        let n = errs.len().max(1) as f64;
        let mut m = Mse::default();
        for e in errs {
            m.dx += e[0] * e[0] / n;
            m.dy += e[1] * e[1] / n;
            m.dyaw += e[2] * e[2] / n;
        }
        m
    }
}

/// Where the wheel/pose time offset of a validation log comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OffsetChoice {
    /// `time_offset_s` stored with the parameters (0 if absent): the latency
    /// is a property of the robot's sensor setup, found at calibration.
    FromParams,
    /// Estimated on the validation log itself (needs no model parameter).
    Auto {
        max: f64,
        step: f64,
    },
    Fixed(f64),
}

/// Which model of a parameter set `validate` scores.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModelChoice {
    /// The turn-rate dependent model where the file has one selected at
    /// calibration (`rate_model.selected`), else the constant ICRs.
    FromParams,
    /// Mandow's constant ICRs (the file's `params`) whatever the file holds.
    Constant,
}

/// Validation settings.
#[derive(Debug, Clone, PartialEq)]
pub struct ValidateConfig {
    pub segment: SegmentConfig,
    pub time_offset: OffsetChoice,
    pub model: ModelChoice,
}

impl Default for ValidateConfig {
    fn default() -> Self {
        Self {
            segment: SegmentConfig::default(),
            time_offset: OffsetChoice::FromParams,
            model: ModelChoice::FromParams,
        }
    }
}

/// The model of one set of a parameter file: its constant ICR parameters,
/// or, with [`ModelChoice::FromParams`], the turn-rate dependent model
/// stored under `rate_model` when calibration selected it. A `rate_model`
/// that is selected but malformed is an error naming the set; files
/// without one (older files) give the constant model.
pub fn model_for(
    pf: &ParamsFile,
    terrain: Option<&str>,
    choice: ModelChoice,
) -> Result<Option<(IcrParams, RateSlopes)>, CalibError> {
    let Some(p) = pf.for_terrain(terrain) else {
        return Ok(None);
    };
    let (set, extra) = match terrain.and_then(|t| pf.terrains.get(t).map(|e| (t, e))) {
        Some((t, e)) => (t.to_string(), &e.extra),
        None => ("params".to_string(), &pf.extra),
    };
    if choice != ModelChoice::FromParams {
        return Ok(Some((p, RateSlopes::NONE)));
    }
    let rate = RateModelEntry::selected(extra)
        .map_err(|reason| CalibError::BadRateModel { set, reason })?;
    let Some(r) = rate else {
        return Ok(Some((p, RateSlopes::NONE)));
    };
    let slopes = RateSlopes {
        k_spread: r.k_spread,
        k_alpha: r.k_alpha,
        k_acc: r.k_acc,
        k_dir: r.k_dir,
        k_x_speed: r.k_x_speed,
        k_spread_speed: r.k_spread_speed,
    };
    Ok(Some((r.params, slopes)))
}

/// One scored segment.
#[derive(Debug, Clone, PartialEq)]
pub struct SegmentScore {
    pub log: usize,
    pub t0: f64,
    pub t1: f64,
    pub terrain: Option<String>,
    pub reference: Increment,
    /// The scored model's prediction (the turn-rate model where selected).
    pub predicted: Increment,
    /// The set's constant ICR model (equal to `predicted` where it is scored).
    pub constant: Increment,
    pub nominal: Increment,
}

/// Scores over all segments and per terrain.
#[derive(Debug, Clone, PartialEq)]
pub struct Validation {
    pub segments: Vec<SegmentScore>,
    pub mse: Mse,
    /// The same segments with each set's constant ICRs (equal to `mse`
    /// unless a turn-rate model was scored).
    pub constant_mse: Mse,
    pub nominal_mse: Mse,
    /// Per terrain: (segments, mse, nominal_mse).
    pub per_terrain: BTreeMap<String, (usize, Mse, Mse)>,
    /// Segments skipped because the params file has no set for their terrain.
    pub no_params: usize,
    pub stats: SegmentStats,
    /// Time offset used per log, s.
    pub offsets: Vec<f64>,
    /// Segments scored with a turn-rate dependent model.
    pub rate_segments: usize,
}

fn err(r: &Increment, p: &Increment) -> [f64; 3] {
    [r.dx - p.dx, r.dy - p.dy, angle::wrap(r.dyaw - p.dyaw)]
}

/// The time offset recorded in a params file (mean over its sets).
pub fn stored_offset(pf: &ParamsFile) -> Option<f64> {
    let mut v: Vec<f64> = pf
        .terrains
        .values()
        .filter_map(|e| e.extra.get("time_offset_s").and_then(|x| x.as_f64()))
        .collect();
    if let Some(o) = pf.extra.get("time_offset_s").and_then(|x| x.as_f64()) {
        v.push(o);
    }
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

/// Scores `params` on `logs` against the no-slip model of each log's
/// `meta.toml` track width. Stationary segments are skipped (both models
/// predict them perfectly); nothing else is dropped.
pub fn validate(
    logs: &[DriveLog],
    params: &ParamsFile,
    cfg: &ValidateConfig,
) -> Result<Validation, CalibError> {
    if logs.is_empty() {
        return Err(CalibError::NoLogs);
    }
    // The score is over chained segments (the contract), whatever the
    // calibration fitted on.
    let scfg = SegmentConfig {
        overlap: None,
        ..cfg.segment.for_logs(logs)
    };
    let mut offsets = Vec::new();
    for log in logs {
        if log.pose.is_empty() {
            return Err(CalibError::NoPose {
                log: log.dir.clone(),
            });
        }
        if log.meta.track_width.is_none() {
            return Err(CalibError::NoTrackWidth {
                log: log.dir.clone(),
            });
        }
        offsets.push(match cfg.time_offset {
            OffsetChoice::Fixed(o) => o,
            OffsetChoice::FromParams => stored_offset(params).unwrap_or(0.0),
            // A long drive's offset is searched on evenly spread windows
            // of it, as `calibrate` does.
            OffsetChoice::Auto { max, step } => {
                let windows = crate::offset::thinned(log, crate::offset::OFFSET_POSES);
                estimate_offset(&windows, &scfg, max, step)
                    .map(|x| x.0)
                    .unwrap_or(0.0)
            }
        });
    }
    let refs: Vec<&DriveLog> = logs.iter().collect();
    let segs = Segments::build(&refs, &offsets, &scfg);
    let mut out = Vec::new();
    let mut no_params = 0;
    let mut rate_segments = 0;
    for s in &segs.segments {
        let Some((p, k)) = model_for(params, s.terrain.as_deref(), cfg.model)? else {
            no_params += 1;
            continue;
        };
        rate_segments += usize::from(!k.is_constant());
        let w = logs[s.log].meta.track_width.unwrap_or(1.0);
        let steps = segs.steps_of(s);
        let predicted = integrate_rate(&p, &k, steps);
        let constant = match params.for_terrain(s.terrain.as_deref()) {
            Some(c) if !k.is_constant() => integrate(&c, steps),
            _ => predicted,
        };
        out.push(SegmentScore {
            log: s.log,
            t0: s.t0,
            t1: s.t1,
            terrain: s.terrain.clone(),
            reference: s.reference,
            predicted,
            constant,
            nominal: integrate(&IcrParams::no_slip(w), steps),
        });
    }
    if out.is_empty() {
        return Err(CalibError::TooFewSegments {
            set: "validation".into(),
            moving: 0,
            needed: 1,
            hint: segs.stats.hint(0),
        });
    }
    let (mse, nominal_mse) = scores(&out);
    let constant_mse = Mse::of(
        &out.iter()
            .map(|x| err(&x.reference, &x.constant))
            .collect::<Vec<_>>(),
    );
    let mut per_terrain = BTreeMap::new();
    let mut names: Vec<String> = out.iter().filter_map(|s| s.terrain.clone()).collect();
    names.sort();
    names.dedup();
    for n in names {
        let sub: Vec<SegmentScore> = out
            .iter()
            .filter(|s| s.terrain.as_deref() == Some(n.as_str()))
            .cloned()
            .collect();
        let (m, nm) = scores(&sub);
        per_terrain.insert(n, (sub.len(), m, nm));
    }
    Ok(Validation {
        segments: out,
        mse,
        constant_mse,
        nominal_mse,
        per_terrain,
        no_params,
        stats: segs.stats,
        offsets,
        rate_segments,
    })
}

fn scores(s: &[SegmentScore]) -> (Mse, Mse) {
    let e: Vec<[f64; 3]> = s.iter().map(|x| err(&x.reference, &x.predicted)).collect();
    let en: Vec<[f64; 3]> = s.iter().map(|x| err(&x.reference, &x.nominal)).collect();
    (Mse::of(&e), Mse::of(&en))
}
