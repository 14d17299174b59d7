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

mod constant;
mod problem;
mod rate;

pub use constant::{fit, fit_reduced, uncertainties, LmConfig, LmFit, ReducedFit};
pub use rate::{
    fit_rate, RateFit, CENTRIPETAL, N_SLOPES, RATE_PARAM_NAMES, TURN_RATE, TURN_RATE_TRACTION,
    TURN_RATE_TRACTION_SIGNED,
};
