//! The robust least-squares problem over the segments in `N` parameters:
//! Levenberg-Marquardt steps, the reweighting, the sandwich uncertainties.
#![allow(non_snake_case)]

use nalgebra::{SMatrix, SVector};
use terraslip_core::kinematics::MIN_SPREAD;

use crate::sandwich::{self, ResidualNoise};
use crate::segment::Segments;

/// A least-squares problem over the segments in `N` parameters: the
/// residuals of every segment for a parameter vector, and which vectors are
/// usable.
pub(super) struct Problem<'a, const N: usize> {
    pub(super) segs: &'a Segments,
    pub(super) residuals: &'a (dyn Fn(&[f64; N]) -> Vec<[f64; 3]> + Sync),
    pub(super) usable: &'a dyn Fn(&[f64; N]) -> bool,
    pub(super) free: [bool; N],
    /// m/rad, to map heading noise into the weighted residual.
    pub(super) yaw_weight: f64,
}

/// `out[i] = f(i)` for every `i`, on all cores (contiguous blocks). Each
/// entry is computed alone, so results do not depend on the thread count.
pub(super) fn par_fill<T: Send>(out: &mut [T], f: &(dyn Fn(usize) -> T + Sync)) {
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
    pub(super) fn residuals_and_jacobian(
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

    pub(super) fn weighted_sse(&self, v: &[f64; N], w: &[f64]) -> f64 {
        (self.residuals)(v)
            .iter()
            .zip(w)
            .filter(|(_, &w)| w > 0.0)
            .map(|(r, &w)| w * (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]))
            .sum()
    }

    /// Normal equations `J^T W J` and `J^T W r`, with fixed parameters decoupled.
    pub(super) fn normal_equations(
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
    pub(super) fn solve(
        &self,
        v: &mut [f64; N],
        w: &[f64],
        max_iterations: usize,
    ) -> (usize, bool) {
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
    pub(super) fn uncertainties(&self, v: &[f64; N], w: &[f64]) -> ([f64; N], ResidualNoise) {
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

pub(super) fn usable(v: &[f64; 5]) -> bool {
    v.iter().all(|x| x.is_finite()) && v[0] - v[1] > MIN_SPREAD && v[3] > 0.0 && v[4] > 0.0
}

pub(super) fn constant_problem<'a>(
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
