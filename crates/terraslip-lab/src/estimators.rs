//! Estimators by name: presets, or `config:FILE.toml`.

use anyhow::Context;
use terraslip::config::EstimatorConfig;

/// `(name, configuration)` of each name.
pub fn resolve(names: &[String]) -> anyhow::Result<Vec<(String, EstimatorConfig)>> {
    names
        .iter()
        .map(|n| {
            let c = match n.strip_prefix("config:") {
                Some(path) => {
                    let text = std::fs::read_to_string(path)
                        .with_context(|| format!("{path}: cannot read"))?;
                    EstimatorConfig::from_toml(&text).with_context(|| path.to_string())?
                }
                None => EstimatorConfig::preset(n).with_context(|| {
                    let known: Vec<&str> = EstimatorConfig::presets().iter().map(|p| p.0).collect();
                    format!("unknown estimator `{n}` (presets: {})", known.join(", "))
                })?,
            };
            Ok((n.clone(), c))
        })
        .collect()
}
