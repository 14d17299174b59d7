//! The content of `summary.json`: what the run found, learned and held.

use terraslip_core::filter::{FilterConfig, SlipHold};
use terraslip_core::slip::Chart;
use terraslip_io::DriveLog;

use crate::config::EstimatorConfig;
use crate::pipeline::EstimateRun;

use super::recommendation::{controller_json, recommendation_json};

/// The content of `summary.json` (without `terrain_evidence`).
pub fn summary_json(log: &DriveLog, est: &EstimateRun, cfg: &EstimatorConfig) -> serde_json::Value {
    let icr = est.final_icr;
    let last = est.last_row;
    let learning = learning_json(est.hold, &cfg.filter);
    serde_json::json!({
        "log": log.dir.display().to_string(),
        "rows": est.row_count,
        "duration_s": est.duration(),
        // The final ICRs: the turn law's straight-line values (a tread speed
        // difference of 0); estimate.csv's rows hold those in effect at each
        // row's turn rate.
        "icr": {
            "y_l": icr.y_l, "y_r": icr.y_r, "x_c": icr.x_c,
            "alpha_l": icr.alpha_l, "alpha_r": icr.alpha_r,
        },
        "icr_holds_at": "straight line (tread speed difference 0)",
        "icr_is": "final state: the estimator's last state; `recommendation` holds the whole drive's figures",
        // Per group of slip parameters: "learned" or "held (why)"; a held
        // group's values in "icr" are its starting values.
        "learning": learning,
        // The whole drive's figures with their 1-sigma (null where held).
        "recommendation": recommendation_json(est.drive.as_ref(), &learning),
        "icr_std": last.map(|r| serde_json::json!({
            "y_l": r.std[3], "y_r": r.std[4], "x_c": r.std[5], "spread": r.std_spread,
        })),
        "track_width": est.track_width,
        "controller": controller_json(&log.meta, &icr, est.drive.as_ref(), &learning),
        "variant": cfg.filter.variant,
        "init": est.init_source,
        // What the run decided before its first row (the gyro and its
        // delay, the slip parameters held, the pose reference's kind), as
        // the node's parameters file keeps it.
        "decided": est.decided.to_json(),
        "clock_offset_s": {"value": est.clock_offset.0, "std": est.clock_offset.1},
        // Where the pose reference sits on the robot (body frame, m), apart
        // from x_c: "stated" (meta.toml's [pose]) or "config".
        "pose_lever_arm_m": {
            "x": est.lever_arm.x, "y": est.lever_arm.y,
            "source": est.lever_arm.source,
        },
        // The spread in effect is (1 + slope |v_r - v_l|) times "icr"'s.
        "turn_law_s_per_m": {"slope": est.turn_law.0, "std": est.turn_law.1},
        // Both speed factors in effect are (1 + slope |v_r - v_l|) times "icr"'s.
        "speed_law_s_per_m": {"slope": est.speed_law.0, "std": est.speed_law.1},
        // At mean tread speed v (m/s): x_c moves by k_x_speed v, the spread
        // scales by 1 + k_spread_speed |v| (on top of the turn law).
        "centripetal": {
            "k_x_speed": est.centripetal.0.k_x_speed,
            "k_spread_speed": est.centripetal.0.k_spread_speed,
            "std_k_x_speed": est.centripetal.1.k_x_speed,
            "std_k_spread_speed": est.centripetal.1.k_spread_speed,
            "learned": est.centripetal.2,
        },
        // The pose noise the filter ended with, whether pose.csv stated it,
        // and what meta.toml states the pose reference is ("gnss",
        // "localiser": no wandering part, `correlated_std_m` 0; or null).
        "pose_noise": {
            "reference": log.meta.pose_reference,
            "std_xy_m": est.noise.std_xy,
            "std_yaw_rad": est.noise.std_yaw,
            "correlated_std_m": est.noise.correlated_std,
            "model_speed_rel_per_sqrt_s": est.noise.model.0.sqrt(),
            "model_yaw_rate_rel_per_sqrt_s": est.noise.model.1.sqrt(),
            "stated_in_log": est.noise.stated,
            "learned": est.noise.learned,
        },
        // The yaw-rate gyro (imu.csv's gyro_z), null without one.
        "gyro": (est.gyro.fused > 0).then(|| serde_json::json!({
            "std_rad_s": est.gyro.std,
            "bias_rad_s": est.gyro.bias,
            "bias_std_rad_s": est.gyro.bias_std,
            // It reads `scale` times the true yaw rate.
            "scale": est.gyro.scale,
            "scale_std": est.gyro.scale_std,
            "scale_learning": if est.gyro.scale_learned {
                "learned"
            } else {
                "held (no position or heading reference: only they show the true turn; its starting value)"
            },
            "windows_fused": est.gyro.fused,
            "windows_widened": est.gyro.widened,
            "wheels_late_by_s": est.gyro_delay,
        })),
        "terrain_changes": est.changes.iter().map(|c| serde_json::json!({
            "t": c.t,
            "terrain": est.terrains.get(c.terrain),
            "action": format!("{:?}", c.action).to_lowercase(),
        })).collect::<Vec<_>>(),
        "stats": {
            "predictions": est.stats.fixes.predictions,
            "fixes": est.stats.fixes_used,
            "position_fused": est.stats.fixes.position_fused,
            "position_gated": est.stats.fixes.position_gated,
            "yaw_fused": est.stats.fixes.yaw_fused,
            "yaw_gated": est.stats.fixes.yaw_gated,
            "anchored": est.stats.fixes.anchored,
            "changes_detected": est.stats.fixes.changes_detected,
            "refused_updates": est.stats.fixes.refused,
            "dropped_fixes": est.stats.dropped_fixes,
        },
        "warnings": log.warnings.iter().chain(&est.warnings).collect::<Vec<_>>(),
        // How well the parameters the filter reported at each time predict
        // the next 2 s of motion against the pose reference (absent without one).
        "prediction": est.prediction.as_ref().map(|p| p.to_json()),
        "outage": est.outage.as_ref().map(|o| o.to_json()),
    })
}

/// The `learning` object of `summary.json`: for the spread, the speed
/// factor difference, the common speed factor and the ICR centre offsets,
/// `"learned"` or `"held (why)"`.
pub fn learning_json(hold: SlipHold, filter: &FilterConfig) -> serde_json::Value {
    const NO_POSITIONS: &str =
        "held (no position reference: only positions show it; its starting value)";
    const NOTHING: &str =
        "held (no position, heading or gyro: nothing measures the motion; its starting value)";
    let filter = FilterConfig { hold, ..*filter };
    let held = filter.held_slots();
    let (spread, difference, speed, offsets) = match filter.chart {
        Chart::Gain => (held[0], held[1], held[2], held[3] || held[4]),
        Chart::Tread => (held[0] || held[1], held[3], held[3], held[2]),
    };
    let state = |is_held: bool, factor: bool| {
        if !filter.learn_icr {
            "held (filter.learn_icr = false)"
        } else if factor && !filter.learn_alpha {
            "held (filter.learn_alpha = false)"
        } else if !is_held {
            "learned"
        } else if hold == SlipHold::All {
            NOTHING
        } else if factor && filter.chart == Chart::Tread {
            "held (no position reference: the tread chart holds both speed factors)"
        } else {
            NO_POSITIONS
        }
    };
    serde_json::json!({
        "spread": state(spread, false),
        "speed_factor_difference": state(difference, true),
        "speed_factor": state(speed, true),
        "icr_centre_offsets": state(offsets, false),
    })
}
