//! Which parameters the data identify: uncertainty thresholds, tread ICRs
//! held when the drive never turns, the genetic algorithm's answers on a
//! bound.

use terraslip_core::IcrParams;

use crate::model::{self, PARAM_NAMES};
use crate::CalibError;

/// Identifiability thresholds on the Jacobian uncertainties: a parameter
/// whose 1-sigma exceeds this is reported as not identified.
pub(super) fn unidentified_by_std(
    std: &[f64; 5],
    spread: f64,
    free: &[bool; 5],
) -> Vec<&'static str> {
    let limits = [0.25 * spread, 0.25 * spread, 0.25 * spread, 0.1, 0.1];
    (0..5)
        .filter(|&k| free[k] && (std[k].is_nan() || std[k] > limits[k]))
        .map(|k| PARAM_NAMES[k])
        .collect()
}

/// The data never turn enough: fails, or with `allow_partial` lists
/// y_l, y_r and x_c as held at their no-slip values, for `reason`.
pub(super) fn hold_tread_icrs(
    reason: String,
    (label, allow_partial): (&str, bool),
    unidentified: &mut Vec<&'static str>,
    notes: &mut Vec<String>,
) -> Result<(), CalibError> {
    let names = vec!["y_l", "y_r", "x_c"];
    if !allow_partial {
        return Err(CalibError::Unobservable {
            set: label.into(),
            params: names,
            reason,
        });
    }
    notes.push(format!(
        "{} kept at the no-slip values: {reason}",
        names.join(", ")
    ));
    unidentified.extend(names);
    Ok(())
}

/// Fails on the first free parameter [`unidentified_by_std`] names, or with
/// `allow_partial` lists each in `unidentified` and `notes`.
pub(super) fn check_identified(
    std: &[f64; 5],
    spread: f64,
    free: &[bool; 5],
    (label, allow_partial): (&str, bool),
    unidentified: &mut Vec<&'static str>,
    notes: &mut Vec<String>,
) -> Result<(), CalibError> {
    for name in unidentified_by_std(std, spread, free) {
        if !allow_partial {
            return Err(CalibError::Unobservable {
                set: label.into(),
                params: vec![name],
                reason: format!(
                    "its 1-sigma uncertainty ({:.3}) is too large for the data to pin it down",
                    std[PARAM_NAMES.iter().position(|n| *n == name).unwrap_or(0)]
                ),
            });
        }
        if !unidentified.contains(&name) {
            unidentified.push(name);
            notes.push(format!("{name} is poorly identified (large uncertainty)"));
        }
    }
    Ok(())
}

/// A warning for each gene of the GA's answer `p` that sits on a bound of
/// its search range (genes fixed at one value excepted): the best value
/// may lie beyond it.
pub(super) fn ga_at_bounds(label: &str, p: &IcrParams, bounds: &[(f64, f64); 5]) -> Vec<String> {
    let v = model::to_vec(p);
    (0..5)
        .filter_map(|k| {
            let (lo, hi) = bounds[k];
            let tol = 1e-3 * (hi - lo);
            let edge = if hi <= lo {
                return None;
            } else if v[k] <= lo + tol {
                ("lower", lo)
            } else if v[k] >= hi - tol {
                ("upper", hi)
            } else {
                return None;
            };
            Some(format!(
                "set `{label}`: the genetic algorithm's {} = {:.4} is at the {} bound {} of \
                 its search range, so the best value may lie beyond it; check track_width \
                 in meta.toml, or widen the bounds",
                PARAM_NAMES[k], v[k], edge.0, edge.1
            ))
        })
        .collect()
}
