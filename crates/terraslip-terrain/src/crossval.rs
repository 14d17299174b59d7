//! Leave-runs-out cross-validation: whole runs out per fold, folds in
//! parallel, held-out runs scored alone, spliced into logs with terrain
//! changes, and chained across folds. Two ways to choose the runs held
//! out: dealt round-robin ([`run_folds`]), or by how they were driven
//! ([`manoeuvre_split`]: runs outside the speeds and turn rates that the
//! training runs of their terrain cover).

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc;

use serde::Serialize;
use terraslip_io::DriveLog;

use crate::confidence::{ConfidenceScore, ScoredWindow};
use crate::error::{Result, TerrainError};
use crate::eval::{score_log, score_timeline, splice, ChangeScore, Confusion, LogScore};
use crate::folds::interleave_by_terrain;
pub use crate::folds::{manoeuvre_split, run_folds, HeldOut, Manoeuvre, SPIN_SHARE_OF_A_SPIN};
use crate::model::{TerrainModel, TerrainTimeline, TrainOptions};

/// Result of a cross-validation.
#[derive(Debug, Clone, Serialize)]
pub struct CrossvalReport {
    pub folds: usize,
    /// Single windows/frames of held-out runs, unfiltered.
    pub raw: Confusion,
    /// Held-out runs filtered one by one (no terrain change inside).
    pub filtered: Confusion,
    /// Held-out runs spliced into logs with terrain changes, raw classifier.
    pub spliced_raw: Confusion,
    /// Same, after the Bayesian filter.
    pub spliced_filtered: Confusion,
    /// `spliced_filtered` without the windows that straddle a terrain change
    /// (IMU windows that began on the previous terrain; for camera frames,
    /// which have no length, the same as `spliced_filtered`).
    pub spliced_filtered_settled: Confusion,
    /// Terrain changes inside the spliced logs. With one run per fold
    /// (leave-one-run-out) there are none, and the spliced figures are
    /// those of single runs: see `chained_filtered` instead.
    pub spliced_changes: usize,
    /// Every run's held-out classifier output (from the model of its own
    /// fold), chained across folds in an order that changes terrain at
    /// every seam where it can, then filtered by the HMM as one sequence.
    /// Unlike the spliced logs this is defined for any number of folds;
    /// it holds no window straddling two runs (each run was classified
    /// alone), so it measures the filter's lag and the classifier's
    /// errors but not the window's own latency at a change.
    pub chained_filtered: Confusion,
    /// Terrain changes in the chained sequence.
    pub chained_changes: usize,
    /// Camera change detector on the held-out runs and the spliced logs.
    pub change: ChangeScore,
    /// Every held-out run on its own, in the order of the input logs.
    pub runs: Vec<RunScore>,
    /// Single-window accuracy of each fold's held-out runs, 0..1, in fold order.
    pub fold_accuracy: Vec<f64>,
    /// Per terrain change in the spliced logs, the time from the change to
    /// the first window whose filtered label is the new terrain, s (`None`
    /// when none is before the next change or the end).
    pub change_latency_s: Vec<Option<f64>>,
    /// Expected calibration error, risk–coverage, "unknown" and the AUROC of a misread
    /// window over every held-out window (each scored by its fold's model).
    pub confidence: ConfidenceScore,
}

impl CrossvalReport {
    /// Median and lowest [`Self::fold_accuracy`].
    pub fn fold_summary(&self) -> (f64, f64) {
        let mut a = self.fold_accuracy.clone();
        a.sort_by(|x, y| x.total_cmp(y));
        (
            a.get(a.len() / 2).copied().unwrap_or(0.0),
            a.first().copied().unwrap_or(0.0),
        )
    }

    /// Share of all held-out windows outside the envelope of their
    /// fold's model (`None` when the models have none).
    pub fn outside_envelope_share(&self) -> Option<f64> {
        let mut any = false;
        let (mut out, mut n) = (0.0, 0.0);
        for r in &self.runs {
            if let Some(f) = r.outside_envelope_share {
                any = true;
                out += f * r.frames as f64;
                n += r.frames as f64;
            }
        }
        any.then(|| out / n.max(1.0))
    }

    /// Median and largest [`Self::change_latency_s`] of the changes that
    /// were followed, s, and how many never were.
    pub fn latency_summary(&self) -> (Option<f64>, Option<f64>, usize) {
        let mut l: Vec<f64> = self.change_latency_s.iter().flatten().copied().collect();
        l.sort_by(|a, b| a.total_cmp(b));
        let never = self.change_latency_s.len() - l.len();
        (l.get(l.len() / 2).copied(), l.last().copied(), never)
    }

    /// One line per held-out run: windows, raw and filtered accuracy, what
    /// it was read as most, mean tread speed and |yaw rate|, and how often
    /// each class was named (in the order of the header's classes).
    pub fn runs_table(&self) -> String {
        let mut s = format!(
            "{:<28} {:>6} {:>6} {:>6} {:>12} {:>6} {:>6} {:>6}  named {:?}\n",
            "run",
            "frames",
            "raw %",
            "filt %",
            "read as",
            "v m/s",
            "|wz|",
            "out %",
            self.raw.classes
        );
        for r in &self.runs {
            s += &format!(
                "{:<28} {:>6} {:>6.1} {:>6.1} {:>12} {:>6.2} {:>6.2} {:>6}  {:?}\n",
                r.log,
                r.frames,
                100.0 * r.raw_accuracy,
                100.0 * r.filtered_accuracy,
                r.most_predicted,
                r.mean_tread_speed,
                r.mean_abs_yaw_rate,
                r.outside_envelope_share
                    .map_or_else(|| "-".to_string(), |f| format!("{:.0}", 100.0 * f)),
                r.predicted_counts
            );
        }
        s
    }
}

/// How one held-out run was read, with what the robot did in it (to tell
/// whether whole-run errors follow the manoeuvre rather than the terrain).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunScore {
    pub log: String,
    /// The run's (first) terrain label.
    pub terrain: String,
    /// Scored windows/frames.
    pub frames: usize,
    /// Raw classifier accuracy on the run, 0..1.
    pub raw_accuracy: f64,
    /// Accuracy after the Bayesian filter (the run alone), 0..1.
    pub filtered_accuracy: f64,
    /// The class the raw classifier named most often.
    pub most_predicted: String,
    /// How often the raw classifier named each class (order of the classes).
    pub predicted_counts: Vec<u64>,
    /// Mean of (|v_left| + |v_right|) / 2 over wheels.csv, m/s.
    pub mean_tread_speed: f64,
    /// Mean |gyro_z| over imu.csv (body yaw rate), rad/s; 0 without gyro_z.
    pub mean_abs_yaw_rate: f64,
    /// Share of the windows outside the model's envelope for the terrain
    /// they were read as (`None` without an envelope).
    pub outside_envelope_share: Option<f64>,
}

impl RunScore {
    fn new(log: &DriveLog, s: &LogScore) -> Self {
        let k = s.raw.classes.len();
        let mut votes = vec![0u64; k];
        for r in &s.raw.counts {
            for (v, c) in votes.iter_mut().zip(r) {
                *v += c;
            }
        }
        let best = (0..k).max_by_key(|&i| votes[i]).unwrap_or(0);
        let gz: Vec<f64> = log.imu.iter().filter_map(|s| s.gyro_z).collect();
        Self {
            log: s.log.clone(),
            terrain: log
                .terrain
                .first()
                .map(|l| l.terrain.clone())
                .unwrap_or_default(),
            frames: s.raw.total() as usize,
            raw_accuracy: s.raw.accuracy(),
            filtered_accuracy: s.filtered.accuracy(),
            most_predicted: s.raw.classes.get(best).cloned().unwrap_or_default(),
            predicted_counts: votes,
            mean_tread_speed: Manoeuvre::of(log).speed,
            mean_abs_yaw_rate: gz.iter().map(|g| g.abs()).sum::<f64>() / gz.len().max(1) as f64,
            outside_envelope_share: s
                .outside_envelope
                .map(|o| o as f64 / s.raw.total().max(1) as f64),
        }
    }
}

/// What one fold yields.
struct FoldResult {
    /// Held-out runs: index, score, classifier output.
    runs: Vec<(usize, LogScore, TerrainTimeline)>,
    spliced: LogScore,
    spliced_changes: usize,
    /// Spliced windows that began on the terrain they end on.
    settled: Confusion,
    latency: Vec<Option<f64>>,
}

fn run_fold(
    logs: &[DriveLog],
    fold: &[usize],
    classes: &[String],
    opts: &TrainOptions,
) -> Result<FoldResult> {
    let train: Vec<DriveLog> = (0..logs.len())
        .filter(|i| !fold.contains(i))
        .map(|i| logs[i].clone())
        .collect();
    let model = TerrainModel::train_classes(&train, classes, opts)?;
    drop(train);
    let mut runs = Vec::with_capacity(fold.len());
    for &i in fold {
        if logs[i].terrain.is_empty() {
            return Err(TerrainError::MissingLabels {
                log: logs[i].name(),
            });
        }
        let tl = model.classify_log(&logs[i])?;
        let s = score_timeline(&model, &logs[i], &tl);
        runs.push((i, s, tl));
    }
    let order = interleave_by_terrain(logs, fold);
    let parts: Vec<&DriveLog> = order.iter().map(|&i| &logs[i]).collect();
    let spliced = splice(&parts, 0.0);
    let s = score_log(&model, &spliced)?;
    let span = model.window_s();
    let mut settled = Confusion::new(classes);
    for (f, t) in s.frames.iter().zip(&s.truth) {
        if let Some(t) = *t {
            if spliced.terrain_at(f.t - span) == spliced.terrain_at(f.t) {
                settled.add(t, f.filtered);
            }
        }
    }
    let latency = change_latencies(&spliced, &s, classes);
    Ok(FoldResult {
        runs,
        spliced_changes: label_changes(&spliced),
        spliced: s,
        settled,
        latency,
    })
}

/// For each label change of `log`, the time until the first frame at or
/// after it whose filtered label is the new terrain, before the next change.
fn change_latencies(log: &DriveLog, s: &LogScore, classes: &[String]) -> Vec<Option<f64>> {
    let mut out = Vec::new();
    for (i, w) in log.terrain.windows(2).enumerate() {
        if w[0].terrain == w[1].terrain {
            continue;
        }
        let Some(c) = classes.iter().position(|n| *n == w[1].terrain) else {
            continue;
        };
        let (tc, next) = (
            w[1].t,
            log.terrain.get(i + 2).map_or(f64::INFINITY, |l| l.t),
        );
        out.push(
            s.frames
                .iter()
                .find(|f| f.t >= tc && f.t < next && f.filtered == c)
                .map(|f| f.t - tc),
        );
    }
    out
}

/// Leave-runs-out cross-validation: a model is trained without the runs of
/// each fold and scored on them; then the held-out runs of the fold are
/// spliced, in an order that changes terrain at every seam, and scored again.
/// Folds run in parallel on the available cores (`TERRASLIP_THREADS`
/// caps them); `progress(done, folds)` is called as they finish. The
/// result does not depend on the number of threads.
pub fn crossval(
    logs: &[DriveLog],
    opts: &TrainOptions,
    k: usize,
    progress: impl FnMut(usize, usize),
) -> Result<CrossvalReport> {
    if k < 2 {
        return Err(TerrainError::Config(format!(
            "cross-validation needs at least 2 folds, got {k}"
        )));
    }
    let folds = run_folds(logs, k);
    if folds.len() < 2 {
        return Err(TerrainError::Training(
            "cross-validation needs at least 2 runs".into(),
        ));
    }
    crossval_folds(logs, opts, &folds, progress)
}

/// The manoeuvre split ([`manoeuvre_split`]) as one fold: a model trained
/// on the other runs, scored on the held-out ones as [`crossval`] scores a
/// fold (`runs`, `chained_filtered` hold the held-out runs only).
pub fn crossval_manoeuvre(
    logs: &[DriveLog],
    opts: &TrainOptions,
    progress: impl FnMut(usize, usize),
) -> Result<(CrossvalReport, Vec<HeldOut>)> {
    let held = manoeuvre_split(logs);
    if held.is_empty() {
        return Err(TerrainError::Training(
            "no run lies outside the speeds and turn rates of the other runs of its terrain \
             (each terrain needs two drives or two spins)"
                .into(),
        ));
    }
    let fold: Vec<usize> = held.iter().map(|h| h.run).collect();
    let rep = crossval_folds(logs, opts, &[fold], progress)?;
    Ok((rep, held))
}

/// Cross-validation over the given folds of run indices (disjoint); runs
/// in no fold are only trained on.
fn crossval_folds(
    logs: &[DriveLog],
    opts: &TrainOptions,
    folds: &[Vec<usize>],
    mut progress: impl FnMut(usize, usize),
) -> Result<CrossvalReport> {
    for (i, a) in logs.iter().enumerate() {
        if !a.dir.as_os_str().is_empty() && logs[..i].iter().any(|b| b.dir == a.dir) {
            return Err(TerrainError::Config(format!(
                "run {} is given twice: it would be trained and tested on",
                a.dir.display()
            )));
        }
    }
    let mut classes: Vec<String> = logs.iter().flat_map(|l| l.terrain_names()).collect();
    classes.sort();
    classes.dedup();
    let threads = std::env::var("TERRASLIP_THREADS")
        .ok()
        .and_then(|v| v.parse::<usize>().ok())
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .clamp(1, folds.len());
    let next = AtomicUsize::new(0);
    let failed = AtomicBool::new(false);
    let mut results: Vec<Option<Result<FoldResult>>> = (0..folds.len()).map(|_| None).collect();
    progress(0, folds.len());
    std::thread::scope(|scope| {
        let (tx, rx) = mpsc::channel();
        for _ in 0..threads {
            let tx = tx.clone();
            let (next, failed, classes) = (&next, &failed, &classes);
            scope.spawn(move || loop {
                let fi = next.fetch_add(1, Ordering::SeqCst);
                if fi >= folds.len() || failed.load(Ordering::SeqCst) {
                    break;
                }
                let r = run_fold(logs, &folds[fi], classes, opts);
                if r.is_err() {
                    failed.store(true, Ordering::SeqCst);
                }
                if tx.send((fi, r)).is_err() {
                    break;
                }
            });
        }
        drop(tx);
        for (done, (fi, r)) in rx.into_iter().enumerate() {
            results[fi] = Some(r);
            progress(done + 1, folds.len());
        }
    });
    let mut rep = CrossvalReport {
        folds: folds.len(),
        raw: Confusion::new(&classes),
        filtered: Confusion::new(&classes),
        spliced_raw: Confusion::new(&classes),
        spliced_filtered: Confusion::new(&classes),
        spliced_filtered_settled: Confusion::new(&classes),
        spliced_changes: 0,
        chained_filtered: Confusion::new(&classes),
        chained_changes: 0,
        change: ChangeScore::default(),
        runs: Vec::new(),
        change_latency_s: Vec::new(),
        fold_accuracy: Vec::new(),
        confidence: ConfidenceScore::of(&[]),
    };
    let mut windows: Vec<ScoredWindow> = Vec::new();
    let mut runs: Vec<(usize, RunScore)> = Vec::with_capacity(logs.len());
    let mut held_out: Vec<Option<(TerrainTimeline, Vec<Option<usize>>)>> = vec![None; logs.len()];
    // In fold order, whatever order they finished in; the first error wins.
    for r in results.into_iter().flatten() {
        let f = r?;
        let mut fold = Confusion::new(&classes);
        for (i, s, tl) in f.runs {
            fold.merge(&s.raw);
            rep.raw.merge(&s.raw);
            rep.filtered.merge(&s.filtered);
            rep.change.merge(&s.change);
            runs.push((i, RunScore::new(&logs[i], &s)));
            windows.extend(s.windows.iter().cloned());
            held_out[i] = Some((tl, s.truth));
        }
        rep.spliced_changes += f.spliced_changes;
        rep.spliced_raw.merge(&f.spliced.raw);
        rep.spliced_filtered.merge(&f.spliced.filtered);
        rep.spliced_filtered_settled.merge(&f.settled);
        rep.change.merge(&f.spliced.change);
        rep.change_latency_s.extend(f.latency);
        rep.fold_accuracy.push(fold.accuracy());
    }
    let tested: Vec<usize> = folds.iter().flatten().copied().collect();
    if runs.len() != tested.len() {
        return Err(TerrainError::Training(
            "cross-validation stopped before every fold was scored".into(),
        ));
    }
    let mut chained = TerrainTimeline {
        classes: classes.clone(),
        ..Default::default()
    };
    let mut truth = Vec::new();
    for i in interleave_by_terrain(logs, &tested) {
        if let Some((tl, t)) = held_out[i].take() {
            chained.frames.extend(tl.frames);
            chained.outside_envelope.extend(tl.outside_envelope);
            chained.changes.extend(tl.changes);
            truth.extend(t);
        }
    }
    let mut prev = None;
    for (f, t) in chained.filter(&opts.belief).iter().zip(&truth) {
        if let Some(t) = *t {
            rep.chained_filtered.add(t, f.filtered);
            rep.chained_changes += usize::from(prev.is_some_and(|p| p != t));
            prev = Some(t);
        }
    }
    rep.confidence = ConfidenceScore::of(&windows);
    runs.sort_by_key(|r| r.0);
    rep.runs = runs.into_iter().map(|r| r.1).collect();
    Ok(rep)
}

/// Number of label changes between consecutive different terrains.
fn label_changes(log: &DriveLog) -> usize {
    log.terrain
        .windows(2)
        .filter(|w| w[0].terrain != w[1].terrain)
        .count()
}

#[cfg(test)]
mod tests {
    use super::*;
    use terraslip_io::{TerrainLabel, WheelSample};

    /// A run of `terrain` at constant tread speeds.
    fn run(terrain: &str, v_left: f64, v_right: f64) -> DriveLog {
        DriveLog {
            wheels: (0..50)
                .map(|k| WheelSample {
                    t: k as f64 * 0.1,
                    v_left,
                    v_right,
                })
                .collect(),
            terrain: vec![TerrainLabel {
                t: 0.0,
                terrain: terrain.into(),
            }],
            ..Default::default()
        }
    }

    #[test]
    fn manoeuvre_split_holds_out_the_fastest_drive_and_the_slowest_spin_per_terrain() {
        let logs = vec![
            run("sand", 0.2, 0.2),    // 0 drive
            run("sand", 0.6, 0.6),    // 1 fastest drive
            run("sand", 0.3, 0.3),    // 2 drive
            run("sand", -0.2, 0.2),   // 3 spin, tread difference 0.4
            run("sand", -0.05, 0.05), // 4 slowest spin, 0.1
            run("sand", 0.59, 0.59),  // 5 within 5 % of the fastest: held out too
            run("snow", 0.4, 0.4),    // 6 only drive of snow: kept for training
            run("snow", -0.1, 0.1),   // 7 only spin of snow: kept
            run("ice", 0.2, 0.3),     // 8 drive that turns
            run("ice", 0.5, 0.7),     // 9 fastest ice drive
        ];
        let held = manoeuvre_split(&logs);
        let runs: Vec<usize> = held.iter().map(|h| h.run).collect();
        assert_eq!(runs, [1, 4, 5, 9]);
        assert!(held[0].manoeuvre.speed > 0.59 && !held[0].manoeuvre.is_spin());
        assert!(held[1].manoeuvre.is_spin());
        assert!(
            held[0].why.contains("0.60 m/s") && held[0].why.contains("0.20-0.30"),
            "{}",
            held[0].why
        );
        assert!(
            held[1].why.contains("0.10") && held[1].why.contains("0.40-0.40"),
            "{}",
            held[1].why
        );
        // Nothing to hold out: an error, not an empty report.
        let opts = TrainOptions::default();
        assert!(crossval_manoeuvre(&logs[6..8], &opts, |_, _| {}).is_err());
    }
}
