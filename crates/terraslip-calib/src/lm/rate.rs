//! The variable-ICR fit: the five parameters with the turn-rate, traction
//! and centripetal slopes of [`RateSlopes`].
#![allow(non_snake_case)]

use terraslip_core::IcrParams;

use super::problem::{usable, Problem};
use crate::model::{from_vec, residuals_rate, to_vec, RateSlopes};
use crate::reduction::Reduction;
use crate::segment::Segments;

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
