//! `terraslip-lab heldout`: DRIVE's learned slip model ([`crate::blr`])
//! against the online default and `calibrate`, each trained on data the
//! score does not see:
//!
//! * every drive: trained on its first half (the online default: the
//!   parameters it had at each start, having seen only the past), scored on
//!   its second half; the online default also started with `--init` from
//!   the first half's calibration;
//! * `--across A:B`: trained on drive A (the online default runs on B,
//!   alone and started with `--init` from A's calibration), scored on B
//!   after its first 60 s, and on each half of that span.
//!
//! Every model is scored on the identical 2 s segments (starts every
//! second that every model can score), each reading the pose with its own
//! clock offset: the online default the one it had learned at the start,
//! `calibrate` its `time_offset_s`, DRIVE's model (which has none) the one
//! that predicts its training data best.
//!
//! Then, on the same spans, the outage table ([`crate::outage_table`]):
//! each model dead-reckoned through 10, 30 and 60 s without the pose, all
//! from the online default's pose at each start (the other online runs'
//! own dead reckoning, and its covariance for the end's NEES, carried
//! there).

use std::path::{Path, PathBuf};

use anyhow::Context;
use terraslip::pipeline::{self, TerrainEvidence};
use terraslip::EstimatorConfig;
use terraslip_calib::prediction::{references, segment_error, PredictionSpec, Timed};
use terraslip_calib::segment::accelerations;
use terraslip_calib::validate::{model_for, stored_offset};
use terraslip_calib::{calibrate, CalibConfig, ModelChoice, RateSlopes};
use terraslip_core::{IcrParams, Twist};
use terraslip_io::{DriveLog, ParamsFile, WheelSample};

use crate::drive_readings::{drive_models, DRIVE, DRIVE_PROTOCOL};
use crate::outage_table;
use crate::prediction_table::{print, Segments};
use crate::scored_model::Model;
use terraslip_calib::outage::OutageScore;

/// Score each estimator on data it was not trained on.
#[derive(clap::Args)]
pub struct Args {
    /// Log directories with a pose reference (default: every one under
    /// ../shared/data/drive).
    logs: Vec<PathBuf>,
    /// Also score drive A's training on drive B (`A:B`, directories;
    /// repeatable).
    #[arg(long, value_name = "A:B")]
    across: Vec<String>,
    /// Also score variants of the online model (its parameters averaged
    /// over the last 5, 20, 60 s; `calibrate`'s clock offset) and write each drive's per-segment
    /// errors to DIR/NAME.csv.
    #[arg(long, value_name = "DIR")]
    diagnose: Option<PathBuf>,
    /// Also score the online estimator with these configurations (a preset
    /// or `config:FILE.toml`; repeatable), each run like the default.
    #[arg(long = "estimator", value_name = "NAME")]
    estimators: Vec<String>,
    /// The online runs' configuration (TOML, as `estimate --config`;
    /// default: the defaults).
    #[arg(long, value_name = "FILE.toml")]
    online_config: Option<PathBuf>,
    /// Also dead-reckon each drive's outages with `calibrate` fitted on the
    /// scored half itself (`hindsight selected`, outage table only): the
    /// best constant slip model for those outages, a bound for its class.
    #[arg(long)]
    hindsight: bool,
}

/// `calibrate` fitted on the scored half itself (`--hindsight`).
const HINDSIGHT: &str = "hindsight selected";
/// The first models of a drive's list: DRIVE's model by DRIVE's protocol,
/// by this port, and the online default.
const READINGS: usize = 3;

/// The model of each terrain label of a drive (`None`: the pooled set).
type TerrainModels = Vec<(Option<String>, Option<(IcrParams, RateSlopes)>)>;

fn terrain_at(log: &DriveLog, t: f64) -> Option<&str> {
    let k = log.terrain.partition_point(|l| l.t <= t);
    k.checked_sub(1).map(|k| log.terrain[k].terrain.as_str())
}

/// `calibrate`'s selected model and its constant ICRs, for the drive
/// `target` (terrain sets by its labels).
fn calibrated<'a>(
    pf: &'a ParamsFile,
    target: &'a DriveLog,
    acc: &'a [f64],
) -> anyhow::Result<[Model<'a>; 2]> {
    let offset = stored_offset(pf).unwrap_or(0.0);
    let mut sets = Vec::new();
    for choice in [ModelChoice::FromParams, ModelChoice::Constant] {
        // Every terrain of the target, resolved once.
        let mut by: TerrainModels = Vec::new();
        for l in std::iter::once(None).chain(target.terrain.iter().map(|l| Some(l.terrain.clone())))
        {
            if !by.iter().any(|b| b.0 == l) {
                let m = model_for(pf, l.as_deref(), choice)?;
                by.push((l, m));
            }
        }
        sets.push(by);
    }
    let model = |by: TerrainModels, name: &str| Model {
        name: name.to_string(),
        twist: Box::new(move |_, w: &WheelSample| {
            let terrain = terrain_at(target, w.t).map(str::to_string);
            let m = by
                .iter()
                .find(|b| b.0 == terrain)
                .or_else(|| by.iter().find(|b| b.0.is_none()))
                .and_then(|b| b.1);
            match m {
                Some((p, k)) => {
                    let i = target
                        .wheels
                        .partition_point(|s| s.t < w.t)
                        .min(acc.len() - 1);
                    k.twist(&p, w.v_left, w.v_right, acc[i])
                }
                None => Twist {
                    v_x: f64::NAN,
                    v_y: f64::NAN,
                    omega: f64::NAN,
                },
            }
        }),
        clock_at: Box::new(move |_| offset),
    };
    let constant = sets.pop().unwrap_or_default();
    let selected = sets.pop().unwrap_or_default();
    Ok([
        model(selected, "calibrate selected"),
        model(constant, "calibrate constant"),
    ])
}

/// What an online model takes of the run at a start.
#[derive(Clone, Copy)]
enum Pick {
    /// The model at the start, as the estimate's `prediction` takes it.
    Start,
    /// [`Pick::Start`]'s parameters averaged over the last `s` seconds.
    Mean(f64),
    /// [`Pick::Start`] with a fixed clock offset (s).
    Clock(f64),
}

/// The online default's run over `target`: one model per pick, the ICRs
/// and clock offset in effect at each start.
fn online_picks<'a>(
    target: &DriveLog,
    cfg: &EstimatorConfig,
    init: Option<&ParamsFile>,
    picks: &[(String, Pick)],
) -> anyhow::Result<(Vec<Model<'a>>, Option<OutageScore>)> {
    let run = pipeline::run(target, cfg, &TerrainEvidence::None, init)?;
    let ts: std::rc::Rc<Vec<f64>> = std::rc::Rc::new(run.rows.iter().map(|r| r.t).collect());
    let start: Vec<Timed> = run.rows.iter().map(|r| r.prediction_model).collect();
    // Prefix sums of the models' values, for the means.
    let vals = |m: &Timed| {
        [
            m.params.y_l,
            m.params.y_r,
            m.params.x_c,
            m.params.alpha_l,
            m.params.alpha_r,
            m.slopes.k_spread,
            m.slopes.k_x_speed,
            m.slopes.k_spread_speed,
        ]
    };
    let mut sums = vec![[0.0; 8]];
    for m in &start {
        let last = sums[sums.len() - 1];
        let v = vals(m);
        sums.push(std::array::from_fn(|k| last[k] + v[k]));
    }
    let acc = std::rc::Rc::new(accelerations(&target.wheels));
    let wheels: std::rc::Rc<Vec<f64>> =
        std::rc::Rc::new(target.wheels.iter().map(|w| w.t).collect());
    let start = std::rc::Rc::new(start);
    let sums = std::rc::Rc::new(sums);
    let mut out = Vec::new();
    for (name, pick) in picks {
        let pick = *pick;
        let (ts, start, sums) = (ts.clone(), start.clone(), sums.clone());
        let model_at = move |t: f64| -> Timed {
            let k = ts.partition_point(|r| *r <= t).max(1) - 1;
            match pick {
                Pick::Start => start[k],
                Pick::Clock(c) => Timed {
                    clock_offset: c,
                    ..start[k]
                },
                Pick::Mean(s) => {
                    let j = ts.partition_point(|r| *r <= t - s).min(k);
                    let n = (k + 1 - j) as f64;
                    let v: [f64; 8] = std::array::from_fn(|i| (sums[k + 1][i] - sums[j][i]) / n);
                    let mut m = start[k];
                    m.params = IcrParams {
                        y_l: v[0],
                        y_r: v[1],
                        x_c: v[2],
                        alpha_l: v[3],
                        alpha_r: v[4],
                    };
                    m.slopes.k_spread = v[5];
                    m.slopes.k_x_speed = v[6];
                    m.slopes.k_spread_speed = v[7];
                    m
                }
            }
        };
        let model_at = std::rc::Rc::new(model_at);
        let (m1, m2) = (model_at.clone(), model_at);
        let (acc, wheels) = (acc.clone(), wheels.clone());
        out.push(Model {
            name: name.clone(),
            twist: Box::new(move |t, w: &WheelSample| {
                let m = m1(t);
                let i = wheels.partition_point(|s| *s < w.t).min(acc.len() - 1);
                m.slopes.twist(&m.params, w.v_left, w.v_right, acc[i])
            }),
            clock_at: Box::new(move |t| m2(t).clock_offset),
        });
    }
    Ok((out, run.outage))
}

/// The online default's run over `target`: the ICRs and clock offset in
/// effect at each start, and the run's outage yardstick.
fn online<'a>(
    target: &DriveLog,
    cfg: &EstimatorConfig,
    init: Option<&ParamsFile>,
    name: &str,
) -> anyhow::Result<(Model<'a>, Option<OutageScore>)> {
    let (mut m, outage) = online_picks(target, cfg, init, &[(name.to_string(), Pick::Start)])?;
    Ok((m.pop().context("no model")?, outage))
}

/// Each online run's name and its outage yardstick.
type Runs = Vec<(String, Option<OutageScore>)>;

/// The online default over `target`, alone and started with `--init`
/// from `pf`, and their runs' outage yardsticks.
fn default_and_init<'a>(
    target: &DriveLog,
    cfg: &EstimatorConfig,
    pf: &ParamsFile,
) -> anyhow::Result<(Vec<Model<'a>>, Runs)> {
    let (mut models, mut runs) = (Vec::new(), Vec::new());
    for (name, init) in [("online default", None), ("online --init", Some(pf))] {
        let (m, o) = online(target, cfg, init, name)?;
        models.push(m);
        runs.push((name.to_string(), o));
    }
    Ok((models, runs))
}

/// The online estimator over `target` with each named configuration, and
/// each run's outage yardstick.
fn online_configs<'a>(
    target: &DriveLog,
    configs: &[(String, EstimatorConfig)],
) -> anyhow::Result<(Vec<Model<'a>>, Runs)> {
    let (mut out, mut outages) = (Vec::new(), Vec::new());
    for (name, cfg) in configs {
        let picks = [(format!("online {name}"), Pick::Start)];
        let (m, o) = online_picks(target, cfg, None, &picks)?;
        out.extend(m);
        outages.push((format!("online {name}"), o));
    }
    Ok((out, outages))
}

/// The outage table's columns on `target` from starts in `[from, to)`,
/// every model setting out from the online default's pose at each start
/// (`runs`: name and the run's yardstick, the first the default's): the
/// default, the other online runs carried into its starts, `calibrate`
/// selected, DRIVE's model, and the default run's no-slip and odometry +
/// gyro.
fn outage_columns(
    target: &DriveLog,
    models: &[Model],
    runs: &Runs,
    from: f64,
    to: f64,
) -> Vec<outage_table::Column> {
    use terraslip::pipeline::outage::{NO_SLIP, ODOMETRY_GYRO, ONLINE};
    let Some((default, score)) = runs.first() else {
        return Vec::new();
    };
    let starts = outage_table::starts(score.as_ref(), from, to);
    let mut cols = vec![outage_table::from_run(
        default,
        score.as_ref(),
        ONLINE,
        from,
    )];
    for (name, o) in &runs[1..] {
        cols.push(outage_table::carried(target, name, o.as_ref(), &starts));
    }
    for m in [DRIVE, DRIVE_PROTOCOL, "calibrate selected", HINDSIGHT]
        .iter()
        .filter_map(|name| models.iter().find(|m| m.name == *name))
    {
        cols.push(outage_table::fixed(target, &m.name, &*m.twist, &starts));
        if m.name == HINDSIGHT {
            if let Some(((a, c), ends)) = crate::hindsight::best_scaled(target, &*m.twist, &starts)
            {
                let name = format!("hindsight best (speed x{a:.2}, turn x{c:.2})");
                cols.push(outage_table::Column { name, ends });
            }
        }
    }
    for model in [NO_SLIP, ODOMETRY_GYRO] {
        let c = outage_table::from_run(model, score.as_ref(), model, from);
        if !c.ends.is_empty() {
            cols.push(c);
        }
    }
    cols
}

/// Mean error of each model on the starts every model can score.
fn score(target: &DriveLog, models: &[Model], from: f64, to: f64) -> (Vec<f64>, usize) {
    let (m, n, _) = score_segments(target, models, from, to);
    (m, n)
}

/// [`score`] and each scored start's time and errors (m).
fn score_segments(
    target: &DriveLog,
    models: &[Model],
    from: f64,
    to: f64,
) -> (Vec<f64>, usize, Segments) {
    let mut segs = Vec::new();
    let refs = references(&target.pose);
    let spec = PredictionSpec::default();
    let mut sums = vec![0.0; models.len()];
    let mut n = 0usize;
    let mut t = from;
    while t + spec.horizon <= to {
        let errs: Option<Vec<f64>> = models
            .iter()
            .map(|m| {
                segment_error(
                    &refs,
                    &target.wheels,
                    &|w| (m.twist)(t, w),
                    t,
                    (m.clock_at)(t),
                    &spec,
                )
                .filter(|e| e.is_finite())
            })
            .collect();
        if let Some(e) = errs {
            for (s, e) in sums.iter_mut().zip(&e) {
                *s += e;
            }
            segs.push((t, e));
            n += 1;
        }
        t += spec.stride;
    }
    (sums.iter().map(|s| s / n.max(1) as f64).collect(), n, segs)
}

fn read(dir: &Path) -> anyhow::Result<DriveLog> {
    DriveLog::read(dir).with_context(|| format!("reading {}", dir.display()))
}

fn name_of(dir: &Path) -> String {
    dir.file_name()
        .map_or(String::new(), |n| n.to_string_lossy().into())
}

/// Scores `models` on `target` in `[from, to)`; each model's clock offset
/// shown is its mean over the scored span.
fn row(
    target: &DriveLog,
    models: &[Model],
    from: f64,
    to: f64,
) -> (Vec<(String, f64, f64)>, usize) {
    let (errs, n) = score(target, models, from, to);
    let cols = models
        .iter()
        .zip(errs)
        .map(|(m, e)| (m.name.clone(), e, (m.clock_at)(0.5 * (from + to))))
        .collect();
    (cols, n)
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let logs = crate::drives::logs_or_default(&a.logs)?;
    let extra = crate::estimators::resolve(&a.estimators)?;
    let cfg = match &a.online_config {
        Some(path) => crate::estimators::config_file(path)?,
        None => EstimatorConfig::default(),
    };
    let spec = PredictionSpec::default();
    let mut table = Vec::new();
    let mut outages = Vec::new();
    let mut readings = Vec::new();
    eprintln!("first half -> second half");
    for dir in &logs {
        let log = read(dir)?;
        let (Some(first), Some(last)) = (log.wheels.first(), log.wheels.last()) else {
            continue;
        };
        let (t0, t1) = (first.t, last.t);
        let mid = 0.5 * (t0 + t1);
        let acc = accelerations(&log.wheels);
        let drive = drive_models(&log, t0, mid)?;
        let mut cc = CalibConfig::default();
        cc.segment.t_max = mid;
        let cal = calibrate(std::slice::from_ref(&log), &cc, &|_| {})?;
        let pf = cal.params_file();
        let hindsight = if a.hindsight {
            let mut cc = CalibConfig::default();
            cc.segment.t_min = mid;
            Some(calibrate(std::slice::from_ref(&log), &cc, &|_| {})?.params_file())
        } else {
            None
        };
        let [selected, constant] = calibrated(&pf, &log, &acc)?;
        let cal_clock = stored_offset(&pf).unwrap_or(0.0);
        let (default_init, mut runs) = default_and_init(&log, &cfg, &pf)?;
        let mut models = Vec::from(drive);
        models.extend(default_init);
        models.extend([constant, selected]);
        if a.diagnose.is_some() {
            let picks = [
                ("mean 5 s".to_string(), Pick::Mean(5.0)),
                ("mean 20 s".to_string(), Pick::Mean(20.0)),
                ("mean 60 s".to_string(), Pick::Mean(60.0)),
                ("calibrate's clock".to_string(), Pick::Clock(cal_clock)),
            ];
            models.extend(online_picks(&log, &EstimatorConfig::default(), None, &picks)?.0);
        }
        let (more, more_runs) = online_configs(&log, &extra)?;
        models.extend(more);
        runs.extend(more_runs);
        let scored = models.len();
        if let Some(h) = &hindsight {
            let [m, _] = calibrated(h, &log, &acc)?;
            models.push(Model {
                name: HINDSIGHT.into(),
                ..m
            });
        }
        outages.push((name_of(dir), outage_columns(&log, &models, &runs, mid, t1)));
        let (cols, n) = row(&log, &models[..READINGS], mid, t1 + 1.0 - spec.horizon);
        readings.push((name_of(dir), cols, n));
        // DRIVE's protocol stays out of the main table's common segments.
        let models = &models[1..scored];
        let (cols, n) = row(&log, models, mid, t1 + 1.0 - spec.horizon);
        if let Some(out) = &a.diagnose {
            let (_, _, segs) = score_segments(&log, models, mid, t1 + 1.0 - spec.horizon);
            let names: Vec<&str> = models.iter().map(|m| m.name.as_str()).collect();
            crate::prediction_table::write_segments(out, &name_of(dir), &names, &segs)?;
        }
        eprintln!("  {}", name_of(dir));
        table.push((name_of(dir), cols, n));
    }
    println!(
        "2 s prediction error on the second half, mean m (clock offset), trained on the first half"
    );
    print(&table);
    for (drive, cols) in &outages {
        outage_table::print(
            &format!("{drive}, second half (trained on the first)"),
            cols,
        );
    }
    let mut outages = Vec::new();
    let mut table = Vec::new();
    for pair in &a.across {
        let (src, dst) = pair
            .split_once(':')
            .with_context(|| format!("--across {pair}: expected A:B"))?;
        let (from_log, to_log) = (read(Path::new(src))?, read(Path::new(dst))?);
        let (Some(a0), Some(a1), Some(b0), Some(b1)) = (
            from_log.wheels.first(),
            from_log.wheels.last(),
            to_log.wheels.first(),
            to_log.wheels.last(),
        ) else {
            continue;
        };
        let drive = drive_models(&from_log, a0.t, a1.t + 1.0)?;
        let cal = calibrate(
            std::slice::from_ref(&from_log),
            &CalibConfig::default(),
            &|_| {},
        )?;
        let pf = cal.params_file();
        let acc = accelerations(&to_log.wheels);
        let [selected, constant] = calibrated(&pf, &to_log, &acc)?;
        let (default_init, mut runs) = default_and_init(&to_log, &cfg, &pf)?;
        let mut models = Vec::from(drive);
        models.extend(default_init);
        models.extend([constant, selected]);
        let (more, more_runs) = online_configs(&to_log, &extra)?;
        models.extend(more);
        runs.extend(more_runs);
        let name = format!("{} -> {}", name_of(Path::new(src)), name_of(Path::new(dst)));
        let (from, to) = (b0.t + spec.warmup, b1.t + 1.0 - spec.horizon);
        outages.push((
            name.clone(),
            outage_columns(&to_log, &models, &runs, from, b1.t),
        ));
        let mid = 0.5 * (from + to);
        // The whole scored span, then its two halves: whether the online
        // estimate gains on the calibration as the drive goes on.
        for (label, t0, t1) in [
            ("", from, to),
            (", first half", from, mid),
            (", second half", mid, to),
        ] {
            let (cols, n) = row(&to_log, &models[1..], t0, t1);
            table.push((format!("{name}{label}"), cols, n));
        }
        let (cols, n) = row(&to_log, &models[..READINGS], from, to);
        readings.push((name, cols, n));
        eprintln!("  {pair}");
    }
    if !table.is_empty() {
        println!();
        println!(
            "2 s prediction error on drive B after 60 s, mean m (clock offset), trained on drive A"
        );
        print(&table);
        for (pair, cols) in &outages {
            outage_table::print(pair, cols);
        }
    }
    println!();
    println!(
        "DRIVE's model, two readings: 2 s prediction error, mean m (clock offset), on the \
         segments both and the online default score (the spans above)"
    );
    print(&readings);
    Ok(())
}
