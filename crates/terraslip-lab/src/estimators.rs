//! Estimators by name: presets, or `config:FILE.toml`.

use anyhow::Context;
use terraslip::config::EstimatorConfig;

/// `(name, configuration)` of each name.
pub fn resolve(names: &[String]) -> anyhow::Result<Vec<(String, EstimatorConfig)>> {
    names
        .iter()
        .map(|n| {
            let c = match n.strip_prefix("config:") {
                Some(path) => config_file(std::path::Path::new(path))?,
                None => EstimatorConfig::preset(n).with_context(|| {
                    let known: Vec<&str> = EstimatorConfig::presets().iter().map(|p| p.0).collect();
                    format!("unknown estimator `{n}` (presets: {})", known.join(", "))
                })?,
            };
            Ok((n.clone(), c))
        })
        .collect()
}

/// An estimator configuration file (TOML, as `terraslip estimate --config`).
pub fn config_file(path: &std::path::Path) -> anyhow::Result<EstimatorConfig> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    EstimatorConfig::from_toml(&text).with_context(|| path.display().to_string())
}
