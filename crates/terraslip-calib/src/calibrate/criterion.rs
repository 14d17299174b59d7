//! The information criterion that decides whether a richer model (a
//! turn-rate model, a reduced parameter set) is worth its parameters.

/// The number of residuals `n` of the information criterion: 3 per
/// segment with weight, counted as the chained equivalent (residuals of
/// overlapping segments are not independent).
pub(super) fn evidence(weights: &[f64], coverage: f64) -> f64 {
    3.0 * weights
        .iter()
        .filter(|&&w| w > 0.0)
        .map(|w| w.min(1.0))
        .sum::<f64>()
        / coverage
}

/// Bayesian information criterion `n ln(J/n) + k ln n` of a weighted
/// eq. 13 sum `j` (per chained equivalent) with `k` fitted parameters.
pub(super) fn bic(j: f64, k: f64, n: f64) -> f64 {
    n * (j.max(1e-300) / n).ln() + k * n.ln()
}
