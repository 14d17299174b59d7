//! One calibration method's answer for one parameter set.

use terraslip_core::IcrParams;

use super::Method;

/// One method's answer for one set.
#[derive(Debug, Clone, PartialEq)]
pub struct MethodFit {
    pub method: Method,
    pub params: IcrParams,
    /// Eq. 13 over the inlier segments.
    pub cost: f64,
    /// Cauchy-robust eq. 13 over the inlier segments (what the methods are
    /// compared by).
    pub robust_cost: f64,
    /// 1-sigma uncertainties at `params`: the sandwich estimate of
    /// [`crate::sandwich`] over the LM fit's segment weights.
    pub std: [f64; 5],
}
