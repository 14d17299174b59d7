//! The calibrated-parameters file: what `terraslip calibrate` writes and
//! `terraslip estimate --init` reads. JSON, the same shape as
//! `calibrate --json`:
//!
//! ```json
//! {"params": {"y_l": 0.3, "y_r": -0.3, "x_c": 0.0, "alpha_l": 1.0, "alpha_r": 1.0}, "cost": 0.1,
//!  "terrains": {"asphalt": {"params": {...}, "cost": 0.05}}}
//! ```
//!
//! `params` (all terrains pooled) and `terrains` are each optional, but at
//! least one must be present. Unknown fields are ignored so later versions
//! can add uncertainties and indexes.

use std::collections::BTreeMap;
use std::path::Path;

use serde::{Deserialize, Serialize};
use terraslip_core::IcrParams;

use crate::LogError;

/// One identified parameter set with its fit quality.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParamEntry {
    pub params: IcrParams,
    /// Fit cost (Mandow eq. 13 over the segments used), if known.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cost: Option<f64>,
    /// Any further per-set information (uncertainties, indexes, method...).
    #[serde(flatten)]
    pub extra: BTreeMap<String, serde_json::Value>,
}

impl ParamEntry {
    pub fn new(params: IcrParams) -> Self {
        Self {
            params,
            cost: None,
            extra: BTreeMap::new(),
        }
    }
}

/// The turn-rate model `terraslip calibrate` stores beside a set's constant
/// ICRs under the key `rate_model` (see `docs/calibration.md`): the
/// straight-line ICRs (body frame, m) and the slopes of the law
/// `terraslip_core::kinematics::TurnRateSlopes` (s/m), plus the optional
/// traction slopes (s^2/m) and centripetal slopes
/// (`terraslip_core::kinematics::CentripetalSlopes`: `k_x_speed` in s,
/// `k_spread_speed` in s/m), each 0 when absent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RateModelEntry {
    pub params: IcrParams,
    pub k_spread: f64,
    pub k_alpha: f64,
    pub k_acc: f64,
    pub k_dir: f64,
    pub k_x_speed: f64,
    pub k_spread_speed: f64,
}

impl RateModelEntry {
    /// The set's `rate_model` (`extra` of a [`ParamEntry`] or of the pooled
    /// set) when calibration selected it; `Ok(None)` when it is absent or
    /// not selected. A selected but malformed one is `Err(reason)`, for
    /// the caller to name the set.
    pub fn selected(extra: &BTreeMap<String, serde_json::Value>) -> Result<Option<Self>, String> {
        let Some(r) = extra.get("rate_model") else {
            return Ok(None);
        };
        if r.get("selected") != Some(&serde_json::Value::Bool(true)) {
            return Ok(None);
        }
        let num = |v: &serde_json::Value, key: &str| {
            v.get(key)
                .and_then(|x| x.as_f64())
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("`{key}` is missing or not a finite number"))
        };
        let optional = |key: &str| match r.get(key) {
            None | Some(serde_json::Value::Null) => Ok(0.0),
            Some(_) => num(r, key),
        };
        let q = r.get("params").ok_or("`params` is missing")?;
        let params = IcrParams {
            y_l: num(q, "y_l")?,
            y_r: num(q, "y_r")?,
            x_c: num(q, "x_c")?,
            alpha_l: num(q, "alpha_l")?,
            alpha_r: num(q, "alpha_r")?,
        };
        check_physical(&params).map_err(|e| format!("params.{e}"))?;
        Ok(Some(Self {
            params,
            k_spread: num(r, "k_spread")?,
            k_alpha: num(r, "k_alpha")?,
            k_acc: optional("k_acc")?,
            k_dir: optional("k_dir")?,
            k_x_speed: optional("k_x_speed")?,
            k_spread_speed: optional("k_spread_speed")?,
        }))
    }
}

/// Largest |y_l|, |y_r|, |x_c| a skid-steering robot's ICRs can have, m.
pub const MAX_ICR_M: f64 = 20.0;
/// Largest tread speed factor alpha.
pub const MAX_ALPHA: f64 = 5.0;

/// Checks one parameter set against physical ranges: ICR coordinates
/// within ±[`MAX_ICR_M`], the left ICR left of the right one (spread
/// `y_l - y_r` at least [`terraslip_core::kinematics::MIN_SPREAD`]) and
/// `alpha` in (0, [`MAX_ALPHA`]]. The error starts with the field's name.
pub fn check_physical(p: &IcrParams) -> Result<(), String> {
    let fix = "fix the file or calibrate again";
    for (name, v) in [("y_l", p.y_l), ("y_r", p.y_r), ("x_c", p.x_c)] {
        if !v.is_finite() || v.abs() > MAX_ICR_M {
            return Err(format!(
                "{name} = {v} is outside [-{MAX_ICR_M}, {MAX_ICR_M}] m; {fix}"
            ));
        }
    }
    for (name, v) in [("alpha_l", p.alpha_l), ("alpha_r", p.alpha_r)] {
        if !(v > 0.0 && v <= MAX_ALPHA) {
            return Err(format!("{name} = {v} is outside (0, {MAX_ALPHA}]; {fix}"));
        }
    }
    p.validate()
        .map_err(|e| format!("y_l, y_r: {e} (y_l must be left of y_r); {fix}"))
}

/// Calibrated parameters: a pooled set and/or one set per terrain.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct ParamsFile {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub params: Option<IcrParams>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cost: Option<f64>,
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub terrains: BTreeMap<String, ParamEntry>,
    #[serde(flatten)]
    pub extra: BTreeMap<String, serde_json::Value>,
}

impl ParamsFile {
    /// What the calibration that wrote the file warned about (its
    /// `warnings`: fits at a limit, a time offset at the edge of its
    /// search), for whoever uses the parameters to hear it too.
    pub fn warnings(&self) -> Vec<String> {
        match self.extra.get("warnings") {
            Some(serde_json::Value::Array(items)) => items
                .iter()
                .map(|w| match w {
                    serde_json::Value::String(s) => s.clone(),
                    other => other.to_string(),
                })
                .collect(),
            _ => Vec::new(),
        }
    }

    /// Reads and validates a parameters file.
    pub fn read(path: &Path) -> Result<Self, LogError> {
        let text = std::fs::read_to_string(path).map_err(|e| LogError::io(path, e))?;
        Self::parse(&text, path)
    }

    /// Parses and validates the JSON text of a parameters file; `path`
    /// names it in errors.
    pub fn parse(text: &str, path: &Path) -> Result<Self, LogError> {
        let pf: ParamsFile = serde_json::from_str(text).map_err(|e| LogError::Parse {
            path: path.to_path_buf(),
            line: e.line() as u64,
            reason: format!(
                "{e}; expected a parameters file as `terraslip calibrate` writes it \
                 (docs/calibration.md)"
            ),
        })?;
        let invalid = |reason: String| LogError::Invalid {
            path: path.to_path_buf(),
            reason,
        };
        if pf.params.is_none() && pf.terrains.is_empty() {
            return Err(invalid(
                "neither `params` nor `terrains` is present; give at least one \
                 (docs/calibration.md)"
                    .into(),
            ));
        }
        let checked = |set: String, p: &IcrParams, extra: &BTreeMap<String, serde_json::Value>| {
            check_physical(p).map_err(|e| invalid(format!("{set}params.{e}")))?;
            RateModelEntry::selected(extra)
                .map_err(|e| invalid(format!("{set}rate_model: {e}")))
                .map(drop)
        };
        if let Some(p) = &pf.params {
            checked(String::new(), p, &pf.extra)?;
        }
        for (name, e) in &pf.terrains {
            checked(format!("terrains.{name}."), &e.params, &e.extra)?;
        }
        Ok(pf)
    }

    /// Writes the file atomically as pretty JSON.
    pub fn write(&self, path: &Path) -> Result<(), LogError> {
        let text = serde_json::to_string_pretty(self).map_err(|e| LogError::Invalid {
            path: path.to_path_buf(),
            reason: e.to_string(),
        })?;
        crate::write_atomic(path, text.as_bytes())
    }

    /// The set for `terrain`, falling back to the pooled set.
    pub fn for_terrain(&self, terrain: Option<&str>) -> Option<IcrParams> {
        terrain
            .and_then(|t| self.terrains.get(t))
            .map(|e| e.params)
            .or(self.params)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn extra(v: serde_json::Value) -> BTreeMap<String, serde_json::Value> {
        BTreeMap::from([("rate_model".to_string(), v)])
    }

    #[test]
    fn rate_model_is_read_only_when_selected_and_well_formed() {
        let q = json!({"y_l": 0.3, "y_r": -0.3, "x_c": 0.0, "alpha_l": 0.9, "alpha_r": 0.95});
        assert_eq!(RateModelEntry::selected(&BTreeMap::new()), Ok(None));
        let off = json!({"selected": false, "params": q, "k_spread": 0.1, "k_alpha": 0.0});
        assert_eq!(RateModelEntry::selected(&extra(off)), Ok(None));
        // Files from before the traction term: k_acc / k_dir read as 0.
        let on = json!({"selected": true, "params": q, "k_spread": -0.1, "k_alpha": 0.02});
        let r = RateModelEntry::selected(&extra(on))
            .expect("well formed")
            .expect("selected");
        assert_eq!(
            (r.k_spread, r.k_alpha, r.k_acc, r.k_dir),
            (-0.1, 0.02, 0.0, 0.0)
        );
        assert_eq!(r.params.alpha_r, 0.95);
        let bad_slope = json!({"selected": true, "params": q, "k_spread": "x", "k_alpha": 0.0});
        let e = RateModelEntry::selected(&extra(bad_slope)).expect_err("malformed");
        assert!(e.contains("k_spread"), "{e}");
        let bad_acc =
            json!({"selected": true, "params": q, "k_spread": 0.0, "k_alpha": 0.0, "k_acc": "x"});
        assert!(RateModelEntry::selected(&extra(bad_acc))
            .expect_err("malformed")
            .contains("k_acc"));
        // The centripetal slopes, read back as written.
        let centripetal = json!({"selected": true, "params": q, "k_spread": 0.0, "k_alpha": 0.0,
            "k_x_speed": 0.12, "k_spread_speed": -0.04});
        let r = RateModelEntry::selected(&extra(centripetal))
            .expect("well formed")
            .expect("selected");
        assert_eq!((r.k_x_speed, r.k_spread_speed), (0.12, -0.04));
        let bad_speed = json!({"selected": true, "params": q, "k_spread": 0.0, "k_alpha": 0.0,
            "k_x_speed": "x"});
        assert!(RateModelEntry::selected(&extra(bad_speed))
            .expect_err("malformed")
            .contains("k_x_speed"));
        let crossed = json!({"selected": true, "k_spread": 0.0, "k_alpha": 0.0,
            "params": {"y_l": -0.3, "y_r": 0.3, "x_c": 0.0, "alpha_l": 1.0, "alpha_r": 1.0}});
        assert!(RateModelEntry::selected(&extra(crossed))
            .expect_err("invalid ICRs")
            .starts_with("params.y_l, y_r:"));
        let no_params = json!({"selected": true, "k_spread": 0.0, "k_alpha": 0.0});
        assert!(RateModelEntry::selected(&extra(no_params))
            .expect_err("missing")
            .contains("params"));
    }
}
