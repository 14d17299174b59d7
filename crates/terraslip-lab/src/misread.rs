//! A simulated terrain classifier with a set confusion: what a vibration
//! model would hand the estimator on a simulated world, right on every
//! ground but one, which it reads as another ground (as sure as the
//! BorealTC model's misreads, or unsure of it).

use terraslip::pipeline::TerrainEvidence;
use terraslip_io::TerrainLabel;
use terraslip_terrain::{BeliefSettings, TerrainTimeline};

use crate::verdict_confidence::Sureness;

/// Seconds between frames (a vibration model's hop).
pub const HOP_S: f64 = 0.5;
/// Length of a classified window, s: a frame at `t` reads the ground at
/// `t − WINDOW_S / 2` (the middle of its window).
pub const WINDOW_S: f64 = 6.0;
/// Length of a stretch of [`Reading::Stretches`], s.
pub const STRETCH_S: f64 = 30.0;
/// Confidence of a right verdict of the [`Confidences::Fixed`] classifier.
pub const RIGHT_CONFIDENCE: f64 = 0.9;
/// Share of a misread verdict's remaining probability the ground's own
/// terrain takes ([`Confidences::Measured`]: it is read second).
const TRUTH_OF_REST: f64 = 0.7;

/// How the classifier reads the misread ground (the world's first).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Reading {
    /// Every ground read right.
    Right,
    /// Read as the next ground the robot drives on.
    Always,
    /// The same, in every other [`STRETCH_S`] of the log's time (right
    /// in between): a ground read partly as another, so the estimator
    /// recalls the other ground's set on it.
    Stretches,
    /// Read as that ground with 0.45, itself with 0.35 (0.55 on a world of
    /// two grounds): the verdict is "unknown" (below 0.5) or unsure, no
    /// evidence either way.
    Unsure,
    /// [`Reading::Stretches`] with each misread "unknown" as in
    /// [`Reading::Unsure`]: the estimator hears nothing of the ground in
    /// its wrong stretches. What trusting only sure verdicts can give at
    /// best when a ground is misread part of the time.
    UnsureStretches,
}

/// How sure the classifier is of its verdicts (right or misread).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Confidences {
    /// As sure as the BorealTC model was on runs it never saw
    /// ([`crate::verdict_confidence`]), drawn per world.
    Measured,
    /// Misreads at this confidence, right verdicts at [`RIGHT_CONFIDENCE`].
    Fixed(f64),
}

impl Reading {
    pub fn name(&self, c: Confidences) -> String {
        let at = match c {
            Confidences::Measured => String::new(),
            Confidences::Fixed(c) => format!(" at {c:.2}"),
        };
        match self {
            Reading::Right => "model, right".into(),
            Reading::Always => format!("model, misread{at}"),
            Reading::Stretches => format!("model, misread{at} half the time"),
            Reading::Unsure => "model, misread unsure".into(),
            Reading::UnsureStretches => "model, misread unsure half the time".into(),
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
/// shared by the other classes (`second` with `second_p` first, when set;
/// all of it when there is no other class).
fn frame(k: usize, read: usize, confidence: f64, second: Option<(usize, f64)>) -> Vec<f64> {
    let mut p = vec![0.0; k];
    p[read] = confidence;
    let mut rest = 1.0 - confidence;
    let second = second.filter(|(s, _)| *s != read);
    if let Some((s, q)) = second {
        p[s] = q;
        rest -= q;
    }
    let others = p.iter().filter(|v| **v == 0.0).count();
    if let Some((s, _)) = second.filter(|_| others == 0) {
        // No third class to take the rest: the second takes it.
        p[s] += rest;
    }
    for v in p.iter_mut().filter(|v| **v == 0.0) {
        *v = rest / others.max(1) as f64;
    }
    p
}

/// The classifier's frames over `[t0, t1]` for a world whose ground
/// changes as `labels` say (`seed` draws the measured confidences).
/// `None` when the world has one ground.
pub fn timeline(
    labels: &[TerrainLabel],
    t0: f64,
    t1: f64,
    reading: Reading,
    confidences: Confidences,
    seed: u64,
) -> Option<TerrainTimeline> {
    let classes = grounds(labels);
    if classes.len() < 2 {
        return None;
    }
    let k = classes.len();
    let (misread, as_) = (0, 1);
    let mut frames = Vec::new();
    let mut sureness = Sureness::new(seed);
    let mut t = t0 + WINDOW_S;
    while t <= t1 {
        if let Some(g) = ground_at(labels, t - 0.5 * WINDOW_S) {
            let truth = classes.iter().position(|c| c == g).unwrap_or(0);
            let wrong = truth == misread
                && match reading {
                    Reading::Right => false,
                    Reading::Always | Reading::Unsure => true,
                    Reading::Stretches | Reading::UnsureStretches => {
                        (t / STRETCH_S) as u64 % 2 == 1
                    }
                };
            let p = match (reading, confidences) {
                (Reading::Unsure | Reading::UnsureStretches, _) if wrong => {
                    frame(k, as_, 0.45, Some((misread, 0.35)))
                }
                (_, Confidences::Fixed(c)) if wrong => frame(k, as_, c, None),
                (_, Confidences::Fixed(_)) => frame(k, truth, RIGHT_CONFIDENCE, None),
                (_, Confidences::Measured) if wrong => {
                    let c = sureness.next(false);
                    frame(k, as_, c, Some((truth, TRUTH_OF_REST * (1.0 - c))))
                }
                (_, Confidences::Measured) => frame(k, truth, sureness.next(true), None),
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
/// `estimate --terrain-model` (verdicts less sure than the evidence floor
/// dropped, the rest floored, each stamped at the middle of its window);
/// verdicts less sure than `min_confidence` are dropped too.
pub fn evidence(mut tl: TerrainTimeline, min_confidence: f64) -> TerrainEvidence {
    tl.frames
        .retain(|(_, p)| terraslip_terrain::confidence::confidence(p) >= min_confidence);
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
        let fixed = Confidences::Fixed(0.9);
        let tl = timeline(&labels(), 0.0, 180.0, Reading::Always, fixed, 1).unwrap();
        assert_eq!(tl.classes, ["sand", "grass"]);
        let at = |t: f64| &tl.frames.iter().find(|f| (f.0 - t).abs() < 1e-9).unwrap().1;
        assert!((at(30.0)[1] - 0.9).abs() < 1e-12);
        assert!((at(90.0)[1] - 0.9).abs() < 1e-12);
        // The window's middle decides: 3 s after the change, still sand.
        assert!((at(62.0)[1] - 0.9).abs() < 1e-12);
        let right = timeline(&labels(), 0.0, 180.0, Reading::Right, fixed, 1).unwrap();
        let r = &right.frames[0].1;
        assert!((r[0] - 0.9).abs() < 1e-12 && (r.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn measured_misreads_are_less_sure_than_right_verdicts() {
        // As on BorealTC: most misreads fall below the evidence floor,
        // most right verdicts stay evidence.
        let tl = timeline(
            &labels(),
            0.0,
            600.0,
            Reading::Always,
            Confidences::Measured,
            5,
        );
        let tl = tl.unwrap();
        let conf = |p: &Vec<f64>| p.iter().copied().fold(0.0, f64::max);
        let (mut wrong, mut right) = (Vec::new(), Vec::new());
        for (t, p) in &tl.frames {
            // sand (0) is read as grass (1) before 60 s and after 120 s.
            let misread = !(60.0..120.0).contains(&(t - 0.5 * WINDOW_S));
            assert!(p[1] > p[0], "t {t}");
            if misread { &mut wrong } else { &mut right }.push(conf(p));
        }
        let sure = |v: &[f64]| v.iter().filter(|c| **c >= 0.8).count() as f64 / v.len() as f64;
        assert!(sure(&wrong) < 0.6, "{}", sure(&wrong));
        assert!(sure(&right) > 0.7, "{}", sure(&right));
        assert!(tl
            .frames
            .iter()
            .all(|(_, p)| (p.iter().sum::<f64>() - 1.0).abs() < 1e-9));
    }

    #[test]
    fn an_unsure_misread_is_no_evidence() {
        let tl = timeline(
            &labels(),
            0.0,
            180.0,
            Reading::Unsure,
            Confidences::Measured,
            1,
        )
        .unwrap();
        let n = tl.frames.len();
        let TerrainEvidence::Likelihoods { frames, .. } = evidence(tl, 0.0) else {
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
