//! Class probabilities over time and their smoothing: the frames a model
//! outputs for a log, the Bayesian (HMM) filter and λ-vote over them
//! (wang2018), and the settings of that filter.

use serde::{Deserialize, Serialize};
use terraslip_core::terrain_belief::{BeliefConfig, TerrainBelief};

use crate::classify::argmax;
use crate::confidence::{confidence, ScoredWindow, EVIDENCE_BELOW, UNKNOWN_BELOW};

/// How classifier outputs are smoothed (wang2018's Bayesian filter + λ-vote).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BeliefSettings {
    pub stay_prob: f64,
    pub stay_prob_on_jump: f64,
    pub vote_lambda: u32,
    /// Class probabilities are mixed with this share of a uniform
    /// distribution before the Bayes update, so that one confident
    /// mistake cannot zero out the true terrain.
    pub prob_floor: f64,
}

impl Default for BeliefSettings {
    fn default() -> Self {
        let b = BeliefConfig::default();
        Self {
            stay_prob: b.stay_prob,
            stay_prob_on_jump: b.stay_prob_on_jump,
            vote_lambda: b.vote_lambda,
            prob_floor: 0.1,
        }
    }
}

impl BeliefSettings {
    pub fn belief_config(&self) -> BeliefConfig {
        BeliefConfig {
            stay_prob: self.stay_prob,
            stay_prob_on_jump: self.stay_prob_on_jump,
            vote_lambda: self.vote_lambda,
        }
    }
}

/// Class probabilities over time, causal: frame `t` uses data up to `t` only.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TerrainTimeline {
    pub classes: Vec<String>,
    /// `(t, probabilities)`: `t` in s (end of the window, or frame time).
    pub frames: Vec<(f64, Vec<f64>)>,
    /// Times (s) at which the camera change detector fired (lv2019); empty for IMU models.
    pub changes: Vec<f64>,
    /// Per frame: driven outside the model's envelope for the terrain it
    /// is read as (its probabilities were mixed with a uniform
    /// distribution). Empty when the model has no envelope.
    pub outside_envelope: Vec<bool>,
    /// Per frame: distance from the training windows of the terrain it is
    /// read as ([`crate::confidence::ClassDistance::novelty`]). Empty when the model has none.
    pub novelty: Vec<f64>,
}

/// One frame after the Bayesian filter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FilteredFrame {
    pub t: f64,
    /// argmax of the classifier output.
    pub raw: usize,
    /// argmax of the filtered belief.
    pub filtered: usize,
    /// Terrain declared by the λ-vote (what the noise schedule would use).
    pub voted: Option<usize>,
}

impl TerrainTimeline {
    /// Share of frames outside the model's envelope, 0..1; `None` when
    /// the model has no envelope or there are no frames.
    pub fn outside_envelope_share(&self) -> Option<f64> {
        let n = self.outside_envelope.len();
        (n > 0).then(|| self.outside_envelope.iter().filter(|&&o| o).count() as f64 / n as f64)
    }

    /// The frames with a true class (`truth[i]`, `None`: unlabelled,
    /// skipped) as [`ScoredWindow`]s: confidence, right or wrong,
    /// "unknown", envelope and novelty.
    pub fn scored_windows(&self, truth: &[Option<usize>]) -> Vec<ScoredWindow> {
        self.frames
            .iter()
            .zip(truth)
            .enumerate()
            .filter_map(|(i, ((time, p), t))| {
                let truth = (*t)?;
                let confidence = confidence(p);
                Some(ScoredWindow {
                    t: *time,
                    truth,
                    predicted: argmax(p),
                    confidence,
                    correct: argmax(p) == truth,
                    unknown: confidence < UNKNOWN_BELOW,
                    outside_envelope: self.outside_envelope.get(i).copied(),
                    novelty: self.novelty.get(i).copied(),
                })
            })
            .collect()
    }

    /// The frames with each probability vector mixed with `floor` of a
    /// uniform distribution (see [`BeliefSettings::prob_floor`]): what to
    /// feed `TerrainBelief::update` so one confident mistake cannot zero
    /// out the true terrain.
    pub fn floored(&self, floor: f64) -> Vec<(f64, Vec<f64>)> {
        let floor = if floor.is_finite() {
            floor.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let k = self.classes.len().max(1) as f64;
        self.frames
            .iter()
            .map(|(t, p)| {
                (
                    *t,
                    p.iter().map(|v| (1.0 - floor) * v + floor / k).collect(),
                )
            })
            .collect()
    }

    /// The frames stamped at the middle of their window instead of its
    /// end (`span`, s: the window's length; 0 for camera frames): the time
    /// whose ground a verdict reads. A window's verdict is the ground under
    /// most of it, so a new ground is read once the window's middle has
    /// crossed onto it; stamped at its end, the verdict comes `span / 2`
    /// after the ground changed. Camera change detections stay at their
    /// frames' times.
    pub fn stamped_at_window_middle(mut self, span: f64) -> Self {
        let half = if span.is_finite() {
            0.5 * span.max(0.0)
        } else {
            0.0
        };
        for (t, _) in &mut self.frames {
            *t -= half;
        }
        self
    }

    /// What a belief may fuse: the frames whose verdict is sure
    /// (confidence at least [`crate::confidence::EVIDENCE_BELOW`]: an
    /// unsure terrain is no evidence, the belief keeps what it had), each
    /// floored by `floor` ([`Self::floored`]).
    pub fn sure_evidence(mut self, floor: f64) -> Self {
        let keep: Vec<bool> = self
            .frames
            .iter()
            .map(|(_, p)| confidence(p) >= EVIDENCE_BELOW)
            .collect();
        self.frames = self.floored(floor);
        self.retain_frames(&keep);
        self
    }

    /// Runs the HMM filter and λ-vote over the frames. A camera change
    /// detection counts as an innovation jump (lower stay probability).
    pub fn filter(&self, settings: &BeliefSettings) -> Vec<FilteredFrame> {
        let k = self.classes.len();
        let mut belief = TerrainBelief::new(k, settings.belief_config());
        let mut next_change = 0;
        self.floored(settings.prob_floor)
            .iter()
            .zip(&self.frames)
            .map(|((t, lik), (_, p))| {
                let mut jump = false;
                while next_change < self.changes.len() && self.changes[next_change] <= *t {
                    jump = true;
                    next_change += 1;
                }
                belief.update(lik, jump);
                FilteredFrame {
                    t: *t,
                    raw: argmax(p),
                    filtered: belief.most_likely(),
                    voted: belief.current(),
                }
            })
            .collect()
    }
    /// Keeps the frames whose `keep` is true, with their envelope and
    /// novelty columns (each kept whole when empty: optional per frame).
    pub(crate) fn retain_frames(&mut self, keep: &[bool]) {
        retain_by(&mut self.frames, keep);
        retain_by(&mut self.outside_envelope, keep);
        retain_by(&mut self.novelty, keep);
    }
}

/// Keeps the items of `v` whose `keep` is true (all when `v` is empty:
/// an optional per-frame column).
fn retain_by<T>(v: &mut Vec<T>, keep: &[bool]) {
    let mut k = keep.iter();
    v.retain(|_| k.next().copied().unwrap_or(false));
}
