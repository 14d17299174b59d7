//! Gradient-boosted trees: multiclass softmax loss, second-order (Newton)
//! leaf values, splits over per-feature quantile bins, row and feature
//! subsampling. Deterministic for a seed.

use serde::{Deserialize, Serialize};

use terraslip_core::rng::SplitMix64;

/// Settings of the boosted trees.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoostParams {
    /// Boosting rounds (one tree per class each).
    pub rounds: usize,
    pub learning_rate: f64,
    pub max_depth: usize,
    /// Fewest training rows in a leaf (fewer on small training sets:
    /// at most a tenth of the rows per class, at least 2).
    pub min_samples_leaf: usize,
    /// L2 weight on the leaf values.
    pub lambda: f64,
    /// Share of rows each round sees.
    pub subsample: f64,
    /// Share of features each tree may split on.
    pub colsample: f64,
    /// Quantile bins per feature (2..=256).
    pub bins: usize,
    pub seed: u64,
}

impl Default for BoostParams {
    fn default() -> Self {
        Self {
            rounds: 150,
            learning_rate: 0.1,
            max_depth: 4,
            min_samples_leaf: 20,
            lambda: 1.0,
            subsample: 0.7,
            colsample: 0.3,
            bins: 32,
            seed: 7,
        }
    }
}

/// A node of a regression tree; a leaf when `left == 0`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RegNode {
    pub feature: u32,
    /// Rows with `x[feature] <= threshold` go left.
    pub threshold: f64,
    pub left: u32,
    pub right: u32,
    /// Leaf value (already scaled by the learning rate).
    pub value: f64,
}

/// The trained ensemble: `trees[r * k + c]` is round `r`'s tree for class `c`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BoostedTrees {
    pub classes: usize,
    /// Initial score per class (log class prior).
    pub base: Vec<f64>,
    pub trees: Vec<Vec<RegNode>>,
}

fn tree_value(nodes: &[RegNode], x: &[f64]) -> f64 {
    let mut i = 0usize;
    for _ in 0..nodes.len() {
        let Some(n) = nodes.get(i) else { return 0.0 };
        if n.left == 0 {
            return n.value;
        }
        let v = x.get(n.feature as usize).copied().unwrap_or(0.0);
        i = if v <= n.threshold { n.left } else { n.right } as usize;
    }
    0.0
}

fn softmax(z: &mut [f64]) {
    let m = z.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let mut s = 0.0;
    for v in z.iter_mut() {
        *v = (*v - m).exp();
        s += *v;
    }
    z.iter_mut().for_each(|v| *v /= s);
}

struct Grower<'a> {
    bins: &'a [Vec<u8>],
    cuts: &'a [Vec<f64>],
    g: &'a [f64],
    h: &'a [f64],
    p: &'a BoostParams,
    features: Vec<usize>,
    nodes: Vec<RegNode>,
}

impl Grower<'_> {
    fn leaf(&mut self, idx: &[usize]) -> u32 {
        let (g, h) = idx
            .iter()
            .fold((0.0, 0.0), |(g, h), &i| (g + self.g[i], h + self.h[i]));
        self.nodes.push(RegNode {
            feature: 0,
            threshold: 0.0,
            left: 0,
            right: 0,
            value: -self.p.learning_rate * g / (h + self.p.lambda),
        });
        (self.nodes.len() - 1) as u32
    }

    fn grow(&mut self, idx: &mut [usize], depth: usize) -> u32 {
        let min_leaf = self.p.min_samples_leaf.max(1);
        if depth >= self.p.max_depth || idx.len() < 2 * min_leaf {
            return self.leaf(idx);
        }
        let (gt, ht) = idx
            .iter()
            .fold((0.0, 0.0), |(g, h), &i| (g + self.g[i], h + self.h[i]));
        let lambda = self.p.lambda;
        let parent = gt * gt / (ht + lambda);
        let mut best: Option<(f64, usize, usize)> = None;
        let nb = self.p.bins;
        let mut hg = vec![0.0f64; nb];
        let mut hh = vec![0.0f64; nb];
        let mut hn = vec![0usize; nb];
        for &f in &self.features {
            hg.iter_mut().for_each(|v| *v = 0.0);
            hh.iter_mut().for_each(|v| *v = 0.0);
            hn.iter_mut().for_each(|v| *v = 0);
            let col = &self.bins[f];
            for &i in idx.iter() {
                let b = col[i] as usize;
                hg[b] += self.g[i];
                hh[b] += self.h[i];
                hn[b] += 1;
            }
            let (mut gl, mut hl, mut nl) = (0.0, 0.0, 0usize);
            for b in 0..self.cuts[f].len() {
                gl += hg[b];
                hl += hh[b];
                nl += hn[b];
                let nr = idx.len() - nl;
                if nl < min_leaf || nr < min_leaf {
                    continue;
                }
                let (gr, hr) = (gt - gl, ht - hl);
                let gain = gl * gl / (hl + lambda) + gr * gr / (hr + lambda) - parent;
                if gain > 1e-9 && best.is_none_or(|(bg, _, _)| gain > bg) {
                    best = Some((gain, f, b));
                }
            }
        }
        let Some((_, f, b)) = best else {
            return self.leaf(idx);
        };
        let col = &self.bins[f];
        let mut split = 0;
        for j in 0..idx.len() {
            if col[idx[j]] as usize <= b {
                idx.swap(j, split);
                split += 1;
            }
        }
        let me = self.nodes.len();
        self.nodes.push(RegNode {
            feature: f as u32,
            threshold: self.cuts[f][b],
            left: 0,
            right: 0,
            value: 0.0,
        });
        let (l, r) = idx.split_at_mut(split);
        let left = self.grow(l, depth + 1);
        let right = self.grow(r, depth + 1);
        self.nodes[me].left = left;
        self.nodes[me].right = right;
        me as u32
    }
}

/// Cut points of one feature: up to `bins - 1` quantiles of its values;
/// value `v` falls in the first bin `b` with `v <= cuts[b]`, else the last.
fn quantile_cuts(values: &mut [f64], bins: usize) -> Vec<f64> {
    values.sort_by(|a, b| a.total_cmp(b));
    let n = values.len();
    let mut cuts: Vec<f64> = (1..bins)
        .map(|q| values[(q * n / bins).min(n - 1)])
        .collect();
    cuts.dedup();
    // The largest value needs no cut (everything is <= it).
    if cuts.last() == values.last() {
        cuts.pop();
    }
    cuts
}

impl BoostedTrees {
    /// Trains on rows `x` (finite, equal length), labels `y` in `0..k`.
    pub fn fit(x: &[Vec<f64>], y: &[usize], k: usize, p: &BoostParams) -> Self {
        let n = x.len();
        let d = x.first().map_or(0, |r| r.len());
        let bins = p.bins.clamp(2, 256);
        // Small training sets (a few dozen camera frames) get smaller
        // leaves: about a tenth of a class's share of the rows, at least 2.
        let min_samples_leaf = p.min_samples_leaf.min((n / (10 * k.max(1))).max(2));
        let p = &BoostParams {
            bins,
            min_samples_leaf,
            ..p.clone()
        };
        let mut cuts = Vec::with_capacity(d);
        let mut binned = Vec::with_capacity(d);
        for f in 0..d {
            let mut col: Vec<f64> = x.iter().map(|r| r[f]).collect();
            let c = quantile_cuts(&mut col, bins);
            binned.push(
                x.iter()
                    .map(|r| c.partition_point(|&t| t < r[f]) as u8)
                    .collect::<Vec<u8>>(),
            );
            cuts.push(c);
        }
        let mut prior = vec![1.0f64; k];
        for &c in y {
            prior[c] += 1.0;
        }
        let total: f64 = prior.iter().sum();
        let base: Vec<f64> = prior.iter().map(|c| (c / total).ln()).collect();
        let mut score: Vec<Vec<f64>> = vec![base.clone(); n];
        let mut rng = SplitMix64(p.seed);
        let mut trees = Vec::with_capacity(p.rounds * k);
        let (mut g, mut h) = (vec![0.0; n], vec![0.0; n]);
        let n_feat = ((p.colsample * d as f64).round() as usize).clamp(1, d.max(1));
        let mut prob = vec![vec![0.0; k]; n];
        for _ in 0..p.rounds {
            for (pr, s) in prob.iter_mut().zip(&score) {
                pr.copy_from_slice(s);
                softmax(pr);
            }
            let rows: Vec<usize> = (0..n).filter(|_| rng.uniform() < p.subsample).collect();
            for c in 0..k {
                for i in 0..n {
                    let pc = prob[i][c];
                    g[i] = pc - f64::from(u8::from(y[i] == c));
                    h[i] = (pc * (1.0 - pc)).max(1e-6);
                }
                // A random feature subset per tree (partial Fisher-Yates).
                let mut feats: Vec<usize> = (0..d).collect();
                for j in 0..n_feat {
                    let r = j + (rng.next_u64() as usize) % (d - j);
                    feats.swap(j, r);
                }
                feats.truncate(n_feat);
                let mut grower = Grower {
                    bins: &binned,
                    cuts: &cuts,
                    g: &g,
                    h: &h,
                    p,
                    features: feats,
                    nodes: Vec::new(),
                };
                let mut idx = rows.clone();
                grower.grow(&mut idx, 0);
                let nodes = grower.nodes;
                for (s, r) in score.iter_mut().zip(x) {
                    s[c] += tree_value(&nodes, r);
                }
                trees.push(nodes);
            }
        }
        Self {
            classes: k,
            base,
            trees,
        }
    }

    /// Class probabilities of one row into `out` (length `classes`).
    pub fn proba(&self, x: &[f64], out: &mut [f64]) {
        let k = self.classes;
        if out.len() != k || k == 0 {
            return;
        }
        out.copy_from_slice(&self.base);
        for (i, t) in self.trees.iter().enumerate() {
            out[i % k] += tree_value(t, x);
        }
        softmax(out);
    }

    /// Whether the ensemble fits `k` classes and `d` features (for loading).
    pub fn is_consistent(&self, k: usize, d: usize) -> bool {
        self.classes == k
            && self.base.len() == k
            && self.trees.len().checked_rem(k) == Some(0)
            && self.trees.iter().all(|t| {
                t.iter().all(|n| {
                    n.threshold.is_finite()
                        && n.value.is_finite()
                        && (n.left == 0
                            || ((n.feature as usize) < d
                                && (n.left as usize) < t.len()
                                && (n.right as usize) < t.len()))
                })
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn boosted_trees_learn_an_interaction_a_single_split_cannot() {
        // Class = XOR of the signs of two features, plus a noise feature.
        let mut rng = SplitMix64(3);
        let mut x = Vec::new();
        let mut y = Vec::new();
        for _ in 0..800 {
            let a = rng.uniform() * 2.0 - 1.0;
            let b = rng.uniform() * 2.0 - 1.0;
            x.push(vec![a, b, rng.uniform()]);
            y.push(usize::from((a > 0.0) != (b > 0.0)));
        }
        let p = BoostParams {
            colsample: 1.0,
            rounds: 60,
            ..Default::default()
        };
        let m = BoostedTrees::fit(&x, &y, 2, &p);
        assert!(m.is_consistent(2, 3));
        let mut out = [0.0; 2];
        let mut hit = 0;
        for (r, &c) in x.iter().zip(&y) {
            m.proba(r, &mut out);
            assert!((out[0] + out[1] - 1.0).abs() < 1e-9);
            hit += usize::from((out[1] > 0.5) == (c == 1));
        }
        assert!(hit > 760, "{hit} of 800");
        // Deterministic for a seed.
        assert_eq!(BoostedTrees::fit(&x, &y, 2, &p), m);
        // A tree pointing outside the feature list is refused.
        let mut bad = m.clone();
        bad.trees[0][0].feature = 9;
        assert!(!bad.is_consistent(2, 3) || bad.trees[0][0].left == 0);
    }
}
