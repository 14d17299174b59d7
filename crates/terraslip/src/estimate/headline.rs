//! The lines `terraslip estimate` ends with, read from `summary.json`: the
//! whole drive's recommendation (or that nothing was learned), then the
//! headline figure, the 2 s prediction against the no-slip model.

use serde_json::Value;

/// Below this gain over the no-slip model (relative, of the mean 2 s
/// error) the learned model is only marginally better.
pub const MARGINAL_GAIN: f64 = 0.10;

fn with_std(v: &Value, digits: usize) -> Option<String> {
    let (x, s) = (v["value"].as_f64()?, v["std"].as_f64()?);
    Some(format!("{x:.digits$} ± {s:.digits$}"))
}

/// The closing lines of `estimate` (without the `estimate: ` counts line);
/// lines that are warnings start with `warning: `.
pub fn headline(summary: &Value) -> Vec<String> {
    let mut lines = Vec::new();
    let r = &summary["recommendation"];
    let l = |k: &str| with_std(&r[k], 3);
    let mut parts = Vec::new();
    if let (Some(a), Some(b)) = (l("alpha_l"), l("alpha_r")) {
        parts.push(format!("speed factors {a} / {b}"));
    }
    let c = &summary["controller"];
    let factor = |k: &str| {
        let v = serde_json::json!({"value": c[k], "std": c[format!("{k}_std")]});
        with_std(&v, 3)
    };
    if let Some(f) = factor("separation_factor") {
        parts.push(format!("separation factor {f}"));
    }
    if let Some(f) = factor("turn_factor") {
        parts.push(format!("turn factor {f}"));
    }
    if c.is_null() {
        if let Some(s) = l("spread_m") {
            parts.push(format!("spread {s} m"));
        }
    }
    if parts.is_empty() {
        lines.push(
            "whole drive: nothing learned (summary.json's `learning` says why); no correction to apply"
                .to_string(),
        );
    } else {
        lines.push(format!(
            "whole drive (1-sigma): {}; held where not named (`learning`)",
            parts.join(", ")
        ));
    }
    let p = &summary["prediction"];
    if let (Some(m), Some(n)) = (p["mean_m"].as_f64(), p["no_slip"]["mean_m"].as_f64()) {
        let gain = if n > 0.0 { 1.0 - m / n } else { 0.0 };
        lines.push(format!(
            "2 s prediction: {m:.3} m mean against {n:.3} m without slip ({:.0} % {}, {} starts)",
            100.0 * gain.abs(),
            if gain >= 0.0 { "better" } else { "worse" },
            p["segments"]
        ));
        if gain < MARGINAL_GAIN {
            lines.push(format!(
                "warning: the learned model predicts the 2 s motion {} than the no-slip model: its slip parameters are not clearly worth using on this robot and ground",
                if gain >= 0.0 {
                    format!("only {:.0} % better", 100.0 * gain)
                } else {
                    "worse".to_string()
                }
            ));
        }
    } else {
        lines.push("2 s prediction: none (summary.json's warnings say why)".to_string());
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_marginal_gain_is_warned_and_held_factors_are_not_shown() {
        let s = serde_json::json!({
            "recommendation": {"alpha_l": null, "alpha_r": null, "spread_m": null},
            "controller": {"separation_factor": null, "turn_factor": null},
            "prediction": {"mean_m": 0.554, "no_slip": {"mean_m": 0.570}, "segments": 334},
        });
        let lines = headline(&s);
        assert!(lines[0].contains("nothing learned"), "{lines:?}");
        assert!(lines[1].contains("0.554 m mean against 0.570 m without slip (3 % better"));
        assert!(lines[2].starts_with("warning: ") && lines[2].contains("only 3 % better"));
    }

    #[test]
    fn learned_factors_carry_their_std() {
        let s = serde_json::json!({
            "recommendation": {"alpha_l": {"value": 0.98, "std": 0.02}, "alpha_r": {"value": 0.97, "std": 0.02}},
            "controller": {"separation_factor": 0.94, "separation_factor_std": 0.013, "turn_factor": 0.954, "turn_factor_std": 0.022},
            "prediction": {"mean_m": 0.3, "no_slip": {"mean_m": 0.6}, "segments": 10},
        });
        let lines = headline(&s);
        assert!(lines[0].contains("speed factors 0.980 ± 0.020 / 0.970 ± 0.020"));
        assert!(lines[0].contains("turn factor 0.954 ± 0.022"));
        assert!(lines[1].contains("50 % better"));
        assert_eq!(lines.len(), 2);
    }
}
