//! Learned speed normalisation of the amplitude-like vibration features.
//!
//! Within one terrain the vibration energy grows with the tread speed
//! (about v¹ for the Husky's temporal band powers, see
//! docs/research-log.md). A tree ensemble sees the speed as a feature but can
//! only split on speeds it was trained at: a run faster than every training
//! run of its terrain looks like a rougher terrain. Here each amplitude-like
//! feature (log variance, log band powers, log σ per speed) gets one slope
//! on ln v, fitted on the training windows *within* terrains (a regression
//! with one intercept per class and one slope shared by all classes), and
//! the classifier is fed `x − slope · ln(v / v_ref)`: the feature as it
//! would read at `v_ref`, a linear extrapolation in ln v that trees
//! cannot do by itself.

use serde::{Deserialize, Serialize};

use crate::current::CurrentBaseline;
use crate::error::{Result, TerrainError};

/// Name of the feature holding the window's mean tread speed, m/s.
pub const SPEED_FEATURE: &str = "tread_speed";

/// Whether the feature named `name` is a log amplitude that grows with speed:
/// per-channel log variance, log band powers (not their shares),
/// log(σ_az / v) and the log motor-current features.
pub fn is_amplitude_like(name: &str) -> bool {
    if name == "log_az_std_per_speed"
        || name.ends_with("_log_var")
        || name.starts_with("current_log_")
    {
        return true;
    }
    if name.ends_with("_share") {
        return false;
    }
    // `accel_z_band3`: the part after the last `band` is a number.
    name.rfind("band").is_some_and(|i| {
        let rest = &name[i + 4..];
        !rest.is_empty() && rest.bytes().all(|b| b.is_ascii_digit())
    })
}

/// Per-feature slopes on ln(tread speed), fitted on training windows.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpeedNormalisation {
    /// Speed the features are mapped to, m/s.
    pub v_ref: f64,
    /// Speeds below this (m/s; standing, slow spins) are taken as this, so
    /// that ln v stays bounded; the fit uses only windows at least this fast.
    pub v_min: f64,
    /// Index of [`SPEED_FEATURE`] in the feature vector.
    pub speed_index: usize,
    /// d feature / d ln v per feature (for log powers: the speed elasticity);
    /// 0 for features that are not normalised.
    pub slopes: Vec<f64>,
    /// The robot's current at a speed and turn, subtracted from
    /// `current_excess` (models with currents and slip terms; `null`
    /// otherwise).
    #[serde(default)]
    pub current_baseline: Option<CurrentBaseline>,
}

impl SpeedNormalisation {
    /// Fits the pooled within-class slopes of the amplitude-like features
    /// among `names` on the windows `x` (labels `y` < `n_classes`) whose
    /// speed is at least `v_min`. A feature without speed spread within any
    /// class gets slope 0.
    pub fn fit(
        x: &[Vec<f64>],
        y: &[usize],
        n_classes: usize,
        names: &[String],
        v_ref: f64,
        v_min: f64,
    ) -> Result<Self> {
        if !(v_ref.is_finite() && v_ref > 0.0 && v_min.is_finite() && v_min > 0.0) {
            return Err(TerrainError::Config(format!(
                "speed normalisation needs positive speeds, got v_ref {v_ref} m/s, v_min {v_min} m/s"
            )));
        }
        let speed_index = names
            .iter()
            .position(|n| n == SPEED_FEATURE)
            .ok_or_else(|| {
                TerrainError::Config(
                    "speed normalisation needs the `full` vibration feature set (tread speed)"
                        .into(),
                )
            })?;
        let d = names.len();
        let mask: Vec<bool> = names.iter().map(|n| is_amplitude_like(n)).collect();
        // Per class: count, Σ u, Σ x_j over the windows used (u = ln v).
        let mut count = vec![0.0f64; n_classes];
        let mut su = vec![0.0f64; n_classes];
        let mut sx = vec![vec![0.0f64; d]; n_classes];
        let used = |row: &Vec<f64>| {
            let v = row.get(speed_index).copied().unwrap_or(f64::NAN);
            v.is_finite() && v >= v_min && row.len() == d && row.iter().all(|f| f.is_finite())
        };
        for (row, &c) in x.iter().zip(y) {
            if c >= n_classes || !used(row) {
                continue;
            }
            count[c] += 1.0;
            su[c] += row[speed_index].ln();
            for (s, f) in sx[c].iter_mut().zip(row) {
                *s += f;
            }
        }
        let mut suu = 0.0;
        let mut sux = vec![0.0f64; d];
        for (row, &c) in x.iter().zip(y) {
            if c >= n_classes || !used(row) {
                continue;
            }
            let du = row[speed_index].ln() - su[c] / count[c];
            suu += du * du;
            for j in (0..d).filter(|&j| mask[j]) {
                sux[j] += du * (row[j] - sx[c][j] / count[c]);
            }
        }
        let slopes = (0..d)
            .map(|j| {
                let b = if mask[j] && suu > 1e-9 {
                    sux[j] / suu
                } else {
                    0.0
                };
                if b.is_finite() {
                    b
                } else {
                    0.0
                }
            })
            .collect();
        Ok(Self {
            v_ref,
            v_min,
            speed_index,
            slopes,
            current_baseline: CurrentBaseline::fit(x, names, speed_index, v_ref, v_min),
        })
    }

    /// Maps one feature vector to the reference speed, in place. A speed
    /// that is not finite leaves the vector unchanged (never NaN).
    pub fn apply(&self, x: &mut [f64]) {
        let Some(&v) = x.get(self.speed_index) else {
            return;
        };
        if !v.is_finite() {
            return;
        }
        let u = (v.max(self.v_min) / self.v_ref).ln();
        if let Some(c) = &self.current_baseline {
            c.apply(x, u);
        }
        for (f, b) in x.iter_mut().zip(&self.slopes) {
            *f -= b * u;
        }
    }

    /// Consistency with a model's feature list (for loading).
    pub fn check(&self, names: &[String]) -> std::result::Result<(), String> {
        if !(self.v_ref.is_finite()
            && self.v_ref > 0.0
            && self.v_min.is_finite()
            && self.v_min > 0.0)
        {
            return Err("speed normalisation: speeds must be positive".into());
        }
        if self.slopes.len() != names.len()
            || names.get(self.speed_index).map(String::as_str) != Some(SPEED_FEATURE)
        {
            return Err("speed normalisation does not match the feature list".into());
        }
        if self.slopes.iter().any(|b| !b.is_finite()) {
            return Err("speed normalisation has a non-finite slope".into());
        }
        let wants_baseline = names.iter().any(|n| n == crate::current::EXCESS_FEATURE);
        match &self.current_baseline {
            Some(c) => c.check(names)?,
            None if wants_baseline => {
                return Err(
                    "the features hold current_excess but the model has no current baseline".into(),
                )
            }
            None => {}
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names() -> Vec<String> {
        [
            "accel_z_log_var",
            "accel_z_zcr",
            "accel_z_band0",
            "accel_z_band0_share",
            "current_log_mean",
            "tread_speed",
            "log_az_std_per_speed",
        ]
        .map(String::from)
        .to_vec()
    }

    #[test]
    fn amplitude_like_features_are_the_log_powers() {
        let mask: Vec<bool> = names().iter().map(|n| is_amplitude_like(n)).collect();
        assert_eq!(mask, [true, false, true, false, true, false, true]);
        assert!(!is_amplitude_like("tread_speed_diff"));
        assert!(!is_amplitude_like("accel_z_band"));
        assert!(!is_amplitude_like("current_hf_share"));
    }

    /// Two terrains whose log power grows as 1.5 ln v, at disjoint speeds
    /// (class 0 slow, class 1 fast) and offsets 0 and 2: the pooled
    /// within-class slope is 1.5 (a fit across classes would mix in the
    /// offset), and the normalised feature no longer depends on speed.
    #[test]
    fn pooled_within_class_slope_removes_the_speed_trend() {
        let row = |v: f64, offset: f64| -> Vec<f64> {
            let p = offset + 1.5 * v.ln();
            vec![p, 0.3, p - 1.0, 0.5, p, v, 7.0]
        };
        let mut x = Vec::new();
        let mut y = Vec::new();
        for i in 0..20 {
            x.push(row(0.1 + 0.01 * i as f64, 0.0));
            y.push(0);
            x.push(row(0.5 + 0.03 * i as f64, 2.0));
            y.push(1);
        }
        // A standing window is left out of the fit.
        x.push(vec![-30.0, 0.0, -30.0, 0.0, -30.0, 0.0, 7.0]);
        y.push(0);
        let sn = SpeedNormalisation::fit(&x, &y, 2, &names(), 0.5, 0.1).unwrap();
        let expect = [1.5, 0.0, 1.5, 0.0, 1.5, 0.0, 0.0];
        for (b, e) in sn.slopes.iter().zip(expect) {
            assert!((b - e).abs() < 1e-9, "{:?}", sn.slopes);
        }
        assert_eq!(sn.speed_index, 5);
        let mut slow = row(0.12, 0.0);
        let mut fast = row(1.0, 0.0);
        sn.apply(&mut slow);
        sn.apply(&mut fast);
        assert!((slow[0] - fast[0]).abs() < 1e-9 && (slow[0] - 1.5 * 0.5f64.ln()).abs() < 1e-9);
        assert_eq!((slow[1], slow[5]), (0.3, 0.12));
        assert!(sn.check(&names()).is_ok());
    }

    #[test]
    fn standing_and_broken_speeds_stay_finite() {
        let sn = SpeedNormalisation {
            v_ref: 0.5,
            v_min: 0.1,
            speed_index: 5,
            slopes: vec![1.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0],
            current_baseline: None,
        };
        for v in [0.0, -0.3, 1e-300] {
            let mut x = vec![1.0, 1.0, 1.0, 1.0, 1.0, v, 1.0];
            sn.apply(&mut x);
            // Clamped to v_min: ln(0.1 / 0.5) = −1.609.
            assert!((x[0] - (1.0 + 5f64.ln())).abs() < 1e-12, "{x:?}");
        }
        for v in [f64::NAN, f64::INFINITY] {
            let mut x = vec![1.0, 1.0, 1.0, 1.0, 1.0, v, 1.0];
            sn.apply(&mut x);
            assert_eq!(x[0], 1.0);
        }
        // Short vectors are left alone rather than indexed out of bounds.
        let mut short = vec![1.0; 3];
        sn.apply(&mut short);
        assert_eq!(short, vec![1.0; 3]);
    }

    #[test]
    fn fit_failure_modes() {
        let x = vec![vec![0.0; 7]; 4];
        let y = vec![0, 0, 1, 1];
        // No tread speed feature (paper set).
        let paper: Vec<String> = ["a", "b"].map(String::from).to_vec();
        assert!(SpeedNormalisation::fit(&x, &y, 2, &paper, 0.5, 0.1).is_err());
        for (r, m) in [(0.0, 0.1), (0.5, f64::NAN), (-1.0, 0.1)] {
            assert!(SpeedNormalisation::fit(&x, &y, 2, &names(), r, m).is_err());
        }
        // Every window below v_min: nothing to fit, all slopes 0.
        let sn = SpeedNormalisation::fit(&x, &y, 2, &names(), 0.5, 0.1).unwrap();
        assert!(sn.slopes.iter().all(|&b| b == 0.0));
        // A file whose slopes do not match the features is refused.
        let mut bad = sn.clone();
        bad.slopes.pop();
        assert!(bad.check(&names()).is_err());
        let mut bad = sn;
        bad.slopes[0] = f64::NAN;
        assert!(bad.check(&names()).is_err());
    }
}
