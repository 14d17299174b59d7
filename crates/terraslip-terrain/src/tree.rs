//! The paper's pruned decision tree (wang2018 §3.2.2): grown on an impurity
//! criterion (entropy, as the paper, or Gini), then pruned by cost
//! complexity.

use serde::{Deserialize, Serialize};

use terraslip_core::rng::SplitMix64;

/// Split criterion of a decision tree.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Criterion {
    /// Information gain (ID3/C4.5, as in wang2018).
    Entropy,
    Gini,
}

/// Settings of one tree.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TreeParams {
    pub criterion: Criterion,
    pub max_depth: usize,
    pub min_samples_leaf: usize,
    /// Features tried per split (all when `None`; clamped to the number of
    /// features).
    pub max_features: Option<usize>,
    /// Cost-complexity weight α of the pruning cost
    /// `C_α(T) = Σ_leaves N_t·H_t + α·|leaves|` (entropy in nats); 0 = no pruning.
    pub prune_alpha: f64,
}

impl Default for TreeParams {
    fn default() -> Self {
        Self {
            criterion: Criterion::Entropy,
            max_depth: 16,
            min_samples_leaf: 2,
            max_features: None,
            prune_alpha: 4.0,
        }
    }
}

/// One node; a leaf when `left == 0` (the root is never anyone's child).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Node {
    pub feature: u32,
    pub threshold: f64,
    pub left: u32,
    pub right: u32,
    /// Class probabilities of the training samples that reached the node.
    pub probs: Vec<f64>,
}

/// A binary decision tree over continuous features.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DecisionTree {
    pub nodes: Vec<Node>,
}

struct Builder<'a> {
    x: &'a [Vec<f64>],
    y: &'a [usize],
    k: usize,
    p: &'a TreeParams,
    rng: SplitMix64,
    nodes: Vec<Node>,
    counts: Vec<Vec<f64>>,
}

fn impurity(c: Criterion, counts: &[f64], n: f64) -> f64 {
    if n <= 0.0 {
        return 0.0;
    }
    match c {
        Criterion::Entropy => counts
            .iter()
            .filter(|&&v| v > 0.0)
            .map(|&v| {
                let p = v / n;
                -p * p.ln()
            })
            .sum(),
        Criterion::Gini => 1.0 - counts.iter().map(|&v| (v / n) * (v / n)).sum::<f64>(),
    }
}

impl Builder<'_> {
    fn grow(&mut self, idx: &mut [usize], depth: usize) -> u32 {
        let mut counts = vec![0.0; self.k];
        for &i in idx.iter() {
            counts[self.y[i]] += 1.0;
        }
        let n = idx.len() as f64;
        let id = self.nodes.len() as u32;
        self.nodes.push(Node {
            feature: 0,
            threshold: 0.0,
            left: 0,
            right: 0,
            probs: counts.iter().map(|c| c / n).collect(),
        });
        self.counts.push(counts.clone());
        let pure = counts.iter().filter(|&&c| c > 0.0).count() <= 1;
        if pure || depth >= self.p.max_depth || idx.len() < 2 * self.p.min_samples_leaf.max(1) {
            return id;
        }
        let d = self.x[idx[0]].len();
        let mut feats: Vec<usize> = (0..d).collect();
        let m = self.p.max_features.unwrap_or(d).clamp(1, d);
        // Partial Fisher-Yates: the first m entries are a random subset.
        for j in 0..m {
            let r = j + (self.rng.next_u64() as usize) % (d - j);
            feats.swap(j, r);
        }
        let parent = impurity(self.p.criterion, &counts, n);
        let min_leaf = self.p.min_samples_leaf.max(1);
        let mut best: Option<(f64, usize, f64)> = None;
        let mut order: Vec<(f64, usize)> = Vec::with_capacity(idx.len());
        let mut left = vec![0.0; self.k];
        for &f in &feats[..m] {
            order.clear();
            order.extend(idx.iter().map(|&i| (self.x[i][f], self.y[i])));
            order.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
            left.iter_mut().for_each(|v| *v = 0.0);
            let mut right = counts.clone();
            for s in 0..order.len() - 1 {
                let (v, c) = order[s];
                left[c] += 1.0;
                right[c] -= 1.0;
                let nl = (s + 1) as f64;
                if s + 1 < min_leaf || order.len() - s - 1 < min_leaf || order[s + 1].0 <= v {
                    continue;
                }
                let nr = n - nl;
                let child = (nl * impurity(self.p.criterion, &left, nl)
                    + nr * impurity(self.p.criterion, &right, nr))
                    / n;
                let gain = parent - child;
                if best.map(|b| gain > b.0).unwrap_or(true) {
                    best = Some((gain, f, 0.5 * (v + order[s + 1].0)));
                }
            }
        }
        let Some((gain, f, thr)) = best else {
            return id;
        };
        if gain <= 1e-12 {
            return id;
        }
        let mut split = 0;
        for j in 0..idx.len() {
            if self.x[idx[j]][f] <= thr {
                idx.swap(j, split);
                split += 1;
            }
        }
        let (l_idx, r_idx) = idx.split_at_mut(split);
        let l = self.grow(l_idx, depth + 1);
        let r = self.grow(r_idx, depth + 1);
        let node = &mut self.nodes[id as usize];
        node.feature = f as u32;
        node.threshold = thr;
        node.left = l;
        node.right = r;
        id
    }

    /// Bottom-up pruning: a subtree becomes a leaf when that does not raise
    /// `Σ_leaves N_t·H_t + α·|leaves|`. Returns (cost, leaves) of the subtree.
    fn prune(&mut self, id: usize, alpha: f64) -> (f64, usize) {
        let counts = &self.counts[id];
        let n: f64 = counts.iter().sum();
        let leaf_cost = n * impurity(Criterion::Entropy, counts, n) + alpha;
        let node = &self.nodes[id];
        if node.left == 0 {
            return (leaf_cost, 1);
        }
        let (l, r) = (node.left as usize, node.right as usize);
        let (cl, nl) = self.prune(l, alpha);
        let (cr, nr) = self.prune(r, alpha);
        if leaf_cost <= cl + cr {
            let node = &mut self.nodes[id];
            node.left = 0;
            node.right = 0;
            (leaf_cost, 1)
        } else {
            (cl + cr, nl + nr)
        }
    }
}

impl DecisionTree {
    /// Grows a tree on rows `x` with labels `y` in `0..k`, then prunes it.
    pub fn fit(x: &[Vec<f64>], y: &[usize], k: usize, p: &TreeParams, seed: u64) -> Self {
        let mut idx: Vec<usize> = (0..x.len()).collect();
        Self::fit_indices(x, y, k, p, seed, &mut idx)
    }

    fn fit_indices(
        x: &[Vec<f64>],
        y: &[usize],
        k: usize,
        p: &TreeParams,
        seed: u64,
        idx: &mut [usize],
    ) -> Self {
        let mut b = Builder {
            x,
            y,
            k,
            p,
            rng: SplitMix64(seed),
            nodes: Vec::new(),
            counts: Vec::new(),
        };
        b.grow(idx, 0);
        if p.prune_alpha > 0.0 {
            b.prune(0, p.prune_alpha);
            b.nodes = compact(&b.nodes);
        }
        Self { nodes: b.nodes }
    }

    /// Number of leaves reachable from the root.
    pub fn leaves(&self) -> usize {
        let mut stack = vec![0usize];
        let mut n = 0;
        while let Some(i) = stack.pop() {
            match self.nodes.get(i) {
                Some(node) if node.left != 0 => {
                    stack.push(node.left as usize);
                    stack.push(node.right as usize);
                }
                Some(_) => n += 1,
                None => {}
            }
        }
        n
    }

    /// The leaf `x` falls in; `None` for a malformed tree (read from a file).
    pub(crate) fn leaf(&self, x: &[f64]) -> Option<&Node> {
        let mut i = 0usize;
        // A tree read from a file may be malformed: bound the walk.
        for _ in 0..=self.nodes.len() {
            let node = self.nodes.get(i)?;
            if node.left == 0 {
                return Some(node);
            }
            let v = x.get(node.feature as usize).copied().unwrap_or(0.0);
            i = if v <= node.threshold {
                node.left
            } else {
                node.right
            } as usize;
        }
        None
    }
}

/// Drops nodes no longer reachable after pruning, renumbering children.
fn compact(nodes: &[Node]) -> Vec<Node> {
    let mut out: Vec<Node> = Vec::new();
    fn copy(nodes: &[Node], i: usize, out: &mut Vec<Node>) -> u32 {
        let id = out.len() as u32;
        out.push(nodes[i].clone());
        if nodes[i].left != 0 {
            let l = copy(nodes, nodes[i].left as usize, out);
            let r = copy(nodes, nodes[i].right as usize, out);
            out[id as usize].left = l;
            out[id as usize].right = r;
        }
        id
    }
    if !nodes.is_empty() {
        copy(nodes, 0, &mut out);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pruning_collapses_noise_splits() {
        // Labels independent of the features: the unpruned tree memorises
        // noise, the pruned one should be (nearly) a single leaf.
        let mut r = SplitMix64(3);
        let x: Vec<Vec<f64>> = (0..200).map(|_| vec![r.uniform(), r.uniform()]).collect();
        let y: Vec<usize> = (0..200).map(|_| (r.next_u64() % 2) as usize).collect();
        let mut p = TreeParams {
            prune_alpha: 0.0,
            ..Default::default()
        };
        let full = DecisionTree::fit(&x, &y, 2, &p, 1);
        p.prune_alpha = 4.0;
        let pruned = DecisionTree::fit(&x, &y, 2, &p, 1);
        assert!(full.leaves() > 20, "unpruned leaves {}", full.leaves());
        assert!(pruned.leaves() <= 3, "pruned leaves {}", pruned.leaves());
    }
}
