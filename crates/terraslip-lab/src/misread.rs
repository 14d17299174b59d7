//! A simulated terrain classifier with a set confusion: what a vibration
//! model would hand the estimator on a simulated world, right on every
//! ground but one, which it reads as another ground (confidently, or
//! unsure of it).

use terraslip::pipeline::TerrainEvidence;
use terraslip_io::TerrainLabel;
use terraslip_terrain::{BeliefSettings, TerrainTimeline};

/// Seconds between frames (a vibration model's hop).
pub const HOP_S: f64 = 0.5;
/// Length of a classified window, s: a frame at `t` reads the ground at
/// `t − WINDOW_S / 2` (the middle of its window).
pub const WINDOW_S: f64 = 6.0;
/// Length of a stretch of [`Reading::Stretches`], s.
pub const STRETCH_S: f64 = 30.0;
/// Confidence of a right verdict.
pub const RIGHT_CONFIDENCE: f64 = 0.9;

/// How the classifier reads the misread ground (the world's first).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Reading {
    /// Every ground read right.
    Right,
    /// Read as the next ground the robot drives on, with this confidence.
    Confident(f64),
    /// The same, in every other [`STRETCH_S`] of the log's time (right
    /// in between): a ground read partly as another, so the estimator
    /// recalls the other ground's set on it.
    Stretches(f64),
    /// Read as that ground with 0.45, itself with 0.35: the verdict is
    /// wrong and "unknown" (below 0.5).
    Unsure,
}

impl Reading {
    pub fn name(&self) -> String {
        match self {
            Reading::Right => "model, right".into(),
            Reading::Confident(c) => format!("model, misread at {c:.2}"),
            Reading::Stretches(c) => format!("model, misread at {c:.2} half the time"),
            Reading::Unsure => "model, misread unsure".into(),
        }
    }
}

/// The world's terrain names in order of first visit.
fn grounds(labels: &[TerrainLabel]) -> Vec<String> {
    let mut g: Vec<String> = Vec::new();
    for l in labels {
        if !g.contains(&l.terrain) {
            g.push(l.terrain.clone());
        }
    }
    g
}

/// The ground at `t` (the label in effect; the first before any).
fn ground_at(labels: &[TerrainLabel], t: f64) -> Option<&str> {
    let i = labels.partition_point(|l| l.t <= t);
    labels.get(i.saturating_sub(1)).map(|l| l.terrain.as_str())
}

/// Class probabilities of one frame: `read` with `confidence`, the rest
/// shared by the other classes (`second` with `second_p` first, when set).
fn frame(k: usize, read: usize, confidence: f64, second: Option<(usize, f64)>) -> Vec<f64> {
    let mut p = vec![0.0; k];
    p[read] = confidence;
    let mut rest = 1.0 - confidence;
    if let Some((s, q)) = second.filter(|(s, _)| *s != read) {
        p[s] = q;
        rest -= q;
    }
    let others = p.iter().filter(|v| **v == 0.0).count();
    for v in p.iter_mut().filter(|v| **v == 0.0) {
        *v = rest / others.max(1) as f64;
    }
    p
}

/// The classifier's frames over `[t0, t1]` for a world whose ground
/// changes as `labels` say. `None` when the world has one ground.
pub fn timeline(
    labels: &[TerrainLabel],
    t0: f64,
    t1: f64,
    reading: Reading,
) -> Option<TerrainTimeline> {
    let classes = grounds(labels);
    if classes.len() < 2 {
        return None;
    }
    let k = classes.len();
    let (misread, as_) = (0, 1);
    let mut frames = Vec::new();
    let mut t = t0 + WINDOW_S;
    while t <= t1 {
        if let Some(g) = ground_at(labels, t - 0.5 * WINDOW_S) {
            let truth = classes.iter().position(|c| c == g).unwrap_or(0);
            let p = match reading {
                Reading::Confident(c) if truth == misread => frame(k, as_, c, None),
                Reading::Stretches(c) if truth == misread && (t / STRETCH_S) as u64 % 2 == 1 => {
                    frame(k, as_, c, None)
                }
                Reading::Unsure if truth == misread => frame(k, as_, 0.45, Some((misread, 0.35))),
                _ => frame(k, truth, RIGHT_CONFIDENCE, None),
            };
            frames.push((t, p));
        }
        t += HOP_S;
    }
    Some(TerrainTimeline {
        classes,
        frames,
        ..Default::default()
    })
}

/// What the estimator is given from the classifier: the same rule as
/// `estimate --terrain-model` (unknown verdicts dropped, the rest floored,
/// each stamped at the middle of its window).
pub fn evidence(tl: TerrainTimeline) -> TerrainEvidence {
    TerrainEvidence::from(
        tl.sure_evidence(BeliefSettings::default().prob_floor)
            .stamped_at_window_middle(WINDOW_S),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn labels() -> Vec<TerrainLabel> {
        [(0.0, "sand"), (60.0, "grass"), (120.0, "sand")]
            .iter()
            .map(|(t, n)| TerrainLabel {
                t: *t,
                terrain: n.to_string(),
            })
            .collect()
    }

    #[test]
    fn the_first_ground_is_read_as_the_second() {
        let tl = timeline(&labels(), 0.0, 180.0, Reading::Confident(0.9)).unwrap();
        assert_eq!(tl.classes, ["sand", "grass"]);
        let at = |t: f64| &tl.frames.iter().find(|f| (f.0 - t).abs() < 1e-9).unwrap().1;
        assert!((at(30.0)[1] - 0.9).abs() < 1e-12);
        assert!((at(90.0)[1] - 0.9).abs() < 1e-12);
        // The window's middle decides: 3 s after the change, still sand.
        assert!((at(62.0)[1] - 0.9).abs() < 1e-12);
        let right = timeline(&labels(), 0.0, 180.0, Reading::Right).unwrap();
        let r = &right.frames[0].1;
        assert!((r[0] - 0.9).abs() < 1e-12 && (r.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn an_unsure_misread_is_no_evidence() {
        let tl = timeline(&labels(), 0.0, 180.0, Reading::Unsure).unwrap();
        let n = tl.frames.len();
        let TerrainEvidence::Likelihoods { frames, .. } = evidence(tl) else {
            panic!("likelihoods");
        };
        // Only the grass frames are left, each stamped at the middle of
        // its window: the grass itself (60-120 s), not 3 s late.
        assert!(frames.len() < n / 2, "{} of {n}", frames.len());
        assert!(frames
            .iter()
            .all(|(t, p)| *t >= 60.0 && *t < 120.0 && p[1] > p[0]));
    }
}
