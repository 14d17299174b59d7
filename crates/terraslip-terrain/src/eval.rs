//! Scoring: confusion matrices, leave-runs-out cross-validation and logs
//! spliced from runs of different terrains (to test the Bayesian filter
//! on terrain changes).

use serde::Serialize;
use terraslip_io::{DriveLog, TerrainLabel};

use crate::error::{Result, TerrainError};
use crate::model::{FilteredFrame, TerrainModel, TerrainTimeline, TrainOptions};

/// Rows = true class, columns = predicted class, in the order of `classes`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Confusion {
    pub classes: Vec<String>,
    pub counts: Vec<Vec<u64>>,
}

impl Confusion {
    pub fn new(classes: &[String]) -> Self {
        Self {
            classes: classes.to_vec(),
            counts: vec![vec![0; classes.len()]; classes.len()],
        }
    }

    pub fn add(&mut self, truth: usize, predicted: usize) {
        if let Some(c) = self
            .counts
            .get_mut(truth)
            .and_then(|r| r.get_mut(predicted))
        {
            *c += 1;
        }
    }

    pub fn merge(&mut self, other: &Confusion) {
        for (r, o) in self.counts.iter_mut().zip(&other.counts) {
            for (a, b) in r.iter_mut().zip(o) {
                *a += b;
            }
        }
    }

    pub fn total(&self) -> u64 {
        self.counts.iter().flatten().sum()
    }

    /// Share of correct predictions, 0..1 (0 when empty).
    pub fn accuracy(&self) -> f64 {
        let ok: u64 = (0..self.counts.len()).map(|i| self.counts[i][i]).sum();
        ok as f64 / self.total().max(1) as f64
    }

    /// Per-class recall, 0..1 (`None` for classes without samples).
    pub fn recall(&self) -> Vec<Option<f64>> {
        self.counts
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let n: u64 = r.iter().sum();
                (n > 0).then(|| r[i] as f64 / n as f64)
            })
            .collect()
    }

    /// Mean of the per-class recalls (balanced accuracy).
    pub fn balanced_accuracy(&self) -> f64 {
        let r: Vec<f64> = self.recall().into_iter().flatten().collect();
        r.iter().sum::<f64>() / r.len().max(1) as f64
    }

    /// The matrix as text: counts and row percentages.
    pub fn to_table(&self) -> String {
        let w = self
            .classes
            .iter()
            .map(|c| c.len())
            .max()
            .unwrap_or(4)
            .max(6);
        let mut s = format!("{:>w$} |", "true\\pred");
        for c in &self.classes {
            s += &format!(" {c:>w$}");
        }
        s += &format!(" | {:>7}\n", "recall");
        for (i, r) in self.counts.iter().enumerate() {
            let n: u64 = r.iter().sum();
            s += &format!("{:>w$} |", self.classes[i]);
            for &c in r {
                let pct = 100.0 * c as f64 / n.max(1) as f64;
                s += &format!(" {:>w$}", format!("{c} ({pct:.0}%)"));
            }
            s += &format!(" | {:>6.1}%\n", 100.0 * r[i] as f64 / n.max(1) as f64);
        }
        s
    }
}

/// A log's frames with truth, raw and filtered predictions.
#[derive(Debug, Clone)]
pub struct LogScore {
    pub log: String,
    /// True class per frame (`None` where the label is not one of the model's classes).
    pub truth: Vec<Option<usize>>,
    pub frames: Vec<FilteredFrame>,
    pub raw: Confusion,
    pub filtered: Confusion,
    /// How the camera change detector did (all zero for IMU models).
    pub change: ChangeScore,
}

/// Scoring of lv2019's change detector against the label changes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct ChangeScore {
    /// Label changes inside the span of the frames.
    pub changes: usize,
    /// Of those, how many the detector flagged at the first or second
    /// frame at or after the change ("within one frame").
    pub detected: usize,
    /// Detections matching no label change.
    pub false_alarms: usize,
}

impl ChangeScore {
    pub fn merge(&mut self, o: &ChangeScore) {
        self.changes += o.changes;
        self.detected += o.detected;
        self.false_alarms += o.false_alarms;
    }
}

/// Matches detections (times) to label changes: a change at `tc` is
/// detected when a detection falls on one of the first two frames at or after `tc`.
pub fn score_changes(log: &DriveLog, frame_times: &[f64], detections: &[f64]) -> ChangeScore {
    let (Some(&first), Some(&last)) = (frame_times.first(), frame_times.last()) else {
        return ChangeScore::default();
    };
    let mut score = ChangeScore::default();
    let mut used = vec![false; detections.len()];
    for w in log.terrain.windows(2) {
        let tc = w[1].t;
        if w[0].terrain == w[1].terrain || tc <= first || tc > last {
            continue;
        }
        score.changes += 1;
        let k = frame_times.partition_point(|&t| t < tc);
        let until = frame_times
            .get(k + 1)
            .or(frame_times.get(k))
            .copied()
            .unwrap_or(tc);
        if let Some(j) = (0..detections.len())
            .find(|&j| !used[j] && detections[j] >= tc && detections[j] <= until)
        {
            used[j] = true;
            score.detected += 1;
        }
    }
    score.false_alarms = used.iter().filter(|u| !**u).count();
    score
}

/// Classifies a labelled log with `model` and scores raw and filtered output.
/// A frame's truth is the label in force at its time.
pub fn score_log(model: &TerrainModel, log: &DriveLog) -> Result<LogScore> {
    if log.terrain.is_empty() {
        return Err(TerrainError::MissingLabels { log: log.name() });
    }
    let tl = model.classify_log(log)?;
    Ok(score_timeline(model, log, &tl))
}

/// [`score_log`] of a timeline already classified by `model`.
fn score_timeline(model: &TerrainModel, log: &DriveLog, tl: &TerrainTimeline) -> LogScore {
    let frames = tl.filter(&model.belief);
    let times: Vec<f64> = tl.frames.iter().map(|f| f.0).collect();
    let change = if model.source == crate::model::Source::Camera {
        score_changes(log, &times, &tl.changes)
    } else {
        ChangeScore::default()
    };
    let mut raw = Confusion::new(&model.classes);
    let mut filtered = Confusion::new(&model.classes);
    let truth: Vec<Option<usize>> = frames
        .iter()
        .map(|f| {
            log.terrain_at(f.t)
                .and_then(|name| model.classes.iter().position(|c| c == name))
        })
        .collect();
    for (f, t) in frames.iter().zip(&truth) {
        if let Some(t) = *t {
            raw.add(t, f.raw);
            filtered.add(t, f.filtered);
        }
    }
    LogScore {
        log: log.name(),
        truth,
        frames,
        raw,
        filtered,
        change,
    }
}

/// One log made of several runs back to back: each run's clock is shifted
/// so that it starts `gap_s` after the previous one ends, and its terrain
/// labels follow. IMU, wheels, images and labels are kept; pose is not.
pub fn splice(runs: &[&DriveLog], gap_s: f64) -> DriveLog {
    let mut out = DriveLog {
        dir: runs.first().map(|r| r.dir.clone()).unwrap_or_default(),
        meta: runs.first().map(|r| r.meta.clone()).unwrap_or_default(),
        ..Default::default()
    };
    let mut offset = 0.0;
    for run in runs {
        let Some((start, end)) = time_span(run) else {
            continue;
        };
        let shift = offset - start;
        out.imu.extend(run.imu.iter().map(|s| {
            let mut s = *s;
            s.t += shift;
            s
        }));
        out.wheels.extend(run.wheels.iter().map(|s| {
            let mut s = *s;
            s.t += shift;
            s
        }));
        out.images.extend(run.images.iter().map(|s| {
            let mut s = s.clone();
            s.t += shift;
            if s.path.is_relative() {
                s.path = run.dir.join(&s.path);
            }
            s
        }));
        // The run's first label holds from its start even if labelled later.
        for (i, l) in run.terrain.iter().enumerate() {
            out.terrain.push(TerrainLabel {
                t: if i == 0 { offset } else { l.t + shift },
                terrain: l.terrain.clone(),
            });
        }
        offset = end + shift + gap_s;
    }
    out
}

/// First and last sensor timestamps of a log (IMU, wheels, images), s.
fn time_span(log: &DriveLog) -> Option<(f64, f64)> {
    let ends = |s: Option<f64>, e: Option<f64>| s.zip(e);
    [
        ends(log.imu.first().map(|s| s.t), log.imu.last().map(|s| s.t)),
        ends(
            log.wheels.first().map(|s| s.t),
            log.wheels.last().map(|s| s.t),
        ),
        ends(
            log.images.first().map(|s| s.t),
            log.images.last().map(|s| s.t),
        ),
    ]
    .into_iter()
    .flatten()
    .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1)))
}

/// Folds of runs: the runs of each terrain (by first label) are dealt
/// round-robin to `k` folds so that every fold tests every terrain it can.
pub fn run_folds(logs: &[DriveLog], k: usize) -> Vec<Vec<usize>> {
    let k = k.max(2);
    let all: Vec<usize> = (0..logs.len()).collect();
    let by_class = group_by_terrain(logs, &all);
    let mut folds = vec![Vec::new(); k];
    let mut next = 0;
    for (_, runs) in &by_class {
        for &r in runs {
            folds[next % k].push(r);
            next += 1;
        }
    }
    folds.retain(|f| !f.is_empty());
    folds
}

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
}

impl CrossvalReport {
    /// One line per held-out run: windows, raw and filtered accuracy, what
    /// it was read as most, mean tread speed and |yaw rate|, and how often
    /// each class was named (in the order of the header's classes).
    pub fn runs_table(&self) -> String {
        let mut s = format!(
            "{:<28} {:>6} {:>6} {:>6} {:>12} {:>6} {:>6}  named {:?}\n",
            "run", "frames", "raw %", "filt %", "read as", "v m/s", "|wz|", self.raw.classes
        );
        for r in &self.runs {
            s += &format!(
                "{:<28} {:>6} {:>6.1} {:>6.1} {:>12} {:>6.2} {:>6.2}  {:?}\n",
                r.log,
                r.frames,
                100.0 * r.raw_accuracy,
                100.0 * r.filtered_accuracy,
                r.most_predicted,
                r.mean_tread_speed,
                r.mean_abs_yaw_rate,
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
        let n_w = log.wheels.len().max(1) as f64;
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
            mean_tread_speed: log
                .wheels
                .iter()
                .map(|w| 0.5 * (w.v_left.abs() + w.v_right.abs()))
                .sum::<f64>()
                / n_w,
            mean_abs_yaw_rate: gz.iter().map(|g| g.abs()).sum::<f64>() / gz.len().max(1) as f64,
        }
    }
}

/// Leave-runs-out cross-validation: a model is trained without the runs of
/// each fold and scored on them; then the held-out runs of the fold are
/// spliced, in an order that changes terrain at every seam, and scored again.
pub fn crossval(
    logs: &[DriveLog],
    opts: &TrainOptions,
    k: usize,
    mut progress: impl FnMut(usize, usize),
) -> Result<CrossvalReport> {
    let mut classes: Vec<String> = logs.iter().flat_map(|l| l.terrain_names()).collect();
    classes.sort();
    classes.dedup();
    let folds = run_folds(logs, k);
    if folds.len() < 2 {
        return Err(TerrainError::Training(
            "cross-validation needs at least 2 runs".into(),
        ));
    }
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
    };
    let mut runs: Vec<(usize, RunScore)> = Vec::with_capacity(logs.len());
    let mut held_out: Vec<Option<(TerrainTimeline, Vec<Option<usize>>)>> = vec![None; logs.len()];
    for (fi, fold) in folds.iter().enumerate() {
        progress(fi, folds.len());
        let train: Vec<DriveLog> = (0..logs.len())
            .filter(|i| !fold.contains(i))
            .map(|i| logs[i].clone())
            .collect();
        let model = TerrainModel::train_classes(&train, &classes, opts)?;
        for &i in fold {
            if logs[i].terrain.is_empty() {
                return Err(TerrainError::MissingLabels {
                    log: logs[i].name(),
                });
            }
            let tl = model.classify_log(&logs[i])?;
            let s = score_timeline(&model, &logs[i], &tl);
            rep.raw.merge(&s.raw);
            rep.filtered.merge(&s.filtered);
            rep.change.merge(&s.change);
            runs.push((i, RunScore::new(&logs[i], &s)));
            held_out[i] = Some((tl, s.truth));
        }
        let order = interleave_by_terrain(logs, fold);
        let runs: Vec<&DriveLog> = order.iter().map(|&i| &logs[i]).collect();
        let spliced = splice(&runs, 0.0);
        let s = score_log(&model, &spliced)?;
        rep.spliced_changes += label_changes(&spliced);
        rep.spliced_raw.merge(&s.raw);
        rep.spliced_filtered.merge(&s.filtered);
        let span = model.window_s();
        for (f, t) in s.frames.iter().zip(&s.truth) {
            if let Some(t) = *t {
                if spliced.terrain_at(f.t - span) == spliced.terrain_at(f.t) {
                    rep.spliced_filtered_settled.add(t, f.filtered);
                }
            }
        }
        rep.change.merge(&s.change);
    }
    progress(folds.len(), folds.len());
    let all: Vec<usize> = (0..logs.len()).collect();
    let mut chained = TerrainTimeline {
        classes: classes.clone(),
        ..Default::default()
    };
    let mut truth = Vec::new();
    for i in interleave_by_terrain(logs, &all) {
        if let Some((tl, t)) = held_out[i].take() {
            chained.frames.extend(tl.frames);
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

/// The runs `runs` grouped by their first terrain label, groups in order of
/// first appearance.
fn group_by_terrain(logs: &[DriveLog], runs: &[usize]) -> Vec<(String, Vec<usize>)> {
    let mut groups: Vec<(String, Vec<usize>)> = Vec::new();
    for &i in runs {
        let c = logs[i]
            .terrain
            .first()
            .map(|x| x.terrain.clone())
            .unwrap_or_default();
        match groups.iter_mut().find(|(n, _)| *n == c) {
            Some((_, v)) => v.push(i),
            None => groups.push((c, vec![i])),
        }
    }
    groups
}

/// Orders runs so that consecutive ones have different terrains as far as possible.
fn interleave_by_terrain(logs: &[DriveLog], runs: &[usize]) -> Vec<usize> {
    let groups = group_by_terrain(logs, runs);
    let mut out = Vec::with_capacity(runs.len());
    let mut round = 0;
    while out.len() < runs.len() {
        for (_, g) in &groups {
            if let Some(&i) = g.get(round) {
                out.push(i);
            }
        }
        round += 1;
    }
    out
}
