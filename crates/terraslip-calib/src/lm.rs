//! Levenberg-Marquardt on the 5 ICR parameters with robust reweighting.
//!
//! Hand-written (5 unknowns, 7 with the turn-rate slopes: the normal
//! equations are a small Cholesky), with
//! Marquardt's diagonal damping, started from the no-slip model. An outer
//! iteratively-reweighted loop (IRLS) drops segments beyond
//! `outlier_sigmas * sigma`, with `sigma` a median-based scale (relocalisation
//! jumps, wheel spin that no kinematic model explains), and, with a finite
//! `cauchy_c`, gives the others the Cauchy weight `1 / (1 + (s/(c sigma))^2)`
//! of their residual norm `s`.
//!
//! Default: trimmed least squares (`cauchy_c` infinite, drop beyond 5 sigma).
//! On the Warthog drives, split in time, it predicted the held-out half
//! better than Cauchy weighting (c = 2.385), which also discounts the hard
//! but genuine segments (fast turns) that the validation scores.
#![allow(non_snake_case)]

use nalgebra::{SMatrix, SVector};
use terraslip_core::kinematics::MIN_SPREAD;
use terraslip_core::IcrParams;

use crate::model::{from_vec, residuals_rate, to_vec, RateSlopes};
use crate::reduction::Reduction;
use crate::sandwich::{self, ResidualNoise};
use crate::segment::Segments;

/// Median of the norm of a 3-D standard normal vector: turns a median
/// residual norm into a per-component sigma.
const CHI3_MEDIAN: f64 = 1.5382;

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

/// A least-squares problem over the segments in `N` parameters: the
/// residuals of every segment for a parameter vector, and which vectors are
/// usable.
struct Problem<'a, const N: usize> {
    segs: &'a Segments,
    residuals: &'a (dyn Fn(&[f64; N]) -> Vec<[f64; 3]> + Sync),
    usable: &'a dyn Fn(&[f64; N]) -> bool,
    free: [bool; N],
    /// m/rad, to map heading noise into the weighted residual.
    yaw_weight: f64,
}

/// `out[i] = f(i)` for every `i`, on all cores (contiguous blocks). Each
/// entry is computed alone, so results do not depend on the thread count.
fn par_fill<T: Send>(out: &mut [T], f: &(dyn Fn(usize) -> T + Sync)) {
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(out.len())
        .max(1);
    if threads == 1 {
        for (i, o) in out.iter_mut().enumerate() {
            *o = f(i);
        }
        return;
    }
    let chunk = out.len().div_ceil(threads);
    std::thread::scope(|scope| {
        for (c, block) in out.chunks_mut(chunk).enumerate() {
            scope.spawn(move || {
                for (k, o) in block.iter_mut().enumerate() {
                    *o = f(c * chunk + k);
                }
            });
        }
    });
}

impl<const N: usize> Problem<'_, N> {
    /// Residuals and their Jacobian w.r.t. the parameters (forward
    /// differences, step 1e-6 relative: N + 1 integrations of the drive
    /// instead of 2N + 1, with a truncation error far below the residual
    /// noise, evaluated on all cores), zero for segments without weight.
    #[allow(clippy::type_complexity)]
    fn residuals_and_jacobian(
        &self,
        v: &[f64; N],
        w: &[f64],
    ) -> (Vec<[f64; 3]>, Vec<[[f64; 3]; N]>) {
        let free = self.free;
        // Column 0: the residuals at v; column k + 1: v with parameter k moved.
        let mut cols: Vec<Vec<[f64; 3]>> = vec![Vec::new(); N + 1];
        par_fill(&mut cols, &|c| {
            if c == 0 {
                return (self.residuals)(v);
            }
            let k = c - 1;
            if !free[k] {
                return Vec::new();
            }
            let mut vp = *v;
            vp[k] += 1e-6 * (1.0 + v[k].abs());
            (self.residuals)(&vp)
        });
        let n = self.segs.segments.len();
        let mut r = std::mem::take(&mut cols[0]);
        let mut J = vec![[[0.0; 3]; N]; n];
        for i in 0..n {
            if w[i] <= 0.0 {
                r[i] = [0.0; 3];
                continue;
            }
            for k in 0..N {
                if !free[k] {
                    continue;
                }
                let h = 1e-6 * (1.0 + v[k].abs());
                for c in 0..3 {
                    // d(pred)/dp = -d(r)/dp
                    J[i][k][c] = -(cols[k + 1][i][c] - r[i][c]) / h;
                }
            }
        }
        (r, J)
    }

    fn weighted_sse(&self, v: &[f64; N], w: &[f64]) -> f64 {
        (self.residuals)(v)
            .iter()
            .zip(w)
            .filter(|(_, &w)| w > 0.0)
            .map(|(r, &w)| w * (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]))
            .sum()
    }

    /// Normal equations `J^T W J` and `J^T W r`, with fixed parameters decoupled.
    fn normal_equations(
        &self,
        r: &[[f64; 3]],
        J: &[[[f64; 3]; N]],
        w: &[f64],
    ) -> (SMatrix<f64, N, N>, SVector<f64, N>) {
        let mut A = SMatrix::<f64, N, N>::zeros();
        let mut g = SVector::<f64, N>::zeros();
        for i in 0..r.len() {
            if w[i] <= 0.0 {
                continue;
            }
            for a in 0..N {
                for c in 0..3 {
                    g[a] += w[i] * J[i][a][c] * r[i][c];
                }
                for b in 0..N {
                    let s: f64 = J[i][a].iter().zip(&J[i][b]).map(|(x, y)| x * y).sum();
                    A[(a, b)] += w[i] * s;
                }
            }
        }
        for k in 0..N {
            if !self.free[k] {
                for j in 0..N {
                    A[(k, j)] = 0.0;
                    A[(j, k)] = 0.0;
                }
                A[(k, k)] = 1.0;
                g[k] = 0.0;
            }
        }
        (A, g)
    }

    /// Weighted least squares by Levenberg-Marquardt from `v`, weights
    /// fixed. Returns the iterations used, and whether they ran out before
    /// the fit converged (the last one still improved the cost).
    fn solve(&self, v: &mut [f64; N], w: &[f64], max_iterations: usize) -> (usize, bool) {
        let mut lambda = 1e-3;
        let mut cost = self.weighted_sse(v, w);
        let mut it = 0;
        while it < max_iterations {
            it += 1;
            let (r, J) = self.residuals_and_jacobian(v, w);
            let (A, g) = self.normal_equations(&r, &J, w);
            let mut improved = false;
            while lambda < 1e12 {
                let mut D = A;
                for k in 0..N {
                    D[(k, k)] += lambda * A[(k, k)].max(1e-12);
                }
                let Some(ch) = D.cholesky() else {
                    lambda *= 10.0;
                    continue;
                };
                let delta = ch.solve(&g);
                let mut cand = *v;
                for k in 0..N {
                    cand[k] += delta[k];
                }
                if (self.usable)(&cand) {
                    let c = self.weighted_sse(&cand, w);
                    if c.is_finite() && c <= cost {
                        let rel = (cost - c) / cost.max(1e-300);
                        let step = delta.norm();
                        *v = cand;
                        cost = c;
                        lambda = (lambda * 0.3).max(1e-12);
                        improved = true;
                        if rel < 1e-10 || step < 1e-10 {
                            return (it, false);
                        }
                        break;
                    }
                }
                lambda *= 10.0;
            }
            if !improved {
                return (it, false);
            }
        }
        (it, true)
    }

    /// 1-sigma of every parameter, the sandwich `A⁻¹ Var(g) A⁻¹` of
    /// [`crate::sandwich`], and the residual noise it assumed. A singular
    /// information matrix gives infinite uncertainties: those parameters are
    /// not identified by the data. NaN for fixed parameters.
    fn uncertainties(&self, v: &[f64; N], w: &[f64]) -> ([f64; N], ResidualNoise) {
        let (r, J) = self.residuals_and_jacobian(v, w);
        let (A, _) = self.normal_equations(&r, &J, w);
        let noise = sandwich::estimate_noise(self.segs, &r, w, self.yaw_weight);
        let M = sandwich::meat(self.segs, &J, w, self.yaw_weight, &noise);
        // The excess and pose noise are estimated from residuals at the fit,
        // which the fit has shrunk by about k of n degrees of freedom.
        let n_free = self.free.iter().filter(|&&f| f).count() as f64;
        let wsum: f64 = w.iter().filter(|&&x| x > 0.0).map(|x| x.min(1.0)).sum();
        let dof = 3.0 * wsum - n_free;
        let inflate = if dof > 0.0 {
            3.0 * wsum / dof
        } else {
            f64::INFINITY
        };
        let mut out = [f64::NAN; N];
        // Scale rows/columns so parameters of different units condition
        // alike; then the scaled matrix has a unit diagonal, and a diagonal
        // element of its inverse over 1e12 means an eigenvalue near 1e-12.
        let mut scale = SVector::<f64, N>::zeros();
        for k in 0..N {
            scale[k] = A[(k, k)].abs().sqrt().max(1e-300);
        }
        let mut S = A;
        for a in 0..N {
            for b in 0..N {
                S[(a, b)] /= scale[a] * scale[b];
            }
        }
        let inv = S
            .cholesky()
            .map(|c| c.inverse())
            .filter(|m| m.iter().all(|x| x.is_finite()) && (0..N).all(|k| m[(k, k)] < 1e12));
        // cov = A⁻¹ M A⁻¹ with A⁻¹ = D⁻¹ S⁻¹ D⁻¹, D = diag(scale).
        let cov = inv.map(|m| {
            let mut Ms = M;
            for a in 0..N {
                for b in 0..N {
                    Ms[(a, b)] /= scale[a] * scale[b];
                }
            }
            m * Ms * m
        });
        for k in 0..N {
            if !self.free[k] {
                continue;
            }
            out[k] = match &cov {
                Some(c) if A[(k, k)] > 0.0 => (inflate * c[(k, k)].max(0.0)).sqrt() / scale[k],
                _ => f64::INFINITY,
            };
        }
        (out, noise)
    }
}

fn usable(v: &[f64; 5]) -> bool {
    v.iter().all(|x| x.is_finite()) && v[0] - v[1] > MIN_SPREAD && v[3] > 0.0 && v[4] > 0.0
}

fn constant_problem<'a>(
    segs: &'a Segments,
    res: &'a (dyn Fn(&[f64; 5]) -> Vec<[f64; 3]> + Sync),
    free: [bool; 5],
    yaw_weight: f64,
) -> Problem<'a, 5> {
    Problem {
        segs,
        residuals: res,
        usable: &usable,
        free,
        yaw_weight,
    }
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

/// Parameter order of the turn-rate dependent fit (and its traction term).
pub const RATE_PARAM_NAMES: [&str; 11] = [
    "y_l",
    "y_r",
    "x_c",
    "alpha_l",
    "alpha_r",
    "k_spread",
    "k_alpha",
    "k_acc",
    "k_dir",
    "k_x_speed",
    "k_spread_speed",
];

/// Number of slopes of [`RateSlopes`].
pub const N_SLOPES: usize = 6;

/// Which slopes of [`RateSlopes`] a variable-ICR fit frees, in the order
/// (k_spread, k_alpha, k_acc, k_dir, k_x_speed, k_spread_speed).
pub const TURN_RATE: [bool; N_SLOPES] = [true, true, false, false, false, false];
/// The turn-rate model with the symmetric traction term `k_acc`.
pub const TURN_RATE_TRACTION: [bool; N_SLOPES] = [true, true, true, false, false, false];
/// The turn-rate model with traction differing when accelerating and braking.
pub const TURN_RATE_TRACTION_SIGNED: [bool; N_SLOPES] = [true, true, true, true, false, false];
/// The centripetal terms alone.
pub const CENTRIPETAL: [bool; N_SLOPES] = [false, false, false, false, true, true];

/// A variable-ICR model ([`RateSlopes`]) fitted jointly with the five ICR
/// parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct RateFit {
    pub params: IcrParams,
    pub slopes: RateSlopes,
    /// 1-sigma of [`RATE_PARAM_NAMES`]; NaN for fixed parameters.
    pub std: [f64; 5 + N_SLOPES],
    /// Weighted eq. 13 sum at the fit.
    pub sse: f64,
    /// Which slopes were fitted (order of [`TURN_RATE`]).
    pub free_slopes: [bool; N_SLOPES],
}

impl RateFit {
    /// Number of fitted slopes.
    pub fn n_slopes(&self) -> usize {
        self.free_slopes.iter().filter(|&&f| f).count()
    }
}

/// Fits a variable-ICR model by Levenberg-Marquardt from `start` and
/// `start_slopes` (slopes not in `free_slopes` keep their start value,
/// normally 0) with the segment weights `w` held fixed (those of the
/// constant fit, so that every model is judged on the same segments).
/// `free` says which of the five ICR parameters are fitted, `reduction`
/// which relations among them are held ([`Reduction::NONE`]: none). `None`
/// when no segment has weight.
#[allow(clippy::too_many_arguments)]
pub fn fit_rate(
    segs: &Segments,
    start: &IcrParams,
    start_slopes: &RateSlopes,
    w: &[f64],
    yaw_weight: f64,
    (free, reduction): (&[bool; 5], Reduction),
    free_slopes: &[bool; N_SLOPES],
    max_iterations: usize,
) -> Option<RateFit> {
    if !w.iter().any(|&x| x > 0.0) {
        return None;
    }
    let split = |v: &[f64; 5 + N_SLOPES]| {
        let mut p = [v[0], v[1], v[2], v[3], v[4]];
        reduction.apply(&mut p);
        (
            from_vec(&p),
            RateSlopes {
                k_spread: v[5],
                k_alpha: v[6],
                k_acc: v[7],
                k_dir: v[8],
                k_x_speed: v[9],
                k_spread_speed: v[10],
            },
        )
    };
    let res = |v: &[f64; 5 + N_SLOPES]| {
        let (p, k) = split(v);
        residuals_rate(&p, &k, segs, yaw_weight)
    };
    let ok = |v: &[f64; 5 + N_SLOPES]| {
        usable(&[v[0], v[1], v[2], v[3], v[4]]) && v[5..].iter().all(|x| x.is_finite())
    };
    let mut f = [false; 5 + N_SLOPES];
    f[..5].copy_from_slice(&reduction.free(*free));
    f[5..].copy_from_slice(free_slopes);
    let problem = Problem {
        segs,
        residuals: &res,
        usable: &ok,
        free: f,
        yaw_weight,
    };
    let mut p0 = to_vec(start);
    reduction.apply(&mut p0);
    let k0 = start_slopes;
    let mut v = [
        p0[0],
        p0[1],
        p0[2],
        p0[3],
        p0[4],
        k0.k_spread,
        k0.k_alpha,
        k0.k_acc,
        k0.k_dir,
        k0.k_x_speed,
        k0.k_spread_speed,
    ];
    problem.solve(&mut v, w, max_iterations);
    let (params, slopes) = split(&v);
    let mut std = problem.uncertainties(&v, w).0;
    let icr_std = reduction.std([std[0], std[1], std[2], std[3], std[4]]);
    std[..5].copy_from_slice(&icr_std);
    Some(RateFit {
        params,
        slopes,
        std,
        sse: problem.weighted_sse(&v, w),
        free_slopes: *free_slopes,
    })
}
