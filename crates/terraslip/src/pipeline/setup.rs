//! What a run starts from: the track width, the terrain names, the
//! starting slip parameters (prior, or `--init`), the clock offset, and the
//! estimator built from them.

use terraslip_core::estimator::Estimator;
use terraslip_core::filter::{Filter, SlipStd, MAX_K_SPREAD_SPEED, MAX_K_X_SPEED};
use terraslip_core::kinematics::CentripetalSlopes;
use terraslip_core::schedule::NoiseSchedule;
use terraslip_core::terrain_belief::MAX_TERRAINS;
use terraslip_core::IcrParams;
use terraslip_io::{DriveLog, ParamsFile};

use super::{PipelineError, TerrainEvidence};
use crate::config::EstimatorConfig;

/// A run's starting point.
pub(super) struct Setup {
    pub estimator: Estimator,
    pub terrains: Vec<String>,
    pub track_width: f64,
    /// Where the starting slip parameters came from: `prior` or `init:<set>`.
    pub init_source: String,
    pub warnings: Vec<String>,
}

pub(super) fn setup(
    log: &DriveLog,
    cfg: &EstimatorConfig,
    evidence: &TerrainEvidence,
    init: Option<&ParamsFile>,
) -> Result<Setup, PipelineError> {
    let dir = log.dir.display().to_string();
    let mut warnings = Vec::new();
    let track_width = match log.meta.track_width {
        Some(w) if w.is_finite() && w > 0.0 => w,
        Some(w) => {
            warnings.push(format!(
                "{dir}/meta.toml: track_width = {w} is not usable; using init.default_track_width = {} m",
                cfg.init.default_track_width
            ));
            cfg.init.default_track_width
        }
        // The tread speeds were made with a separation S (an odometry
        // twist): the model starts in that scale, the controller's own
        // (spread S), so that a factor nothing taught reads 1.
        None if log
            .meta
            .separation
            .is_some_and(|s| s.is_finite() && s > 0.0) =>
        {
            let s = log.meta.separation.unwrap_or(cfg.init.default_track_width);
            warnings.push(format!(
                "{dir}: no track width (meta.toml's `track_width`; for a ROS 2 bag, `[meta] track_width` in the --topics file); the model starts from the separation the tread speeds were made with, S = {s} m (meta.toml's `separation`)"
            ));
            s
        }
        None => {
            warnings.push(format!(
                "{dir}: no track width (meta.toml's `track_width`; for a ROS 2 bag, `[meta] track_width` in the --topics file); using init.default_track_width = {} m",
                cfg.init.default_track_width
            ));
            cfg.init.default_track_width
        }
    };

    let terrains = terrain_names(evidence);
    if terrains.len() > MAX_TERRAINS {
        warnings.push(format!(
            "{} terrains; only the first {MAX_TERRAINS} can be remembered",
            terrains.len()
        ));
    }

    // Starting slip parameters: the --init set of the terrain the drive
    // starts on (as far as anything tells), else the prior.
    let mut prior = cfg.prior(track_width);
    let mut init_source = "prior".to_string();
    let mut meas = cfg.measurement;
    if let Some(pf) = init {
        match starting_set(pf, evidence, log) {
            Some((name, p, extra)) => {
                prior = init_prior(cfg, &name, p, extra, prior)?;
                init_source = format!("init:{name}");
            }
            None => warnings.push(
                "--init has one set per terrain but nothing tells which terrain the drive is on \
                 (no --terrain-labels or --terrain-model, and terrain.csv does not name a single \
                 terrain): started from the prior; the sets are recalled once the terrain is known"
                    .into(),
            ),
        }
    }
    let mut filter_cfg = cfg.filter;
    if let Some(pf) = init {
        if let Some(o) = terraslip_calib::validate::stored_offset(pf) {
            // The calibration's clock offset between wheels and pose, found
            // from a whole drive: the filter holds it. The offset belongs to
            // the two clocks, not the ground, and the filter's own fixes do
            // not pin it against its slip states (docs/estimator.md).
            meas.clock_offset = init_offset("time_offset_s", Some(o))?;
            filter_cfg.learn_clock = false;
        } else if let Some(v) = pf.extra.get("clock_offset_s") {
            // The offset a run of this filter had learned (the node's
            // parameters file): the clock starts there and goes on learning.
            meas.clock_offset = init_offset("clock_offset_s", v.as_f64())?;
        }
    }
    if let Some(g) = init.and_then(|pf| pf.extra.get("gyro_scale")) {
        meas.gyro_scale = init_gyro_scale(g)?;
    }
    if let Some(m) = log.meta.pose {
        // Where the log states the reference sits on the robot.
        meas.lever_arm_x = m.lever_arm_x;
        meas.lever_arm_y = m.lever_arm_y;
    }
    if meas.encoder_tick == 0.0 {
        if let (Some(r), Some(n)) = (log.meta.wheel_radius, log.meta.ticks_per_rev) {
            if r.is_finite() && r > 0.0 && n.is_finite() && n >= 1.0 {
                meas.encoder_tick = 2.0 * std::f64::consts::PI * r / n;
            }
        }
    }

    let filter = Filter::new(&prior, filter_cfg, meas, cfg.band(track_width))
        .map_err(|e| PipelineError::Config(e.to_string()))?;
    let mut schedule = NoiseSchedule::new(cfg.schedule_config());
    if init_source != "prior" {
        // A detected slip change falls back to the given set.
        schedule.start_from(&prior.icr, prior.std);
    }
    if let Some(pf) = init {
        for (name, entry) in &pf.terrains {
            match terrains.iter().position(|n| n == name) {
                Some(k) => schedule.seed(k, &entry.params, set_std(cfg, entry.extra.get("std"))),
                None if !terrains.is_empty() => warnings.push(format!(
                    "--init: terrain `{name}` never appears in the terrain evidence; ignored"
                )),
                None => {}
            }
        }
    }
    let estimator = Estimator::new(filter, schedule, cfg.filter.max_wheel_gap);
    Ok(Setup {
        estimator,
        terrains,
        track_width,
        init_source,
        warnings,
    })
}

/// Terrain names: labels in order of appearance, or the classifier's classes.
pub(super) fn terrain_names(evidence: &TerrainEvidence) -> Vec<String> {
    match evidence {
        TerrainEvidence::None => Vec::new(),
        TerrainEvidence::Labels(l) => {
            let mut names: Vec<String> = Vec::new();
            for x in l {
                if !names.contains(&x.terrain) {
                    names.push(x.terrain.clone());
                }
            }
            names
        }
        TerrainEvidence::Likelihoods { classes, .. } => classes.clone(),
    }
}

/// The `--init` set to start from: the first labelled terrain's; else,
/// without evidence, the terrain `terrain.csv` names if it names only one;
/// else the only set of the file, or its pooled set. `None` when the file
/// has several terrain sets and nothing picks one.
fn starting_set<'a>(
    pf: &'a ParamsFile,
    evidence: &TerrainEvidence,
    log: &DriveLog,
) -> Option<(String, IcrParams, &'a Extra)> {
    let named = |t: &str| {
        pf.terrains
            .get(t)
            .map(|e| (t.to_string(), e.params, &e.extra))
    };
    if let TerrainEvidence::Labels(l) = evidence {
        if let Some(found) = l.first().and_then(|x| named(&x.terrain)) {
            return Some(found);
        }
    }
    let mut labels: Vec<&str> = log.terrain.iter().map(|x| x.terrain.as_str()).collect();
    labels.dedup();
    if let [only] = labels.as_slice() {
        if let Some(found) = named(only) {
            return Some(found);
        }
    }
    if let Some(p) = pf.params {
        return Some(("params".into(), p, &pf.extra));
    }
    match pf.terrains.iter().collect::<Vec<_>>().as_slice() {
        [(name, e)] => Some(((*name).clone(), e.params, &e.extra)),
        _ => None,
    }
}

type Extra = std::collections::BTreeMap<String, serde_json::Value>;

/// The gyro's scale error `k_g` from an `--init` file's `gyro_scale` (the
/// multiplier `1 + k_g` a run learned: the gyro reads it times the true
/// yaw rate).
fn init_gyro_scale(v: &serde_json::Value) -> Result<f64, PipelineError> {
    let max = terraslip_core::filter::MAX_GYRO_SCALE;
    match v.as_f64() {
        Some(g) if (g - 1.0).abs() <= max => Ok(g - 1.0),
        _ => Err(PipelineError::Init(format!(
            "gyro_scale = {v}: expected the gyro's scale as a multiplier within {}..{} (1 = exact)",
            1.0 - max,
            1.0 + max
        ))),
    }
}

/// Fraction of the configured prior std (`init.std_k_x_speed`,
/// `init.std_k_spread_speed`) below which a calibration's stated std of a
/// centripetal term is not taken: the terms differ from drive to drive of
/// the same ground by more than one calibration's own std.
const CENTRIPETAL_STD_FLOOR: f64 = 0.25;

/// `prior` started from the `--init` set `name`: its parameters (those of
/// its selected turn-rate model, with its centripetal terms, when
/// calibration selected one) with their stated stds, never tighter than
/// `init.calibrated_std` (the centripetal terms' never tighter than
/// [`CENTRIPETAL_STD_FLOOR`] of their prior's); the selected model's
/// speed factors' turn law `k_alpha` (s/m) is held, so the filter's model
/// is the calibration's.
fn init_prior(
    cfg: &EstimatorConfig,
    name: &str,
    p: IcrParams,
    extra: &Extra,
    mut prior: terraslip_core::filter::Prior,
) -> Result<terraslip_core::filter::Prior, PipelineError> {
    p.validate()
        .map_err(|e| PipelineError::Init(format!("set `{name}`: {e}")))?;
    prior.icr = p;
    let stated = |std: Option<&serde_json::Value>| set_std(cfg, std);
    prior.std = stated(extra.get("std"));
    // A turn law the calibration selected comes with its own
    // straight-line parameters, and its centripetal terms with theirs.
    let law = terraslip_io::RateModelEntry::selected(extra)
        .map_err(|e| PipelineError::Init(format!("set `{name}`: rate_model {e}")))?;
    if let Some(r) = law {
        r.params
            .validate()
            .map_err(|e| PipelineError::Init(format!("set `{name}`: rate_model params: {e}")))?;
        if r.k_spread.is_nan() || r.k_spread.abs() > 2.0 {
            return Err(PipelineError::Init(format!(
                "set `{name}`: rate_model k_spread = {} s/m is beyond +-2",
                r.k_spread
            )));
        }
        let limits = [
            ("k_x_speed", r.k_x_speed, MAX_K_X_SPEED, "s"),
            (
                "k_spread_speed",
                r.k_spread_speed,
                MAX_K_SPREAD_SPEED,
                "s/m",
            ),
        ];
        for (key, v, max, unit) in limits {
            if v.abs() > max {
                return Err(PipelineError::Init(format!(
                    "set `{name}`: rate_model {key} = {v} {unit} is beyond +-{max}"
                )));
            }
        }
        if r.k_alpha.is_nan() || r.k_alpha.abs() > terraslip_core::filter::MAX_TURN_LAW {
            return Err(PipelineError::Init(format!(
                "set `{name}`: rate_model k_alpha = {} s/m is beyond +-{}",
                r.k_alpha,
                terraslip_core::filter::MAX_TURN_LAW
            )));
        }
        prior.icr = r.params;
        prior.turn_law = r.k_spread;
        prior.speed_law = r.k_alpha;
        prior.speed_law_std = 0.0;
        // Those parameters' own uncertainty, not the constant
        // model's.
        let model = extra.get("rate_model");
        prior.std = stated(model.and_then(|m| m.get("std")));
        if r.k_x_speed != 0.0 || r.k_spread_speed != 0.0 {
            let c = model.and_then(|m| m.get("centripetal"));
            let std = |key: &str, prior_std: f64| {
                c.and_then(|c| c.get(key))
                    .and_then(|v| v.as_f64())
                    .filter(|v| v.is_finite() && *v >= 0.0)
                    .map_or(prior_std, |v| v.max(CENTRIPETAL_STD_FLOOR * prior_std))
            };
            prior.centripetal = CentripetalSlopes {
                k_x_speed: r.k_x_speed,
                k_spread_speed: r.k_spread_speed,
            };
            // A term the configuration holds (its prior std 0) is held at
            // the calibration's value.
            let held = |v: f64| if v > 0.0 { Some(v) } else { None };
            let sd = prior.centripetal_std;
            prior.centripetal_std = CentripetalSlopes {
                k_x_speed: held(sd.k_x_speed).map_or(0.0, |v| std("std_k_x_speed", v)),
                k_spread_speed: held(sd.k_spread_speed)
                    .map_or(0.0, |v| std("std_k_spread_speed", v)),
            };
        }
    }
    Ok(prior)
}

/// A clock offset between wheels and pose read from `--init`'s `key`, s:
/// a number within the filter's bound.
fn init_offset(key: &str, o: Option<f64>) -> Result<f64, PipelineError> {
    let max = terraslip_core::filter::MAX_CLOCK_OFFSET;
    o.filter(|o| o.is_finite() && o.abs() <= max)
        .ok_or_else(|| {
            PipelineError::Init(format!(
                "{key} must be a number of seconds within +-{max}, not {}",
                o.map_or("a non-number".into(), |o| o.to_string())
            ))
        })
}

/// The uncertainty a set of an `--init` file starts the filter with: its
/// stated `std` (the calibration's own uncertainty) where it has one,
/// never tighter than `init.calibrated_std`.
pub(super) fn set_std(cfg: &EstimatorConfig, std: Option<&serde_json::Value>) -> SlipStd {
    std.and_then(stated_std)
        .map_or(cfg.init.calibrated_std, |s| {
            wider(s, cfg.init.calibrated_std)
        })
}

/// A `std` object `terraslip calibrate` writes with a parameter set
/// (`y_l, y_r, x_c, alpha_l, alpha_r`), as independent stds of spread,
/// centre, x_c, speed factor and factor difference.
fn stated_std(s: &serde_json::Value) -> Option<SlipStd> {
    if !s.is_object() {
        return None;
    }
    // `null` (a parameter the calibration's reduced model held: its
    // relation to another, or `x_c` at 0) or absent: the floor then
    // applies to it.
    let get = |k: &str| match s.get(k) {
        None | Some(serde_json::Value::Null) => Some(0.0),
        Some(v) => v.as_f64().filter(|v| v.is_finite() && *v >= 0.0),
    };
    let (yl, yr, xc, al, ar) = (
        get("y_l")?,
        get("y_r")?,
        get("x_c")?,
        get("alpha_l")?,
        get("alpha_r")?,
    );
    Some(SlipStd {
        spread: yl.hypot(yr),
        centre: 0.5 * yl.hypot(yr),
        x_c: xc,
        alpha: 0.5 * al.hypot(ar),
        alpha_diff: al.hypot(ar),
    })
}

/// The larger of two stds, entry by entry.
fn wider(a: SlipStd, b: SlipStd) -> SlipStd {
    SlipStd {
        spread: a.spread.max(b.spread),
        centre: a.centre.max(b.centre),
        x_c: a.x_c.max(b.x_c),
        alpha: a.alpha.max(b.alpha),
        alpha_diff: a.alpha_diff.max(b.alpha_diff),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A calibrated set whose turn law was selected: the constant model's
    /// parameters and std at the top, the law's own under `rate_model`.
    fn calibrated_set() -> (IcrParams, Extra) {
        let json = serde_json::json!({
            "std": {"y_l": 0.04, "y_r": 0.04, "x_c": 0.03, "alpha_l": 0.009, "alpha_r": 0.009},
            "rate_model": {
                "selected": true,
                "k_spread": -0.06, "k_alpha": -0.05,
                "params": {"y_l": 1.36, "y_r": -1.38, "x_c": 0.02, "alpha_l": 0.93, "alpha_r": 0.95},
                "std": {"y_l": 0.097, "y_r": 0.095, "x_c": 0.028, "alpha_l": 0.03, "alpha_r": 0.03}
            }
        });
        let extra: Extra = serde_json::from_value(json).unwrap();
        (IcrParams::new(1.25, -1.27, 0.016), extra)
    }

    #[test]
    fn a_selected_turn_law_starts_with_its_own_std() {
        let cfg = EstimatorConfig::default();
        let (p, extra) = calibrated_set();
        let prior = init_prior(&cfg, "gravel", p, &extra, cfg.prior(1.1)).unwrap();
        assert_eq!(prior.icr.y_l, 1.36);
        assert_eq!(prior.turn_law, -0.06);
        // The law's speed factor slope, held.
        assert_eq!((prior.speed_law, prior.speed_law_std), (-0.05, 0.0));
        assert!(
            (prior.std.spread - 0.097f64.hypot(0.095)).abs() < 1e-12,
            "{:?}",
            prior.std
        );
        assert!(
            (prior.std.alpha - 0.5 * 0.03f64.hypot(0.03)).abs() < 1e-12,
            "{:?}",
            prior.std
        );
    }

    #[test]
    fn a_model_with_centripetal_terms_starts_the_filter_from_them() {
        let cfg = EstimatorConfig::default();
        let (p, mut extra) = calibrated_set();
        let m = extra.get_mut("rate_model").unwrap();
        m["k_x_speed"] = serde_json::json!(0.23);
        m["k_spread_speed"] = serde_json::json!(-0.04);
        m["centripetal"] = serde_json::json!({
            "selected": true, "k_x_speed": 0.23, "k_spread_speed": -0.04,
            "std_k_x_speed": 0.09, "std_k_spread_speed": 0.001,
        });
        let prior = init_prior(&cfg, "gravel", p, &extra, cfg.prior(1.1)).unwrap();
        // The selected model's own straight-line ICRs, law and terms.
        assert_eq!(prior.icr.y_l, 1.36);
        assert_eq!(prior.turn_law, -0.06);
        assert_eq!(prior.centripetal.k_x_speed, 0.23);
        assert_eq!(prior.centripetal.k_spread_speed, -0.04);
        // The stated std of a learned term, the held one held.
        assert_eq!(prior.centripetal_std.k_x_speed, 0.09);
        assert_eq!(prior.centripetal_std.k_spread_speed, 0.0);
        // Learned, never tighter than the floor.
        let mut learning = cfg.clone();
        learning.init.std_k_spread_speed = 0.1;
        let prior = init_prior(&learning, "gravel", p, &extra, learning.prior(1.1)).unwrap();
        assert_eq!(
            prior.centripetal_std.k_spread_speed,
            CENTRIPETAL_STD_FLOOR * 0.1
        );
        // A term beyond the filter's range is refused, naming it.
        extra.get_mut("rate_model").unwrap()["k_x_speed"] = serde_json::json!(3.0);
        let err = init_prior(&cfg, "gravel", p, &extra, cfg.prior(1.1)).unwrap_err();
        assert!(err.to_string().contains("k_x_speed"), "{err}");
    }

    /// A reduced set (`calibrate`'s reduced models) states no 1-sigma
    /// for a parameter it held (`null`): the others keep theirs.
    #[test]
    fn a_reduced_set_keeps_the_std_it_states() {
        let cfg = EstimatorConfig::default();
        let (p, mut extra) = calibrated_set();
        extra.remove("rate_model");
        extra.insert(
            "std".into(),
            serde_json::json!({"y_l": 0.09, "y_r": 0.09, "x_c": null, "alpha_l": 0.013, "alpha_r": 0.013}),
        );
        let prior = init_prior(&cfg, "grass", p, &extra, cfg.prior(1.1)).unwrap();
        assert!(
            (prior.std.spread - 0.09f64.hypot(0.09)).abs() < 1e-12,
            "{:?}",
            prior.std
        );
        assert_eq!(prior.std.x_c, cfg.init.calibrated_std.x_c);
    }

    #[test]
    fn a_constant_set_keeps_its_std_never_tighter_than_the_floor() {
        let cfg = EstimatorConfig::default();
        let (p, mut extra) = calibrated_set();
        extra.remove("rate_model");
        let prior = init_prior(&cfg, "gravel", p, &extra, cfg.prior(1.1)).unwrap();
        assert_eq!(prior.speed_law, cfg.prior(1.1).speed_law);
        assert_eq!(prior.icr, p);
        assert!((prior.std.spread - 0.04f64.hypot(0.04)).abs() < 1e-12);
        assert_eq!(
            prior.std.alpha_diff,
            cfg.init
                .calibrated_std
                .alpha_diff
                .max(0.009f64.hypot(0.009))
        );
    }
}
