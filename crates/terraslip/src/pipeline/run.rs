//! Running the estimator over a log, or over streams of rows, and
//! finishing the run's figures.

use terraslip_core::estimator::Estimator;
use terraslip_io::{DriveLog, ParamsFile, PoseObs};

/// Seconds of a drive's start its decisions are made from (the node's
/// warm-up).
use super::decide;
use super::gyro_delay::{gyro_delay_referenced, GyroClock};
use super::replay::{self, Context, Replay, RowSink, Streams};
use super::setup;
use super::{
    EstimateRun, LeverArm, NoiseUsed, PipelineError, RunOptions, RunStats, TerrainEvidence,
};
use crate::config::EstimatorConfig;

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
        pose_reference: log.meta.pose_reference,
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
            decided,
        },
    ))
}

/// Pose rows read ahead to tell whether a log has positions and headings
/// (a few minutes of 10 Hz fixes).
const POSE_LOOKAHEAD: usize = 2000;

/// What the set-up decided, carried into the result.
#[derive(Clone)]
pub(super) struct RunInfo {
    pub(super) terrains: Vec<String>,
    pub(super) track_width: f64,
    pub(super) init_source: String,
    pub(super) warnings: Vec<String>,
    pub(super) decided: decide::Decisions,
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

pub(super) fn finish(
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
        decided,
    } = setup;
    let dir = log.dir.display().to_string();
    let f = estimator.filter();
    let (std_xy, std_yaw, correlated_std) = f.noise(
        totals.std_xy.unwrap_or(cfg.measurement.std_xy),
        totals.std_yaw.unwrap_or(cfg.measurement.std_yaw),
    );
    let band = cfg.band(track_width);
    warnings.extend(totals.band.warnings(totals.rows));
    warnings.extend(super::row::off_axle_hint(
        f.icr().x_c,
        &band,
        log.meta.pose.is_some(),
        totals.positions,
    ));
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
        drive: totals.drive.finish(super::row::learned_gyro_scale(f)),
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
        gyro_delay: decided.gyro_delay,
        decided,
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
