//! `terrain-trust --borealtc DIR`: the estimator on the BorealTC runs given
//! the labels, no terrain, and a terrain model trained without the run's
//! fold of runs (`estimate --terrain-model` as the estimator sees it:
//! `TerrainModel::estimator_evidence`, the model's belief settings). The
//! runs have no pose, so no prediction or outage figure: per run, the share
//! of its time the estimator held a terrain other than the label, and how
//! far the spread it learned from the gyro ends from the labels' run.

use std::path::Path;

use anyhow::Context;
use terraslip::config::EstimatorConfig;
use terraslip::pipeline::{self, EstimateRun, RunOptions, TerrainEvidence};
use terraslip_io::DriveLog;
use terraslip_terrain::{run_folds, TerrainModel, TrainOptions};

use crate::stats::quantile;

/// Shares of `[first wheel sample, last]` in which the terrain the run
/// declared (its `changes`) is not `truth`, and is `truth`; before the
/// first declaration no terrain is held, which is neither.
fn wrong_right_shares(run: &EstimateRun, log: &DriveLog, truth: &str) -> (f64, f64) {
    let (Some(a), Some(b)) = (log.wheels.first(), log.wheels.last()) else {
        return (f64::NAN, f64::NAN);
    };
    let (t0, t1) = (a.t, b.t);
    let (mut wrong, mut right) = (0.0, 0.0);
    for (i, c) in run.changes.iter().enumerate() {
        let end = run.changes.get(i + 1).map_or(t1, |n| n.t).min(t1);
        let held = (end - c.t.max(t0)).max(0.0);
        if run.terrains.get(c.terrain).map(String::as_str) == Some(truth) {
            right += held;
        } else {
            wrong += held;
        }
    }
    let span = (t1 - t0).max(1e-9);
    (wrong / span, right / span)
}

fn estimate(
    log: &DriveLog,
    cfg: &EstimatorConfig,
    ev: &TerrainEvidence,
) -> anyhow::Result<EstimateRun> {
    Ok(pipeline::run_with(
        log,
        cfg,
        ev,
        None,
        RunOptions::default(),
        &mut |_, _| {},
    )?)
}

/// Per run: `(name, wrong share, |spread − labels' spread| / labels', declared changes)`
/// for the model, and the spread difference without terrain.
struct RunTrust {
    name: String,
    wrong: f64,
    /// Share of the run's time on the right terrain.
    right: f64,
    spread_model: f64,
    spread_none: f64,
    changes: usize,
}

/// A run's classifier evidence and the belief settings of the model that
/// made it, as kept between runs of the benchmark (`--evidence-cache`).
#[derive(serde::Serialize, serde::Deserialize)]
struct CachedEvidence {
    classes: Vec<String>,
    frames: Vec<(f64, Vec<f64>)>,
    changes: Vec<f64>,
    belief: terraslip_terrain::BeliefSettings,
}

fn cache_path(cache: Option<&Path>, log: &DriveLog) -> Option<std::path::PathBuf> {
    cache.map(|c| c.join(format!("{}.json", log.name())))
}

fn read_cached(path: Option<&Path>) -> Option<CachedEvidence> {
    let text = std::fs::read_to_string(path?).ok()?;
    serde_json::from_str(&text).ok()
}

/// The estimator settings and evidence of one run: from the cache when it
/// holds the run, else from `model` (written to the cache); frames whose
/// confidence before the floor is below `min_confidence` are dropped.
fn run_evidence(
    base: &EstimatorConfig,
    log: &DriveLog,
    model: Option<&TerrainModel>,
    cache: Option<&Path>,
    min_confidence: f64,
) -> anyhow::Result<(EstimatorConfig, TerrainEvidence)> {
    let path = cache_path(cache, log);
    let c = match read_cached(path.as_deref()) {
        Some(c) => c,
        None => {
            let model = model.context("no model for a run the evidence cache lacks")?;
            let t = model.estimator_evidence(log)?;
            let c = CachedEvidence {
                classes: t.classes,
                frames: t.frames,
                changes: t.changes,
                belief: model.belief,
            };
            if let Some(p) = &path {
                let tmp = p.with_extension("json.tmp");
                std::fs::write(&tmp, serde_json::to_string(&c)?)
                    .with_context(|| tmp.display().to_string())?;
                std::fs::rename(&tmp, p).with_context(|| p.display().to_string())?;
            }
            c
        }
    };
    let mut cfg = base.clone();
    cfg.belief.stay_prob = c.belief.stay_prob;
    cfg.belief.stay_prob_on_jump = c.belief.stay_prob_on_jump;
    cfg.belief.vote_lambda = c.belief.vote_lambda;
    // The frames were floored: p' = (1 - f) p + f / k.
    let (f, k) = (c.belief.prob_floor, c.classes.len().max(1) as f64);
    let frames = c
        .frames
        .into_iter()
        .filter(|(_, p)| {
            let top = p.iter().copied().fold(0.0, f64::max);
            (top - f / k) / (1.0 - f).max(1e-9) >= min_confidence
        })
        .collect();
    let ev = TerrainEvidence::Likelihoods {
        classes: c.classes,
        frames,
        changes: c.changes,
    };
    Ok((cfg, ev))
}

/// `cache`: a directory keeping each run's classifier evidence, so that
/// the models are trained only for runs it does not hold yet;
/// `min_confidence`: the evidence's frames less sure than this are dropped.
pub fn run(
    dir: &Path,
    folds: usize,
    cache: Option<&Path>,
    min_confidence: f64,
) -> anyhow::Result<()> {
    let mut paths: Vec<_> = std::fs::read_dir(dir)
        .with_context(|| format!("{}: cannot list", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("terrain.csv").exists())
        .collect();
    paths.sort();
    let logs: Vec<DriveLog> = paths
        .iter()
        .map(|p| DriveLog::read(p).with_context(|| p.display().to_string()))
        .collect::<anyhow::Result<_>>()?;
    if logs.len() < 2 {
        anyhow::bail!("{}: fewer than 2 labelled runs", dir.display());
    }
    let base = EstimatorConfig::default();
    let mut rows = Vec::new();
    for (f, fold) in run_folds(&logs, folds).iter().enumerate() {
        let cached = fold
            .iter()
            .all(|&i| read_cached(cache_path(cache, &logs[i]).as_deref()).is_some());
        let model = if cached {
            None
        } else {
            let train: Vec<DriveLog> = (0..logs.len())
                .filter(|i| !fold.contains(i))
                .map(|i| logs[i].clone())
                .collect();
            eprintln!("fold {}: training on {} runs", f + 1, train.len());
            Some(TerrainModel::train(&train, &TrainOptions::default())?)
        };
        for &i in fold {
            let log = &logs[i];
            let Some(truth) = log.terrain.first().map(|l| l.terrain.clone()) else {
                continue;
            };
            let labels = estimate(log, &base, &TerrainEvidence::Labels(log.terrain.clone()))?;
            let none = estimate(log, &base, &TerrainEvidence::None)?;
            let (cfg, ev) = run_evidence(&base, log, model.as_ref(), cache, min_confidence)?;
            let with = estimate(log, &cfg, &ev)?;
            let d0 = labels.final_icr.spread();
            let (wrong, right) = wrong_right_shares(&with, log, &truth);
            rows.push(RunTrust {
                name: log.name(),
                wrong,
                right,
                spread_model: 100.0 * (with.final_icr.spread() - d0).abs() / d0.abs().max(1e-9),
                spread_none: 100.0 * (none.final_icr.spread() - d0).abs() / d0.abs().max(1e-9),
                changes: with.changes.len().saturating_sub(1),
            });
        }
    }
    rows.sort_by(|a, b| a.name.cmp(&b.name));
    println!(
        "\nBorealTC, {} runs, {folds} outer folds (each run classified by a model trained without its fold); no pose, so:",
        rows.len()
    );
    println!(
        "{:28} {:>8} {:>8} {:>16} {:>16} {:>8}",
        "run", "wrong %", "right %", "spread vs labels %", "none vs labels %", "changes"
    );
    for r in &rows {
        println!(
            "{:28} {:8.1} {:8.1} {:16.2} {:16.2} {:8}",
            r.name,
            100.0 * r.wrong,
            100.0 * r.right,
            r.spread_model,
            r.spread_none,
            r.changes
        );
    }
    let col = |f: fn(&RunTrust) -> f64| -> (f64, f64) {
        let v: Vec<f64> = rows.iter().map(f).collect();
        (quantile(&v, 0.5), quantile(&v, 1.0))
    };
    let (wm, ww) = col(|r| 100.0 * r.wrong);
    let (sm, sw) = col(|r| r.spread_model);
    let (nm, nw) = col(|r| r.spread_none);
    println!(
        "median / worst: time on a wrong terrain {wm:.1} / {ww:.1} %; final spread off the labels' run: model {sm:.2} / {sw:.2} %, no terrain {nm:.2} / {nw:.2} %"
    );
    let right: Vec<f64> = rows.iter().map(|r| 100.0 * r.right).collect();
    println!(
        "time on the right terrain: median {:.1} %, least {:.1} %, mean {:.1} %",
        quantile(&right, 0.5),
        quantile(&right, 0.0),
        right.iter().sum::<f64>() / right.len().max(1) as f64
    );
    Ok(())
}
