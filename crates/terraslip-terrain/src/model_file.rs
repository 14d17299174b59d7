//! The model file: JSON, written atomically, its version checked before
//! anything else and its consistency after.

use std::path::Path;

use terraslip_core::terrain_belief::MAX_TERRAINS;

use crate::classify::Classifier;
use crate::error::{Result, TerrainError};
use crate::features::Features;
use crate::model::{Source, TerrainModel, MODEL_FORMAT_VERSION};

impl TerrainModel {
    /// Writes the model as JSON, atomically.
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        let path = path.as_ref();
        let json = serde_json::to_vec_pretty(self).map_err(|e| TerrainError::ModelFile {
            path: path.to_path_buf(),
            reason: e.to_string(),
        })?;
        terraslip_io::write_atomic(path, &json).map_err(|e| TerrainError::ModelFile {
            path: path.to_path_buf(),
            reason: e.to_string(),
        })
    }

    /// Reads a model, refusing other format versions and inconsistent files.
    pub fn load(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let err = |reason: String| TerrainError::ModelFile {
            path: path.to_path_buf(),
            reason,
        };
        let text = std::fs::read_to_string(path).map_err(|e| err(e.to_string()))?;
        // Check the version before the full parse, so that a file of another
        // version says so instead of failing on some renamed field.
        let value: serde_json::Value = serde_json::from_str(&text)
            .map_err(|e| err(format!("not a terrain model (JSON error: {e})")))?;
        let found = value
            .get("format_version")
            .and_then(|v| v.as_u64())
            .ok_or_else(|| err("not a terrain model: no `format_version`".into()))?;
        if found != MODEL_FORMAT_VERSION as u64 {
            return Err(TerrainError::ModelVersion {
                path: path.to_path_buf(),
                found: found.min(u32::MAX as u64) as u32,
                expected: MODEL_FORMAT_VERSION,
            });
        }
        let model: Self =
            serde_json::from_value(value).map_err(|e| err(format!("bad terrain model: {e}")))?;
        model
            .validate()
            .map_err(|e| err(format!("{e}; retrain it with `terraslip terrain train`")))?;
        Ok(model)
    }

    /// Reads a model that must classify exactly `classes` (in any order).
    pub fn load_for_classes(path: impl AsRef<Path>, classes: &[String]) -> Result<Self> {
        let m = Self::load(path)?;
        m.check_classes(classes)?;
        Ok(m)
    }

    /// Fails unless the model's classes are `classes` (in any order).
    pub fn check_classes(&self, classes: &[String]) -> Result<()> {
        let mut a = self.classes.clone();
        let mut b = classes.to_vec();
        a.sort();
        b.sort();
        if a != b {
            return Err(TerrainError::ClassMismatch {
                model: self.classes.clone(),
                expected: classes.to_vec(),
            });
        }
        Ok(())
    }

    fn validate(&self) -> std::result::Result<(), String> {
        let k = self.classes.len();
        if !(2..=MAX_TERRAINS).contains(&k) {
            return Err(format!("{k} classes; a model needs 2..={MAX_TERRAINS}"));
        }
        check_class_names(&self.classes)?;
        let d = self.feature_names.len();
        if self.normalisation.mean.len() != d || self.normalisation.std.len() != d {
            return Err("normalisation does not match the feature list".into());
        }
        let expected = match &self.features {
            Features::Vibration { config, .. } => config.feature_names(),
            Features::Vision { config, .. } => config.feature_names(),
        };
        if expected != self.feature_names {
            return Err("feature list does not match the feature settings".into());
        }
        let wants_slopes =
            matches!(&self.features, Features::Vibration { config, .. } if config.speed_norm);
        match &self.speed_normalisation {
            Some(sn) if wants_slopes => sn.check(&self.feature_names)?,
            None if !wants_slopes => {}
            Some(_) => return Err("speed slopes in a model trained without speed_norm".into()),
            None => return Err("speed_norm is set but the model holds no speed slopes".into()),
        }
        match (&self.envelope, &self.features) {
            (Some(e), Features::Vibration { .. }) => e.check(k)?,
            (None, _) => {}
            (Some(_), _) => return Err("a manoeuvre envelope in a camera model".into()),
        }
        if let Some(cd) = &self.class_distance {
            cd.check(k, d)?;
        }
        let source_ok = matches!(
            (&self.features, self.source),
            (Features::Vibration { .. }, Source::Imu) | (Features::Vision { .. }, Source::Camera)
        );
        if !source_ok {
            return Err(format!(
                "source `{}` does not match the features",
                self.source.name()
            ));
        }
        if self
            .normalisation
            .std
            .iter()
            .any(|s| !(s.is_finite() && *s > 0.0))
        {
            return Err("normalisation has a non-positive scale".into());
        }
        if self.normalisation.mean.iter().any(|m| !m.is_finite()) {
            return Err("normalisation has a non-finite mean".into());
        }
        check_classifier(&self.classifier, k, d)
    }
}

/// Class names must be distinct and non-empty.
fn check_class_names(classes: &[String]) -> std::result::Result<(), String> {
    for (i, c) in classes.iter().enumerate() {
        if c.trim().is_empty() {
            return Err(format!("classes[{i}] is empty; every class needs a name"));
        }
        if let Some(j) = classes[..i].iter().position(|o| o == c) {
            return Err(format!(
                "classes[{j}] and classes[{i}] are both `{c}`; each class must appear once"
            ));
        }
    }
    Ok(())
}

/// Child links of node `i` of a tree of `len` nodes point to later nodes
/// (so that every walk ends at a leaf).
fn forward(i: usize, len: usize, left: u32, right: u32) -> bool {
    let ok = |c: u32| (c as usize) > i && (c as usize) < len;
    ok(left) && ok(right)
}

/// The classifier must fit `k` classes and `d` features: no empty tree or
/// neighbour set, child links that point forward inside each tree, split
/// features that exist, and probabilities in [0, 1] summing to 1.
fn check_classifier(c: &Classifier, k: usize, d: usize) -> std::result::Result<(), String> {
    match c {
        Classifier::Tree(t) => {
            if t.nodes.is_empty() {
                return Err("classifier: the tree has no nodes".into());
            }
            for (i, n) in t.nodes.iter().enumerate() {
                let at = format!("classifier: tree node {i}");
                if n.probs.len() != k {
                    return Err(format!(
                        "{at}: {} probabilities for {k} classes",
                        n.probs.len()
                    ));
                }
                if n.probs.iter().any(|p| !(0.0..=1.0).contains(p)) {
                    return Err(format!("{at}: a probability is outside [0, 1]"));
                }
                if (n.probs.iter().sum::<f64>() - 1.0).abs() > 1e-3 {
                    return Err(format!("{at}: probabilities do not sum to 1"));
                }
                if n.left != 0
                    && !(forward(i, t.nodes.len(), n.left, n.right) && (n.feature as usize) < d)
                {
                    return Err(format!(
                        "{at}: child links or split feature out of the tree"
                    ));
                }
            }
            Ok(())
        }
        Classifier::Knn(knn) => {
            if knn.x.is_empty() || knn.x.len() != knn.y.len() || knn.k == 0 {
                return Err("classifier: k-NN needs k >= 1 and one class per stored sample".into());
            }
            if !knn.y.iter().all(|&c| c < k)
                || !knn
                    .x
                    .iter()
                    .all(|r| r.len() == d && r.iter().all(|v| v.is_finite()))
            {
                return Err("classifier: k-NN samples do not match the classes or features".into());
            }
            Ok(())
        }
        Classifier::Boost(b) => {
            if b.trees.is_empty() || b.trees.iter().any(|t| t.is_empty()) {
                return Err("classifier: the boosted ensemble has an empty tree".into());
            }
            let links = b.trees.iter().all(|t| {
                t.iter()
                    .enumerate()
                    .all(|(i, n)| n.left == 0 || forward(i, t.len(), n.left, n.right))
            });
            if !(links && b.is_consistent(k, d) && b.base.iter().all(|v| v.is_finite())) {
                return Err(
                    "classifier: boosted trees do not match the classes or features".into(),
                );
            }
            Ok(())
        }
    }
}
