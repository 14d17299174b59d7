//! The constant-ICR fit: the five parameters by robust Levenberg-Marquardt,
//! their uncertainties, and the fit under a reduction's relations.
#![allow(non_snake_case)]

use terraslip_core::IcrParams;

use super::problem::constant_problem;
use crate::model::{from_vec, residuals_rate, to_vec, RateSlopes};
use crate::reduction::Reduction;
use crate::sandwich::ResidualNoise;
use crate::segment::Segments;

/// Median of the norm of a 3-D standard normal vector: turns a median
/// residual norm into a per-component sigma.
pub(super) const CHI3_MEDIAN: f64 = 1.5382;

/// Settings of the robust Levenberg-Marquardt fit.
#[derive(Debug, Clone, PartialEq)]
pub struct LmConfig {
    /// LM iterations per reweighting round.
    pub max_iterations: usize,
    /// Reweighting rounds (1 = plain least squares).
    pub irls_rounds: usize,
    /// Cauchy scale in units of the robust sigma (2.385: 95 % efficiency);
    /// infinite = every inlier weighs 1 (trimmed least squares).
    pub cauchy_c: f64,
    /// Segments whose residual norm exceeds this many sigmas get weight 0.
    pub outlier_sigmas: f64,
    /// Which of (y_l, y_r, x_c, alpha_l, alpha_r) are fitted; the others
    /// keep their starting value.
    pub free: [bool; 5],
    /// Relations among them the fit holds ([`Reduction::NONE`]: none).
    pub reduction: Reduction,
}

impl Default for LmConfig {
    fn default() -> Self {
        Self {
            max_iterations: 50,
            irls_rounds: 8,
            cauchy_c: f64::INFINITY,
            outlier_sigmas: 5.0,
            free: [true; 5],
            reduction: Reduction::NONE,
        }
    }
}

/// Outcome of a fit.
#[derive(Debug, Clone, PartialEq)]
pub struct LmFit {
    pub params: IcrParams,
    /// 1-sigma uncertainties of (y_l, y_r, x_c, alpha_l, alpha_r), the
    /// sandwich estimate of [`crate::sandwich`]; NaN for fixed ones.
    pub std: [f64; 5],
    /// The residual noise that estimate assumed.
    pub noise: ResidualNoise,
    /// Final per-segment weights (0 = dropped as an outlier).
    pub weights: Vec<f64>,
    /// Robust per-component residual scale, m.
    pub sigma: f64,
    /// Total LM iterations.
    pub iterations: usize,
    /// A reweighting round ran out of iterations
    /// ([`LmConfig::max_iterations`]) before it converged.
    pub capped: bool,
}

/// Robust LM fit from `start` over the segments with `active[i]`.
/// `None` when nothing can be fitted (no active segment).
pub fn fit(
    segs: &Segments,
    start: &IcrParams,
    active: &[bool],
    yaw_weight: f64,
    cfg: &LmConfig,
) -> Option<LmFit> {
    let n = segs.segments.len();
    if active.iter().filter(|&&a| a).count() == 0 {
        return None;
    }
    let reduction = cfg.reduction;
    let res = |v: &[f64; 5]| {
        let mut v = *v;
        reduction.apply(&mut v);
        residuals_rate(&from_vec(&v), &RateSlopes::NONE, segs, yaw_weight)
    };
    let problem = constant_problem(segs, &res, reduction.free(cfg.free), yaw_weight);
    let mut v = to_vec(start);
    reduction.apply(&mut v);
    let mut w: Vec<f64> = active.iter().map(|&a| if a { 1.0 } else { 0.0 }).collect();
    let mut iterations = 0;
    let mut capped = false;
    let mut sigma = f64::NAN;
    for round in 0..cfg.irls_rounds.max(1) {
        let before = v;
        let (used, out_of_iterations) = problem.solve(&mut v, &w, cfg.max_iterations);
        reduction.apply(&mut v);
        iterations += used;
        capped |= out_of_iterations;
        let norms: Vec<f64> = res(&v)
            .iter()
            .zip(active)
            .map(|(r, &a)| {
                if a {
                    (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt()
                } else {
                    f64::NAN
                }
            })
            .collect();
        let mut act: Vec<f64> = norms.iter().copied().filter(|x| x.is_finite()).collect();
        if act.is_empty() {
            // Every residual overflowed: nothing finite to fit.
            return None;
        }
        act.sort_by(f64::total_cmp);
        sigma = (act[act.len() / 2] / CHI3_MEDIAN).max(1e-9);
        if cfg.irls_rounds <= 1 {
            break;
        }
        let c = cfg.cauchy_c * sigma;
        for i in 0..n {
            w[i] = if !active[i] || !norms[i].is_finite() || norms[i] > cfg.outlier_sigmas * sigma {
                0.0
            } else {
                1.0 / (1.0 + (norms[i] / c).powi(2))
            };
        }
        let moved = before
            .iter()
            .zip(&v)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        if round > 0 && moved < 1e-7 {
            break;
        }
    }
    let (std, noise) = problem.uncertainties(&v, &w);
    Some(LmFit {
        params: from_vec(&v),
        std: reduction.std(std),
        noise,
        weights: w,
        sigma,
        iterations,
        capped,
    })
}

/// 1-sigma of the constant model's parameters at `v` with segment weights
/// `w`: the sandwich estimate of [`crate::sandwich`]. A singular
/// information matrix gives infinite uncertainties: those parameters are
/// not identified by the data. NaN for fixed parameters.
pub fn uncertainties(
    v: &[f64; 5],
    segs: &Segments,
    w: &[f64],
    yaw_weight: f64,
    free: &[bool; 5],
) -> [f64; 5] {
    let res = |v: &[f64; 5]| residuals_rate(&from_vec(v), &RateSlopes::NONE, segs, yaw_weight);
    constant_problem(segs, &res, *free, yaw_weight)
        .uncertainties(v, w)
        .0
}

/// A constant-ICR set holding `reduction`'s relations, fitted by
/// Levenberg-Marquardt from `start` with the segment weights `w` held fixed
/// (those of the full fit, so that every model is judged on the same
/// segments). `free` says which of the five parameters may be fitted at
/// all. The dependent parameters' 1-sigma are their free partners'
/// ([`Reduction::std`]); `x_c` held at 0 has NaN. `None` when no segment
/// has weight.
pub fn fit_reduced(
    segs: &Segments,
    start: &IcrParams,
    w: &[f64],
    yaw_weight: f64,
    free: &[bool; 5],
    reduction: Reduction,
    max_iterations: usize,
) -> Option<ReducedFit> {
    if !w.iter().any(|&x| x > 0.0) {
        return None;
    }
    let res = |v: &[f64; 5]| {
        let mut v = *v;
        reduction.apply(&mut v);
        residuals_rate(&from_vec(&v), &RateSlopes::NONE, segs, yaw_weight)
    };
    let problem = constant_problem(segs, &res, reduction.free(*free), yaw_weight);
    let mut v = to_vec(start);
    reduction.apply(&mut v);
    problem.solve(&mut v, w, max_iterations);
    // The dependent parameters follow the fitted ones.
    reduction.apply(&mut v);
    let (std, _) = problem.uncertainties(&v, w);
    Some(ReducedFit {
        params: from_vec(&v),
        std: reduction.std(std),
        sse: problem.weighted_sse(&v, w),
        n_free: reduction.free(*free).iter().filter(|&&f| f).count(),
    })
}

/// A constant-ICR set fitted under a [`Reduction`].
#[derive(Debug, Clone, PartialEq)]
pub struct ReducedFit {
    /// The full set, its relations holding.
    pub params: IcrParams,
    /// 1-sigma of (y_l, y_r, x_c, alpha_l, alpha_r); NaN where held.
    pub std: [f64; 5],
    /// Weighted eq. 13 sum at the fit.
    pub sse: f64,
    /// Parameters fitted.
    pub n_free: usize,
}
