//! `terraslip demo [--out DIR]`: simulate the papers' drive, run every
//! estimator variant over it, print the comparison table, write plots and a
//! report page.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use terraslip::config::EstimatorConfig;
use terraslip::glossary;
use terraslip::metrics::{self, Scorecard};
use terraslip::pipeline::{self, EstimateRun, RunOptions, TerrainEvidence};
use terraslip_io::TerrainLabel;
use terraslip_report::markdown_table;
use terraslip_sim::{simulate, Scenario, SimRun};

use super::simulate::{check_target, replace_dir, staging_dir};
use crate::progress::Progress;

mod notes;
mod pages;
mod plots;

const DETAILS: &str = "\
Simulates the drive of lv2019 §IV (soil -> grass -> asphalt, 1 Hz GNSS with
2 m correlated error, 1° compass, 540-tick encoders, ICRs that vary with the
turn rate, a 30 s GNSS outage), runs every estimator variant over it with the
log's terrain labels as evidence, and compares them:

  re-convergence   seconds after each terrain change until the spread
                   d = y_l - y_r stays within 2 cm of the truth (5 s means)
  steady RMS       ICR errors after the first 20 s on each terrain
  outage drift     dead reckoning on the estimated ICRs through the outage
                   (every pose fix dropped), end-point error in % of the path

DIR gets: report.html and report.md (table + plots), table.md, summary.json,
the plots as SVG, and the simulated log in DIR/log (try
`terraslip estimate DIR/log --out est --terrain-labels`).

Examples:
  terraslip demo
  terraslip demo --out /tmp/demo --seed 7
  terraslip demo --scenario papers-rtk     # the same drive, RTK-grade reference";

/// Simulate the papers' drive, compare every estimator variant, write a report.
#[derive(clap::Args, Debug)]
#[command(after_long_help = DETAILS)]
pub struct Args {
    /// Output directory (replaced if it holds an earlier demo).
    #[arg(long, default_value = "demo-out")]
    pub out: PathBuf,
    /// Seed of the simulated drive.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Scenario to drive (built-in name or TOML file); it should have terrain
    /// changes and one GNSS outage.
    #[arg(long, default_value = "papers")]
    pub scenario: String,
}

/// Who each variant is, in a few words (the glossary's short form).
fn short(name: &str) -> &'static str {
    glossary::short(name).unwrap_or("")
}

/// One variant's run and scores.
pub(super) struct Outcome {
    name: String,
    run: EstimateRun,
    card: Scorecard,
}

/// Seconds after a change in which the steady-state error is not counted.
const SETTLE: f64 = 20.0;

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

fn cm(v: f64) -> String {
    if v.is_finite() {
        format!("{:.1}", 100.0 * v)
    } else {
        "-".into()
    }
}

/// The comparison table: one row per variant.
pub(super) struct Table {
    pub headers: Vec<String>,
    pub rows: Vec<Vec<String>>,
    pub markdown: String,
}

impl Table {
    fn new(outcomes: &[Outcome], changes: &[(f64, String)]) -> Self {
        let (headers, rows) = cells(outcomes, changes);
        let header_refs: Vec<&str> = headers.iter().map(String::as_str).collect();
        let markdown = markdown_table(&header_refs, &rows);
        Self {
            headers,
            rows,
            markdown,
        }
    }

    /// The table with aligned columns, for the terminal.
    fn text(&self) -> String {
        text_table(&self.headers, &self.rows)
    }
}

fn cells(outcomes: &[Outcome], changes: &[(f64, String)]) -> (Vec<String>, Vec<Vec<String>>) {
    let mut headers = vec!["variant".to_string()];
    for (t, name) in changes {
        headers.push(format!("re-conv. to {name} @{t:.0}s [s]"));
    }
    for h in [
        "RMS d [cm]",
        "RMS y_l [cm]",
        "RMS y_r [cm]",
        "RMS x_c [cm]",
        "outage drift [%]",
    ] {
        headers.push(h.to_string());
    }
    let rows = outcomes
        .iter()
        .map(|o| {
            let mut r = vec![o.name.clone()];
            for (t, _) in changes {
                let rec = o
                    .card
                    .reconvergence
                    .iter()
                    .find(|c| (c.t_change - t).abs() < 1e-6);
                r.push(match rec {
                    Some(c) => match c.seconds {
                        Some(s) => format!("{s:.1}"),
                        None => format!("> {:.0}", c.segment),
                    },
                    None => "-".into(),
                });
            }
            let rms = &o.card.rms;
            r.extend([cm(rms.d), cm(rms.y_l), cm(rms.y_r), cm(rms.x_c)]);
            r.push(match &o.card.drift {
                Some(d) => format!("{:.2} ({:.2} m of {:.1} m)", d.percent, d.error, d.distance),
                None => "-".into(),
            });
            r
        })
        .collect();
    (headers, rows)
}

/// The table with aligned columns, for the terminal.
fn text_table(headers: &[String], rows: &[Vec<String>]) -> String {
    let mut width: Vec<usize> = headers.iter().map(|h| h.chars().count()).collect();
    for r in rows {
        for (w, c) in width.iter_mut().zip(r) {
            *w = (*w).max(c.chars().count());
        }
    }
    let line = |cells: &[String]| {
        cells
            .iter()
            .zip(&width)
            .enumerate()
            .map(|(i, (c, w))| {
                if i == 0 {
                    format!("{c:<w$}")
                } else {
                    format!("{c:>w$}")
                }
            })
            .collect::<Vec<_>>()
            .join("  ")
    };
    let mut out = line(headers);
    out.push('\n');
    out.push_str(&"-".repeat(out.chars().count().saturating_sub(1)));
    for r in rows {
        out.push('\n');
        out.push_str(&line(r));
    }
    out
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
