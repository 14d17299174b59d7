//! Classifiers over feature vectors: the paper's pruned decision tree
//! (wang2018 §3.2.2, [`crate::tree`]), k-nearest neighbours on standardised
//! features (chen2023 §3.2.3), and gradient-boosted trees ([`crate::boost`],
//! the default). All output class probabilities.

use serde::{Deserialize, Serialize};

pub use crate::boost::{BoostParams, BoostedTrees};
use crate::error::{Result, TerrainError};
pub use crate::tree::{Criterion, DecisionTree, Node, TreeParams};

/// Feature scaling to zero mean, unit variance, learnt on training data.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Standardizer {
    pub mean: Vec<f64>,
    pub std: Vec<f64>,
}

impl Standardizer {
    /// Learns per-feature mean and standard deviation (constant features
    /// get std 1 so they pass through centred).
    pub fn fit(x: &[Vec<f64>]) -> Self {
        let d = x.first().map_or(0, |r| r.len());
        let n = x.len().max(1) as f64;
        let mut mean = vec![0.0; d];
        for r in x {
            for (m, v) in mean.iter_mut().zip(r) {
                *m += v / n;
            }
        }
        let mut var = vec![0.0; d];
        for r in x {
            for ((s, v), m) in var.iter_mut().zip(r).zip(&mean) {
                *s += (v - m) * (v - m) / n;
            }
        }
        let std = var
            .into_iter()
            .map(|v| if v.sqrt() > 1e-12 { v.sqrt() } else { 1.0 })
            .collect();
        Self { mean, std }
    }

    pub fn apply(&self, row: &[f64]) -> Vec<f64> {
        row.iter()
            .zip(self.mean.iter().zip(&self.std))
            .map(|(v, (m, s))| (v - m) / s)
            .collect()
    }
}

/// k-nearest neighbours (Euclidean, on standardised features).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Knn {
    pub k: usize,
    pub x: Vec<Vec<f64>>,
    pub y: Vec<usize>,
}

impl Knn {
    fn proba(&self, q: &[f64], out: &mut [f64]) {
        let mut d: Vec<(f64, usize)> = self
            .x
            .iter()
            .zip(&self.y)
            .map(|(r, &c)| {
                (
                    r.iter().zip(q).map(|(a, b)| (a - b) * (a - b)).sum::<f64>(),
                    c,
                )
            })
            .collect();
        let k = self.k.clamp(1, d.len().max(1));
        if d.len() > k {
            d.select_nth_unstable_by(k - 1, |a, b| a.0.total_cmp(&b.0));
        }
        // chen2023's discriminant: the share of the k neighbours in each class.
        for &(_, c) in d.iter().take(k) {
            if let Some(o) = out.get_mut(c) {
                *o += 1.0 / k as f64;
            }
        }
    }
}

/// Which classifier to train.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ClassifierKind {
    /// wang2018's entropy tree with cost-complexity pruning.
    Tree,
    /// chen2023's k-nearest neighbours.
    Knn,
    /// Gradient-boosted trees (softmax loss).
    Boost,
}

/// Training settings for every kind.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClassifierParams {
    pub kind: ClassifierKind,
    pub tree: TreeParams,
    pub knn_k: usize,
    pub boost: BoostParams,
}

impl Default for ClassifierParams {
    fn default() -> Self {
        Self {
            kind: ClassifierKind::Boost,
            tree: TreeParams::default(),
            knn_k: 5,
            boost: BoostParams::default(),
        }
    }
}

/// A trained classifier.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Classifier {
    Tree(DecisionTree),
    Knn(Knn),
    Boost(BoostedTrees),
}

/// Fewest training samples a class must have.
pub const MIN_SAMPLES_PER_CLASS: usize = 3;

impl Classifier {
    /// Trains on standardised rows `x`, labels `y` in `0..k`.
    pub fn fit(x: &[Vec<f64>], y: &[usize], k: usize, p: &ClassifierParams) -> Result<Self> {
        check_training_set(x, y, k)?;
        Ok(match p.kind {
            ClassifierKind::Tree => Self::Tree(DecisionTree::fit(x, y, k, &p.tree, 1)),
            ClassifierKind::Knn => {
                if p.knn_k == 0 {
                    return Err(TerrainError::Config("knn k must be at least 1".into()));
                }
                Self::Knn(Knn {
                    k: p.knn_k,
                    x: x.to_vec(),
                    y: y.to_vec(),
                })
            }
            ClassifierKind::Boost => {
                let b = &p.boost;
                if b.rounds == 0
                    || !(b.learning_rate > 0.0 && b.learning_rate.is_finite())
                    || !(b.subsample > 0.0 && b.subsample <= 1.0)
                    || !(b.colsample > 0.0 && b.colsample <= 1.0)
                    || !(b.lambda >= 0.0 && b.lambda.is_finite())
                {
                    return Err(TerrainError::Config(format!(
                        "boosted trees need rounds >= 1, learning rate > 0, \
                         subsample and colsample in (0, 1], lambda >= 0; got {b:?}"
                    )));
                }
                Self::Boost(BoostedTrees::fit(x, y, k, b))
            }
        })
    }

    /// Class probabilities of one standardised row, written to `out` (length k).
    pub fn predict_proba(&self, x: &[f64], out: &mut [f64]) {
        out.iter_mut().for_each(|o| *o = 0.0);
        match self {
            Self::Tree(t) => {
                if let Some(leaf) = t.leaf(x) {
                    for (o, p) in out.iter_mut().zip(&leaf.probs) {
                        *o = *p;
                    }
                }
            }
            Self::Knn(knn) => knn.proba(x, out),
            Self::Boost(b) => b.proba(x, out),
        }
    }
}

fn check_training_set(x: &[Vec<f64>], y: &[usize], k: usize) -> Result<()> {
    if x.len() != y.len() {
        return Err(TerrainError::Training(format!(
            "{} rows but {} labels",
            x.len(),
            y.len()
        )));
    }
    let d = x.first().map_or(0, |r| r.len());
    if d == 0 || x.iter().any(|r| r.len() != d) {
        return Err(TerrainError::Training(
            "feature rows are empty or of unequal length".into(),
        ));
    }
    if x.iter().flatten().any(|v| !v.is_finite()) {
        return Err(TerrainError::Training("non-finite feature value".into()));
    }
    let mut counts = vec![0usize; k];
    for &c in y {
        match counts.get_mut(c) {
            Some(n) => *n += 1,
            None => return Err(TerrainError::Training(format!("label {c} out of 0..{k}"))),
        }
    }
    if k < 2 {
        return Err(TerrainError::Training(format!(
            "need at least 2 classes, got {k}"
        )));
    }
    if let Some((c, n)) = counts
        .iter()
        .enumerate()
        .find(|(_, &n)| n < MIN_SAMPLES_PER_CLASS)
    {
        return Err(TerrainError::Training(format!(
            "class #{c} has {n} samples, fewer than {MIN_SAMPLES_PER_CLASS}"
        )));
    }
    Ok(())
}

pub use terraslip_core::rng::SplitMix64;

/// The most probable class of a probability vector (the first of ties).
pub fn argmax(p: &[f64]) -> usize {
    let mut best = 0;
    for (i, v) in p.iter().enumerate() {
        if *v > p[best] {
            best = i;
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two Gaussian-ish blobs per class in 2-D, separable with one split each.
    fn blobs(n: usize, seed: u64) -> (Vec<Vec<f64>>, Vec<usize>) {
        let mut r = SplitMix64(seed);
        let centres = [(0.0, 0.0), (3.0, 0.0), (0.0, 3.0)];
        let mut x = Vec::new();
        let mut y = Vec::new();
        for i in 0..n {
            let c = i % 3;
            let (a, b) = centres[c];
            x.push(vec![
                a + r.uniform() - 0.5,
                b + r.uniform() - 0.5,
                r.uniform(),
            ]);
            y.push(c);
        }
        (x, y)
    }

    fn accuracy(c: &Classifier, x: &[Vec<f64>], y: &[usize]) -> f64 {
        let mut p = vec![0.0; 3];
        let ok = x
            .iter()
            .zip(y)
            .filter(|(r, &t)| {
                c.predict_proba(r, &mut p);
                let best = (0..3).max_by(|&a, &b| p[a].total_cmp(&p[b])).unwrap();
                (p.iter().sum::<f64>() - 1.0).abs() < 1e-9 && best == t
            })
            .count();
        ok as f64 / x.len() as f64
    }

    #[test]
    fn every_kind_separates_blobs_on_held_out_data() {
        let (x, y) = blobs(150, 1);
        let (xt, yt) = blobs(90, 2);
        // Boosted trees split on 32 quantile bins per feature: a coarser
        // boundary on 150 training rows (3 of the 90 held-out rows wrong).
        for (kind, least) in [
            (ClassifierKind::Tree, 0.97),
            (ClassifierKind::Knn, 0.97),
            (ClassifierKind::Boost, 0.95),
        ] {
            let p = ClassifierParams {
                kind,
                ..Default::default()
            };
            let c = Classifier::fit(&x, &y, 3, &p).unwrap();
            let acc = accuracy(&c, &xt, &yt);
            assert!(acc > least, "{kind:?}: {acc}");
        }
    }

    #[test]
    fn too_few_samples_and_bad_rows_are_training_errors() {
        let x = vec![vec![0.0], vec![1.0], vec![2.0], vec![3.0]];
        let y = vec![0, 0, 0, 1];
        let e = Classifier::fit(&x, &y, 2, &ClassifierParams::default()).unwrap_err();
        assert!(
            matches!(e, TerrainError::Training(ref m) if m.contains("class #1")),
            "{e}"
        );
        let bad = vec![vec![0.0], vec![f64::NAN], vec![2.0], vec![3.0]];
        assert!(Classifier::fit(&bad, &[0, 0, 1, 1], 2, &ClassifierParams::default()).is_err());
        assert!(Classifier::fit(&x, &[0, 0, 1], 2, &ClassifierParams::default()).is_err());
        assert!(Classifier::fit(&x, &[0, 0, 0, 0], 1, &ClassifierParams::default()).is_err());
    }

    #[test]
    fn malformed_tree_does_not_panic() {
        let t = Classifier::Tree(DecisionTree {
            nodes: vec![Node {
                feature: 99,
                threshold: 0.0,
                left: 5,
                right: 0,
                probs: vec![1.0],
            }],
        });
        let mut out = [0.0; 2];
        t.predict_proba(&[0.0], &mut out);
        assert_eq!(out, [0.0, 0.0]);
    }
}
