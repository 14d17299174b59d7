//! Runs the online estimator over a drive log, event by event on the log's
//! own timestamps: a wheels row predicts over the time since the previous
//! one; a pose row is fused at its own time (the prediction is split there);
//! terrain evidence drives the noise schedule.

#![allow(non_snake_case)]

use terraslip_core::filter::{Fate, Filter, FilterError, PoseFix, UpdateReport};
use terraslip_core::kinematics::TurnRateSlopes;
use terraslip_core::model::{
    self, MatN, SlipCov, State, EAST, K, NORTH, RATE_K, SLIP, YAW, Y_L, Y_R,
};
use terraslip_core::schedule::{ChangeAction, NoiseSchedule};
use terraslip_core::terrain_belief::{TerrainBelief, MAX_TERRAINS};
use terraslip_core::IcrParams;
use terraslip_io::{DriveLog, ParamsFile, PoseObs, TerrainLabel};

use crate::config::{EstimatorConfig, ReportIcr};

/// Where the estimator learns which terrain the robot is on.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum TerrainEvidence {
    /// No terrain evidence: no schedule, no memory.
    #[default]
    None,
    /// Labels (the log's `terrain.csv`): a perfect classifier.
    Labels(Vec<TerrainLabel>),
    /// Causal classifier outputs: `frames[i] = (t, p)` with `p[k]` the
    /// probability (or likelihood) of `classes[k]` for the window ending at `t`.
    Likelihoods {
        classes: Vec<String>,
        frames: Vec<(f64, Vec<f64>)>,
        /// Times (s) at which a camera change detector fired (lv2019). The
        /// next frame after one is fused as after an innovation jump (lower
        /// stay probability), so the belief follows the change sooner.
        changes: Vec<f64>,
    },
}

impl From<terraslip_terrain::TerrainTimeline> for TerrainEvidence {
    fn from(t: terraslip_terrain::TerrainTimeline) -> Self {
        TerrainEvidence::Likelihoods {
            classes: t.classes,
            frames: t.frames,
            changes: t.changes,
        }
    }
}

/// Options of one run besides the configuration.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RunOptions {
    /// Drop every pose fix with `t0 <= t < t1` (a simulated GNSS + compass
    /// outage, to measure dead reckoning).
    pub outage: Option<(f64, f64)>,
}

/// The estimate after one wheels row (log-format.md columns and more).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EstimateRow {
    /// Time of the wheels row, s.
    pub t: f64,
    /// Position east / north, m (ENU); yaw, rad (CCW from east).
    pub east: f64,
    pub north: f64,
    pub yaw: f64,
    /// ICRs, m (body frame).
    pub y_l: f64,
    pub y_r: f64,
    pub x_c: f64,
    /// Tread speed factors.
    pub alpha_l: f64,
    pub alpha_r: f64,
    /// Standard deviations of the eight states (east, north, yaw, y_l, y_r,
    /// x_c, alpha_l, alpha_r).
    pub std: [f64; 8],
    /// Std of the spread y_l - y_r, m.
    pub std_spread: f64,
    /// Index into [`EstimateRun::terrains`] of the believed terrain.
    pub terrain: Option<usize>,
    /// A pose fix was fused since the previous row.
    pub fused: bool,
    /// A pose fix part was gated since the previous row.
    pub gated: bool,
    /// NIS of the last fix since the previous row (NaN-free: 0 if none).
    pub nis: f64,
    /// Factor on the ICR process noise (schedule x adaptation).
    pub q_scale: f64,
    /// The spread's turn-rate slope in effect (s/m; 0 = constant ICRs).
    pub k_spread: f64,
}

/// One terrain change the schedule acted on.
#[derive(Debug, Clone, PartialEq)]
pub struct TerrainChange {
    /// Time, s.
    pub t: f64,
    /// Index into [`EstimateRun::terrains`].
    pub terrain: usize,
    /// What the schedule did.
    pub action: ChangeAction,
}

/// Counters of one run.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RunStats {
    pub predictions: usize,
    pub fixes: usize,
    pub position_fused: usize,
    pub position_gated: usize,
    pub yaw_fused: usize,
    pub yaw_gated: usize,
    pub reanchored: usize,
    /// Fixes the filter refused (singular innovation covariance and such).
    pub skipped_updates: usize,
    /// Fixes dropped by [`RunOptions::outage`].
    pub dropped_fixes: usize,
}

/// Result of [`run`].
#[derive(Debug, Clone, PartialEq)]
pub struct EstimateRun {
    /// One row per wheels row.
    pub rows: Vec<EstimateRow>,
    /// Terrain names the rows' indices refer to.
    pub terrains: Vec<String>,
    /// Terrain changes the schedule acted on.
    pub changes: Vec<TerrainChange>,
    /// Track width used for the band and default ICRs, m.
    pub track_width: f64,
    /// Final ICR estimate: the straight-line values when a turn-rate law
    /// is in use ([`Self::rate`]).
    pub final_icr: IcrParams,
    /// Turn-rate law at the end of the run (the spread slope as learned,
    /// when it is; [`TurnRateSlopes::NONE`] = constant ICRs).
    pub rate: TurnRateSlopes,
    /// Std of the spread slope at the end, s/m (~0 when not learned).
    pub rate_std: f64,
    /// Where [`Self::rate`] started: `config` or `init:<set>`.
    pub rate_source: String,
    /// Counters.
    pub stats: RunStats,
    /// Things the user should know (data used with caveats).
    pub warnings: Vec<String>,
}

impl EstimateRun {
    /// Duration covered by the rows, s.
    pub fn duration(&self) -> f64 {
        match (self.rows.first(), self.rows.last()) {
            (Some(a), Some(b)) => b.t - a.t,
            _ => 0.0,
        }
    }

    /// Name of a row's terrain.
    pub fn terrain_name(&self, row: &EstimateRow) -> Option<&str> {
        row.terrain
            .and_then(|i| self.terrains.get(i))
            .map(|s| s.as_str())
    }
}

/// Why a run failed.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    #[error("{dir}: wheels.csv has no rows")]
    NoWheels { dir: String },
    #[error("invalid configuration: {0}")]
    Config(String),
    #[error("initial parameters: {0}")]
    Init(String),
    #[error("{dir}: wheels.csv row at t = {t}: {source}")]
    Filter {
        dir: String,
        t: f64,
        #[source]
        source: FilterError,
    },
}

/// Runs the estimator over `log`. See [`run_with`].
pub fn run(
    log: &DriveLog,
    cfg: &EstimatorConfig,
    evidence: &TerrainEvidence,
    init: Option<&ParamsFile>,
) -> Result<EstimateRun, PipelineError> {
    run_with(
        log,
        cfg,
        evidence,
        init,
        RunOptions::default(),
        &mut |_, _| {},
    )
}

/// Runs the estimator over `log` with options; `progress(done, total)` is
/// called every few thousand wheels rows.
pub fn run_with(
    log: &DriveLog,
    cfg: &EstimatorConfig,
    evidence: &TerrainEvidence,
    init: Option<&ParamsFile>,
    opts: RunOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<EstimateRun, PipelineError> {
    cfg.validate().map_err(|e| PipelineError::Config(e.0))?;
    let dir = log.dir.display().to_string();
    if log.wheels.is_empty() {
        return Err(PipelineError::NoWheels { dir });
    }
    let mut warnings = Vec::new();

    let track_width = match log.meta.track_width {
        Some(w) if w.is_finite() && w > 0.0 => w,
        Some(w) => {
            warnings.push(format!(
                "{dir}/meta.toml: track_width = {w} is not usable; using {} m",
                cfg.init.default_track_width
            ));
            cfg.init.default_track_width
        }
        None => {
            warnings.push(format!(
                "{dir}: no track_width in meta.toml; using init.default_track_width = {} m",
                cfg.init.default_track_width
            ));
            cfg.init.default_track_width
        }
    };

    // Terrain names: labels in order of appearance, or the classifier's classes.
    let terrains: Vec<String> = match evidence {
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
    };
    if terrains.len() > MAX_TERRAINS {
        warnings.push(format!(
            "{} terrains; only the first {MAX_TERRAINS} can be remembered",
            terrains.len()
        ));
    }

    // Starting ICRs: --init pooled set, else the first labelled terrain's set,
    // else the no-slip model widened by init.spread_factor.
    let first_terrain = match evidence {
        TerrainEvidence::Labels(l) => l.first().map(|x| x.terrain.as_str()),
        _ => None,
    };
    let calibrated = init.and_then(|p| {
        p.for_terrain(first_terrain)
            .or_else(|| p.terrains.values().next().map(|e| e.params))
    });
    // The turn-rate law: the config's slopes, or those the calibration
    // selected for the same set as the starting ICRs (which are then its
    // straight-line ICRs, not the constant fit's turn average).
    let mut rate = TurnRateSlopes {
        k_spread: cfg.filter.rate_k_spread,
        k_alpha: cfg.filter.rate_k_alpha,
    };
    let mut rate_source = "config".to_string();
    let mut calibrated = calibrated;
    if let (Some(pf), true) = (init, cfg.filter.rate_from_init) {
        let (set, extra) = match first_terrain.and_then(|t| pf.terrains.get_key_value(t)) {
            Some((name, e)) => (name.as_str(), &e.extra),
            None if pf.params.is_some() => ("params", &pf.extra),
            None => match pf.terrains.iter().next() {
                Some((name, e)) => (name.as_str(), &e.extra),
                None => ("params", &pf.extra),
            },
        };
        if let Some((p, k)) = selected_rate_model(extra, set)? {
            calibrated = Some(p);
            rate = k;
            rate_source = format!("init:{set}");
        }
    }
    let icr0 = match calibrated {
        Some(p) => {
            p.validate()
                .map_err(|e| PipelineError::Init(e.to_string()))?;
            p
        }
        None => {
            let d = cfg.init.spread_factor * track_width;
            IcrParams::new(0.5 * d, -0.5 * d, 0.0)
        }
    };
    let icr_cov: SlipCov = if calibrated.is_some() {
        cfg.calibrated_std().to_slip_cov()
    } else {
        terraslip_core::IcrStd {
            spread: cfg.init.std_spread_factor * track_width,
            centre: cfg.init.std_centre,
            x_c: cfg.init.std_x_c,
            alpha: cfg.init.std_alpha,
            alpha_diff: cfg.init.std_alpha_diff,
        }
        .to_slip_cov()
    };

    // Starting pose: the first fix (whatever part it has).
    // Poses move onto the wheels' clock (measurement.pose_latency); the
    // outage window is in the log's own time.
    let latency = cfg.measurement.pose_latency;
    let pose: Vec<PoseObs> = log
        .pose
        .iter()
        .filter(|p| match opts.outage {
            Some((t0, t1)) => !(p.t >= t0 && p.t < t1),
            None => true,
        })
        .map(|p| PoseObs {
            t: p.t - latency,
            ..*p
        })
        .collect();
    let dropped = log.pose.len() - pose.len();
    if log.pose.is_empty() {
        warnings.push(format!(
            "{dir}: no pose observations: dead reckoning from the origin with the initial ICRs"
        ));
    }
    let first_pos = pose.iter().find_map(|p| p.east.zip(p.north));
    let first_yaw = pose.iter().find_map(|p| p.yaw);
    let std_xy0 = pose
        .iter()
        .find_map(|p| p.std_xy)
        .unwrap_or(cfg.measurement.std_xy);
    let std_yaw0 = pose
        .iter()
        .find_map(|p| p.std_yaw)
        .unwrap_or(cfg.measurement.std_yaw);
    let (e0, n0) = first_pos.unwrap_or((0.0, 0.0));
    let y0 = first_yaw.unwrap_or(0.0);
    let mut x0: State = model::state(e0, n0, y0, &icr0);
    // The first fix seeds the state at the first wheels time: widen the
    // uncertainty by how far the robot can have moved and turned before it.
    let t_fix = pose.first().map_or(log.wheels[0].t, |p| p.t);
    let (mut travel, mut turn) = (0.0, 0.0);
    for w in log.wheels.windows(2).take_while(|w| w[1].t <= t_fix) {
        let dt = w[1].t - w[0].t;
        travel += w[1].v_left.abs().max(w[1].v_right.abs()) * dt;
        turn += (w[1].v_right - w[1].v_left).abs() / (cfg.band.min_spread * track_width) * dt;
    }
    let mut P0 = MatN::zeros();
    let pos_var = if first_pos.is_some() {
        std_xy0 * std_xy0 + travel * travel
    } else {
        1e-6
    };
    let yaw_var = if first_yaw.is_some() {
        std_yaw0 * std_yaw0 + turn * turn
    } else if first_pos.is_some() {
        cfg.init.std_yaw_unknown.powi(2)
    } else {
        1e-6
    };
    P0[(EAST, EAST)] = pos_var;
    P0[(NORTH, NORTH)] = pos_var;
    P0[(YAW, YAW)] = yaw_var;
    P0.fixed_view_mut::<K, K>(SLIP, SLIP).copy_from(&icr_cov);
    // The spread's turn-rate slope: learned from its prior, or fixed (a
    // vanishing variance keeps the covariance positive-definite).
    x0[RATE_K] = rate.k_spread;
    P0[(RATE_K, RATE_K)] = if cfg.filter.learn_rate_k_spread {
        cfg.init.std_rate_k_spread.powi(2)
    } else {
        1e-12
    };

    let mut fcfg = cfg.filter_config(track_width);
    fcfg.rate_k_alpha = rate.k_alpha;
    if rate.k_spread.abs() > fcfg.max_rate_k_spread {
        return Err(PipelineError::Init(format!(
            "{rate_source}: k_spread = {} s/m is beyond filter.max_rate_k_spread = {}",
            rate.k_spread, fcfg.max_rate_k_spread
        )));
    }
    if fcfg.encoder_tick == 0.0 {
        if let (Some(r), Some(n)) = (log.meta.wheel_radius, log.meta.ticks_per_rev) {
            if r.is_finite() && r > 0.0 && n.is_finite() && n >= 1.0 {
                fcfg.encoder_tick = 2.0 * std::f64::consts::PI * r / n;
            }
        }
    }
    let filter_err = |t: f64, source: FilterError| PipelineError::Filter {
        dir: dir.clone(),
        t,
        source,
    };
    let mut filter = Filter::new(x0, P0, fcfg).map_err(|e| filter_err(log.wheels[0].t, e))?;

    let mut schedule = NoiseSchedule::new(cfg.schedule_config());
    if let Some(pf) = init {
        for (name, entry) in &pf.terrains {
            if let Some(k) = terrains.iter().position(|n| n == name) {
                // Under a turn-rate law the filter holds straight-line ICRs.
                let seeded = match (rate.is_constant(), cfg.filter.rate_from_init) {
                    (false, true) => selected_rate_model(&entry.extra, name)?.map(|(p, _)| p),
                    _ => None,
                };
                schedule.seed(k, &seeded.unwrap_or(entry.params), cfg.calibrated_std());
            } else {
                warnings.push(format!(
                    "--init: terrain `{name}` never appears in the terrain evidence; ignored"
                ));
            }
        }
    }
    let mut belief = match evidence {
        TerrainEvidence::Likelihoods { classes, .. } => {
            Some(TerrainBelief::new(classes.len(), cfg.belief_config()))
        }
        _ => None,
    };

    let mut stats = RunStats {
        dropped_fixes: dropped,
        ..Default::default()
    };
    let mut rows = Vec::with_capacity(log.wheels.len());
    let mut changes = Vec::new();
    let mut pi = 0usize; // next pose fix
    let mut li = 0usize; // next label / frame
    let mut current_terrain: Option<usize> = None;
    let mut jump_since_frame = false;
    let mut ci = 0usize; // next camera change detection
    let mut t_prev = log.wheels[0].t;
    // Fixes before the first wheels row are fused at the start.
    let total = log.wheels.len();
    let mut moved = false;
    let mut gaps = 0usize;
    let max_speed = log
        .wheels
        .iter()
        .map(|w| w.v_left.abs().max(w.v_right.abs()))
        .fold(0.0f64, f64::max);

    let fuse = |filter: &mut Filter,
                schedule: &mut NoiseSchedule,
                p: &PoseObs,
                stats: &mut RunStats|
     -> Option<UpdateReport> {
        let fix = PoseFix {
            position: p.east.zip(p.north),
            yaw: p.yaw,
            std_xy: p.std_xy.unwrap_or(cfg.measurement.std_xy),
            std_yaw: p.std_yaw.unwrap_or(cfg.measurement.std_yaw),
        };
        stats.fixes += 1;
        match filter.update(p.t, &fix) {
            Ok(rep) => {
                for (fate, fused, gated) in [
                    (
                        rep.position,
                        &mut stats.position_fused,
                        &mut stats.position_gated,
                    ),
                    (rep.yaw, &mut stats.yaw_fused, &mut stats.yaw_gated),
                ] {
                    match fate {
                        Fate::Fused => *fused += 1,
                        Fate::Gated => *gated += 1,
                        Fate::Reanchored => stats.reanchored += 1,
                        Fate::Absent => {}
                    }
                }
                schedule.on_update(filter);
                Some(rep)
            }
            Err(_) => {
                stats.skipped_updates += 1;
                None
            }
        }
    };

    for (i, w) in log.wheels.iter().enumerate() {
        let mut fused = false;
        let mut gated = false;
        let mut nis = 0.0;
        if w.v_left.abs() >= cfg.filter.still_speed || w.v_right.abs() >= cfg.filter.still_speed {
            moved = true;
        }

        // Terrain evidence up to this row's time.
        match evidence {
            TerrainEvidence::Labels(labels) => {
                while li < labels.len() && labels[li].t <= w.t {
                    li += 1;
                }
                if li > 0 {
                    let k = terrains.iter().position(|n| *n == labels[li - 1].terrain);
                    if let Some(k) = k {
                        if current_terrain != Some(k) {
                            let action = schedule
                                .on_terrain(&mut filter, k)
                                .map_err(|e| filter_err(w.t, e))?;
                            changes.push(TerrainChange {
                                t: w.t,
                                terrain: k,
                                action,
                            });
                            current_terrain = Some(k);
                        }
                    }
                }
            }
            TerrainEvidence::Likelihoods {
                frames,
                changes: detections,
                ..
            } => {
                if let Some(b) = belief.as_mut() {
                    while li < frames.len() && frames[li].0 <= w.t {
                        while ci < detections.len() && detections[ci] <= frames[li].0 {
                            jump_since_frame = true;
                            ci += 1;
                        }
                        if let Some(k) = b.update(&frames[li].1, jump_since_frame) {
                            let action = schedule
                                .on_terrain(&mut filter, k)
                                .map_err(|e| filter_err(w.t, e))?;
                            changes.push(TerrainChange {
                                t: frames[li].0,
                                terrain: k,
                                action,
                            });
                        }
                        jump_since_frame = false;
                        li += 1;
                    }
                    current_terrain = b.current();
                }
            }
            TerrainEvidence::None => {}
        }

        // Predict to each fix in (t_prev, w.t], fuse it, then to w.t. The
        // row's speeds are the mean over the interval that ends at w.t.
        let mut t_cur = t_prev;
        let (mut vl, mut vr) = (w.v_left, w.v_right);
        // Nothing is known about the motion in a gap: held speeds are not
        // integrated over it; before each step inside it the pose
        // uncertainty grows by as far as the fastest tread could have gone.
        let gap = i > 0 && w.t - t_prev > cfg.filter.max_wheel_gap;
        if gap {
            (vl, vr) = (0.0, 0.0);
            gaps += 1;
            if gaps == 1 {
                warnings.push(format!(
                    "{dir}/wheels.csv: {:.1} s without tread speeds before t = {}; pose uncertainty widened instead of integrating",
                    w.t - t_prev,
                    w.t
                ));
            }
        }
        // One prediction step of `dt` (s) with this row's speeds.
        let advance = |filter: &mut Filter,
                       schedule: &mut NoiseSchedule,
                       stats: &mut RunStats,
                       dt: f64|
         -> Result<(), PipelineError> {
            if gap {
                let reach = max_speed * dt;
                filter.inflate_pose(reach * reach, std::f64::consts::PI.powi(2));
            }
            filter.predict(vl, vr, dt).map_err(|e| filter_err(w.t, e))?;
            schedule.on_predict(filter, dt);
            stats.predictions += 1;
            Ok(())
        };
        while pi < pose.len() && pose[pi].t <= w.t {
            let p = pose[pi];
            if i > 0 && p.t > t_cur {
                advance(&mut filter, &mut schedule, &mut stats, p.t - t_cur)?;
                t_cur = p.t;
            }
            if let Some(rep) = fuse(&mut filter, &mut schedule, &p, &mut stats) {
                fused |= matches!(rep.position, Fate::Fused | Fate::Reanchored)
                    || matches!(rep.yaw, Fate::Fused | Fate::Reanchored);
                gated |= rep.position == Fate::Gated || rep.yaw == Fate::Gated;
                nis = rep.nis;
                jump_since_frame |= rep.jump;
            }
            pi += 1;
        }
        if i > 0 && w.t > t_cur {
            advance(&mut filter, &mut schedule, &mut stats, w.t - t_cur)?;
        }
        t_prev = w.t;

        let s = filter.state();
        let mut sd = [0.0; 8];
        sd.copy_from_slice(&filter.std()[..8]);
        let P = filter.covariance();
        let var_d = P[(Y_L, Y_L)] + P[(Y_R, Y_R)] - 2.0 * P[(Y_L, Y_R)];
        // The ICRs in effect at this row's speeds (the law's factors are
        // known, so the stds scale with them), or the straight-line ones.
        let (icr, (gs, ga)) = match cfg.filter.report_icr {
            ReportIcr::Instantaneous => filter.icr_now(),
            ReportIcr::Straight => (filter.icr(), (1.0, 1.0)),
        };
        sd[Y_L] *= gs;
        sd[Y_R] *= gs;
        sd[model::ALPHA_L] *= ga;
        sd[model::ALPHA_R] *= ga;
        rows.push(EstimateRow {
            t: w.t,
            east: s[EAST],
            north: s[NORTH],
            yaw: s[YAW],
            y_l: icr.y_l,
            y_r: icr.y_r,
            x_c: icr.x_c,
            alpha_l: icr.alpha_l,
            alpha_r: icr.alpha_r,
            std: sd,
            std_spread: gs * var_d.max(0.0).sqrt(),
            terrain: current_terrain,
            fused,
            gated,
            nis: if nis.is_finite() { nis } else { 0.0 },
            q_scale: filter.icr_noise_scale(),
            k_spread: filter.rate().k_spread,
        });
        if i % 4096 == 0 {
            progress(i, total);
        }
    }
    progress(total, total);
    if !moved {
        warnings.push(format!(
            "{dir}: the robot never moves (all tread speeds below {} m/s): the ICRs are unobservable and stay at their initial values",
            cfg.filter.still_speed
        ));
    }
    if stats.skipped_updates > 0 {
        warnings.push(format!(
            "{} pose fix(es) could not be fused (innovation covariance not positive-definite)",
            stats.skipped_updates
        ));
    }
    Ok(EstimateRun {
        rows,
        terrains,
        changes,
        track_width,
        final_icr: filter.icr(),
        rate: filter.rate(),
        rate_std: filter.std()[RATE_K],
        rate_source,
        stats,
        warnings,
    })
}

/// The turn-rate model of a parameter set (the `rate_model` key
/// `terraslip calibrate` writes: straight-line `params`, `k_spread`,
/// `k_alpha`) when calibration selected it; `None` when absent or not
/// selected. A selected but malformed one is an error naming the set.
fn selected_rate_model(
    extra: &std::collections::BTreeMap<String, serde_json::Value>,
    set: &str,
) -> Result<Option<(IcrParams, TurnRateSlopes)>, PipelineError> {
    let bad = |reason: String| PipelineError::Init(format!("set `{set}`: rate_model {reason}"));
    let Some(r) = terraslip_io::RateModelEntry::selected(extra).map_err(bad)? else {
        return Ok(None);
    };
    if r.k_spread.abs() > 10.0 || r.k_alpha.abs() > 10.0 {
        return Err(bad(format!(
            "slopes k_spread = {}, k_alpha = {} s/m are beyond +-10 s/m",
            r.k_spread, r.k_alpha
        )));
    }
    // The online filter has no traction term: k_acc / k_dir stay offline.
    let k = TurnRateSlopes {
        k_spread: r.k_spread,
        k_alpha: r.k_alpha,
    };
    Ok(Some((r.params, k)))
}
