//! What `summary.json` recommends: the whole drive's slip figures with
//! their uncertainty ([`crate::pipeline::recommend`]), and the controller's
//! factors made from them. A figure the drive did not teach (its group
//! held in `learning`) is `null`, never its starting value.

use serde_json::{json, Value};

use crate::pipeline::recommend::{DriveFigures, Figure};
use terraslip_core::IcrParams;

/// What `learning` says of each group (`"learned"` or `"held (why)"`).
struct Learning<'a> {
    spread: &'a str,
    difference: &'a str,
    speed: &'a str,
}

impl<'a> Learning<'a> {
    fn of(learning: &'a Value) -> Self {
        let state = |k: &str| learning[k].as_str().unwrap_or("held (not reported)");
        Self {
            spread: state("spread"),
            difference: state("speed_factor_difference"),
            speed: state("speed_factor"),
        }
    }

    /// The first group of `states` that is held, or "learned".
    fn all(states: &[&'a str]) -> &'a str {
        states
            .iter()
            .find(|s| **s != LEARNED)
            .copied()
            .unwrap_or(LEARNED)
    }

    /// The speed factors: their common value and their difference.
    fn speed_factors(&self) -> &'a str {
        Self::all(&[self.speed, self.difference])
    }

    /// spread / mean speed factor: what the turn shows.
    fn turn(&self) -> &'a str {
        Self::all(&[self.spread, self.difference])
    }

    /// The spread itself: the turn and the common speed factor.
    fn separation(&self) -> &'a str {
        Self::all(&[self.spread, self.difference, self.speed])
    }
}

const LEARNED: &str = "learned";

fn figure(f: Figure, learned: bool) -> Value {
    if learned && f.value.is_finite() && f.std.is_finite() {
        json!({"value": f.value, "std": f.std})
    } else {
        Value::Null
    }
}

/// The `recommendation` object of `summary.json`: the whole drive's
/// spread (m), speed factors and turn spread (spread / mean speed factor,
/// m), each `{value, std}` or `null` when the drive did not teach it
/// (`learning` says why); `null` without rows.
pub fn recommendation_json(drive: Option<&DriveFigures>, learning: &Value) -> Value {
    let Some(d) = drive else {
        return Value::Null;
    };
    let l = Learning::of(learning);
    json!({
        "basis": format!(
            "whole drive: the estimator's ICRs in effect at each row averaged over the drive, \
             weighted by their information, the spread in the gyro's final scale where the \
             filter learns it; 1-sigma the larger of the batch-means error over {} stretches \
             and the filter's own at its best-informed row (with the gyro scale's)",
            d.batches
        ),
        "spread_m": figure(d.spread, l.separation() == LEARNED),
        "alpha_l": figure(d.alpha_l, l.speed_factors() == LEARNED),
        "alpha_r": figure(d.alpha_r, l.speed_factors() == LEARNED),
        "turn_spread_m": figure(d.turn_spread, l.turn() == LEARNED),
    })
}

/// The `controller` object of `summary.json`: for tread speeds made from a
/// controller's odometry twist with separation S (`meta.toml`'s
/// `separation`), the factors by which its `wheel_separation_multiplier` is
/// off, from the whole drive (`drive`): `separation_factor` = spread / S
/// (with the speed factors as its radius multipliers), `turn_factor` =
/// spread / (mean speed factor × S) (with its radius multipliers left at
/// 1: what a course check measures), each with its `_std`; `null` when the
/// drive did not teach it (`learning` says why). `final_state` gives the
/// same factors of the estimator's last state (`icr_final`). The ICRs are
/// in S's scale: absolute (`wheel_separation_m`, the spread) only when S
/// was the controller's own. `null` for measured tread speeds.
pub fn controller_json(
    meta: &terraslip_io::Meta,
    icr_final: &IcrParams,
    drive: Option<&DriveFigures>,
    learning: &Value,
) -> Value {
    let Some(s) = meta.separation.filter(|s| s.is_finite() && *s > 0.0) else {
        return Value::Null;
    };
    let l = Learning::of(learning);
    let (sep_learned, turn_learned) = (l.separation() == LEARNED, l.turn() == LEARNED);
    let absolute = meta.separation_is_absolute();
    let scaled = |f: Option<Figure>, learned: bool| {
        f.filter(|f| learned && f.value.is_finite() && f.std.is_finite())
            .map(|f| (f.value / s, f.std / s))
    };
    let sep = scaled(drive.map(|d| d.spread), sep_learned);
    let turn = scaled(drive.map(|d| d.turn_spread), turn_learned);
    let spread = icr_final.y_l - icr_final.y_r;
    let alpha = 0.5 * (icr_final.alpha_l + icr_final.alpha_r);
    json!({
        "separation_m": s,
        "separation_source": meta.separation_source.as_deref().unwrap_or("given"),
        "icr_scale": if absolute { "absolute" } else { "nominal: the ICRs are in the scale of the separation used; only the factors carry over" },
        "basis": "whole drive (summary.json's `recommendation`)",
        "separation_factor": sep.map(|f| f.0),
        "separation_factor_std": sep.map(|f| f.1),
        "turn_factor": turn.map(|f| f.0),
        "turn_factor_std": turn.map(|f| f.1),
        "learning": {"separation_factor": l.separation(), "turn_factor": l.turn()},
        "wheel_separation_m": sep.filter(|_| absolute).map(|f| f.0 * s),
        "final_state": {
            "separation_factor": sep_learned.then_some(spread / s),
            "turn_factor": turn_learned.then_some(spread / (alpha * s)),
        },
    })
}
