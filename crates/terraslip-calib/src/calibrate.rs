//! The whole offline calibration: segments, time offset, the three methods,
//! identifiability checks, one parameter set per terrain.

use serde_json::{json, Value};
use terraslip_core::IcrParams;
use terraslip_io::{DriveLog, ParamEntry, ParamsFile};

use crate::ga::{self, GaConfig};
use crate::lm::{self, LmConfig, RateFit, RATE_PARAM_NAMES};
use crate::model::{self, PARAM_NAMES};
use crate::offset::{self, estimate_offset};
use crate::segment::{SegmentConfig, SegmentStats, Segments};
use crate::symmetric::{self, SymmetricMissing};
use crate::CalibError;

/// Identification method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Method {
    /// Robust Levenberg-Marquardt from the no-slip model.
    Lm,
    /// Mandow's genetic algorithm.
    Ga,
    /// Mandow's quick symmetric calibration (eqs. 11-12).
    Symmetric,
}

impl Method {
    pub fn name(self) -> &'static str {
        match self {
            Method::Lm => "lm",
            Method::Ga => "ga",
            Method::Symmetric => "symmetric",
        }
    }
}

/// How the wheel/pose time offset is chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TimeOffset {
    /// Searched per log in `[-max, max]` s on a `step` grid.
    Auto { max: f64, step: f64 },
    /// The same given offset (s) for every log.
    Fixed(f64),
}

/// GA knobs exposed to users; the bounds default to ones scaled by the
/// robot's track width.
#[derive(Debug, Clone, PartialEq)]
pub struct GaSettings {
    pub population: usize,
    pub generations: usize,
    pub seed: u64,
    pub gene_bits: Option<u32>,
    pub bounds: Option<[(f64, f64); 5]>,
    pub threads: Option<usize>,
}

impl Default for GaSettings {
    fn default() -> Self {
        let d = GaConfig::for_track_width(1.0);
        Self {
            population: d.population,
            generations: d.generations,
            seed: d.seed,
            gene_bits: None,
            bounds: None,
            threads: None,
        }
    }
}

/// Calibration settings. Defaults are what `terraslip calibrate` uses.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibConfig {
    pub segment: SegmentConfig,
    /// Weight between metres and radians in eq. 13, m/rad: a heading error
    /// of 1 rad costs as much as a position error of `yaw_weight` m.
    /// Mandow et al. use 1. The default 0.5 is about the sideways shift a
    /// heading error causes at the end of a 1 s segment driven at 1 m/s
    /// (`d * dphi / 2`); on the Warthog drives it predicted held-out
    /// positions better than 1 (see docs/research-log.md).
    pub yaw_weight: f64,
    /// `None` runs every method and keeps the best.
    pub method: Option<Method>,
    pub lm: LmConfig,
    pub ga: GaSettings,
    pub time_offset: TimeOffset,
    /// Fewest moving segments (after outlier removal) a set needs.
    pub min_segments: usize,
    /// Fewest segments turning more than 0.1 rad for the spread and x_c to
    /// be identifiable.
    pub min_turning_segments: usize,
    /// Instead of failing when the data cannot identify some parameters,
    /// keep those at their no-slip value, fit the rest and list them under
    /// `unidentified`.
    pub allow_partial: bool,
    /// Whether to fit the turn-rate dependent model ([`RateSlopes`](crate::model::RateSlopes)) next to
    /// the constant one.
    pub rate_model: RateModel,
    /// Whether to fit the traction term (`k_acc`, and `k_dir` with
    /// `traction_signed`) on top of the turn-rate model. `Auto` selects it
    /// by the same information criterion; `Off` unless `rate_model` is on.
    pub traction: RateModel,
    /// Let the traction term differ between accelerating and braking.
    pub traction_signed: bool,
}

/// Whether the turn-rate dependent ICR model ([`RateSlopes`](crate::model::RateSlopes)) is fitted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RateModel {
    /// Only Mandow's constant ICRs.
    Off,
    /// Fitted, and selected when it lowers the Bayesian information
    /// criterion over the constant model on the same segments and both
    /// slopes are identified.
    Auto,
    /// Fitted and selected whenever both slopes are identified.
    On,
}

impl RateModel {
    pub fn name(self) -> &'static str {
        match self {
            RateModel::Off => "off",
            RateModel::Auto => "auto",
            RateModel::On => "on",
        }
    }
}

/// The turn-rate dependent model of one set and why it was (not) selected.
#[derive(Debug, Clone, PartialEq)]
pub struct RateChoice {
    /// The turn-rate model (slopes `k_spread`, `k_alpha`).
    pub fit: RateFit,
    /// Bayesian information criterion `n ln(J/n) + k ln n` of the constant
    /// winner and of the rate model, over the same weighted segments
    /// (`n` = 3 residuals per segment, `k` = free parameters).
    pub bic_constant: f64,
    pub bic_rate: f64,
    /// The turn-rate model with the traction term, when it was fitted, and
    /// its criterion.
    pub traction: Option<(RateFit, f64)>,
    /// Whether the traction model is the one written (implies `selected`).
    pub traction_selected: bool,
    /// Why the traction model was not selected, when it was fitted.
    pub traction_reason: Option<String>,
    /// Whether `validate` and the file use a variable model.
    pub selected: bool,
    /// Why it was not selected.
    pub reason: Option<String>,
}

impl Default for CalibConfig {
    fn default() -> Self {
        Self {
            // Fit on a segment from every pose (see `SegmentConfig::overlap`):
            // it uses all the data, and on simulated drives it recovers the
            // true parameters best of all the segmentations tried
            // (docs/research-log.md, `fit_segments`). Overlap costs
            // little: the LM integrates each drive once per parameter vector.
            segment: SegmentConfig {
                overlap: Some(0.0),
                ..SegmentConfig::default()
            },
            yaw_weight: 0.5,
            method: None,
            lm: LmConfig::default(),
            ga: GaSettings::default(),
            time_offset: TimeOffset::Auto {
                max: 0.5,
                step: 0.01,
            },
            min_segments: 10,
            min_turning_segments: 5,
            allow_partial: false,
            rate_model: RateModel::Auto,
            traction: RateModel::Auto,
            traction_signed: false,
        }
    }
}

/// One method's answer for one set.
#[derive(Debug, Clone, PartialEq)]
pub struct MethodFit {
    pub method: Method,
    pub params: IcrParams,
    /// Eq. 13 over the inlier segments.
    pub cost: f64,
    /// Cauchy-robust eq. 13 over the inlier segments (what the methods are
    /// compared by).
    pub robust_cost: f64,
    /// 1-sigma uncertainties at `params`: the sandwich estimate of
    /// [`crate::sandwich`] over the LM fit's segment weights.
    pub std: [f64; 5],
}

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
    /// Mean number of segments covering an instant ([`Segments::coverage`]):
    /// 1 for chained segments; counts are corrected by it.
    pub coverage: f64,
    /// The residual noise (pose reference and excess) the uncertainties
    /// assume, estimated at the LM fit.
    pub noise: crate::sandwich::ResidualNoise,
    pub yaw_weight: f64,
    pub track_width: Option<f64>,
    pub wheel_radius: Option<f64>,
    pub pioneer: bool,
}

/// The result for all sets.
#[derive(Debug, Clone, PartialEq)]
pub struct Calibration {
    pub sets: Vec<SetCalibration>,
    /// Warnings about the input (from the log reader and the segmenter).
    pub warnings: Vec<String>,
}

/// Progress events for a CLI progress bar.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Progress<'a> {
    Stage(&'a str),
    Generation { done: usize, total: usize },
}

fn finite_or_null(x: f64) -> Value {
    if x.is_finite() {
        json!(x)
    } else {
        Value::Null
    }
}

fn params_json(p: &IcrParams) -> Value {
    json!({"y_l": p.y_l, "y_r": p.y_r, "x_c": p.x_c, "alpha_l": p.alpha_l, "alpha_r": p.alpha_r})
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
        if let Some(r) = &self.rate {
            x.insert("rate_model".into(), r.to_json());
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
        pf
    }
}

/// Spread (m) that best explains the yaw changes with unit alphas:
/// `dyaw ~ int (v_r - v_l) dt / spread`. A starting point without meta.toml.
fn spread_from_yaw(segs: &Segments) -> Option<f64> {
    let (mut num, mut den) = (0.0, 0.0);
    for s in &segs.segments {
        num += s.int_diff * s.int_diff;
        den += s.int_diff * s.reference.dyaw;
    }
    let d = num / den;
    (d.is_finite() && d > 0.0).then_some(d)
}

/// Second stage of the offset search, with the model itself: the profile
/// of the fit over the offset. At each offset within +-0.15 s of the
/// model-free estimate (50 ms steps, the same segments at every one, see
/// [`offset::common_segments`]) a quick per-terrain LM fit is made, and the
/// offset whose fit leaves the smallest trimmed residual (mean squared norm
/// of the best 90 % of segments, so stalled poses do not decide) wins,
/// refined by a parabola. This is the joint least-squares estimate of the
/// offset and the parameters; the model-free first stage only sees
/// symmetric ICRs and pure rotation or translation. Returns `offset`
/// unchanged when no fit is possible.
fn refine_offset(
    log: &DriveLog,
    cfg: &SegmentConfig,
    offset: f64,
    max: f64,
    yaw_weight: f64,
) -> f64 {
    const STEP: f64 = 0.05;
    let grid: Vec<f64> = (-3..=3)
        .map(|k| offset + STEP * k as f64)
        .filter(|t| t.abs() <= max + 1e-9)
        .collect();
    let curve = profile(log, cfg, &grid, yaw_weight);
    offset::parabolic_minimum(&curve, STEP).unwrap_or(offset)
}

/// `(offset, trimmed residual)` of a quick per-terrain LM fit at each
/// offset of `grid`, all on the same segments.
fn profile(log: &DriveLog, cfg: &SegmentConfig, grid: &[f64], yaw_weight: f64) -> Vec<(f64, f64)> {
    let all = offset::common_segments(log, grid, cfg);
    let Some(first) = all.first() else {
        return Vec::new();
    };
    let width = match log.meta.track_width.or_else(|| spread_from_yaw(first)) {
        Some(w) => w,
        None => return Vec::new(),
    };
    let mut names: Vec<Option<String>> = Vec::new();
    for s in &first.segments {
        if !names.contains(&s.terrain) {
            names.push(s.terrain.clone());
        }
    }
    let quick = LmConfig {
        irls_rounds: 2,
        ..LmConfig::default()
    };
    // Warm start from the previous offset's fit: neighbouring offsets have
    // neighbouring parameters.
    let mut starts: Vec<IcrParams> = vec![IcrParams::no_slip(width); names.len()];
    let mut curve = Vec::new();
    for (segs, &t) in all.iter().zip(grid) {
        let mut sq: Vec<f64> = Vec::new();
        for (name, start) in names.iter().zip(starts.iter_mut()) {
            let active: Vec<bool> = segs.segments.iter().map(|s| s.terrain == *name).collect();
            if active.iter().filter(|&&a| a).count() < 10 {
                continue;
            }
            let Some(f) = lm::fit(segs, start, &active, yaw_weight, &quick) else {
                continue;
            };
            *start = f.params;
            sq.extend(
                segs.segments
                    .iter()
                    .zip(&active)
                    .filter(|(_, &a)| a)
                    .map(|(s, _)| {
                        let r = model::residual(&f.params, segs, s, yaw_weight);
                        r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
                    }),
            );
        }
        if sq.len() < 10 {
            continue;
        }
        sq.sort_by(f64::total_cmp);
        let keep = (sq.len() * 9).div_ceil(10);
        curve.push((t, sq[..keep].iter().sum::<f64>() / keep as f64));
    }
    curve
}

/// Calibrates from `logs` (each must have `pose.csv`).
pub fn calibrate(
    logs: &[DriveLog],
    cfg: &CalibConfig,
    progress: &dyn Fn(Progress),
) -> Result<Calibration, CalibError> {
    if logs.is_empty() {
        return Err(CalibError::NoLogs);
    }
    let mut warnings = Vec::new();
    for log in logs {
        if log.pose.is_empty() {
            return Err(CalibError::NoPose {
                log: log.dir.clone(),
            });
        }
        warnings.extend(log.warnings.iter().cloned());
    }
    let scfg = cfg.segment.for_logs(logs);
    // The offset search compares candidates; chained segments suffice and
    // keep it fast.
    let ocfg = SegmentConfig {
        overlap: None,
        ..scfg.clone()
    };
    progress(Progress::Stage("aligning wheel and pose streams"));
    let mut offsets = Vec::with_capacity(logs.len());
    for log in logs {
        let o = match cfg.time_offset {
            TimeOffset::Fixed(o) => o,
            TimeOffset::Auto { max, step } => match estimate_offset(log, &ocfg, max, step) {
                Some((o, _)) => o,
                None => {
                    warnings.push(format!(
                        "{}: too few moving segments to estimate the time offset; using 0 s",
                        log.dir.display()
                    ));
                    0.0
                }
            },
        };
        let o = match cfg.time_offset {
            TimeOffset::Auto { max, step } => {
                let o = refine_offset(log, &ocfg, o, max, cfg.yaw_weight);
                if o.abs() >= max - 0.5 * step {
                    warnings.push(format!(
                        "{}: the time offset {o:+.3} s is at the edge of its search range \
                         (±{max} s), so the true offset may lie beyond it; check the two \
                         clocks, or give it with --time-offset SECONDS",
                        log.dir.display()
                    ));
                }
                o
            }
            TimeOffset::Fixed(_) => o,
        };
        offsets.push(o);
    }
    let refs: Vec<&DriveLog> = logs.iter().collect();
    let all = Segments::build(&refs, &offsets, &scfg);
    // Group by terrain; logs without labels go to the pooled set.
    let mut names: Vec<Option<String>> = Vec::new();
    for s in &all.segments {
        if !names.contains(&s.terrain) {
            names.push(s.terrain.clone());
        }
    }
    if names.is_empty() {
        names.push(None);
    }
    let track_width = logs.iter().find_map(|l| l.meta.track_width);
    let wheel_radius = logs.iter().find_map(|l| l.meta.wheel_radius);
    let pioneer = logs.iter().any(|l| {
        l.meta.robot.as_deref().is_some_and(|r| {
            let r = r.to_ascii_lowercase();
            r.contains("p3at") || r.contains("p3-at") || r.contains("pioneer")
        })
    });
    let mut sets = Vec::new();
    let n_sets = names.len();
    let mut first_err: Option<CalibError> = None;
    for name in names {
        let mut segs = all.clone();
        segs.retain(|s| s.terrain == name);
        let label = name.clone().unwrap_or_else(|| "all".into());
        progress(Progress::Stage(&label));
        let mut set = match calibrate_set(&segs, &label, track_width, cfg, progress) {
            Ok(s) => s,
            // One terrain patch too short to calibrate must not sink the others.
            Err(e) if n_sets > 1 => {
                warnings.push(format!("terrain `{label}` not calibrated: {e}"));
                first_err.get_or_insert(e);
                continue;
            }
            Err(e) => return Err(e),
        };
        set.terrain = name;
        // Counts and offsets of the logs that drove on this terrain.
        let mut used_logs: Vec<usize> = segs.segments.iter().map(|s| s.log).collect();
        used_logs.dedup();
        used_logs.sort_unstable();
        used_logs.dedup();
        for &i in &used_logs {
            if let Some(st) = all.per_log.get(i) {
                set.stats.add(st);
            }
        }
        set.time_offsets = used_logs
            .iter()
            .map(|&i| (logs[i].name(), offsets[i]))
            .collect();
        set.track_width = track_width;
        set.wheel_radius = wheel_radius;
        set.pioneer = pioneer;
        for d in &mut set.dropped {
            if let Ok(i) = d.log.parse::<usize>() {
                d.log = logs.get(i).map(|l| l.name()).unwrap_or_default();
            }
        }
        sets.push(set);
    }
    if sets.is_empty() {
        if let Some(e) = first_err {
            return Err(e);
        }
    }
    Ok(Calibration { sets, warnings })
}

/// Identifiability thresholds on the Jacobian uncertainties: a parameter
/// whose 1-sigma exceeds this is reported as not identified.
fn unidentified_by_std(std: &[f64; 5], spread: f64, free: &[bool; 5]) -> Vec<&'static str> {
    let limits = [0.25 * spread, 0.25 * spread, 0.25 * spread, 0.1, 0.1];
    (0..5)
        .filter(|&k| free[k] && (std[k].is_nan() || std[k] > limits[k]))
        .map(|k| PARAM_NAMES[k])
        .collect()
}

impl RateChoice {
    /// The `rate_model` entry of the parameter file: the jointly fitted
    /// ICR parameters and slopes, their 1-sigma, the criterion and whether
    /// it was selected (only then does `validate` use it).
    pub fn to_json(&self) -> Value {
        let f = self.written();
        let std: serde_json::Map<String, Value> = RATE_PARAM_NAMES
            .iter()
            .zip(f.std)
            .take(5 + if f.slopes.has_traction() { 4 } else { 2 })
            .filter(|(_, s)| !s.is_nan())
            .map(|(n, s)| (n.to_string(), finite_or_null(s)))
            .collect();
        let mut v = json!({
            "selected": self.selected,
            "params": params_json(&f.params),
            "k_spread": f.slopes.k_spread,
            "k_alpha": f.slopes.k_alpha,
            "std": std,
            "cost": f.sse,
            "bic_constant": self.bic_constant,
            "bic_rate": self.bic_rate,
        });
        if self.traction_selected {
            v["k_acc"] = json!(f.slopes.k_acc);
            v["k_dir"] = json!(f.slopes.k_dir);
        }
        if let Some((t, b)) = &self.traction {
            v["traction"] = json!({
                "selected": self.traction_selected,
                "k_acc": t.slopes.k_acc,
                "k_dir": t.slopes.k_dir,
                "std_k_acc": finite_or_null(t.std[7]),
                "std_k_dir": finite_or_null(t.std[8]),
                "bic": b,
            });
            if let Some(r) = &self.traction_reason {
                v["traction"]["reason"] = json!(r);
            }
        }
        if let Some(r) = &self.reason {
            v["reason"] = json!(r);
        }
        v
    }

    /// The variable model the file holds: the traction model when it was
    /// selected, else the turn-rate model.
    pub fn written(&self) -> &RateFit {
        match &self.traction {
            Some((t, _)) if self.traction_selected => t,
            _ => &self.fit,
        }
    }
}

/// Fits the turn-rate model from the constant winner over the constant
/// fit's segment weights and decides whether it is worth its two slopes.
#[allow(clippy::too_many_arguments)]
fn choose_rate(
    segs: &Segments,
    best: &MethodFit,
    weights: &[f64],
    yaw_weight: f64,
    lm_cfg: &LmConfig,
    mode: RateModel,
    traction: (RateModel, bool),
    coverage: f64,
) -> Option<RateChoice> {
    let fit = lm::fit_rate(
        segs,
        &best.params,
        &model::RateSlopes::NONE,
        weights,
        yaw_weight,
        &lm_cfg.free,
        &lm::TURN_RATE,
        lm_cfg.max_iterations,
    )?;
    // Residuals of overlapping segments are not independent: count the
    // chained equivalent.
    let n = 3.0
        * weights
            .iter()
            .filter(|&&w| w > 0.0)
            .map(|w| w.min(1.0))
            .sum::<f64>()
        / coverage;
    let k = lm_cfg.free.iter().filter(|&&f| f).count() as f64;
    let j0 = model::cost(&best.params, segs, weights, yaw_weight) / coverage;
    let bic = |j: f64, k: f64| n * (j.max(1e-300) / n).ln() + k * n.ln();
    let (bic_constant, bic_rate) = (bic(j0, k), bic(fit.sse / coverage, k + 2.0));
    // A slope is identified when its 1-sigma is under 0.1 s/m: a factor
    // of 10 % per m/s of tread speed difference.
    let unidentified = fit.std[5..7].iter().any(|s| !(s.is_finite() && *s < 0.1));
    let reason = if unidentified {
        Some("the slopes are not identified by these segments (1-sigma over 0.1 s/m)".to_string())
    } else if mode == RateModel::Auto && bic_rate >= bic_constant {
        Some("it does not lower the information criterion".to_string())
    } else {
        None
    };
    // The traction term is fitted on top of the turn-rate model, from it,
    // over the same weights, and must beat whichever of the constant and
    // turn-rate models is selected.
    let (mut t_fit, mut t_selected, mut t_reason) = (None, false, None);
    if traction.0 != RateModel::Off && !unidentified {
        let free_slopes = if traction.1 {
            lm::TURN_RATE_TRACTION_SIGNED
        } else {
            lm::TURN_RATE_TRACTION
        };
        if let Some(t) = lm::fit_rate(
            segs,
            &fit.params,
            &fit.slopes,
            weights,
            yaw_weight,
            &lm_cfg.free,
            &free_slopes,
            lm_cfg.max_iterations,
        ) {
            let b = bic(t.sse / coverage, k + t.n_slopes() as f64);
            let floor = if reason.is_none() {
                bic_rate
            } else {
                bic_constant
            };
            // Identified: 1-sigma under 0.05 s^2/m, a 5 % change of the speed
            // factors per m/s^2 of tread acceleration.
            let n_t = t.n_slopes();
            let sd = &t.std[5..5 + n_t];
            t_reason = if sd
                .iter()
                .enumerate()
                .any(|(i, s)| !(s.is_finite() && *s < if i < 2 { 0.1 } else { 0.05 }))
            {
                Some("the traction slopes are not identified (1-sigma over 0.05 s^2/m)".to_string())
            } else if traction.0 == RateModel::Auto && b >= floor {
                Some("it does not lower the information criterion".to_string())
            } else {
                None
            };
            t_selected = t_reason.is_none();
            t_fit = Some((t, b));
        }
    }
    let selected = reason.is_none() || t_selected;
    Some(RateChoice {
        fit,
        bic_constant,
        bic_rate,
        traction: t_fit,
        traction_selected: t_selected,
        traction_reason: t_reason,
        selected,
        reason: if selected { None } else { reason },
    })
}

fn calibrate_set(
    segs: &Segments,
    label: &str,
    track_width: Option<f64>,
    cfg: &CalibConfig,
    progress: &dyn Fn(Progress),
) -> Result<SetCalibration, CalibError> {
    let n = segs.len();
    // Overlapping segments share their poses: count and weigh the evidence
    // as the equivalent chained segments.
    let coverage = segs.coverage();
    let chained = |k: usize| (k as f64 / coverage).round() as usize;
    if chained(n) < cfg.min_segments {
        return Err(CalibError::TooFewSegments {
            set: label.into(),
            moving: chained(n),
            needed: cfg.min_segments,
        });
    }
    let mut notes = Vec::new();
    let mut unidentified: Vec<&'static str> = Vec::new();
    let turning = chained(
        segs.segments
            .iter()
            .filter(|s| s.reference.dyaw.abs() > 0.1)
            .count(),
    );
    let mut lm_cfg = cfg.lm.clone();
    if turning < cfg.min_turning_segments {
        let names = vec!["y_l", "y_r", "x_c"];
        let reason = format!(
            "only {turning} of {n} moving segments turn more than 0.1 rad (need {}): the reference never turns enough to separate the tread ICRs",
            cfg.min_turning_segments
        );
        if !cfg.allow_partial {
            return Err(CalibError::Unobservable {
                set: label.into(),
                params: names,
                reason,
            });
        }
        notes.push(format!(
            "{} kept at the no-slip values: {reason}",
            names.join(", ")
        ));
        unidentified.extend(names);
        lm_cfg.free = [false, false, false, true, true];
    }
    let width = match track_width.or_else(|| spread_from_yaw(segs)) {
        Some(w) => w,
        None => {
            return Err(CalibError::Unobservable {
                set: label.into(),
                params: vec!["y_l", "y_r"],
                reason: "no track_width in meta.toml and the yaw changes do not give one".into(),
            })
        }
    };
    let start = IcrParams::no_slip(width);
    let active = vec![true; n];
    progress(Progress::Stage("levenberg-marquardt"));
    let lm_fit = lm::fit(segs, &start, &active, cfg.yaw_weight, &lm_cfg).ok_or_else(|| {
        CalibError::TooFewSegments {
            set: label.into(),
            moving: 0,
            needed: cfg.min_segments,
        }
    })?;
    let inlier: Vec<bool> = lm_fit.weights.iter().map(|&w| w > 0.0).collect();
    let used = inlier.iter().filter(|&&b| b).count();
    if chained(used) < cfg.min_segments {
        return Err(CalibError::TooFewSegments {
            set: label.into(),
            moving: chained(used),
            needed: cfg.min_segments,
        });
    }
    let c = cfg.lm.cauchy_c * lm_fit.sigma;
    let ones: Vec<f64> = inlier.iter().map(|&b| if b { 1.0 } else { 0.0 }).collect();
    let score = |method: Method, p: IcrParams| MethodFit {
        method,
        params: p,
        cost: model::cost(&p, segs, &ones, cfg.yaw_weight),
        robust_cost: model::robust_cost(&p, segs, &inlier, cfg.yaw_weight, c),
        std: lm::uncertainties(
            &model::to_vec(&p),
            segs,
            &lm_fit.weights,
            cfg.yaw_weight,
            &lm_cfg.free,
        ),
    };
    let mut fits = Vec::new();
    let wants = |m: Method| cfg.method.is_none() || cfg.method == Some(m);
    if wants(Method::Lm) {
        fits.push(score(Method::Lm, lm_fit.params));
    }
    if wants(Method::Ga) {
        let mut gcfg = GaConfig::for_track_width(width);
        gcfg.population = cfg.ga.population;
        gcfg.generations = cfg.ga.generations;
        gcfg.seed = cfg.ga.seed;
        gcfg.gene_bits = cfg.ga.gene_bits;
        gcfg.threads = cfg.ga.threads;
        if let Some(b) = cfg.ga.bounds {
            gcfg.bounds = b;
        }
        // Genes the data cannot identify stay at the start value.
        let sv = model::to_vec(&start);
        for ((b, &v), &free) in gcfg.bounds.iter_mut().zip(&sv).zip(&lm_cfg.free) {
            if !free {
                *b = (v, v);
            }
        }
        // Mandow's GA scores chained segments: one pass over the drive per
        // individual, so overlapping segments would multiply its cost; its
        // answer is then scored on every segment like the others.
        let chained_inliers: Vec<bool> = segs
            .chained_mask()
            .iter()
            .zip(&inlier)
            .map(|(&a, &b)| a && b)
            .collect();
        let fitness =
            |p: &IcrParams| model::robust_cost(p, segs, &chained_inliers, cfg.yaw_weight, c);
        let total = gcfg.generations;
        let r = ga::minimise(&fitness, &gcfg, Some(&start), &|g| {
            progress(Progress::Generation { done: g + 1, total })
        });
        fits.push(score(Method::Ga, r.params));
    }
    if wants(Method::Symmetric) {
        match symmetric::fit(segs, &inlier) {
            Ok(s) => {
                notes.push(format!(
                    "symmetric: {} spin-in-place and {} straight segments",
                    s.spin_segments, s.straight_segments
                ));
                fits.push(score(Method::Symmetric, s.params));
            }
            Err(missing) => {
                let what = match missing {
                    SymmetricMissing::Spins => "spin-in-place segments",
                    SymmetricMissing::Straights => "straight segments",
                };
                if cfg.method == Some(Method::Symmetric) {
                    return Err(CalibError::SymmetricNeeds {
                        set: label.into(),
                        what,
                    });
                }
                notes.push(format!(
                    "symmetric calibration skipped: the drive has no {what}"
                ));
            }
        }
    }
    let best = fits
        .iter()
        .min_by(|a, b| a.robust_cost.total_cmp(&b.robust_cost))
        .cloned()
        .ok_or(CalibError::NoLogs)?;
    for name in unidentified_by_std(&best.std, best.params.spread(), &lm_cfg.free) {
        if !cfg.allow_partial {
            return Err(CalibError::Unobservable {
                set: label.into(),
                params: vec![name],
                reason: format!(
                    "its 1-sigma uncertainty ({:.3}) is too large for the data to pin it down",
                    best.std[PARAM_NAMES.iter().position(|n| *n == name).unwrap_or(0)]
                ),
            });
        }
        if !unidentified.contains(&name) {
            unidentified.push(name);
            notes.push(format!("{name} is poorly identified (large uncertainty)"));
        }
    }
    let rate = match cfg.rate_model {
        RateModel::Off => None,
        m => choose_rate(
            segs,
            &best,
            &lm_fit.weights,
            cfg.yaw_weight,
            &lm_cfg,
            m,
            (cfg.traction, cfg.traction_signed),
            coverage,
        ),
    };
    let dropped = segs
        .segments
        .iter()
        .zip(&inlier)
        .filter(|(_, &k)| !k)
        .map(|(s, _)| {
            let r = model::residual(&best.params, segs, s, cfg.yaw_weight);
            DroppedSegment {
                log: s.log.to_string(),
                t0: s.t0,
                t1: s.t1,
                residual: (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt(),
            }
        })
        .collect();
    Ok(SetCalibration {
        terrain: None,
        best,
        fits,
        segments_used: used,
        dropped,
        stats: SegmentStats::default(),
        sigma: lm_fit.sigma,
        noise: lm_fit.noise,
        time_offsets: Vec::new(),
        unidentified,
        notes,
        yaw_weight: cfg.yaw_weight,
        track_width,
        wheel_radius: None,
        pioneer: false,
        rate,
        coverage,
    })
}
