//! Leave-runs-out cross-validation on a directory of labelled runs.
//!
//! `cargo run -p terraslip-terrain --release --example crossval -- DIR [tree|knn|forest] [paper|full] [folds]`
//!
//! Spatial bands (docs/research-log.md, "tried, not kept"):
//! `TS_SBANDS=6` adds them to the temporal bands, `TS_SBANDS=6 TS_BANDS=0`
//! replaces the temporal bands with them.
//!
//! Learnt speed normalisation (`VibrationConfig::speed_norm`, default on):
//! `TS_SPEEDNORM=0` turns the speed normalisation off; `TS_VREF`, `TS_VMIN` (m/s).

use terraslip_terrain::*;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let dir = args
        .get(1)
        .ok_or("usage: crossval DIR [tree|knn|forest] [paper|full] [folds]")?;
    let mut entries: Vec<_> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok())
        .map(|e| e.path())
        .collect();
    entries.sort();
    let logs: Vec<_> = entries
        .iter()
        .map(terraslip_io::DriveLog::read)
        .collect::<Result<_, _>>()?;
    let mut opts = TrainOptions::default();
    opts.classifier.kind = match args.get(2).map(String::as_str) {
        Some("tree") => ClassifierKind::Tree,
        Some("knn") => ClassifierKind::Knn,
        _ => ClassifierKind::Forest,
    };
    if args.get(3).map(String::as_str) == Some("paper") {
        opts.vibration = VibrationConfig::paper();
    }
    // Quick experiments: TS_WINDOW, TS_BANDS, TS_TREES, TS_MAXF, TS_SEED (forest),
    // TS_SLIP=0 (format-1 features), TS_MINLEAF, TS_DEPTH, TS_CHANNELS=z.
    let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<f64>().ok());
    if let Some(w) = env("TS_WINDOW") {
        opts.vibration.window_s = w;
    }
    if let Some(b) = env("TS_BANDS") {
        opts.vibration.bands = b as usize;
    }
    if let Some(t) = env("TS_TREES") {
        opts.classifier.forest.n_trees = t as usize;
    }
    if let Some(m) = env("TS_MAXF") {
        opts.classifier.forest.tree.max_features = Some(m as usize);
    }
    if env("TS_SLIP") == Some(0.0) {
        opts.vibration.slip = false;
    }
    if let Some(m) = env("TS_SEED") {
        opts.classifier.forest.seed = m as u64;
    }
    if let Some(m) = env("TS_MINLEAF") {
        opts.classifier.forest.tree.min_samples_leaf = m as usize;
    }
    if let Some(m) = env("TS_DEPTH") {
        opts.classifier.forest.tree.max_depth = m as usize;
    }
    // Spatial bands: TS_SBANDS (count), TS_SMIN / TS_SMAX (cycles/m),
    // TS_SCALING=profile.
    if let Some(b) = env("TS_SBANDS") {
        opts.vibration.spatial_bands = b as usize;
    }
    if let Some(m) = env("TS_SMIN") {
        opts.vibration.spatial_min_cpm = m;
    }
    if let Some(m) = env("TS_SMAX") {
        opts.vibration.spatial_max_cpm = m;
    }
    if std::env::var("TS_SCALING").as_deref() == Ok("profile") {
        opts.vibration.spatial_scaling = SpatialScaling::Profile;
    }
    // Learnt speed normalisation (default on): TS_SPEEDNORM=0 turns it off;
    // TS_VREF / TS_VMIN (m/s).
    if let Some(v) = env("TS_SPEEDNORM") {
        opts.vibration.speed_norm = v != 0.0;
    }
    if let Some(v) = env("TS_VREF") {
        opts.vibration.speed_norm_ref = v;
    }
    if let Some(v) = env("TS_VMIN") {
        opts.vibration.speed_norm_min = v;
    }
    if std::env::var("TS_CHANNELS").as_deref() == Ok("z") {
        opts.vibration.channels = ChannelSet::AccelZ;
    }
    let folds: usize = args.get(4).map_or(Ok(5), |s| s.parse())?;
    let t0 = std::time::Instant::now();
    let rep = crossval(&logs, &opts, folds, |i, n| eprint!("\rfold {i}/{n}"))?;
    eprintln!();
    println!(
        "{} logs, {} folds, {:.1} s",
        logs.len(),
        rep.folds,
        t0.elapsed().as_secs_f64()
    );
    println!(
        "raw windows: accuracy {:.3} balanced {:.3} (n = {})",
        rep.raw.accuracy(),
        rep.raw.balanced_accuracy(),
        rep.raw.total()
    );
    println!("{}", rep.raw.to_table());
    println!("runs filtered: accuracy {:.3}", rep.filtered.accuracy());
    println!(
        "spliced raw: accuracy {:.3}; spliced filtered: accuracy {:.3} (misclassification {:.2} %)",
        rep.spliced_raw.accuracy(),
        rep.spliced_filtered.accuracy(),
        100.0 * (1.0 - rep.spliced_filtered.accuracy())
    );
    println!("{}", rep.spliced_filtered.to_table());
    println!(
        "spliced logs hold {} terrain changes; filtered, windows straddling a change left out: accuracy {:.3} (misclassification {:.2} %, n = {} of {})",
        rep.spliced_changes,
        rep.spliced_filtered_settled.accuracy(),
        100.0 * (1.0 - rep.spliced_filtered_settled.accuracy()),
        rep.spliced_filtered_settled.total(),
        rep.spliced_filtered.total()
    );
    println!(
        "held-out outputs chained across folds ({} terrain changes), filtered: accuracy {:.3} (misclassification {:.2} %)",
        rep.chained_changes,
        rep.chained_filtered.accuracy(),
        100.0 * (1.0 - rep.chained_filtered.accuracy())
    );
    print!("{}", rep.runs_table());
    Ok(())
}
