//! The reduced constant-ICR models next to the full one, and the
//! information criterion that picks among them ([`crate::reduction`]).

use serde_json::{json, Value};

use super::criterion::{bic, evidence};
use super::method_fit::MethodFit;
use crate::lm::{self, LmConfig, ReducedFit};
use crate::model;
use crate::reduction::Reduction;
use crate::segment::Segments;

/// The reduced models of one set and the one selected.
#[derive(Debug, Clone, PartialEq)]
pub struct ReductionChoice {
    /// The relations the set's parameters hold ([`Reduction::NONE`]: the
    /// full model).
    pub selected: Reduction,
    /// Bayesian information criterion `n ln(J/n) + k ln n` of the full
    /// constant model, over the full fit's segment weights (`n` = 3
    /// residuals per chained-equivalent segment, `k` = fitted parameters).
    pub bic_full: f64,
    /// Every reduced model fitted, with its criterion on the same segments.
    pub candidates: Vec<(Reduction, ReducedFit, f64)>,
    /// The criterion of the model selected with all five parameters free
    /// (its variable terms included) and of the one selected holding the
    /// best reduced set, when a reduced set beat the full constant one:
    /// the lower decides `selected`.
    pub selected_bics: Option<(f64, f64)>,
    /// Why no reduced model was fitted, when none was.
    pub reason: Option<String>,
}

impl ReductionChoice {
    /// No reduced model fitted, for `reason`.
    pub fn not_tried(reason: &str) -> Self {
        Self {
            selected: Reduction::NONE,
            bic_full: f64::NAN,
            candidates: Vec::new(),
            selected_bics: None,
            reason: Some(reason.into()),
        }
    }

    /// The selected reduced fit, `None` for the full model.
    pub fn fit(&self) -> Option<&ReducedFit> {
        self.candidates
            .iter()
            .find(|c| c.0 == self.selected && !self.selected.is_none())
            .map(|c| &c.1)
    }

    /// The criterion of the best reduced constant set (the full set's when
    /// none is fitted).
    pub fn bic_reduced(&self) -> f64 {
        self.candidates
            .iter()
            .map(|c| c.2)
            .fold(self.bic_full, f64::min)
    }

    /// The `reduction` entry of the parameter file.
    pub fn to_json(&self) -> Value {
        if let Some(r) = &self.reason {
            return json!({"selected": self.selected.describe(), "reason": r});
        }
        let candidates: Vec<Value> = self
            .candidates
            .iter()
            .map(|(r, f, b)| {
                json!({
                    "holds": r.describe(),
                    "bic": b,
                    "cost": f.sse,
                    "parameters": f.n_free,
                })
            })
            .collect();
        let mut v = json!({
            "selected": self.selected.describe(),
            "criterion": "lowest BIC n ln(J/n) + k ln n over the full fit's segments, \
                          of the selected model with and without the best reduced set",
            "bic_full": self.bic_full,
            "candidates": candidates,
        });
        if let Some((full, reduced)) = self.selected_bics {
            v["bic_selected_full"] = json!(full);
            v["bic_selected_reduced"] = json!(reduced);
        }
        v
    }

    /// One line for the CLI's report.
    pub fn summary(&self) -> String {
        if let Some(r) = &self.reason {
            return format!("reduced models: none tried, {r}");
        }
        let best = self.bic_reduced();
        match (self.selected.is_none(), self.selected_bics) {
            (true, None) => format!(
                "reduced models: all five parameters kept (BIC {:.1}; best reduced set {best:.1})",
                self.bic_full
            ),
            (true, Some((full, reduced))) => format!(
                "reduced models: all five parameters kept: the selected model's BIC {full:.1} \
                 against {reduced:.1} holding the best reduced set (constant sets: {:.1} \
                 and {best:.1})",
                self.bic_full
            ),
            (false, b) => format!(
                "reduced models: holds {} (BIC {best:.1} against {:.1} with all five free; \
                 selected models {}): the data do not pay for the parameters it removes",
                self.selected.describe(),
                self.bic_full,
                b.map_or(String::new(), |(f, r)| format!("{r:.1} against {f:.1}"))
            ),
        }
    }
}

/// Fits every reduced model that bears on fitted parameters the full
/// winner `best` leaves unresolved ([`Reduction::unresolved`]), from it,
/// over the full fit's segment weights, and selects the lowest information
/// criterion (the full model on ties).
pub(super) fn choose_reduction(
    segs: &Segments,
    best: &MethodFit,
    weights: &[f64],
    yaw_weight: f64,
    lm_cfg: &LmConfig,
    coverage: f64,
) -> ReductionChoice {
    let n = evidence(weights, coverage);
    let k = lm_cfg.free.iter().filter(|&&f| f).count();
    let bic_full = bic(
        model::cost(&best.params, segs, weights, yaw_weight) / coverage,
        k as f64,
        n,
    );
    let mut candidates = Vec::new();
    for r in Reduction::all() {
        if r.is_none() || !r.applies_to(lm_cfg.free) || !r.unresolved(&best.std) {
            continue;
        }
        if let Some(f) = lm::fit_reduced(
            segs,
            &best.params,
            weights,
            yaw_weight,
            &lm_cfg.free,
            r,
            lm_cfg.max_iterations,
        ) {
            let b = bic(f.sse / coverage, f.n_free as f64, n);
            candidates.push((r, f, b));
        }
    }
    if candidates.is_empty() {
        return ReductionChoice::not_tried(
            "the full fit resolves every parameter a relation would remove \
             (1-sigma under 0.05 m for the ICRs, 0.01 for the speed factors)",
        );
    }
    let selected = candidates
        .iter()
        .filter(|c| c.2 < bic_full)
        .min_by(|a, b| a.2.total_cmp(&b.2))
        .map_or(Reduction::NONE, |c| c.0);
    ReductionChoice {
        selected,
        bic_full,
        candidates,
        selected_bics: None,
        reason: None,
    }
}

/// `best` under the selected reduction: its parameters, costs and 1-sigma
/// those of the reduced fit (the method stays the one whose answer it
/// started from).
pub(super) fn reduced_best(
    best: &MethodFit,
    fit: &ReducedFit,
    segs: &Segments,
    (inlier, ones): (&[bool], &[f64]),
    yaw_weight: f64,
    cauchy: f64,
) -> MethodFit {
    MethodFit {
        method: best.method,
        params: fit.params,
        cost: model::cost(&fit.params, segs, ones, yaw_weight),
        robust_cost: model::robust_cost(&fit.params, segs, inlier, yaw_weight, cauchy),
        std: fit.std,
    }
}
