//! Bayesian (HMM forward) filter over a small set of terrains, and the
//! λ-vote that decides when the estimator should treat the terrain as changed
//! (wang2018). Allocation-free: at most [`MAX_TERRAINS`] classes.
//!
//! First cut (fixed transition matrix, no adaptation): the terrain
//! engineer replaces the internals; the public API is what the pipeline uses.

/// Most terrain classes a belief can hold.
pub const MAX_TERRAINS: usize = 8;

/// Settings of the terrain belief.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct BeliefConfig {
    /// Probability of staying on the same terrain between two updates.
    pub stay_prob: f64,
    /// Same, used for the update right after the estimator's innovation jumped
    /// (a terrain change is then more likely).
    pub stay_prob_on_jump: f64,
    /// Consecutive updates the most likely terrain must win before a switch
    /// is declared.
    pub vote_lambda: u32,
}

impl Default for BeliefConfig {
    fn default() -> Self {
        Self {
            stay_prob: 0.98,
            stay_prob_on_jump: 0.6,
            vote_lambda: 3,
        }
    }
}

/// Belief over `n` terrains.
#[derive(Debug, Clone)]
pub struct TerrainBelief {
    n: usize,
    p: [f64; MAX_TERRAINS],
    cfg: BeliefConfig,
    current: Option<usize>,
    candidate: Option<usize>,
    votes: u32,
}

impl TerrainBelief {
    /// A uniform belief over `n_terrains` (clamped to 1..=[`MAX_TERRAINS`]).
    pub fn new(n_terrains: usize, cfg: BeliefConfig) -> Self {
        let n = n_terrains.clamp(1, MAX_TERRAINS);
        let mut p = [0.0; MAX_TERRAINS];
        for v in p.iter_mut().take(n) {
            *v = 1.0 / n as f64;
        }
        Self {
            n,
            p,
            cfg,
            current: None,
            candidate: None,
            votes: 0,
        }
    }

    /// Fuses one classifier output: `likelihood[i]` ∝ p(features | terrain i)
    /// (class probabilities are fine). `innovation_jump` tells that the
    /// estimator saw an innovation jump since the last update.
    /// Returns `Some(terrain)` when the vote declares a (new) terrain.
    pub fn update(&mut self, likelihood: &[f64], innovation_jump: bool) -> Option<usize> {
        let n = self.n;
        let stay = if innovation_jump {
            self.cfg.stay_prob_on_jump
        } else {
            self.cfg.stay_prob
        };
        let leave = if n > 1 {
            (1.0 - stay) / (n - 1) as f64
        } else {
            0.0
        };
        let mut prior = [0.0; MAX_TERRAINS];
        for i in 0..n {
            prior[i] = stay * self.p[i] + leave * (1.0 - self.p[i]);
        }
        let mut sum = 0.0;
        for i in 0..n {
            let l = likelihood.get(i).copied().unwrap_or(0.0);
            let l = if l.is_finite() && l > 0.0 { l } else { 1e-12 };
            self.p[i] = prior[i] * l;
            sum += self.p[i];
        }
        if !(sum.is_finite() && sum > 0.0) {
            for v in self.p.iter_mut().take(n) {
                *v = 1.0 / n as f64;
            }
        } else {
            for v in self.p.iter_mut().take(n) {
                *v /= sum;
            }
        }
        self.vote()
    }

    fn vote(&mut self) -> Option<usize> {
        let best = self.most_likely();
        if Some(best) == self.current {
            self.candidate = None;
            self.votes = 0;
            return None;
        }
        if Some(best) == self.candidate {
            self.votes += 1;
        } else {
            self.candidate = Some(best);
            self.votes = 1;
        }
        if self.votes >= self.cfg.vote_lambda.max(1) {
            self.current = Some(best);
            self.candidate = None;
            self.votes = 0;
            return Some(best);
        }
        None
    }

    /// Posterior probabilities of the `n` terrains.
    pub fn probabilities(&self) -> &[f64] {
        &self.p[..self.n]
    }

    /// Index of the most probable terrain right now (before the vote).
    pub fn most_likely(&self) -> usize {
        let mut best = 0;
        for i in 1..self.n {
            if self.p[i] > self.p[best] {
                best = i;
            }
        }
        best
    }

    /// The terrain declared by the vote, if any yet.
    pub fn current(&self) -> Option<usize> {
        self.current
    }
}
