//! Scoring: confusion matrices, leave-runs-out cross-validation and logs
//! spliced from runs of different terrains (to test the Bayesian filter
//! on terrain changes).

use serde::Serialize;
use terraslip_io::{DriveLog, TerrainLabel};

use crate::error::{Result, TerrainError};
use crate::model::{FilteredFrame, TerrainModel, TrainOptions};

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
    Ok(LogScore {
        log: log.name(),
        truth,
        frames,
        raw,
        filtered,
        change,
    })
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
    /// Camera change detector on the held-out runs and the spliced logs.
    pub change: ChangeScore,
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
        change: ChangeScore::default(),
    };
    for (fi, fold) in folds.iter().enumerate() {
        progress(fi, folds.len());
        let train: Vec<DriveLog> = (0..logs.len())
            .filter(|i| !fold.contains(i))
            .map(|i| logs[i].clone())
            .collect();
        let model = TerrainModel::train_classes(&train, &classes, opts)?;
        for &i in fold {
            let s = score_log(&model, &logs[i])?;
            rep.raw.merge(&s.raw);
            rep.filtered.merge(&s.filtered);
            rep.change.merge(&s.change);
        }
        let order = interleave_by_terrain(logs, fold);
        let runs: Vec<&DriveLog> = order.iter().map(|&i| &logs[i]).collect();
        let spliced = splice(&runs, 0.0);
        let s = score_log(&model, &spliced)?;
        rep.spliced_raw.merge(&s.raw);
        rep.spliced_filtered.merge(&s.filtered);
        rep.change.merge(&s.change);
    }
    progress(folds.len(), folds.len());
    Ok(rep)
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
