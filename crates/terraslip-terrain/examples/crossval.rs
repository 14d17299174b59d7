//! Leave-runs-out cross-validation on a directory of labelled runs.
//!
//! `cargo run -p terraslip-terrain --release --example crossval -- DIR [tree|knn|boost] [paper|full] [folds]`
//!
//! Learnt speed normalisation (`VibrationConfig::speed_norm`, default on):
//! `TS_SPEEDNORM=0` turns the speed normalisation off; `TS_VREF`, `TS_VMIN`
//! (m/s; without it the floor is chosen by inner cross-validation).
//! `TS_CURRENTS=0`: no motor-current features (default: when every log has
//! them).
//!
//! The BorealTC paper's protocol: `TS_PARTITION=5` cuts every run into 5 s
//! partitions and deals them at random (seed `TS_SPLIT_SEED`, default 1)
//! to the folds, so windows of one run are both trained and tested on
//! (4 s windows unless `TS_WINDOW`).
//!
//! The manoeuvre split: `TS_SPLIT=manoeuvre` holds out every terrain's
//! fastest drive and slowest spin ([`manoeuvre_split`]) and trains once on
//! the rest (`folds` is ignored).
//!
//! Speed copies of the training logs ([`augment`], on by default):
//! `TS_AUGMENT=0.7,1.4` (speed factors), `TS_AUGMENT=none` (recorded
//! windows only).

use terraslip_terrain::classify::SplitMix64;
use terraslip_terrain::*;

/// The log cut into consecutive `secs`-long pieces (IMU, wheels, currents;
/// the label in force at each piece's start), named `<run>/pNNN`.
fn partitions(log: &terraslip_io::DriveLog, secs: f64) -> Vec<terraslip_io::DriveLog> {
    let (Some(a), Some(b)) = (log.imu.first(), log.imu.last()) else {
        return Vec::new();
    };
    let n = ((b.t - a.t) / secs).floor() as usize;
    (0..n)
        .filter_map(|i| {
            let (t0, t1) = (a.t + i as f64 * secs, a.t + (i + 1) as f64 * secs);
            let label = log.terrain_at(t0)?.to_string();
            Some(terraslip_io::DriveLog {
                dir: log.dir.join(format!("p{i:03}")),
                imu: log
                    .imu
                    .iter()
                    .filter(|s| s.t >= t0 && s.t < t1)
                    .copied()
                    .collect(),
                wheels: log
                    .wheels
                    .iter()
                    .filter(|s| s.t >= t0 && s.t < t1)
                    .copied()
                    .collect(),
                currents: log
                    .currents
                    .iter()
                    .filter(|s| s.t >= t0 && s.t < t1)
                    .copied()
                    .collect(),
                terrain: vec![terraslip_io::TerrainLabel {
                    t: t0,
                    terrain: label,
                }],
                meta: log.meta.clone(),
                ..Default::default()
            })
        })
        .collect()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let dir = args
        .get(1)
        .ok_or("usage: crossval DIR [tree|knn|boost] [paper|full] [folds]")?;
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
        _ => ClassifierKind::Boost,
    };
    if args.get(3).map(String::as_str) == Some("paper") {
        opts.vibration = VibrationConfig::paper();
    }
    // Quick experiments: TS_WINDOW, TS_BANDS, TS_SEED (boosted trees),
    // TS_SLIP=0 (format-1 features), TS_CHANNELS=z.
    let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<f64>().ok());
    if let Some(w) = env("TS_WINDOW") {
        opts.vibration.window_s = w;
    }
    if let Some(b) = env("TS_BANDS") {
        opts.vibration.bands = b as usize;
    }
    if env("TS_SLIP") == Some(0.0) {
        opts.vibration.slip = false;
    }
    if let Some(m) = env("TS_SEED") {
        opts.classifier.boost.seed = m as u64;
    }
    // Boosted trees: TS_ROUNDS, TS_LR, TS_BDEPTH, TS_COLS.
    if let Some(v) = env("TS_ROUNDS") {
        opts.classifier.boost.rounds = v as usize;
    }
    if let Some(v) = env("TS_LR") {
        opts.classifier.boost.learning_rate = v;
    }
    if let Some(v) = env("TS_BDEPTH") {
        opts.classifier.boost.max_depth = v as usize;
    }
    if let Some(v) = env("TS_COLS") {
        opts.classifier.boost.colsample = v;
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
        opts.speed_floor = Some(v);
    }
    if std::env::var("TS_CHANNELS").as_deref() == Ok("z") {
        opts.imu_channels = Some(ChannelSet::AccelZ);
    }
    if env("TS_CURRENTS") == Some(0.0) {
        opts.currents = Some(false);
    }
    // Speed copies (default: augment::SpeedAugmentation::default()):
    // TS_AUGMENT=0.7,1.4 (factors), TS_AUGMENT=none.
    if let Ok(f) = std::env::var("TS_AUGMENT") {
        let factors = f
            .split(',')
            .filter(|s| !s.trim().is_empty() && s.trim() != "none")
            .map(|s| s.trim().parse::<f64>())
            .collect::<Result<Vec<_>, _>>()?;
        opts.speed_augmentation =
            (!factors.is_empty()).then_some(augment::SpeedAugmentation { factors });
    }
    let folds: usize = args.get(4).map_or(Ok(5), |s| s.parse())?;
    let logs = match env("TS_PARTITION") {
        Some(secs) => {
            if env("TS_WINDOW").is_none() {
                opts.vibration.window_s = 4.0;
            }
            let mut parts: Vec<_> = logs.iter().flat_map(|l| partitions(l, secs)).collect();
            let mut rng = SplitMix64(env("TS_SPLIT_SEED").unwrap_or(1.0) as u64);
            for i in (1..parts.len()).rev() {
                let j = (rng.next_u64() as usize) % (i + 1);
                parts.swap(i, j);
            }
            println!(
                "paper protocol: {} partitions of {secs} s, {} s windows, dealt at random",
                parts.len(),
                opts.vibration.window_s
            );
            parts
        }
        None => logs,
    };
    let t0 = std::time::Instant::now();
    let progress = |i, n| eprint!("\rfolds done {i}/{n}");
    let rep = if std::env::var("TS_SPLIT").as_deref() == Ok("manoeuvre") {
        let (rep, held) = crossval_manoeuvre(&logs, &opts, progress)?;
        eprintln!();
        for h in &held {
            println!("held out {}: {}", logs[h.run].name(), h.why);
        }
        rep
    } else {
        crossval(&logs, &opts, folds, progress)?
    };
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
    let (med, worst) = rep.fold_summary();
    println!(
        "per fold: median {:.3}, worst {:.3} ({} folds)",
        med,
        worst,
        rep.fold_accuracy.len()
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
    let (med, worst, never) = rep.latency_summary();
    println!(
        "spliced terrain changes to a correct filtered label: median {:.1} s, worst {:.1} s, never {} of {}",
        med.unwrap_or(f64::NAN),
        worst.unwrap_or(f64::NAN),
        never,
        rep.change_latency_s.len()
    );
    if let Some(f) = rep.outside_envelope_share() {
        println!(
            "held-out windows outside their fold's training envelope: {:.1} %",
            100.0 * f
        );
    }
    print!("{}", rep.runs_table());
    Ok(())
}
