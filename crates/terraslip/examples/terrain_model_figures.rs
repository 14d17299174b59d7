//! The estimator's target with a trained terrain classifier as evidence
//! (`estimate --terrain-model`): re-converge within 5 s of what the log's
//! own labels (`--terrain-labels`) achieve.
//!
//!     cargo run -p terraslip --release --example terrain_model_figures -- [SCENARIO] [--seeds N] [--window S] [--verbose]
//!
//! Trains an IMU (vibration) model on seeds 101 and 102 of the scenario,
//! then for test seeds 1..=N runs the default estimator twice, with labels
//! and with the model, and prints the re-convergence after every terrain
//! change and the worst difference.

use terraslip::config::EstimatorConfig;
use terraslip::metrics;
use terraslip::pipeline::{self, RunOptions, TerrainEvidence};
use terraslip_sim::{simulate, Scenario};
use terraslip_terrain::{TerrainModel, TrainOptions};

fn main() -> anyhow::Result<()> {
    let mut scenario = "papers".to_string();
    let mut seeds = 3u64;
    let mut window = 2.0;
    let mut verbose = false;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--seeds" => seeds = args.next().and_then(|s| s.parse().ok()).unwrap_or(seeds),
            "--window" => window = args.next().and_then(|s| s.parse().ok()).unwrap_or(window),
            "--verbose" => verbose = true,
            _ => scenario = a,
        }
    }
    let sc = Scenario::resolve(&scenario)?;
    let train: Vec<_> = [101, 102]
        .iter()
        .map(|&s| simulate(&sc, s).map(|r| r.log))
        .collect::<Result<_, _>>()?;
    let mut opts = TrainOptions::default();
    opts.vibration.window_s = window;
    let model = TerrainModel::train(&train, &opts)?;
    let cfg = EstimatorConfig::default();
    let mut model_cfg = cfg.clone();
    model_cfg.belief.stay_prob = model.belief.stay_prob;
    model_cfg.belief.stay_prob_on_jump = model.belief.stay_prob_on_jump;
    model_cfg.belief.vote_lambda = model.belief.vote_lambda;

    println!("## {scenario}: imu model, {window} s windows, trained on seeds 101-102\n");
    println!("| seed | change | labels: re-conv. (s) | model: re-conv. (s) | model - labels (s) |");
    println!("|---|---|---|---|---|");
    let mut worst: f64 = 0.0;
    let mut missing = 0;
    for seed in 1..=seeds {
        let log = simulate(&sc, seed)?.log;
        let timeline = model.estimator_evidence(&log)?;
        let runs = [
            (&cfg, TerrainEvidence::Labels(log.terrain.clone())),
            (&model_cfg, TerrainEvidence::from(timeline)),
        ];
        let mut cards = Vec::new();
        for (c, ev) in &runs {
            let run = pipeline::run_with(&log, c, ev, None, RunOptions::default(), &mut |_, _| {})?;
            if verbose {
                for ch in &run.changes {
                    eprintln!(
                        "seed {seed}: declared {:?} at {:.1} s ({:?})",
                        run.terrains.get(ch.terrain),
                        ch.t,
                        ch.action
                    );
                }
            }
            cards.push(metrics::scorecard(
                &run,
                &log.truth,
                &log.terrain,
                None,
                20.0,
            ));
        }
        for (a, b) in cards[0].reconvergence.iter().zip(&cards[1].reconvergence) {
            let fmt = |s: Option<f64>| s.map_or("never".to_string(), |v| format!("{v:.1}"));
            let diff = match (a.seconds, b.seconds) {
                (Some(x), Some(y)) => {
                    worst = worst.max(y - x);
                    format!("{:+.1}", y - x)
                }
                _ => {
                    missing += 1;
                    "-".into()
                }
            };
            println!(
                "| {seed} | {:.0} s -> {} | {} | {} | {diff} |",
                a.t_change,
                a.terrain,
                fmt(a.seconds),
                fmt(b.seconds)
            );
        }
    }
    println!("\nworst model - labels: {worst:+.1} s (target <= 5 s); changes not re-converged by one of them: {missing}");
    Ok(())
}
