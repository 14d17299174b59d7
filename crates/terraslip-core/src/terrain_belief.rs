//! Bayesian (HMM forward) filter over a small set of terrains, and the
//! λ-vote that decides when the estimator should treat the terrain as changed
//! (wang2018 §3.2.3 and §3.1.1). Allocation-free: at most [`MAX_TERRAINS`] classes.
//!
//! Filter (wang2018 eq. 28-29): the prior is `P(χ_t = i) = Σ_j m_ij P(χ_{t−1} = j)`
//! with `m_ii = μ` (stay probability) and `m_ij = (1 − μ)/(k − 1)`; the posterior
//! multiplies by the classifier's likelihood and normalises. When the
//! estimator's innovation jumps (a hint of a terrain change), `μ` is lowered
//! to `stay_prob_on_jump` for that one update, so that the belief can follow
//! a real change at once instead of after a run of mistakes.
//!
//! Vote (wang2018 §3.1.1): the filtered verdicts of the last λ updates are
//! kept; when more than half of them name a terrain other than the current
//! one, that terrain is declared (the noise schedule's trigger).

/// Most terrain classes a belief can hold.
pub const MAX_TERRAINS: usize = 8;

/// Longest λ-vote window kept (λ is clamped to this).
pub const MAX_VOTE_LAMBDA: u32 = 31;

/// Settings of the terrain belief.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields, default))]
pub struct BeliefConfig {
    /// Probability `μ` of staying on the same terrain between two updates.
    pub stay_prob: f64,
    /// Same, used for the update right after the estimator's innovation jumped
    /// (a terrain change is then more likely).
    pub stay_prob_on_jump: f64,
    /// λ: number of recent filtered verdicts the vote looks at; a terrain is
    /// declared when it wins more than half of them (odd values avoid ties;
    /// see [`vote_lambda_for`]). 1 = follow the filter at once.
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
    /// Ring of the last λ filtered verdicts.
    recent: [u8; MAX_VOTE_LAMBDA as usize],
    recent_len: usize,
    recent_next: usize,
}

impl TerrainBelief {
    /// A uniform belief over `n_terrains` (clamped to 1..=[`MAX_TERRAINS`]).
    pub fn new(n_terrains: usize, cfg: BeliefConfig) -> Self {
        let n = n_terrains.clamp(1, MAX_TERRAINS);
        let mut b = Self {
            n,
            p: [0.0; MAX_TERRAINS],
            cfg,
            current: None,
            recent: [0; MAX_VOTE_LAMBDA as usize],
            recent_len: 0,
            recent_next: 0,
        };
        b.reset();
        b
    }

    /// Back to a uniform belief with no declared terrain.
    pub fn reset(&mut self) {
        for (i, v) in self.p.iter_mut().enumerate() {
            *v = if i < self.n { 1.0 / self.n as f64 } else { 0.0 };
        }
        self.current = None;
        self.recent_len = 0;
        self.recent_next = 0;
    }

    /// Fuses one classifier output: `likelihood[i]` ∝ p(features | terrain i)
    /// (class probabilities are fine; missing, negative or non-finite
    /// entries count as tiny). `innovation_jump` tells that the estimator
    /// saw an innovation jump since the last update.
    /// Returns `Some(terrain)` when the vote declares a (new) terrain.
    pub fn update(&mut self, likelihood: &[f64], innovation_jump: bool) -> Option<usize> {
        let n = self.n;
        let stay = if innovation_jump {
            self.cfg.stay_prob_on_jump
        } else {
            self.cfg.stay_prob
        };
        // A stay probability below 1/n would make leaving likelier than staying.
        let stay = if stay.is_finite() {
            stay.clamp(1.0 / n as f64, 1.0)
        } else {
            1.0
        };
        let leave = if n > 1 {
            (1.0 - stay) / (n - 1) as f64
        } else {
            0.0
        };
        let mut sum = 0.0;
        for i in 0..n {
            // Σ_j m_ij p_j with the rows summing to one: stay·p_i + leave·(1 − p_i).
            let prior = stay * self.p[i] + leave * (1.0 - self.p[i]);
            let l = likelihood.get(i).copied().unwrap_or(0.0);
            let l = if l.is_finite() && l > 1e-12 { l } else { 1e-12 };
            self.p[i] = prior * l;
            sum += self.p[i];
        }
        if !(sum.is_finite() && sum > 0.0) {
            for v in self.p.iter_mut().take(n) {
                *v = 1.0 / n as f64;
            }
        } else {
            for v in self.p.iter_mut().take(n) {
                *v /= sum;
                // Keep every terrain reachable: a zero would never recover.
                if *v < 1e-12 {
                    *v = 1e-12;
                }
            }
        }
        self.vote()
    }

    fn vote(&mut self) -> Option<usize> {
        let lambda = self.cfg.vote_lambda.clamp(1, MAX_VOTE_LAMBDA) as usize;
        let best = self.most_likely();
        self.recent[self.recent_next] = best as u8;
        self.recent_next = (self.recent_next + 1) % lambda;
        self.recent_len = (self.recent_len + 1).min(lambda);
        let mut counts = [0usize; MAX_TERRAINS];
        for &v in &self.recent[..self.recent_len] {
            counts[v as usize] += 1;
        }
        // "More than half of the λ" (not of the verdicts seen so far): the
        // first declaration waits for enough evidence too.
        let winner = (0..self.n).find(|&i| 2 * counts[i] > lambda)?;
        if Some(winner) == self.current {
            return None;
        }
        self.current = Some(winner);
        Some(winner)
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

/// Probability that more than half of `lambda` independent verdicts, each
/// right with probability `p`, are right (wang2018 eq. 14).
pub fn vote_reliability(p: f64, lambda: u32) -> f64 {
    let p = if p.is_finite() {
        p.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let l = lambda.max(1);
    let mut rho = 0.0;
    let mut binom = 1.0f64; // C(l, i), built up from i = 0
    for i in 0..=l {
        if i > 0 {
            binom = binom * (l - i + 1) as f64 / i as f64;
        }
        if 2 * i > l {
            rho += binom * libm::pow(p, i as f64) * libm::pow(1.0 - p, (l - i) as f64);
        }
    }
    rho
}

/// Smallest odd λ whose vote is right with probability at least `rho` when
/// each verdict is right with probability `p` (wang2018 §3.1.1);
/// `None` when `p <= 0.5` or no λ up to [`MAX_VOTE_LAMBDA`] suffices.
pub fn vote_lambda_for(p: f64, rho: f64) -> Option<u32> {
    // Also refuses NaN.
    if p.is_nan() || p <= 0.5 {
        return None;
    }
    (1..=MAX_VOTE_LAMBDA)
        .step_by(2)
        .find(|&l| vote_reliability(p, l) >= rho)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg(lambda: u32) -> BeliefConfig {
        BeliefConfig {
            stay_prob: 0.98,
            stay_prob_on_jump: 0.5,
            vote_lambda: lambda,
        }
    }

    #[test]
    fn filter_corrects_isolated_mistakes() {
        let mut b = TerrainBelief::new(3, cfg(3));
        let good = [0.7, 0.2, 0.1];
        let bad = [0.1, 0.7, 0.2];
        let mut wrong = 0;
        for k in 0..100 {
            b.update(if k % 5 == 4 { &bad } else { &good }, false);
            if k > 3 && b.most_likely() != 0 {
                wrong += 1;
            }
        }
        assert_eq!(wrong, 0);
        assert_eq!(b.current(), Some(0));
        let s: f64 = b.probabilities().iter().sum();
        assert!((s - 1.0).abs() < 1e-9);
    }

    #[test]
    fn innovation_jump_lets_the_belief_follow_a_change_sooner() {
        let a = [0.7, 0.3];
        let bb = [0.3, 0.7];
        let steps_to_switch = |jump: bool| {
            let mut b = TerrainBelief::new(2, cfg(1));
            for _ in 0..50 {
                b.update(&a, false);
            }
            for k in 0..50 {
                b.update(&bb, jump && k == 0);
                if b.most_likely() == 1 {
                    return k;
                }
            }
            99
        };
        let plain = steps_to_switch(false);
        let helped = steps_to_switch(true);
        assert!(helped < plain, "with jump {helped}, without {plain}");
        assert_eq!(helped, 0);
    }

    #[test]
    fn vote_needs_a_majority_of_lambda() {
        let mut b = TerrainBelief::new(2, cfg(5));
        let a = [0.99, 0.01];
        let c = [0.01, 0.99];
        // Two verdicts are not a majority of 5.
        assert_eq!(b.update(&a, false), None);
        assert_eq!(b.update(&a, false), None);
        assert_eq!(b.update(&a, false), Some(0));
        for _ in 0..10 {
            b.update(&a, false);
        }
        let mut declared_after = None;
        for k in 0..20 {
            if b.update(&c, true) == Some(1) {
                declared_after = Some(k);
                break;
            }
        }
        // Verdict flips on the first update (jump), the vote needs 3 of 5.
        assert_eq!(declared_after, Some(2));
    }

    #[test]
    fn garbage_likelihoods_keep_a_valid_distribution() {
        let mut b = TerrainBelief::new(3, cfg(3));
        b.update(&[f64::NAN, -1.0, f64::INFINITY], false);
        b.update(&[], true);
        b.update(&[0.0, 0.0, 0.0], false);
        let p = b.probabilities();
        assert!(p.iter().all(|v| v.is_finite() && *v > 0.0));
        assert!((p.iter().sum::<f64>() - 1.0).abs() < 1e-9);
        // A belief is never stuck: a terrain driven to ~0 recovers.
        let mut b = TerrainBelief::new(2, cfg(1));
        for _ in 0..2000 {
            b.update(&[1.0, 0.0], false);
        }
        for _ in 0..200 {
            b.update(&[0.0, 1.0], false);
        }
        assert_eq!(b.most_likely(), 1);
        let bad = TerrainBelief::new(0, cfg(0));
        assert_eq!(bad.probabilities().len(), 1);
    }

    #[test]
    fn lambda_from_classifier_accuracy_matches_the_binomial() {
        // λ = 1 is the classifier itself.
        assert!((vote_reliability(0.8, 1) - 0.8).abs() < 1e-12);
        // λ = 3: p³ + 3p²(1−p) = 0.896 at p = 0.8 (the paper rounds to 0.9).
        assert!((vote_reliability(0.8, 3) - 0.896).abs() < 1e-12);
        assert_eq!(vote_lambda_for(0.8, 0.89), Some(3));
        // ρ(9) = 0.9804, ρ(7) = 0.9667 (the paper says "larger than 9").
        assert_eq!(vote_lambda_for(0.8, 0.98), Some(9));
        assert_eq!(vote_lambda_for(0.8, 0.99), Some(13));
        assert_eq!(vote_lambda_for(0.5, 0.9), None);
        assert_eq!(vote_lambda_for(f64::NAN, 0.9), None);
    }
}
