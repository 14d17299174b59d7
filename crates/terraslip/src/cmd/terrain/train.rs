//! `terraslip terrain train`: a classifier from labelled logs, saved as a
//! JSON model.

use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::Context;
use indicatif::ProgressBar;
use terraslip_terrain::TerrainModel;

use super::logs::read_logs;
use super::settings::{options, TrainSettings};

#[derive(clap::Args)]
pub(super) struct TrainArgs {
    /// Log directories with terrain.csv labels.
    #[arg(required = true)]
    logs: Vec<PathBuf>,
    /// Model file to write (JSON).
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    settings: TrainSettings,
}

pub(super) fn run(a: TrainArgs) -> anyhow::Result<()> {
    super::super::inputs_with(&a.logs, &[("--roi", a.settings.roi.as_deref())])
        .check("--out", &a.out)?;
    let opts = options(&a.settings)?;
    let logs = read_logs(&a.logs, false)?;
    let spinner = std::io::stderr().is_terminal().then(|| {
        let spinner = ProgressBar::new_spinner();
        spinner.set_message("extracting features and training");
        spinner.enable_steady_tick(Duration::from_millis(200));
        spinner
    });
    let t0 = Instant::now();
    let model = TerrainModel::train(&logs, &opts);
    if let Some(s) = spinner {
        s.finish_and_clear();
    }
    let model = model.context("training the terrain model")?;
    model
        .save(&a.out)
        .with_context(|| format!("writing model {}", a.out.display()))?;
    eprintln!(
        "trained the {} model on {} log{}: {} classes, {} features, samples per class {}",
        model.source.name(),
        logs.len(),
        if logs.len() == 1 { "" } else { "s" },
        model.classes.len(),
        model.feature_names.len(),
        model
            .classes
            .iter()
            .zip(&model.training.samples_per_class)
            .map(|(c, n)| format!("{c}={n}"))
            .collect::<Vec<_>>()
            .join(" ")
    );
    if !model.training.speed_copies.is_empty() {
        eprintln!(
            "and on {} windows of speed copies (r = {}) where their terrain was not driven",
            model
                .training
                .speed_copy_samples_per_class
                .iter()
                .sum::<usize>(),
            model
                .training
                .speed_copies
                .iter()
                .map(|r| r.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    eprintln!(
        "reads {}; wrote {} ({:.0} s)",
        model.channels_description(),
        a.out.display(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}
