//! The fit on windows of fixes: the five ICR parameters by Gauss-Newton on
//! the windows' residuals, outlier windows dropped, their uncertainties.

use nalgebra::{SMatrix, SVector};
use terraslip_core::kinematics::MIN_SPREAD;
use terraslip_core::IcrParams;

use crate::track::{cost, residuals, window_rms, Tracks, Window};

/// A fit on windows.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackFit {
    pub params: IcrParams,
    /// 1-sigma of (y_l, y_r, x_c, alpha_l, alpha_r); NaN for fixed ones,
    /// infinite for ones the windows do not identify.
    pub std: [f64; 5],
    /// 1-sigma of the spread `y_l - y_r`, m.
    pub spread_std: f64,
    /// Windows kept (false: dropped as outliers).
    pub inliers: Vec<bool>,
    /// Robust residual scale per axis, m (the fixes' noise as seen).
    pub sigma: f64,
    /// Sum of squared residuals over the inliers, m^2.
    pub cost: f64,
    pub iterations: usize,
}

/// Windows whose RMS residual exceeds this many times the median's are
/// dropped (a reference that wanders, a wheel that spins).
pub const OUTLIER_RATIO: f64 = 3.0;

type Mat5 = SMatrix<f64, 5, 5>;
type Vec5 = SVector<f64, 5>;

/// The Jacobian of the residuals (one row per residual, free columns only
/// non-zero) by central differences.
fn jacobian(v: &[f64; 5], free: &[bool; 5], tracks: &Tracks, active: &[bool]) -> Vec<[f64; 5]> {
    let m = residuals(&from_u(v), tracks, active).0.len();
    let mut j = vec![[0.0; 5]; m];
    for k in (0..5).filter(|&k| free[k]) {
        let h = 1e-6 * v[k].abs().max(1.0);
        let (mut a, mut b) = (*v, *v);
        a[k] += h;
        b[k] -= h;
        let (ra, rb) = (
            residuals(&from_u(&a), tracks, active).0,
            residuals(&from_u(&b), tracks, active).0,
        );
        for (row, (x, y)) in j.iter_mut().zip(ra.iter().zip(&rb)) {
            row[k] = (x - y) / (2.0 * h);
        }
    }
    j
}

/// Which parameters a fit frees, in the order (spread `y_l - y_r`, centre
/// `(y_l + y_r) / 2`, `x_c`, `alpha_l`, `alpha_r`).
pub type Free = [bool; 5];

/// Every ICR parameter.
pub const ALL: Free = [true; 5];

/// The differential-drive model: spread and speed factors, the ICRs
/// centred and `x_c` held at 0 (what a controller file can hold).
pub const DIFF_DRIVE: Free = [true, false, false, true, true];

/// The speed factors only (the spread and the rest held).
pub const SPEED_ONLY: Free = [false, false, false, true, true];

/// Which of (y_l, y_r, x_c, alpha_l, alpha_r) a fit that frees `free`
/// moves.
pub fn moved(free: &Free) -> [bool; 5] {
    let y = free[0] || free[1];
    [y, y, free[2], free[3], free[4]]
}

fn to_u(p: &IcrParams) -> [f64; 5] {
    [
        p.y_l - p.y_r,
        0.5 * (p.y_l + p.y_r),
        p.x_c,
        p.alpha_l,
        p.alpha_r,
    ]
}

fn from_u(u: &[f64; 5]) -> IcrParams {
    IcrParams {
        y_l: u[1] + 0.5 * u[0],
        y_r: u[1] - 0.5 * u[0],
        x_c: u[2],
        alpha_l: u[3],
        alpha_r: u[4],
    }
}

fn usable(u: &[f64; 5]) -> bool {
    u.iter().all(|x| x.is_finite()) && u[0] > MIN_SPREAD && u[3] > 0.0 && u[4] > 0.0
}

/// Levenberg-Marquardt on the active windows from `v`; returns the
/// iterations used.
fn solve(v: &mut [f64; 5], free: &[bool; 5], tracks: &Tracks, active: &[bool]) -> usize {
    let mut lambda = 1e-3;
    let mut c = cost(&from_u(v), tracks, active);
    for it in 0..100 {
        let r = residuals(&from_u(v), tracks, active).0;
        let j = jacobian(v, free, tracks, active);
        let (mut a, mut g) = (Mat5::zeros(), Vec5::zeros());
        for (row, &x) in j.iter().zip(&r) {
            let jr = Vec5::from_row_slice(row);
            a += jr * jr.transpose();
            g += jr * x;
        }
        for k in (0..5).filter(|&k| !free[k]) {
            a[(k, k)] = 1.0;
        }
        let mut improved = false;
        while lambda < 1e12 {
            let mut d = a;
            for k in 0..5 {
                d[(k, k)] += lambda * a[(k, k)].max(1e-12);
            }
            // J is the residuals' own: the Gauss-Newton step is -(J'J)^-1 J'r.
            let Some(step) = d.cholesky().map(|ch| ch.solve(&g)) else {
                lambda *= 10.0;
                continue;
            };
            let mut t = *v;
            for k in (0..5).filter(|&k| free[k]) {
                t[k] -= step[k];
            }
            let ct = if usable(&t) {
                cost(&from_u(&t), tracks, active)
            } else {
                f64::INFINITY
            };
            if ct < c {
                let done = (c - ct) <= 1e-12 * c.max(1e-12);
                *v = t;
                c = ct;
                lambda = (lambda * 0.3).max(1e-9);
                improved = !done;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            return it + 1;
        }
    }
    100
}

/// 1-sigma of the free parameters at `v`: the sandwich `A^-1 B A^-1` with
/// `A = J'J` and `B` the outer products of the windows' gradients `J_w' r_w`,
/// overlapping windows' cross terms included, so noise shared by the fixes
/// of a window (a GNSS error that wanders) and by overlapping windows is
/// counted.
/// Infinite where `A` is singular. Returns the 1-sigma of (y_l, y_r, x_c,
/// alpha_l, alpha_r) and of the spread.
fn uncertainties(v: &[f64; 5], free: &Free, tracks: &Tracks, active: &[bool]) -> ([f64; 5], f64) {
    let (r, at) = residuals(&from_u(v), tracks, active);
    let j = jacobian(v, free, tracks, active);
    let mut a = Mat5::zeros();
    for row in &j {
        let jr = Vec5::from_row_slice(row);
        a += jr * jr.transpose();
    }
    let wins: Vec<&Window> = tracks
        .windows
        .iter()
        .zip(active)
        .filter(|(_, &a)| a)
        .map(|(w, _)| w)
        .collect();
    let grads: Vec<Vec5> = at
        .windows(2)
        .map(|s| (s[0]..s[1]).fold(Vec5::zeros(), |g, m| g + Vec5::from_row_slice(&j[m]) * r[m]))
        .collect();
    let mut b = Mat5::zeros();
    for (x, gx) in grads.iter().enumerate() {
        b += gx * gx.transpose();
        for (y, gy) in grads.iter().enumerate().skip(x + 1) {
            if wins[x].log == wins[y].log && wins[y].t0 < wins[x].t1 && wins[x].t0 < wins[y].t1 {
                b += gx * gy.transpose() + gy * gx.transpose();
            }
        }
    }
    // Fixed parameters: a unit diagonal in A and nothing in B, so the
    // inverse of A is that of the free block.
    for k in (0..5).filter(|&k| !free[k]) {
        for i in 0..5 {
            a[(k, i)] = 0.0;
            a[(i, k)] = 0.0;
            b[(k, i)] = 0.0;
            b[(i, k)] = 0.0;
        }
        a[(k, k)] = 1.0;
    }
    let mut std = [f64::NAN; 5];
    let Some(ai) = a.try_inverse() else {
        return ([f64::INFINITY; 5], f64::INFINITY);
    };
    // From (spread, centre, ...) to (y_l, y_r, ...).
    let mut t = Mat5::identity();
    t[(0, 0)] = 0.5;
    t[(0, 1)] = 1.0;
    t[(1, 0)] = -0.5;
    t[(1, 1)] = 1.0;
    let cov_u = ai * b * ai;
    let cov = t * cov_u * t.transpose();
    let moves = moved(free);
    for k in (0..5).filter(|&k| moves[k]) {
        let s = cov[(k, k)];
        std[k] = if s.is_finite() && s >= 0.0 {
            s.sqrt()
        } else {
            f64::INFINITY
        };
    }
    let s = cov_u[(0, 0)];
    let spread_std = if !free[0] {
        f64::NAN
    } else if s.is_finite() && s >= 0.0 {
        s.sqrt()
    } else {
        f64::INFINITY
    };
    (std, spread_std)
}

/// Fits the parameters marked `free` ([`Free`]) from `start` on the windows with
/// `active[i]`, dropping windows whose RMS residual is over
/// [`OUTLIER_RATIO`] times the median's and refitting until the inliers
/// stop changing. `None` with no active window.
pub fn fit(tracks: &Tracks, start: &IcrParams, free: &Free, active: &[bool]) -> Option<TrackFit> {
    if !active.iter().any(|&a| a) {
        return None;
    }
    let mut v = to_u(start);
    let mut inliers = active.to_vec();
    let mut iterations = 0;
    let mut sigma = f64::NAN;
    for _ in 0..6 {
        iterations += solve(&mut v, free, tracks, &inliers);
        let rms = window_rms(&from_u(&v), tracks);
        let mut act: Vec<f64> = rms
            .iter()
            .zip(active)
            .filter(|(x, &a)| a && x.is_finite())
            .map(|(x, _)| *x)
            .collect();
        if act.is_empty() {
            return None;
        }
        act.sort_by(f64::total_cmp);
        sigma = act[act.len() / 2];
        let next: Vec<bool> = rms
            .iter()
            .zip(active)
            .map(|(x, &a)| a && x.is_finite() && *x <= OUTLIER_RATIO * sigma)
            .collect();
        if next == inliers {
            break;
        }
        inliers = next;
    }
    let (std, spread_std) = uncertainties(&v, free, tracks, &inliers);
    let params = from_u(&v);
    Some(TrackFit {
        cost: cost(&params, tracks, &inliers),
        params,
        std,
        spread_std,
        inliers,
        sigma,
        iterations,
    })
}
