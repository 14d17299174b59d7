//! `terraslip demo [--out DIR]`: simulate the papers' drive, run every
//! estimator variant over it, print the comparison table, write plots and a
//! report page.

use std::path::Path;

use anyhow::{Context, Result};
use terraslip::config::EstimatorConfig;
use terraslip::metrics::{self};
use terraslip::pipeline::{self, RunOptions, TerrainEvidence};
use terraslip_io::TerrainLabel;
use terraslip_sim::{simulate, Scenario, SimRun};

use super::simulate::{check_target, replace_dir, staging_dir};
use crate::progress::Progress;

mod args;
mod notes;
mod outcome;
mod pages;
mod plots;
mod table;

pub use args::Args;
use outcome::{short, Outcome, SETTLE};
use table::Table;

pub fn run(args: Args) -> Result<()> {
    let started = std::time::Instant::now();
    let mut inputs = super::inputs();
    // A scenario file (a built-in name is no path).
    if Path::new(&args.scenario).is_file() {
        inputs.add(Path::new(&args.scenario), "the scenario file");
    }
    inputs.check_replaced("--out", &args.out)?;
    check_target(&args.out, "summary.json", "an earlier demo")?;
    let mut scenario = Scenario::resolve(&args.scenario)?;
    // The demo compares estimators; camera frames would only cost time.
    scenario.camera.rate = 0.0;
    let sim = simulate(&scenario, args.seed)?;
    let log = &sim.log;
    let outage = scenario
        .gnss
        .outages
        .first()
        .map(|o| (o.start, o.start + o.duration));

    let presets = EstimatorConfig::presets();
    let bar = Progress::new(presets.len() as u64, "variants");
    let evidence = TerrainEvidence::Labels(log.terrain.clone());
    let mut outcomes = Vec::new();
    for (name, cfg) in presets {
        bar.set_message(format!("demo: {name}"));
        let run = pipeline::run_with(
            log,
            &cfg,
            &evidence,
            None,
            RunOptions { outage },
            &mut |_, _| {},
        )
        .with_context(|| format!("variant {name}"))?;
        let card = metrics::scorecard(&run, &log.truth, &log.terrain, outage, SETTLE);
        outcomes.push(Outcome {
            name: name.to_string(),
            run,
            card,
        });
        bar.inc(1);
    }
    bar.finish();

    let changes = change_labels(&log.terrain);
    let table = Table::new(&outcomes, &changes);
    println!(
        "{} estimator variants on `{}` (seed {}): {}\n",
        outcomes.len(),
        scenario.name,
        args.seed,
        scenario.description
    );
    println!("{}\n", table.text());
    for o in &outcomes {
        println!("  {:<13} {}", o.name, short(&o.name));
    }
    println!(
        "\n  re-conv.: s after the change until d = y_l - y_r stays within 2 cm of the truth (5 s means);\n  \
         RMS: from {SETTLE:.0} s after each change; outage drift: dead reckoning with every pose fix dropped."
    );
    let notes = notes::notes(&outcomes, &log.truth);
    if !notes.is_empty() {
        println!("\n  On this run:");
        for n in &notes {
            println!("  - {n}");
        }
    }

    let staging = staging_dir(&args.out)?;
    let written = write_outputs(&staging, &sim, &outcomes, outage, &table, &notes, &args);
    if let Err(e) = written {
        let _ = std::fs::remove_dir_all(&staging);
        return Err(e);
    }
    replace_dir(&staging, &args.out)?;
    eprintln!(
        "demo: {} variants on `{}` (seed {}, {:.0} s) in {:.1} s; report: {}",
        outcomes.len(),
        scenario.name,
        args.seed,
        scenario.duration(),
        started.elapsed().as_secs_f64(),
        args.out.join("report.html").display()
    );
    Ok(())
}

/// `(time, "-> terrain")` of every terrain change.
fn change_labels(labels: &[TerrainLabel]) -> Vec<(f64, String)> {
    labels
        .windows(2)
        .filter(|w| w[0].terrain != w[1].terrain)
        .map(|w| (w[1].t, w[1].terrain.clone()))
        .collect()
}

/// Every figure, the pages and the simulated log into `dir`.
fn write_outputs(
    dir: &Path,
    sim: &SimRun,
    outcomes: &[Outcome],
    outage: Option<(f64, f64)>,
    table: &Table,
    notes: &[String],
    args: &Args,
) -> Result<()> {
    let log = &sim.log;
    let changes = change_labels(&log.terrain);
    let marks = plots::Marks {
        changes: &changes,
        outage,
    };
    let mut figures = vec![plots::spread(dir, log, outcomes, &marks)?];
    figures.extend(plots::icrs(dir, log, outcomes, &marks)?);
    figures.push(plots::trajectory(dir, sim, outcomes)?);
    figures.extend(plots::outage(dir, log, outcomes, outage)?);
    pages::Pages {
        sim,
        outcomes,
        outage,
        changes: &changes,
        table,
        notes,
        figures: &figures,
        args,
    }
    .write(dir)?;
    sim.write(dir.join("log"))?;
    Ok(())
}
