//! The JSON forms of a calibration's figures and parameters.

use serde_json::{json, Value};
use terraslip_core::IcrParams;

/// A figure as JSON: the number, or `null` where it is not finite.
pub(super) fn finite_or_null(x: f64) -> Value {
    if x.is_finite() {
        json!(x)
    } else {
        Value::Null
    }
}

/// ICR parameters as a JSON object (m, dimensionless factors).
pub(super) fn params_json(p: &IcrParams) -> Value {
    json!({"y_l": p.y_l, "y_r": p.y_r, "x_c": p.x_c, "alpha_l": p.alpha_l, "alpha_r": p.alpha_r})
}
