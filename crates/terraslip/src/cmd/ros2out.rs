//! ROS 2 outputs of `estimate --mcap` and `calibrate --ros2-params`.

use std::path::Path;

use anyhow::{Context, Result};
use terraslip::pipeline::{EstimateRow, EstimateRun};
use terraslip_io::{DriveLog, ParamsFile};
use terraslip_ros2::diffdrive::{params_yaml, DiffDriveParams, ParamsBlock};
use terraslip_ros2::out::{EstimateMcap, EstimateSample};

/// Writes the estimate (and, for a bag input, its used topics) into `path`.
pub fn write_mcap(path: &Path, input: &Path, log: &DriveLog, est: &EstimateRun) -> Result<()> {
    let imported = super::bag::imported(input);
    let origin = imported.as_ref().map_or(0, |i| i.0);
    let ns = |t: f64| (origin as f64 + t * 1e9).max(0.0) as u64;
    let mut m = EstimateMcap::create(path)?;
    for (k, r) in est.rows.iter().enumerate() {
        let w = log.wheels.get(k).map(|w| (w.v_left, w.v_right));
        m.estimate(&sample(r, ns(r.t), w), est.terrain_name(r))?;
    }
    let mut passed = 0;
    if let Some((_, topics)) = &imported {
        let mut bag = terraslip_ros2::Bag::open(input)?;
        let idx: Vec<usize> = topics.iter().filter_map(|t| bag.topic(t)).collect();
        passed = m.pass_through(&mut bag, &idx)?;
    }
    m.finish()?;
    eprintln!(
        "mcap: {} estimate rows{} -> {}",
        est.rows.len(),
        if passed > 0 {
            format!(" and {passed} input messages")
        } else {
            String::new()
        },
        path.display()
    );
    Ok(())
}

/// The messages' content of estimate row `r` stamped `stamp_ns` (ns since
/// the epoch); the body twist and its covariance from the row's tread
/// speeds `wheels` (m/s, left and right) when known (else a twist of 0 at
/// standstill's covariance).
pub fn sample(r: &EstimateRow, stamp_ns: u64, wheels: Option<(f64, f64)>) -> EstimateSample {
    let (l, rr) = wheels.unwrap_or((0.0, 0.0));
    let icr = r.icr();
    let t = icr.twist(l, rr);
    let icr_cov = terraslip_core::slip::SlipMat::from_fn(|i, k| r.icr_cov[i][k]);
    let tc = terraslip_core::odometry::twist_covariance(&icr, &icr_cov, &r.twist_noise, l, rr);
    EstimateSample {
        stamp_ns,
        east: r.east,
        north: r.north,
        yaw: r.yaw,
        pose_cov: r.pose_cov,
        twist: [t.v_x, t.v_y, t.omega],
        twist_cov: std::array::from_fn(|i| std::array::from_fn(|k| tc[(i, k)])),
        icr: [r.y_l, r.y_r, r.x_c, r.alpha_l, r.alpha_r],
        std_icr: [r.std[3], r.std[4], r.std[5], r.std[6], r.std[7]],
        nis: r.nis,
        fused: r.fused,
        gated: r.gated,
        q_scale: r.q_scale,
        change: r.change,
    }
}

/// Writes a diff_drive_controller parameter file from calibrated `pf`, with
/// the 2 s prediction error of each set and of its diff-drive approximation
/// on `logs`.
pub fn write_params(
    path: &Path,
    pf: &ParamsFile,
    logs: &[DriveLog],
    score: impl Fn(&[DriveLog], &ParamsFile) -> Option<f64>,
) -> Result<()> {
    let meta = &logs.first().context("no logs")?.meta;
    // Tread speeds made from an odometry twist with a nominal separation:
    // only the factor on the controller's multiplier is known.
    let nominal = meta
        .separation
        .filter(|_| !meta.separation_is_absolute())
        .map(|s| (s, meta.separation_source.clone().unwrap_or_default()));
    let sep = match (meta.track_width.filter(|w| *w > 0.0), &nominal) {
        (Some(w), _) => w,
        (None, Some((s, _))) => *s,
        // Joint rates times a wheel radius: the spread learned is in
        // metres, so it is the wheel_separation itself.
        (None, None) => {
            let spread = pf
                .params
                .or_else(|| pf.terrains.values().next().map(|e| e.params))
                .map(|p| p.spread())
                .filter(|s| s.is_finite() && *s > 0.0)
                .context("--ros2-params: the log's meta.toml needs track_width (the nominal wheel_separation)")?;
            eprintln!(
                "--ros2-params: no nominal wheel_separation in the log (meta.toml's track_width); wheel_separation is the learned spread, {spread:.4} m"
            );
            spread
        }
    };
    let radius = meta.wheel_radius.filter(|r| *r > 0.0);
    let mut sets: Vec<(String, terraslip_core::IcrParams, Option<String>)> = Vec::new();
    if let Some(p) = pf.params {
        sets.push(("all".into(), p, left_out(&pf.extra)));
    }
    for (name, e) in &pf.terrains {
        sets.push((name.clone(), e.params, left_out(&e.extra)));
    }
    let diff_drive = |p: &terraslip_core::IcrParams| terraslip_core::IcrParams {
        y_l: p.spread() / 2.0,
        y_r: -p.spread() / 2.0,
        x_c: 0.0,
        ..*p
    };
    let mut blocks = Vec::new();
    for (name, p, left_out) in &sets {
        let only = |q: terraslip_core::IcrParams| {
            let mut f = pf.clone();
            if name == "all" {
                f.params = Some(q);
            } else if let Some(e) = f.terrains.get_mut(name) {
                e.params = q;
            }
            f
        };
        let cost = match (score(logs, &only(*p)), score(logs, &only(diff_drive(p)))) {
            (Some(a), Some(b)) => Some((a, b)),
            _ => None,
        };
        blocks.push(ParamsBlock {
            terrain: name.clone(),
            params: DiffDriveParams::from_icr(p.y_l, p.y_r, p.alpha_l, p.alpha_r, sep, radius),
            separation_factor: meta.separation.map(|s| p.spread() / s),
            y_l: p.y_l,
            y_r: p.y_r,
            x_c: p.x_c,
            cost,
            left_out: left_out.clone(),
        });
    }
    // The controller is named by its odometry topic's namespace when the
    // tread speeds came from one.
    let name = logs
        .iter()
        .filter_map(|l| super::bag::imported(&l.dir))
        .flat_map(|(_, topics)| topics)
        .filter(|t| t.ends_with("/odom"))
        .find_map(|t| terraslip_ros2::diffdrive::controller_name(&t).map(str::to_string))
        .unwrap_or_else(|| "diff_drive_controller".to_string());
    let mut text = params_yaml(
        &name,
        &blocks,
        nominal.as_ref().map(|(s, src)| (*s, src.as_str())),
    );
    if let Some(note) = assumed_radius_note(meta, &blocks) {
        // After the header's comments.
        let at = text.find("\n\n").unwrap_or(text.len());
        text.insert_str(at, &note);
    }
    terraslip_io::write_atomic(path, text.as_bytes())?;
    eprintln!("wrote {}", path.display());
    Ok(())
}

/// When the tread speeds were made from joint rates with a wheel radius
/// the recording does not state as the robot's (`meta.toml`'s
/// `wheel_radius_source` other than `given`), comment lines saying that the
/// radius multipliers are relative to it and what radius each side then
/// has: applied as written, `wheel_radius` x multiplier.
fn assumed_radius_note(meta: &terraslip_io::Meta, blocks: &[ParamsBlock]) -> Option<String> {
    let r = meta.wheel_radius?;
    let source = meta.wheel_radius_source.as_deref()?;
    if source == "given" {
        return None;
    }
    let why = match source {
        "odometry" => "the base driver's odometry\n# is made from the same joints with it",
        _ => "the\n# recording does not state the robot's",
    };
    let mut s = format!(
        "\n# wheel_radius {r} m is the radius assumed for the recording's joint rates ({source}: {why}), and the radius multipliers are relative to it:\n# applied as written, each wheel's radius is wheel_radius x its multiplier:"
    );
    for b in blocks {
        let p = &b.params;
        s.push_str(&format!(
            "\n#   {}: left {:.4} m, right {:.4} m",
            b.terrain,
            r * p.left_wheel_radius_multiplier,
            r * p.right_wheel_radius_multiplier
        ));
    }
    Some(s)
}

/// The non-zero terms of a set's selected variable model (`rate_model`),
/// which the controller cannot hold; `None` without one (or a malformed
/// one: `calibrate` only writes well-formed ones, `validate` names it).
fn left_out(extra: &std::collections::BTreeMap<String, serde_json::Value>) -> Option<String> {
    let r = terraslip_io::RateModelEntry::selected(extra).ok()??;
    let terms: Vec<String> = [
        ("k_spread", r.k_spread, "s/m"),
        ("k_alpha", r.k_alpha, "s/m"),
        ("k_acc", r.k_acc, "s^2/m"),
        ("k_dir", r.k_dir, "s^2/m"),
        ("k_x_speed", r.k_x_speed, "s"),
        ("k_spread_speed", r.k_spread_speed, "s/m"),
    ]
    .iter()
    .filter(|(_, v, _)| *v != 0.0)
    .map(|(n, v, u)| format!("{n} = {v:.4} {u}"))
    .collect();
    (!terms.is_empty()).then(|| terms.join(", "))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_selected_centripetal_model_is_named_as_left_out() {
        let extra = |v: serde_json::Value| {
            serde_json::from_value(serde_json::json!({"rate_model": v})).unwrap()
        };
        let q = serde_json::json!({"y_l": 0.6, "y_r": -0.6, "x_c": 0.0, "alpha_l": 0.9, "alpha_r": 0.9});
        let on = serde_json::json!({"selected": true, "params": q, "k_spread": 0.0, "k_alpha": 0.0,
            "k_x_speed": 0.12, "k_spread_speed": 0.05});
        assert_eq!(
            left_out(&extra(on)).as_deref(),
            Some("k_x_speed = 0.1200 s, k_spread_speed = 0.0500 s/m")
        );
        let off =
            serde_json::json!({"selected": false, "params": q, "k_spread": 0.1, "k_alpha": 0.0});
        assert_eq!(left_out(&extra(off)), None);
        assert_eq!(left_out(&Default::default()), None);
    }
}
