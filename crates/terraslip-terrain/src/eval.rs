//! Scoring: confusion matrices, scored logs and logs spliced from runs of
//! different terrains (to test the Bayesian filter on terrain changes).
//! Leave-runs-out cross-validation is in [`crate::crossval`](mod@crate::crossval).

use serde::Serialize;
use terraslip_io::{DriveLog, TerrainLabel};

use crate::confidence::ScoredWindow;
use crate::error::{Result, TerrainError};
use crate::model::{FilteredFrame, TerrainModel, TerrainTimeline};

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

    /// The matrix as text: counts and row percentages, columns aligned
    /// whatever the lengths of the names and counts.
    pub fn to_table(&self) -> String {
        let cells: Vec<Vec<String>> = self
            .counts
            .iter()
            .map(|r| {
                let n: u64 = r.iter().sum();
                r.iter()
                    .map(|&c| format!("{c} ({:.0}%)", 100.0 * c as f64 / n.max(1) as f64))
                    .collect()
            })
            .collect();
        let label = "true\\pred";
        let lw = self
            .classes
            .iter()
            .map(|c| c.chars().count())
            .chain([label.len()])
            .max()
            .unwrap_or(0);
        let w = self
            .classes
            .iter()
            .map(|c| c.chars().count())
            .chain(cells.iter().flatten().map(|c| c.len()))
            .max()
            .unwrap_or(0);
        let mut s = format!("{label:>lw$} |");
        for c in &self.classes {
            s += &format!(" {c:>w$}");
        }
        s += &format!(" | {:>7}\n", "recall");
        for (i, r) in self.counts.iter().enumerate() {
            let n: u64 = r.iter().sum();
            s += &format!("{:>lw$} |", self.classes[i]);
            for c in &cells[i] {
                s += &format!(" {c:>w$}");
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
    /// Frames driven outside the model's envelope for the terrain they
    /// were read as (`None` for a model without an envelope).
    pub outside_envelope: Option<usize>,
    /// Every labelled window: confidence, "unknown", envelope, novelty.
    pub windows: Vec<ScoredWindow>,
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
pub(crate) fn score_timeline(
    model: &TerrainModel,
    log: &DriveLog,
    tl: &TerrainTimeline,
) -> LogScore {
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
        frames,
        raw,
        filtered,
        change,
        outside_envelope: model
            .envelope
            .as_ref()
            .map(|_| tl.outside_envelope.iter().filter(|&&o| o).count()),
        windows: tl.scored_windows(&truth),
        truth,
    }
}

/// One log made of several runs back to back: each run's clock is shifted
/// so that it starts `gap_s` after the previous one ends, and its terrain
/// labels follow. IMU, wheels, currents, images and labels are kept; pose
/// is not.
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
        out.currents.extend(run.currents.iter().map(|s| {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn confusion_table_columns_line_up_with_long_counts_and_short_names() {
        let classes: Vec<String> = ["ice", "sandy_loam", "a"].map(String::from).to_vec();
        let mut c = Confusion::new(&classes);
        for _ in 0..12345 {
            c.add(0, 0);
        }
        c.add(0, 1);
        c.add(2, 2);
        let table = c.to_table();
        let lines: Vec<&str> = table.lines().collect();
        assert_eq!(lines.len(), 4);
        // Every `|` and every line end at the same column.
        let bars = |l: &str| -> Vec<usize> { l.match_indices('|').map(|(i, _)| i).collect() };
        for l in &lines {
            assert_eq!(bars(l), bars(lines[0]), "\n{table}");
            assert_eq!(l.chars().count(), lines[0].chars().count(), "\n{table}");
        }
        assert!(lines[1].contains("12345 (100%)"));
    }
}
