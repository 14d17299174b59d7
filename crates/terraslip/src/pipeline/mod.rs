//! Runs the online estimator over a drive log: the streams (tread speeds,
//! pose fixes, terrain evidence) are merged by time and handed to
//! [`terraslip_core::Estimator`] event by event, exactly as a robot would;
//! one [`EstimateRow`] is taken after each wheels row.

pub mod decide;
mod gyro_delay;
pub mod live;
pub mod outage;
pub mod recommend;
mod replay;
pub mod row;
mod setup;
mod terrain_feed;
pub mod warmup;

use terraslip_calib::prediction::PredictionScore;
use terraslip_core::estimator::{Estimator, FixCounts};
use terraslip_core::filter::{IcrBand, PoseFix, SlipHold};
use terraslip_core::schedule::ChangeAction;
use terraslip_core::IcrParams;
use terraslip_io::{DriveLog, LogError, ParamsFile, PoseObs, TerrainLabel};

use crate::config::EstimatorConfig;
/// Seconds of a drive's start its decisions are made from (the node's
/// warm-up).
pub use gyro_delay::SPAN as DECISION_SPAN;
pub use gyro_delay::{gyro_delay, gyro_delay_in, gyro_delay_referenced, GyroClock};
use replay::{Context, Replay};
pub use replay::{RowSink, Streams};
pub use row::row;

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
    /// Standard deviations of east, north (m), yaw (rad), y_l, y_r, x_c (m),
    /// alpha_l, alpha_r.
    pub std: [f64; 8],
    /// Std of the spread y_l - y_r, m.
    pub std_spread: f64,
    /// Covariance of (east, north, yaw) with its cross terms (m², m·rad,
    /// rad²); a heading not yet found from any fix has variance π² and no
    /// cross terms.
    pub pose_cov: [[f64; 3]; 3],
    /// Covariance of (y_l, y_r, x_c, alpha_l, alpha_r) in effect.
    pub icr_cov: [[f64; 5]; 5],
    /// The filter's model noise at this row.
    pub model_noise: terraslip_core::odometry::ModelNoise,
    /// The model's twist error averaged over one second, as learned from
    /// the fixes so far (what the published twist covariance states).
    pub twist_noise: terraslip_core::odometry::TwistNoise,
    /// Index into [`EstimateRun::terrains`] of the believed terrain.
    pub terrain: Option<usize>,
    /// A pose fix part was fused since the previous row.
    pub fused: bool,
    /// A pose fix part was gated since the previous row.
    pub gated: bool,
    /// NIS of the last fix since the previous row (position + heading
    /// parts; 0 if none).
    pub nis: f64,
    /// Factor the terrain schedule applies to the slip random walk.
    pub q_scale: f64,
    /// The slip-change detector fired since the previous row.
    pub change: bool,
    /// The pose stream's clock offset in effect, s.
    pub clock_offset: f64,
    /// What a 2 s prediction from this row takes of the estimate: the ICRs
    /// at this row's turn, the centripetal terms (applied at each later
    /// row's speed) and the clock offset.
    pub prediction_model: terraslip_calib::prediction::Timed,
}

impl EstimateRow {
    /// The ICR parameters in effect at this row.
    pub fn icr(&self) -> terraslip_core::IcrParams {
        terraslip_core::IcrParams {
            y_l: self.y_l,
            y_r: self.y_r,
            x_c: self.x_c,
            alpha_l: self.alpha_l,
            alpha_r: self.alpha_r,
        }
    }
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
    /// What happened to the fixes.
    pub fixes: FixCounts,
    /// Fixes given to the estimator.
    pub fixes_used: usize,
    /// Fixes dropped by [`RunOptions::outage`].
    pub dropped_fixes: usize,
}

/// The measurement noise the run used in the end.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseUsed {
    /// Position std per axis, m (as learned, for fixes at the stated std).
    pub std_xy: f64,
    /// Heading std, rad.
    pub std_yaw: f64,
    /// Std of the slowly wandering part of the position error, m.
    pub correlated_std: f64,
    /// Model noise of the speed, m^2/s per (m/s)^2, and of the yaw rate,
    /// rad^2/s per (rad/s)^2 (learned with the rest).
    pub model: (f64, f64),
    /// Whether `pose.csv` stated the stds (`std_xy`, `std_yaw` columns).
    pub stated: bool,
    /// Whether the noise was learned from the residuals.
    pub learned: bool,
}

/// Result of [`run`].
#[derive(Debug, Clone, PartialEq)]
pub struct EstimateRun {
    /// One row per wheels row (empty when [`run_streams`] handed them to
    /// a sink instead).
    pub rows: Vec<EstimateRow>,
    /// How many rows the run made, and the first and the last of them.
    pub row_count: usize,
    pub first_row: Option<EstimateRow>,
    pub last_row: Option<EstimateRow>,
    /// The rows' ICRs averaged over the whole drive, with their
    /// uncertainty ([`recommend`]); `None` without rows.
    pub drive: Option<recommend::DriveFigures>,
    /// The 2 s motion-prediction error of the parameters the rows
    /// reported against the pose reference (what
    /// [`crate::prediction_score`] computes from the rows); `None` without
    /// a pose reference.
    pub prediction: Option<PredictionScore>,
    /// The outage yardstick: the estimate dead-reckoned through 10, 30
    /// and 60 s without pose fixes from starts every 10 s, beside no-slip
    /// odometry and odometry + gyro ([`outage`]); `None` without a pose
    /// reference or a start.
    pub outage: Option<terraslip_calib::outage::OutageScore>,
    /// Terrain names the rows' indices refer to.
    pub terrains: Vec<String>,
    /// Terrain changes the schedule acted on.
    pub changes: Vec<TerrainChange>,
    /// Track width used for the band and the prior, m.
    pub track_width: f64,
    /// The physical band the ICRs were kept in.
    pub band: IcrBand,
    /// Final slip parameters (straight-line values).
    pub final_icr: IcrParams,
    /// Final turn law slope and its std, s/m.
    pub turn_law: (f64, f64),
    /// Final slope of the speed factors' turn law and its std, s/m.
    pub speed_law: (f64, f64),
    /// Final centripetal terms (`k_x_speed` s, `k_spread_speed` s/m), their
    /// stds, and whether they were learned (false: held at their starting
    /// values, without a position reference or with a zero prior std).
    pub centripetal: (
        terraslip_core::kinematics::CentripetalSlopes,
        terraslip_core::kinematics::CentripetalSlopes,
        bool,
    ),
    /// The slip parameters the log's sensors could not teach, held at
    /// their starting values (decided from the log: positions, headings,
    /// gyro).
    pub hold: SlipHold,
    /// Where the starting slip parameters came from (`prior`, `init:<set>`).
    pub init_source: String,
    /// Final clock offset of the pose stream and its std, s.
    pub clock_offset: (f64, f64),
    /// Where the pose reference sits on the robot, as used in the end.
    pub lever_arm: LeverArm,
    /// The yaw-rate gyro as learned (all zero without one).
    pub gyro: terraslip_core::filter::GyroNoise,
    /// How late the wheels are stamped against the gyro, s.
    pub gyro_delay: f64,
    /// The measurement noise in the end.
    pub noise: NoiseUsed,
    /// Counters.
    pub stats: RunStats,
    /// Things the user should know (data used with caveats, parameters that
    /// sat on a limit).
    pub warnings: Vec<String>,
}

impl EstimateRun {
    /// Duration covered by the rows, s.
    pub fn duration(&self) -> f64 {
        match (self.first_row, self.last_row) {
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

/// Where the pose reference sits on the robot (its lever arm from the
/// wheel axle's centre, body frame), apart from the slip parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LeverArm {
    /// m, forward and left.
    pub x: f64,
    pub y: f64,
    /// `stated` (meta.toml's `[pose]`) or `config` (the configured
    /// `measurement.lever_arm_x`, `_y`, 0 by default).
    pub source: &'static str,
}

impl LeverArm {
    /// The lever arm `filter` ended with, for a log whose meta.toml
    /// states one or not.
    fn of(filter: &terraslip_core::Filter, stated: bool) -> Self {
        let (x, y) = filter.lever_arm();
        let source = if stated { "stated" } else { "config" };
        Self { x, y, source }
    }
}

/// Why a run failed.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    #[error("{dir}: wheels.csv has no rows; a drive needs at least one")]
    NoWheels { dir: String },
    #[error("invalid configuration: {0}")]
    Config(String),
    #[error("initial parameters: {0}")]
    Init(String),
    #[error(transparent)]
    Read(#[from] LogError),
    #[error("{path}: write failed: {source}; check the free space and permissions there")]
    Write {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("{dir}: the estimator failed at t = {t} s: {source}; check that row of wheels.csv and pose.csv, meta.toml's sizes and any --init or --config")]
    Filter {
        dir: String,
        t: f64,
        #[source]
        source: terraslip_core::FilterError,
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
    let total = log.wheels.len();
    let mut rows = Vec::with_capacity(total);
    let gyro = || {
        log.imu
            .iter()
            .filter_map(|s| s.gyro_z.map(|g| Ok((s.t, g))))
    };
    let gyro_clock = if cfg.measurement.std_gyro > 0.0 {
        gyro_delay_referenced(
            &mut log.wheels.iter().copied().map(Ok),
            &mut gyro(),
            &mut log.pose.iter().cloned().map(Ok),
        )
    } else {
        GyroClock::Unknown
    };
    let streams = Streams {
        wheels: &mut log.wheels.iter().copied().map(Ok),
        pose: &mut log.pose.iter().cloned().map(Ok),
        gyro: &mut gyro(),
        gyro_clock,
    };
    let mut run = run_streams(
        log,
        streams,
        cfg,
        evidence,
        init,
        opts,
        &mut rows,
        &mut |done| progress(done, total),
    )?;
    progress(total, total);
    run.rows = rows;
    Ok(run)
}

/// [`run_with`] over `streams` instead of `log`'s wheels and pose (of
/// `log`, only its directory, `meta.toml` and `terrain.csv` are read),
/// each row handed to `sink` as it is made; the result's `rows` stay
/// empty. `progress(done)` is called every few thousand wheels rows.
#[allow(clippy::too_many_arguments)]
pub fn run_streams(
    log: &DriveLog,
    streams: Streams,
    cfg: &EstimatorConfig,
    evidence: &TerrainEvidence,
    init: Option<&ParamsFile>,
    opts: RunOptions,
    sink: &mut dyn RowSink,
    progress: &mut dyn FnMut(usize),
) -> Result<EstimateRun, PipelineError> {
    cfg.validate().map_err(|e| PipelineError::Config(e.0))?;
    let dir = log.dir.display().to_string();
    let mut wheels = streams.wheels.peekable();
    if let Some(Err(_)) = wheels.peek() {
        if let Some(Err(e)) = wheels.next() {
            return Err(e.into());
        }
    }
    if wheels.peek().is_none() {
        return Err(PipelineError::NoWheels { dir });
    }
    // What the log can teach: its first pose rows tell whether it has
    // positions and headings (they are handed on to the run unchanged).
    let mut ahead = Vec::new();
    for row in &mut *streams.pose {
        let stop = row.is_err() || ahead.len() + 1 >= POSE_LOOKAHEAD;
        ahead.push(row);
        if stop {
            break;
        }
    }
    let seen = |f: fn(&PoseObs) -> bool| ahead.iter().flatten().any(f);
    let positions = seen(|p| p.east.is_some() && p.north.is_some());
    let headings = seen(|p| p.yaw.is_some());
    let mut chained = ahead.into_iter().chain(streams.pose);
    let pose: &mut dyn Iterator<Item = _> = &mut chained;
    let mut pose = pose.peekable();
    // The gyro is fused when configured and when it is the body's yaw
    // rate; its samples are moved onto the wheels' clock.
    let mut gyro = streams.gyro.peekable();
    let seen = decide::Seen {
        gyro_clock: streams.gyro_clock,
        positions,
        headings,
        gyro: gyro.peek().is_some(),
    };
    let (decided, gyro_warning) = decide::Decisions::new(&dir, cfg, seen);
    let mut warnings: Vec<String> = gyro_warning.into_iter().collect();
    let mut no_gyro = std::iter::empty();
    let gyro: &mut dyn Iterator<Item = _> = if decided.fuse_gyro {
        &mut gyro
    } else {
        &mut no_gyro
    };
    let mut gyro = gyro.peekable();
    let delay = decided.gyro_delay;
    let setup::Setup {
        mut estimator,
        terrains,
        track_width,
        init_source,
        warnings: setup_warnings,
    } = setup::setup(log, &decided.filter_config(cfg), evidence, init)?;
    warnings.splice(0..0, setup_warnings);
    warnings.extend(decide::warnings(
        &dir,
        cfg,
        &decided,
        track_width,
        pose.peek().is_some(),
        &init_source,
    ));
    let cx = Context {
        dir: &dir,
        cfg,
        evidence,
        opts,
        terrains: &terrains,
        track_width,
        estimator: &mut estimator,
        warnings: &mut warnings,
        sink,
        progress,
    };
    let replay = replay::replay(cx, &mut wheels, &mut pose, &mut gyro, delay)?;
    Ok(finish(
        log,
        cfg,
        &estimator,
        replay,
        RunInfo {
            terrains,
            track_width,
            init_source,
            warnings,
            gyro_delay: delay,
        },
    ))
}

/// Pose rows read ahead to tell whether a log has positions and headings
/// (a few minutes of 10 Hz fixes).
const POSE_LOOKAHEAD: usize = 2000;

/// What the set-up decided, carried into the result.
#[derive(Clone)]
struct RunInfo {
    terrains: Vec<String>,
    track_width: f64,
    init_source: String,
    warnings: Vec<String>,
    gyro_delay: f64,
}

/// The run's result: the learned noise, the warnings the whole run
/// reveals, the counters.
/// Why a run has no 2 s prediction figure, given the pose rows with a
/// position it saw, its wheels rows and their span (s).
fn no_prediction(dir: &str, positions: usize, rows: usize, duration: f64) -> String {
    use terraslip_calib::prediction::{warmup_for, PredictionSpec};
    let spec = PredictionSpec::default();
    if positions == 0 {
        return format!(
            "{dir}: no 2 s prediction figure: the log has no pose reference (pose.csv with positions) to score it against"
        );
    }
    let warmup = warmup_for(&spec, duration);
    if duration < warmup + spec.horizon + spec.stride {
        return format!(
            "{dir}: no 2 s prediction figure: the drive ({duration:.1} s of wheels rows) is too short for a start after a warm-up of {warmup} s and a {} s horizon",
            spec.horizon
        );
    }
    format!(
        "{dir}: no 2 s prediction figure: after the first {warmup} s of the {rows} wheels rows, no start has {} s of pose reference without a gap over {} s (a 1 Hz GNSS is too sparse) and a start heading (the reference's, or the estimate's)",
        spec.horizon, spec.max_gap
    )
}

fn finish(
    log: &DriveLog,
    cfg: &EstimatorConfig,
    estimator: &Estimator,
    replay: Replay,
    setup: RunInfo,
) -> EstimateRun {
    let Replay {
        changes,
        used,
        dropped,
        totals,
    } = replay;
    let RunInfo {
        terrains,
        track_width,
        init_source,
        mut warnings,
        gyro_delay,
    } = setup;
    let dir = log.dir.display().to_string();
    let f = estimator.filter();
    let (std_xy, std_yaw, correlated_std) = f.noise(
        totals.std_xy.unwrap_or(cfg.measurement.std_xy),
        totals.std_yaw.unwrap_or(cfg.measurement.std_yaw),
    );
    let band = cfg.band(track_width);
    warnings.extend(totals.band.warnings(totals.rows));
    if !totals.moved {
        warnings.push(format!(
            "{dir}: the robot never moves (all tread speeds below {} m/s): the ICRs are unobservable and stay at their initial values",
            cfg.filter.still_speed
        ));
    }
    let counts = estimator.counts();
    if counts.refused > 0 {
        warnings.push(format!(
            "{} pose fix(es) could not be fused (the update would have lost positive-definiteness)",
            counts.refused
        ));
    }
    let prediction = totals.prediction.finish();
    if prediction.is_none() {
        let span = match (&totals.first, &totals.last) {
            (Some(a), Some(b)) => b.t - a.t,
            _ => 0.0,
        };
        warnings.push(no_prediction(&dir, totals.positions, totals.rows, span));
    }
    EstimateRun {
        rows: Vec::new(),
        row_count: totals.rows,
        first_row: totals.first,
        last_row: totals.last,
        drive: totals.drive.finish(),
        prediction,
        outage: totals.outage.finish(),
        terrains,
        changes,
        track_width,
        band,
        final_icr: f.icr(),
        turn_law: f.turn_law(),
        speed_law: f.speed_law(),
        centripetal: {
            let (c, sd) = f.centripetal();
            (c, sd, f.learns_centripetal())
        },
        hold: f.config().hold,
        init_source,
        clock_offset: f.clock_offset(),
        lever_arm: LeverArm::of(f, log.meta.pose.is_some()),
        gyro: f.gyro_noise(),
        gyro_delay,
        noise: NoiseUsed {
            std_xy,
            std_yaw,
            correlated_std,
            model: f.model_noise(),
            stated: totals.stated,
            learned: cfg.filter.noise_memory > 0.0,
        },
        stats: RunStats {
            fixes: counts,
            fixes_used: used,
            dropped_fixes: dropped,
        },
        warnings,
    }
}

/// The fix a pose row gives: the configured noise where the row states
/// none.
pub fn pose_fix(cfg: &EstimatorConfig, p: &PoseObs) -> PoseFix {
    PoseFix {
        position: p.east.zip(p.north),
        yaw: p.yaw,
        std_xy: p.std_xy.unwrap_or(cfg.measurement.std_xy),
        std_yaw: p.std_yaw.unwrap_or(cfg.measurement.std_yaw),
        stated: p.std_xy.is_some() || p.std_yaw.is_some(),
    }
}

/// A streaming estimator as [`run`] builds it for a robot of track width
/// `track_width` (m) without terrain evidence, and the source of its
/// starting slip parameters (`prior`, `init:<set>`). Per-terrain sets of
/// `init` are for [`seed_terrain`] once their terrain is declared.
pub fn estimator(
    cfg: &EstimatorConfig,
    track_width: f64,
    init: Option<&ParamsFile>,
) -> Result<(Estimator, String, Vec<String>), PipelineError> {
    cfg.validate().map_err(|e| PipelineError::Config(e.0))?;
    let mut log = DriveLog::default();
    log.meta.track_width = Some(track_width);
    let s = setup::setup(&log, cfg, &TerrainEvidence::None, init)?;
    Ok((s.estimator, s.init_source, s.warnings))
}

/// Seeds terrain `k`'s memory with `init`'s set named `name`, as [`run`]
/// does for each terrain of its evidence.
pub fn seed_terrain(
    est: &mut Estimator,
    cfg: &EstimatorConfig,
    init: &ParamsFile,
    k: usize,
    name: &str,
) {
    if let Some(entry) = init.terrains.get(name) {
        est.schedule_mut().seed(
            k,
            &entry.params,
            setup::set_std(cfg, entry.extra.get("std")),
        );
    }
}
