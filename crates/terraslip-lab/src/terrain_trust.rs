//! `terraslip-lab terrain-trust`: how far the estimator can trust a
//! terrain classifier. On the family of simulated worlds, the default
//! estimator given no terrain, the labels, and a simulated classifier
//! ([`crate::misread`]) that reads every ground right, or the world's first
//! ground as the next one (always, or half the time; as sure as the
//! BorealTC model's misreads, or at a fixed confidence), or unsure of it
//! (always, or half the time);
//! figures per world:
//! the 2 s prediction error and the drift over the world's 30 s outage,
//! against the true pose (as `family`). With `--borealtc DIR`, also the
//! BorealTC runs (no pose: [`crate::borealtc_trust`]).

use std::sync::Mutex;

use terraslip::metrics;
use terraslip::pipeline::{self, RunOptions, TerrainEvidence};
use terraslip_sim::family::Subset;

use crate::family::{draw, prediction, simulate_world};
use crate::misread::{self, Confidences, Reading};
use crate::seeds::SeedQueue;
use crate::silent_changes::SilentChanges;
use crate::stats::quantile;

/// The estimator given labels, a classifier or nothing, on simulated
/// worlds whose classifier misreads a ground, and on BorealTC.
#[derive(clap::Args)]
pub struct Args {
    /// Number of worlds.
    #[arg(long, default_value_t = 20)]
    worlds: u64,
    /// Seed of the first world.
    #[arg(long, default_value_t = 1)]
    first_seed: u64,
    /// The simulated classifier's misreads at this confidence (the
    /// probability it gives the wrong ground) and its right verdicts at 0.9,
    /// instead of confidences drawn as the BorealTC model's were.
    #[arg(long)]
    confidence: Option<f64>,
    /// The worlds with a yaw-rate gyro (as `family --gyro`): a change of
    /// terrain declared in the outage is tried on it.
    #[arg(long)]
    gyro: bool,
    /// Also the BorealTC runs in DIR (one log per run), each classified
    /// by a model trained without its fold of runs.
    #[arg(long, value_name = "DIR")]
    borealtc: Option<std::path::PathBuf>,
    /// Outer folds of whole runs on BorealTC.
    #[arg(long, default_value_t = 5)]
    folds: usize,
    /// A directory keeping each BorealTC run's classifier evidence (made
    /// by its fold's model), so that later runs of the benchmark train no
    /// model for the runs it holds. Empty it when the terrain model or the
    /// evidence it hands the estimator changes.
    #[arg(long, value_name = "DIR")]
    evidence_cache: Option<std::path::PathBuf>,
    /// The frames of the classifier's evidence whose confidence (before the
    /// belief's floor) is below this are dropped too, to try evidence
    /// floors above the built-in one (on BorealTC, on the evidence cache
    /// without training again; frames the evidence already left out stay
    /// out).
    #[arg(long, default_value_t = 0.0)]
    min_confidence: f64,
}

/// The evidence each run of a world is given, in report order.
fn evidences(c: Confidences) -> Vec<(String, Option<Reading>)> {
    let mut v = vec![("no terrain".into(), None), ("labels".into(), None)];
    for r in [
        Reading::Right,
        Reading::Always,
        Reading::Stretches,
        Reading::Unsure,
        Reading::UnsureStretches,
    ] {
        v.push((r.name(c), Some(r)));
    }
    v
}

/// Per world: `(seed, [(prediction m, outage drift %) per evidence],
/// [changes of ground the classifier was silent on, per evidence])`.
type WorldFigures = (u64, Vec<(f64, f64)>, Vec<SilentChanges>);

fn world_figures(
    seed: u64,
    evidences: &[(String, Option<Reading>)],
    confidences: Confidences,
    gyro: bool,
    min_confidence: f64,
) -> anyhow::Result<WorldFigures> {
    let cfg = terraslip::config::EstimatorConfig::default();
    let w = draw(seed, Subset::All, gyro, 0.0);
    let sim = simulate_world(&w, seed)?;
    let outage = (w.outage.0 + w.clock_offset, w.outage.1 + w.clock_offset);
    let labels = &sim.log.terrain;
    let (t0, t1) = (
        sim.log.wheels.first().map_or(0.0, |s| s.t),
        sim.log.wheels.last().map_or(0.0, |s| s.t),
    );
    let mut out = Vec::new();
    let mut silent = Vec::new();
    for (name, reading) in evidences {
        let evidence = match *reading {
            None if name == "labels" => TerrainEvidence::Labels(labels.clone()),
            None => TerrainEvidence::None,
            Some(r) => misread::timeline(labels, t0, t1, r, confidences, seed)
                .map_or(TerrainEvidence::None, |tl| {
                    misread::evidence(tl, min_confidence)
                }),
        };
        let opts = RunOptions {
            outage: Some(outage),
        };
        let run = pipeline::run_with(&sim.log, &cfg, &evidence, None, opts, &mut |_, _| {})?;
        let drift = metrics::outage_drift(&run, &sim.log.truth, w.outage.0, w.outage.1);
        silent.push(SilentChanges::of_run(labels, &evidence, &run));
        out.push((
            prediction(&run, &sim),
            drift.map_or(f64::NAN, |d| d.percent),
        ));
    }
    Ok((seed, out, silent))
}

/// `median / worst (world)` of one figure over worlds.
fn median_worst(v: &[(u64, f64)]) -> (f64, f64, u64) {
    let vals: Vec<f64> = v.iter().map(|x| x.1).collect();
    let worst = v
        .iter()
        .filter(|x| !x.1.is_nan())
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .copied()
        .unwrap_or((0, f64::NAN));
    (quantile(&vals, 0.5), worst.1, worst.0)
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let confidences = match a.confidence {
        None => Confidences::Measured,
        Some(c) if c > 0.5 && c < 1.0 => Confidences::Fixed(c),
        Some(c) => anyhow::bail!("--confidence {c}: expected a probability in (0.5, 1)"),
    };
    let seeds: Vec<u64> = (a.first_seed..a.first_seed + a.worlds).collect();
    let results: Mutex<Vec<WorldFigures>> = Mutex::new(Vec::new());
    let queue = SeedQueue::new(seeds.clone());
    let threads = std::thread::available_parallelism().map_or(2, |n| n.get());
    std::thread::scope(|s| -> anyhow::Result<()> {
        let handles: Vec<_> = (0..threads)
            .map(|_| {
                s.spawn(|| -> anyhow::Result<()> {
                    while let Some(seed) = queue.take() {
                        let f = world_figures(
                            seed,
                            &evidences(confidences),
                            confidences,
                            a.gyro,
                            a.min_confidence,
                        )?;
                        results.lock().unwrap_or_else(|e| e.into_inner()).push(f);
                    }
                    Ok(())
                })
            })
            .collect();
        for h in handles {
            h.join()
                .map_err(|_| anyhow::anyhow!("a world's thread panicked"))??;
        }
        Ok(())
    })?;
    let mut results = results.into_inner().unwrap_or_else(|e| e.into_inner());
    results.sort_by_key(|r| r.0);
    println!(
        "{} worlds (seeds {}-{}), default estimator; 2 s prediction (m) and 30 s outage drift (% of the distance) against the true pose",
        seeds.len(),
        a.first_seed,
        a.first_seed + a.worlds - 1
    );
    println!(
        "{:28} {:>21} {:>21} {:>17}",
        "terrain evidence", "prediction med/worst", "outage med/worst", "x labels med/worst"
    );
    let labels_at = 1;
    for (i, (name, _)) in evidences(confidences).iter().enumerate() {
        let pick = |j: usize| -> Vec<(u64, f64)> {
            results
                .iter()
                .map(|(s, f, _)| (*s, if j == 0 { f[i].0 } else { f[i].1 }))
                .collect()
        };
        let labels = |j: usize| -> Vec<(u64, f64)> {
            results
                .iter()
                .map(|(s, f, _)| {
                    (
                        *s,
                        if j == 0 {
                            f[labels_at].0
                        } else {
                            f[labels_at].1
                        },
                    )
                })
                .collect()
        };
        let (pm, pw, ps) = median_worst(&pick(0));
        let (om, ow, os) = median_worst(&pick(1));
        let (lpm, lpw, _) = median_worst(&labels(0));
        let (lom, low, _) = median_worst(&labels(1));
        println!(
            "{name:28} {pm:6.3} {pw:6.3} (w {ps:3}) {om:6.2} {ow:6.2} (w {os:3})   pred {:.2}/{:.2} outage {:.2}/{:.2}",
            pm / lpm,
            pw / lpw,
            om / lom,
            ow / low
        );
    }
    println!(
        "changes of ground with no sure classifier frame for {} s: detector fired / recalled a set / started a fresh one",
        crate::silent_changes::WITHIN_S
    );
    for (i, (name, reading)) in evidences(confidences).iter().enumerate() {
        let mut c = SilentChanges::default();
        results.iter().for_each(|r| c.add(&r.2[i]));
        if reading.is_some() && c.silent > 0 {
            println!(
                "{name:36} {:3} silent: {:3} caught, {:3} recalled, {:3} fresh",
                c.silent, c.caught, c.recalled, c.fresh
            );
        }
    }
    if let Some(dir) = &a.borealtc {
        crate::borealtc_trust::run(dir, a.folds, a.evidence_cache.as_deref(), a.min_confidence)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_classifier_always_right_predicts_as_well_as_the_labels() {
        // A 6 s window reads a new ground; the estimator must recall its
        // set where the ground changed, not when the window has moved on.
        let ev = [
            ("labels".to_string(), None),
            (
                Reading::Right.name(Confidences::Fixed(0.9)),
                Some(Reading::Right),
            ),
        ];
        let figures: Vec<WorldFigures> = (1..=12)
            .map(|seed| world_figures(seed, &ev, Confidences::Fixed(0.9), false, 0.0).unwrap())
            .collect();
        let median = |i: usize| {
            let v: Vec<f64> = figures.iter().map(|(_, f, _)| f[i].0).collect();
            quantile(&v, 0.5)
        };
        let ratio = median(1) / median(0);
        assert!(ratio <= 1.05, "2 s prediction {ratio:.3} x the labels'");
    }
}
