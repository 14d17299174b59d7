//! Where the pose reference sits on the robot: the lever arm of the point
//! its positions are of (a GNSS antenna, a lidar frame) from the base
//! frame's origin, the wheel axle's centre. From the topics file's
//! `[pose] lever_arm`, else `[meta.pose]`, else the bag's static transforms
//! (the chain from the base frame to the frame the pose messages name);
//! written to the log's meta.toml `[pose]` so that `estimate` and
//! `calibrate` keep it apart from the slip model's x_c.

use std::collections::HashMap;

use terraslip_io::{Meta, PoseMount};

use super::config::TopicsConfig;
use super::frames::StaticTf;
use super::report::ImportReport;
use crate::Bag;

/// A lever arm shorter than this (m, horizontal) is the base frame's origin.
const AT_ORIGIN_M: f64 = 1e-3;
/// meta.toml's bound on a lever arm, m (terraslip-io refuses beyond it).
const MAX_M: f64 = 50.0;

/// What the lever arm is worked out from, after the bag is read.
pub(super) struct PoseFrame<'a> {
    pub bag: &'a Bag,
    pub cfg: &'a TopicsConfig,
    /// The pose and static-transform topics.
    pub pose: Option<usize>,
    pub tf: Option<usize>,
    /// The frame each topic names (the pose topic's: the point it gives).
    pub frames: &'a HashMap<usize, String>,
    pub tf_tree: &'a StaticTf,
}

/// `v` m to a tenth of a millimetre, without a `-0.0`.
fn round(v: f64) -> f64 {
    (v * 1e4).round() / 1e4 + 0.0
}

/// The topics-file line that states the lever arm.
const OVERRIDE: &str = "`[pose] lever_arm = [x, y]` (m, base frame) in a --topics file states it";

/// Sets `meta.pose` from the topics file or the static transforms, and
/// says where it came from (a `decided:` line) or why none was found.
pub(super) fn apply(s: &PoseFrame, meta: &mut Meta, report: &mut ImportReport) {
    let Some(pose) = s.pose else { return };
    let name = &s.bag.topics[pose].name;
    if let Some([x, y]) = s.cfg.pose.lever_arm {
        meta.pose = Some(PoseMount {
            lever_arm_x: x,
            lever_arm_y: y,
        });
        report.decisions.push(format!(
            "pose reference {name} sits at ({x:.3}, {y:.3}) m from the axle's centre, from the topics file: its lever arm, written to meta.toml [pose]"
        ));
        return;
    }
    if meta.pose.is_some() {
        // `[meta.pose]` of the topics file: stated as it is.
        return;
    }
    let base = s.cfg.tf.base_frame.as_str();
    let Some(frame) = s
        .frames
        .get(&pose)
        .map(|f| f.trim_start_matches('/'))
        .filter(|f| !f.is_empty() && *f != base.trim_start_matches('/'))
    else {
        return;
    };
    let tf_name = s.tf.map(|t| s.bag.topics[t].name.as_str());
    let Some((_, [x, y, _])) = tf_name.and(s.tf_tree.transform(base, frame)) else {
        let why = match tf_name {
            Some(t) => format!("{t} has no transform from {base} to it"),
            None => "the bag has no /tf_static".to_string(),
        };
        report.decisions.push(format!(
            "pose reference {name} (frame `{frame}`) taken at the axle's centre ({why}); {OVERRIDE}"
        ));
        return;
    };
    if !(x.abs() <= MAX_M && y.abs() <= MAX_M) {
        report.warnings.push(format!(
            "{name}: {} places its frame `{frame}` at ({x:.1}, {y:.1}) m from {base}, beyond a robot's size: not used as its lever arm; {OVERRIDE}",
            tf_name.unwrap_or_default()
        ));
        return;
    }
    if x.hypot(y) < AT_ORIGIN_M {
        return;
    }
    // Tenths of a millimetre (a chain of float transforms adds ~1e-17 m),
    // without a `-0.0`.
    let (x, y) = (round(x), round(y));
    meta.pose = Some(PoseMount {
        lever_arm_x: x,
        lever_arm_y: y,
    });
    report.decisions.push(format!(
        "pose reference {name} (frame `{frame}`) sits at ({x:.3}, {y:.3}) m from {base}'s origin, from {}: its lever arm, written to meta.toml [pose] and kept apart from x_c; {OVERRIDE}",
        tf_name.unwrap_or_default()
    ));
}
