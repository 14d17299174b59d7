//! What a calibration found, per parameter set, and the parameter file it
//! writes.

use serde_json::{json, Value};
use terraslip_io::{ParamEntry, ParamsFile};

use super::json::{finite_or_null, params_json};
use super::method_fit::MethodFit;
use super::{RateChoice, ReductionChoice};
use crate::model::PARAM_NAMES;
use crate::segment::SegmentStats;

/// A segment dropped as an outlier.
#[derive(Debug, Clone, PartialEq)]
pub struct DroppedSegment {
    pub log: String,
    pub t0: f64,
    pub t1: f64,
    /// Residual norm at the best parameters, m.
    pub residual: f64,
}

/// The calibration of one set (one terrain, or everything pooled).
#[derive(Debug, Clone, PartialEq)]
pub struct SetCalibration {
    /// Terrain name; `None` for an unlabelled pooled set.
    pub terrain: Option<String>,
    pub best: MethodFit,
    pub fits: Vec<MethodFit>,
    pub segments_used: usize,
    pub dropped: Vec<DroppedSegment>,
    /// Segmentation counts of the logs that contributed to this set (the
    /// whole log, all its terrains).
    pub stats: SegmentStats,
    /// Robust per-component residual scale, m.
    pub sigma: f64,
    /// Per log: name and wheel-to-pose time offset, s.
    pub time_offsets: Vec<(String, f64)>,
    /// Parameters the data could not identify (kept at their start value).
    pub unidentified: Vec<&'static str>,
    pub notes: Vec<String>,
    /// The turn-rate dependent model, unless `RateModel::Off`.
    pub rate: Option<RateChoice>,
    /// The reduced constant models and the one `best` holds, unless
    /// [`CalibConfig::reduced_models`](super::CalibConfig::reduced_models) is off.
    pub reduction: Option<ReductionChoice>,
    /// Mean number of segments covering an instant ([`Segments::coverage`](crate::segment::Segments::coverage)):
    /// 1 for chained segments; counts are corrected by it.
    pub coverage: f64,
    /// The residual noise (pose reference and excess) the uncertainties
    /// assume, estimated at the LM fit.
    pub noise: crate::sandwich::ResidualNoise,
    pub yaw_weight: f64,
    pub track_width: Option<f64>,
    pub wheel_radius: Option<f64>,
    pub pioneer: bool,
    /// Position-only references: the turn factor from the windows and from
    /// the course check, and the combination the parameters carry.
    pub course: Option<TurnFigures>,
}

/// The turn factor `spread / (mean speed factor * S)` of a position-only
/// calibration, measured two ways ([`crate::course`]).
#[derive(Debug, Clone, PartialEq)]
pub struct TurnFigures {
    /// The separation `S` the tread speeds were made with, m.
    pub separation: f64,
    /// From the windows' fit, with its 1-sigma.
    pub windows: (f64, f64),
    /// From the course check, with its 1-sigma (jackknife over stretches).
    pub course: (f64, f64),
    pub stretches: usize,
    pub pairs: usize,
    /// The treads' asymmetry the course check fitted, with its 1-sigma
    /// (`None`: held at 0).
    pub asymmetry: Option<(f64, f64)>,
    /// The two combined by their inverse variances, with its 1-sigma: what
    /// the set's spread carries.
    pub combined: (f64, f64),
}

/// The result for all sets.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibration {
    pub sets: Vec<SetCalibration>,
    /// Warnings about the input (from the log reader and the segmenter).
    pub warnings: Vec<String>,
}

impl SetCalibration {
    /// Steering efficiency chi (Mandow eq. 9), if the track width is known.
    pub fn chi(&self) -> Option<f64> {
        self.track_width
            .map(|w| self.best.params.steering_efficiency(w))
    }

    /// Pioneer P3-AT server settings (Mandow eqs. 14-15, as printed there):
    /// `Ticksmm = round(alpha r 138/110)` with `r` in mm and `alpha` the mean
    /// factor; `Revcount = round(2 pi x_ICR Ticksmm / 8)` with `x_ICR` the
    /// half-spread in mm. With the factory alpha = 1, x_ICR = 300 mm and
    /// r = 110 mm this gives 138 and 32 515.
    pub fn pioneer_settings(&self) -> Option<(i64, i64)> {
        let r_mm = self.wheel_radius? * 1000.0;
        let p = &self.best.params;
        let alpha = 0.5 * (p.alpha_l + p.alpha_r);
        let ticksmm = (alpha * r_mm * 138.0 / 110.0).round();
        let x_icr_mm = 0.5 * p.spread() * 1000.0;
        let revcount = (2.0 * std::f64::consts::PI * x_icr_mm * ticksmm / 8.0).round();
        Some((ticksmm as i64, revcount as i64))
    }

    /// The file entry: params, eq. 13 cost and the extras.
    pub fn entry(&self) -> ParamEntry {
        let mut e = ParamEntry::new(self.best.params);
        e.cost = Some(self.best.cost);
        let x = &mut e.extra;
        x.insert("method".into(), json!(self.best.method.name()));
        let std: serde_json::Map<String, Value> = PARAM_NAMES
            .iter()
            .zip(self.best.std)
            .map(|(n, s)| (n.to_string(), finite_or_null(s)))
            .collect();
        x.insert("std".into(), Value::Object(std));
        let methods: serde_json::Map<String, Value> = self
            .fits
            .iter()
            .map(|f| {
                (
                    f.method.name().to_string(),
                    json!({"params": params_json(&f.params), "cost": f.cost, "robust_cost": f.robust_cost}),
                )
            })
            .collect();
        x.insert("methods".into(), Value::Object(methods));
        if let Some(chi) = self.chi() {
            x.insert("chi".into(), json!(chi));
        }
        x.insert("e".into(), json!(self.best.params.eccentricity()));
        let offsets: Vec<f64> = self.time_offsets.iter().map(|o| o.1).collect();
        if !offsets.is_empty() {
            let mean = offsets.iter().sum::<f64>() / offsets.len() as f64;
            x.insert("time_offset_s".into(), json!(mean));
            let per_log: serde_json::Map<String, Value> = self
                .time_offsets
                .iter()
                .map(|(n, o)| (n.clone(), json!(o)))
                .collect();
            x.insert("time_offsets".into(), Value::Object(per_log));
        }
        if let Some(r) = &self.reduction {
            x.insert("reduction".into(), r.to_json());
        }
        if let Some(r) = &self.rate {
            x.insert("rate_model".into(), r.to_json());
        }
        if let Some(c) = &self.course {
            x.insert(
                "turn_factor".into(),
                json!({
                    "separation_m": c.separation,
                    "windows": c.windows.0, "windows_std": finite_or_null(c.windows.1),
                    "course_check": c.course.0, "course_check_std": c.course.1,
                    "stretches": c.stretches, "pairs": c.pairs,
                    "course_check_asymmetry": c.asymmetry.map(|a| a.0),
                    "course_check_asymmetry_std": c.asymmetry.map(|a| a.1),
                    "combined": c.combined.0, "combined_std": c.combined.1,
                }),
            );
        }
        x.insert("yaw_weight".into(), json!(self.yaw_weight));
        x.insert("sigma_m".into(), json!(self.sigma));
        x.insert(
            "residual_noise".into(),
            json!({
                "pose_xy_m": self.noise.pose_xy,
                "pose_yaw_rad": self.noise.pose_yaw,
                "excess_xy_m_per_sqrt_s": self.noise.excess_xy,
                "excess_yaw_rad_per_sqrt_s": self.noise.excess_yaw,
            }),
        );
        x.insert("segments_used".into(), json!(self.segments_used));
        if self.coverage > 1.0 {
            x.insert("segment_coverage".into(), json!(self.coverage));
        }
        x.insert("segments_dropped".into(), json!(self.dropped.len()));
        x.insert("segments_stationary".into(), json!(self.stats.stationary));
        x.insert("stale_poses".into(), json!(self.stats.stale_poses));
        x.insert("mistimed_poses".into(), json!(self.stats.mistimed_poses));
        x.insert("implausible_segments".into(), json!(self.stats.implausible));
        let dropped: Vec<Value> = self
            .dropped
            .iter()
            .map(|d| json!({"log": d.log, "t0": d.t0, "t1": d.t1, "residual_m": d.residual}))
            .collect();
        x.insert("dropped".into(), Value::Array(dropped));
        if !self.unidentified.is_empty() {
            x.insert("unidentified".into(), json!(self.unidentified));
        }
        if !self.notes.is_empty() {
            x.insert("notes".into(), json!(self.notes));
        }
        if self.pioneer {
            if let Some((t, r)) = self.pioneer_settings() {
                x.insert("ticksmm".into(), json!(t));
                x.insert("revcount".into(), json!(r));
            }
        }
        e
    }
}

impl Calibration {
    /// What `calibrate` writes and `estimate --init` reads: a pooled set as
    /// top-level `params`, or one set per terrain under `terrains`.
    pub fn params_file(&self) -> ParamsFile {
        let mut pf = ParamsFile::default();
        for s in &self.sets {
            let e = s.entry();
            match &s.terrain {
                Some(name) => {
                    pf.terrains.insert(name.clone(), e);
                }
                None => {
                    pf.params = Some(e.params);
                    pf.cost = e.cost;
                    pf.extra = e.extra;
                }
            }
        }
        if !self.warnings.is_empty() {
            pf.extra
                .insert("warnings".into(), serde_json::json!(self.warnings));
        }
        pf
    }
}
