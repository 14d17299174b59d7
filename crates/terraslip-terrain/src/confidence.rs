//! How far a verdict can be trusted: the confidence below which the
//! answer is "unknown", the distance of a window from the training windows
//! of the terrain it is read as (novelty), and the scores that measure
//! both: expected calibration error, risk–coverage and the AUROC of
//! "window misread".

use serde::{Deserialize, Serialize};

/// Bins of the expected calibration error.
pub const ECE_BINS: usize = 15;

/// Confidence (largest class probability) below which a verdict is
/// "unknown": the model gives the other terrains together at least as much
/// as the one it reads. A constant, not fitted on the runs: the model's
/// own probabilities are calibrated on windows of runs it never saw
/// (expected calibration error 0.047 over BorealTC's outer folds, where
/// 2.8 % of the windows are unknown and 64 % of those right, against 94.8 %
/// of the others).
pub const UNKNOWN_BELOW: f64 = 0.5;

/// Confidence below which a verdict is no evidence for the estimator
/// ([`crate::TerrainTimeline::sure_evidence`]). Stricter than
/// [`UNKNOWN_BELOW`]: the windows of a run overlap and share its driving,
/// so the terrain belief takes a run of verdicts at 0.55-0.6 (wrong four
/// times in ten) as if each were independent, grows sure, and the
/// estimator recalls the wrong ground's slip for the whole run. Chosen on
/// the BorealTC runs' outer folds (each run classified by a model trained
/// without it) among 0.5, 0.6, 0.7, 0.75, 0.8 and 0.85: the worst run's
/// time on a wrong terrain 93 %, 91 %, 66 %, 34 %, 31 % and 30 %
/// (docs/figures/terrain.md). 0.9, tuned on half the runs and the
/// simulated worlds of seeds 1-50 (`terraslip-lab terrain-trust`), lost
/// there on the worlds whose classifier misreads a ground half the time.
pub const EVIDENCE_BELOW: f64 = 0.8;

/// Whether a probability vector is an "unknown" verdict (its confidence
/// below [`UNKNOWN_BELOW`]).
pub fn is_unknown(p: &[f64]) -> bool {
    confidence(p) < UNKNOWN_BELOW
}

/// The largest class probability (0 for an empty vector).
pub fn confidence(p: &[f64]) -> f64 {
    p.iter().copied().fold(0.0, f64::max)
}

/// Per window: confidence and whether the argmax is the truth.
pub fn confidence_and_correct(probs: &[Vec<f64>], truth: &[usize]) -> (Vec<f64>, Vec<bool>) {
    probs
        .iter()
        .zip(truth)
        .map(|(p, &t)| (confidence(p), crate::classify::argmax(p) == t))
        .unzip()
}

/// Expected calibration error: windows binned by confidence into `bins`
/// equal bins of [0, 1]; the mean over windows of |accuracy − mean
/// confidence| of their bin. 0 without windows.
pub fn ece(conf: &[f64], correct: &[bool], bins: usize) -> f64 {
    let bins = bins.max(1);
    let mut n = vec![0.0; bins];
    let mut c = vec![0.0; bins];
    let mut a = vec![0.0; bins];
    for (&p, &ok) in conf.iter().zip(correct) {
        let b = ((p.clamp(0.0, 1.0) * bins as f64) as usize).min(bins - 1);
        n[b] += 1.0;
        c[b] += p;
        a[b] += f64::from(u8::from(ok));
    }
    let total: f64 = n.iter().sum();
    if total == 0.0 {
        return 0.0;
    }
    (0..bins)
        .filter(|&b| n[b] > 0.0)
        .map(|b| (a[b] - c[b]).abs())
        .sum::<f64>()
        / total
}

/// Windows sorted by confidence, most confident first (ties by index).
fn by_confidence(conf: &[f64]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..conf.len()).collect();
    order.sort_by(|&i, &j| conf[j].total_cmp(&conf[i]).then(i.cmp(&j)));
    order
}

/// Accuracy of the `coverage` share (0..1) of the most confident windows
/// (at least one window); `None` without windows.
pub fn accuracy_at_coverage(conf: &[f64], correct: &[bool], coverage: f64) -> Option<f64> {
    if conf.is_empty() {
        return None;
    }
    let order = by_confidence(conf);
    let keep = ((coverage.clamp(0.0, 1.0) * conf.len() as f64).round() as usize).max(1);
    let ok = order[..keep].iter().filter(|&&i| correct[i]).count();
    Some(ok as f64 / keep as f64)
}

/// Risk–coverage curve: `(coverage, accuracy of the kept windows)` at
/// coverage 0.1, 0.2, ..., 1.0 (most confident windows kept first).
pub fn risk_coverage(conf: &[f64], correct: &[bool]) -> Vec<(f64, f64)> {
    (1..=10)
        .filter_map(|k| {
            let c = k as f64 / 10.0;
            accuracy_at_coverage(conf, correct, c).map(|a| (c, a))
        })
        .collect()
}

/// Area under the ROC curve of `score` separating the `positive` windows
/// (e.g. misread) from the others: the probability that a positive scores
/// higher than a negative, ties counting half. `None` when either class is
/// empty.
pub fn auroc(score: &[f64], positive: &[bool]) -> Option<f64> {
    let r = ranks(score);
    let n_pos = positive.iter().filter(|p| **p).count() as f64;
    let rank_sum: f64 = r
        .iter()
        .zip(positive)
        .filter(|(_, p)| **p)
        .map(|(r, _)| r)
        .sum();
    let n_neg = score.len() as f64 - n_pos;
    (n_pos > 0.0 && n_neg > 0.0).then(|| (rank_sum - n_pos * (n_pos + 1.0) / 2.0) / (n_pos * n_neg))
}

/// Distance of a window from the training windows of each terrain, in
/// standardised feature space: per class a diagonal Gaussian (mean and
/// spread of the training windows); the novelty of a window read as class
/// c is its root mean squared z-score against c.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClassDistance {
    /// Per class, per feature: mean of the standardised training windows.
    pub mean: Vec<Vec<f64>>,
    /// Per class, per feature: their standard deviation (at least 1e-3).
    pub std: Vec<Vec<f64>>,
}

impl ClassDistance {
    /// Fits on standardised rows `x` of classes `y` (`k` classes).
    pub fn fit(x: &[Vec<f64>], y: &[usize], k: usize) -> Self {
        let d = x.first().map_or(0, |r| r.len());
        let mut n = vec![0.0; k];
        let mut mean = vec![vec![0.0; d]; k];
        let mut sq = vec![vec![0.0; d]; k];
        for (r, &c) in x.iter().zip(y) {
            n[c] += 1.0;
            for (j, v) in r.iter().enumerate() {
                mean[c][j] += v;
                sq[c][j] += v * v;
            }
        }
        let mut std = vec![vec![1.0; d]; k];
        for c in 0..k {
            let nc = f64::max(n[c], 1.0);
            for j in 0..d {
                mean[c][j] /= nc;
                let var = sq[c][j] / nc - mean[c][j] * mean[c][j];
                std[c][j] = var.max(0.0).sqrt().max(1e-3);
            }
        }
        Self { mean, std }
    }

    /// Root mean squared z-score of standardised row `x` against class `c`
    /// (non-finite features skipped; 0 for an unknown class).
    pub fn novelty(&self, x: &[f64], c: usize) -> f64 {
        let (Some(m), Some(s)) = (self.mean.get(c), self.std.get(c)) else {
            return 0.0;
        };
        let (mut sum, mut n) = (0.0, 0usize);
        for ((v, m), s) in x.iter().zip(m).zip(s) {
            if v.is_finite() {
                let z = (v - m) / s;
                sum += z * z;
                n += 1;
            }
        }
        (sum / n.max(1) as f64).sqrt()
    }

    pub(crate) fn check(&self, k: usize, d: usize) -> Result<(), String> {
        let ok = |v: &Vec<Vec<f64>>| {
            v.len() == k
                && v.iter()
                    .all(|r| r.len() == d && r.iter().all(|x| x.is_finite()))
        };
        if !(ok(&self.mean) && ok(&self.std) && self.std.iter().flatten().all(|s| *s > 0.0)) {
            return Err("class distance does not match the classes or features".into());
        }
        Ok(())
    }
}

/// One scored window: its classifier output and what is known about it.
#[derive(Debug, Clone, PartialEq)]
pub struct ScoredWindow {
    /// End of the window (or frame time), s.
    pub t: f64,
    /// True and predicted (argmax) class.
    pub truth: usize,
    pub predicted: usize,
    /// Largest class probability.
    pub confidence: f64,
    /// Whether the argmax is the true class.
    pub correct: bool,
    /// Whether the verdict is "unknown" ([`UNKNOWN_BELOW`]).
    pub unknown: bool,
    /// Driven outside the envelope of the terrain it is read as (`None`:
    /// the model has no envelope).
    pub outside_envelope: Option<bool>,
    /// Distance from the training windows of that terrain (`None`: none).
    pub novelty: Option<f64>,
}

/// How far a model's confidence can be trusted, over scored windows.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ConfidenceScore {
    pub windows: usize,
    /// Expected calibration error, [`ECE_BINS`] bins.
    pub ece: f64,
    /// Accuracy of the 80 % most confident windows.
    pub accuracy_at_80: Option<f64>,
    /// `(coverage, accuracy)` keeping the most confident first.
    pub risk_coverage: Vec<(f64, f64)>,
    /// Share of windows answered "unknown".
    pub unknown_share: f64,
    /// Accuracy of the windows not answered "unknown".
    pub accuracy_answered: Option<f64>,
    /// AUROC of "window misread" for 1 − confidence, the envelope flag,
    /// the novelty, and the mean of the ranks of 1 − confidence and
    /// novelty (no parameter fitted).
    pub auroc_confidence: Option<f64>,
    pub auroc_envelope: Option<f64>,
    pub auroc_novelty: Option<f64>,
    pub auroc_confidence_and_novelty: Option<f64>,
}

impl ConfidenceScore {
    pub fn of(w: &[ScoredWindow]) -> Self {
        let conf: Vec<f64> = w.iter().map(|w| w.confidence).collect();
        let ok: Vec<bool> = w.iter().map(|w| w.correct).collect();
        let wrong: Vec<bool> = ok.iter().map(|o| !o).collect();
        let unsure: Vec<f64> = conf.iter().map(|c| 1.0 - c).collect();
        let answered: Vec<&ScoredWindow> = w.iter().filter(|w| !w.unknown).collect();
        let env: Option<Vec<f64>> = w
            .iter()
            .map(|w| w.outside_envelope.map(|o| f64::from(u8::from(o))))
            .collect();
        let nov: Option<Vec<f64>> = w.iter().map(|w| w.novelty).collect();
        let both = nov.as_ref().map(|n| {
            let (a, b) = (ranks(&unsure), ranks(n));
            a.iter().zip(&b).map(|(x, y)| x + y).collect::<Vec<f64>>()
        });
        Self {
            windows: w.len(),
            ece: ece(&conf, &ok, ECE_BINS),
            accuracy_at_80: accuracy_at_coverage(&conf, &ok, 0.8),
            risk_coverage: risk_coverage(&conf, &ok),
            unknown_share: (w.len() - answered.len()) as f64 / w.len().max(1) as f64,
            accuracy_answered: (!answered.is_empty()).then(|| {
                answered.iter().filter(|w| w.correct).count() as f64 / answered.len() as f64
            }),
            auroc_confidence: auroc(&unsure, &wrong),
            auroc_envelope: env.and_then(|e| auroc(&e, &wrong)),
            auroc_novelty: nov.and_then(|n| auroc(&n, &wrong)),
            auroc_confidence_and_novelty: both.and_then(|b| auroc(&b, &wrong)),
        }
    }

    /// The figures as text, one line each.
    pub fn to_text(&self) -> String {
        let pct = |v: Option<f64>| v.map_or_else(|| "-".into(), |v| format!("{:.1} %", 100.0 * v));
        let num = |v: Option<f64>| v.map_or_else(|| "-".into(), |v| format!("{v:.3}"));
        let curve: Vec<String> = self
            .risk_coverage
            .iter()
            .map(|(c, a)| format!("{:.0}%:{:.1}", 100.0 * c, 100.0 * a))
            .collect();
        format!(
            "confidence: expected calibration error {:.3} ({ECE_BINS} bins); accuracy of the 80 % most \
             confident windows {}\nrisk-coverage (windows kept: accuracy %): {}\n\
             unknown: {:.1} % of the windows; accuracy of the others {}\n\
             AUROC of a misread window: 1 - confidence {}, envelope {}, novelty {}, both ranks {}\n",
            self.ece,
            pct(self.accuracy_at_80),
            curve.join(" "),
            100.0 * self.unknown_share,
            pct(self.accuracy_answered),
            num(self.auroc_confidence),
            num(self.auroc_envelope),
            num(self.auroc_novelty),
            num(self.auroc_confidence_and_novelty),
        )
    }
}

/// Mid-ranks of `v` (1-based, ties share their mean rank).
fn ranks(v: &[f64]) -> Vec<f64> {
    let mut idx: Vec<usize> = (0..v.len()).collect();
    idx.sort_by(|&i, &j| v[i].total_cmp(&v[j]));
    let mut r = vec![0.0; v.len()];
    let mut k = 0;
    while k < idx.len() {
        let mut e = k;
        while e + 1 < idx.len() && v[idx[e + 1]] == v[idx[k]] {
            e += 1;
        }
        for &i in &idx[k..=e] {
            r[i] = 0.5 * ((k + 1) + (e + 1)) as f64;
        }
        k = e + 1;
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ece_of_a_known_case() {
        // 10 windows at confidence 0.9, 6 right: bin gap 0.3, weight 1 → 0.3.
        let conf = vec![0.9; 10];
        let ok: Vec<bool> = (0..10).map(|i| i < 6).collect();
        assert!((ece(&conf, &ok, 15) - 0.3).abs() < 1e-12);
        // Two bins: 4 at 0.95 all right (gap 0.05), 4 at 0.55 half right
        // (gap 0.05) → 0.05.
        let conf = [0.95, 0.95, 0.95, 0.95, 0.55, 0.55, 0.55, 0.55];
        let ok = [true, true, true, true, true, true, false, false];
        assert!((ece(&conf, &ok, 15) - 0.05).abs() < 1e-12);
    }

    #[test]
    fn auroc_of_known_orders() {
        assert_eq!(
            auroc(&[0.1, 0.2, 0.8, 0.9], &[false, false, true, true]),
            Some(1.0)
        );
        assert_eq!(
            auroc(&[0.9, 0.8, 0.2, 0.1], &[false, false, true, true]),
            Some(0.0)
        );
        assert_eq!(auroc(&[0.5, 0.5], &[false, true]), Some(0.5));
        assert_eq!(auroc(&[0.5, 0.5], &[true, true]), None);
    }

    #[test]
    fn coverage_keeps_the_most_confident() {
        let conf = [0.99, 0.9, 0.8, 0.6, 0.5];
        let ok = [true, true, true, false, false];
        assert_eq!(accuracy_at_coverage(&conf, &ok, 0.6), Some(1.0));
        assert_eq!(accuracy_at_coverage(&conf, &ok, 1.0), Some(0.6));
        let rc = risk_coverage(&conf, &ok);
        assert_eq!(rc.len(), 10);
        assert_eq!(rc[9], (1.0, 0.6));
    }

    #[test]
    fn novelty_grows_away_from_the_class() {
        let x = vec![
            vec![0.0, 0.0],
            vec![1.0, 1.0],
            vec![5.0, 5.0],
            vec![6.0, 6.0],
        ];
        let d = ClassDistance::fit(&x, &[0, 0, 1, 1], 2);
        assert!(d.novelty(&[0.5, 0.5], 0) < 0.1);
        assert!(d.novelty(&[5.5, 5.5], 0) > 5.0);
        assert!(d.check(2, 2).is_ok());
    }
}
