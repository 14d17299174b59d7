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
    /// Reads and validates a parameters file.
    pub fn read(path: &Path) -> Result<Self, LogError> {
        let text = std::fs::read_to_string(path).map_err(|e| LogError::io(path, e))?;
        let pf: ParamsFile = serde_json::from_str(&text).map_err(|e| LogError::Parse {
            path: path.to_path_buf(),
            line: e.line() as u64,
            reason: e.to_string(),
        })?;
        let invalid = |reason: String| LogError::Invalid {
            path: path.to_path_buf(),
            reason,
        };
        if pf.params.is_none() && pf.terrains.is_empty() {
            return Err(invalid("neither `params` nor `terrains` is present".into()));
        }
        if let Some(p) = &pf.params {
            p.validate().map_err(|e| invalid(format!("params: {e}")))?;
        }
        for (name, e) in &pf.terrains {
            e.params
                .validate()
                .map_err(|err| invalid(format!("terrains.{name}: {err}")))?;
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
