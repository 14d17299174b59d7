//! The turn-rate dependent model next to the constant one, and the
//! information criterion that decides whether it is kept.

use serde_json::{json, Value};

use super::criterion::{bic, evidence};
use super::json::{finite_or_null, params_json};
use super::method_fit::MethodFit;
use super::RateModel;
use crate::lm::{self, LmConfig, RateFit, RATE_PARAM_NAMES};
use crate::model;
use crate::reduction::Reduction;
use crate::segment::Segments;

/// The turn-rate dependent model of one set and why it was (not) selected.
#[derive(Debug, Clone, PartialEq)]
pub struct RateChoice {
    /// The turn-rate model (slopes `k_spread`, `k_alpha`).
    pub fit: RateFit,
    /// Bayesian information criterion `n ln(J/n) + k ln n` of the constant
    /// winner and of the rate model, over the same weighted segments
    /// (`n` = 3 residuals per segment, `k` = free parameters).
    pub bic_constant: f64,
    pub bic_rate: f64,
    /// The turn-rate model with the traction term, when it was fitted, and
    /// its criterion.
    pub traction: Option<(RateFit, f64)>,
    /// Whether the traction model is the one written (implies `selected`).
    pub traction_selected: bool,
    /// Why the traction model was not selected, when it was fitted.
    pub traction_reason: Option<String>,
    /// The centripetal terms fitted on top of whichever of the constant,
    /// turn-rate and traction models was selected, and its criterion.
    pub centripetal: Option<(RateFit, f64)>,
    /// Whether the centripetal model is the one written (implies `selected`).
    pub centripetal_selected: bool,
    /// Why the centripetal model was not selected, when it was fitted.
    pub centripetal_reason: Option<String>,
    /// Whether `validate` and the file use a variable model.
    pub selected: bool,
    /// Why it was not selected.
    pub reason: Option<String>,
}

impl RateChoice {
    /// The `rate_model` entry of the parameter file: the jointly fitted
    /// ICR parameters and slopes, their 1-sigma, the criterion and whether
    /// it was selected (only then does `validate` use it).
    pub fn to_json(&self) -> Value {
        let f = self.written();
        let std: serde_json::Map<String, Value> = RATE_PARAM_NAMES
            .iter()
            .zip(f.std)
            .filter(|(_, s)| !s.is_nan())
            .map(|(n, s)| (n.to_string(), finite_or_null(s)))
            .collect();
        let mut v = json!({
            "selected": self.selected,
            "params": params_json(&f.params),
            "k_spread": f.slopes.k_spread,
            "k_alpha": f.slopes.k_alpha,
            "std": std,
            "cost": f.sse,
            "bic_constant": self.bic_constant,
            "bic_rate": self.bic_rate,
        });
        if f.slopes.has_traction() {
            v["k_acc"] = json!(f.slopes.k_acc);
            v["k_dir"] = json!(f.slopes.k_dir);
        }
        if f.slopes.has_centripetal() {
            v["k_x_speed"] = json!(f.slopes.k_x_speed);
            v["k_spread_speed"] = json!(f.slopes.k_spread_speed);
        }
        if let Some((t, b)) = &self.traction {
            v["traction"] = json!({
                "selected": self.traction_selected,
                "k_acc": t.slopes.k_acc,
                "k_dir": t.slopes.k_dir,
                "std_k_acc": finite_or_null(t.std[7]),
                "std_k_dir": finite_or_null(t.std[8]),
                "bic": b,
            });
            if let Some(r) = &self.traction_reason {
                v["traction"]["reason"] = json!(r);
            }
        }
        if let Some((c, b)) = &self.centripetal {
            v["centripetal"] = json!({
                "selected": self.centripetal_selected,
                "k_x_speed": c.slopes.k_x_speed,
                "k_spread_speed": c.slopes.k_spread_speed,
                "std_k_x_speed": finite_or_null(c.std[9]),
                "std_k_spread_speed": finite_or_null(c.std[10]),
                "bic": b,
            });
            if let Some(r) = &self.centripetal_reason {
                v["centripetal"]["reason"] = json!(r);
            }
        }
        if let Some(r) = &self.reason {
            v["reason"] = json!(r);
        }
        v
    }

    /// The information criterion of the model `validate` scores: the
    /// variable model written when one is selected, else the constant set.
    pub fn selected_bic(&self) -> f64 {
        if !self.selected {
            return self.bic_constant;
        }
        match (&self.centripetal, &self.traction) {
            (Some((_, b)), _) if self.centripetal_selected => *b,
            (_, Some((_, b))) if self.traction_selected => *b,
            _ => self.bic_rate,
        }
    }

    /// The variable model the file holds: the centripetal model when it
    /// was selected, else the traction model when it was, else the
    /// turn-rate model.
    pub fn written(&self) -> &RateFit {
        match (&self.centripetal, &self.traction) {
            (Some((c, _)), _) if self.centripetal_selected => c,
            (_, Some((t, _))) if self.traction_selected => t,
            _ => &self.fit,
        }
    }
}

/// Fits the turn-rate model from the selected constant set `best` (which
/// holds `reduction`; the variable models hold it too) over the constant
/// fit's segment weights and decides whether it is worth its two slopes.
#[allow(clippy::too_many_arguments)]
pub(super) fn choose_rate(
    segs: &Segments,
    (best, reduction): (&MethodFit, Reduction),
    weights: &[f64],
    yaw_weight: f64,
    lm_cfg: &LmConfig,
    mode: RateModel,
    traction: (RateModel, bool),
    centripetal: RateModel,
    coverage: f64,
) -> Option<RateChoice> {
    let fit = lm::fit_rate(
        segs,
        &best.params,
        &model::RateSlopes::NONE,
        weights,
        yaw_weight,
        (&lm_cfg.free, reduction),
        &lm::TURN_RATE,
        lm_cfg.max_iterations,
    )?;
    let n = evidence(weights, coverage);
    let free = reduction.free(lm_cfg.free);
    let k = free.iter().filter(|&&f| f).count() as f64;
    let j0 = model::cost(&best.params, segs, weights, yaw_weight) / coverage;
    let bic = |j: f64, k: f64| bic(j, k, n);
    let (bic_constant, bic_rate) = (bic(j0, k), bic(fit.sse / coverage, k + 2.0));
    // A slope is identified when its 1-sigma is under 0.1 s/m: a factor
    // of 10 % per m/s of tread speed difference.
    let unidentified = fit.std[5..7].iter().any(|s| !(s.is_finite() && *s < 0.1));
    let reason = if unidentified {
        Some("the slopes are not identified by these segments (1-sigma over 0.1 s/m)".to_string())
    } else if mode == RateModel::Auto && bic_rate >= bic_constant {
        Some("it does not lower the information criterion".to_string())
    } else {
        None
    };
    // The traction term is fitted on top of the turn-rate model, from it,
    // over the same weights, and must beat whichever of the constant and
    // turn-rate models is selected.
    let (mut t_fit, mut t_selected, mut t_reason) = (None, false, None);
    if traction.0 != RateModel::Off && !unidentified {
        let free_slopes = if traction.1 {
            lm::TURN_RATE_TRACTION_SIGNED
        } else {
            lm::TURN_RATE_TRACTION
        };
        if let Some(t) = lm::fit_rate(
            segs,
            &fit.params,
            &fit.slopes,
            weights,
            yaw_weight,
            (&lm_cfg.free, reduction),
            &free_slopes,
            lm_cfg.max_iterations,
        ) {
            let b = bic(t.sse / coverage, k + t.n_slopes() as f64);
            let floor = if reason.is_none() {
                bic_rate
            } else {
                bic_constant
            };
            // Identified: 1-sigma under 0.05 s^2/m, a 5 % change of the speed
            // factors per m/s^2 of tread acceleration.
            let n_t = t.n_slopes();
            let sd = &t.std[5..5 + n_t];
            t_reason = if sd
                .iter()
                .enumerate()
                .any(|(i, s)| !(s.is_finite() && *s < if i < 2 { 0.1 } else { 0.05 }))
            {
                Some("the traction slopes are not identified (1-sigma over 0.05 s^2/m)".to_string())
            } else if traction.0 == RateModel::Auto && b >= floor {
                Some("it does not lower the information criterion".to_string())
            } else {
                None
            };
            t_selected = t_reason.is_none();
            t_fit = Some((t, b));
        }
    }
    // The centripetal terms go on top of whichever model is selected so
    // far, from it, over the same weights, and must beat it.
    let (floor, base_params, base_slopes, base_free) = match &t_fit {
        Some((t, b)) if t_selected => (*b, t.params, t.slopes, t.free_slopes),
        _ if reason.is_none() => (bic_rate, fit.params, fit.slopes, fit.free_slopes),
        _ => (
            bic_constant,
            best.params,
            model::RateSlopes::NONE,
            [false; lm::N_SLOPES],
        ),
    };
    let (mut c_fit, mut c_selected, mut c_reason) = (None, false, None);
    if centripetal != RateModel::Off {
        let mut free_slopes = base_free;
        for (f, c) in free_slopes.iter_mut().zip(lm::CENTRIPETAL) {
            *f |= c;
        }
        // The longitudinal shift needs x_c itself to be identified.
        free_slopes[4] &= free[2];
        if let Some(c) = lm::fit_rate(
            segs,
            &base_params,
            &base_slopes,
            weights,
            yaw_weight,
            (&lm_cfg.free, reduction),
            &free_slopes,
            lm_cfg.max_iterations,
        ) {
            let b = bic(c.sse / coverage, k + c.n_slopes() as f64);
            // Identified: 1-sigma under 0.05 s for the shift (5 cm of x_c
            // per m/s) and under 0.1 s/m for the spread (10 % per m/s).
            let sd = [c.std[9], c.std[10]];
            let limits = [0.05, 0.1];
            c_reason = if free_slopes[4..]
                .iter()
                .zip(sd.iter().zip(limits))
                .any(|(&f, (s, l))| f && !(s.is_finite() && *s < l))
            {
                Some(
                    "the centripetal slopes are not identified (1-sigma over 0.05 s / 0.1 s/m)"
                        .to_string(),
                )
            } else if centripetal == RateModel::Auto && b >= floor {
                Some("it does not lower the information criterion".to_string())
            } else {
                None
            };
            c_selected = c_reason.is_none();
            c_fit = Some((c, b));
        }
    }
    let selected = reason.is_none() || t_selected || c_selected;
    Some(RateChoice {
        fit,
        bic_constant,
        bic_rate,
        traction: t_fit,
        traction_selected: t_selected,
        traction_reason: t_reason,
        centripetal: c_fit,
        centripetal_selected: c_selected,
        centripetal_reason: c_reason,
        selected,
        reason: if selected { None } else { reason },
    })
}
