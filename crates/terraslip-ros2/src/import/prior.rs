//! The controller's own model, for a log whose wheels came from its
//! odometry twist: the treads the speeds were made for are `S` apart and
//! roll as the controller says (spread `S`, `x_c` 0, speed factors 1). That
//! is stated information, written as an `--init` file (`controller.json`)
//! the estimator can start from.

use std::path::Path;

use terraslip_io::{Meta, ParamsFile};

use super::ImportReport;

/// File name of the controller's model in an imported log.
pub const CONTROLLER_FILE: &str = "controller.json";

/// The controller's model as a parameters file, when the wheel source of
/// `report` was an odometry twist (Odometry or TwistStamped) read with the
/// separation of `cfg`; `None` otherwise. No std is stated: `--init` starts
/// it with the calibrated-parameter widths (`init.calibrated_std`), so the
/// drive moves it only as far as it really shows.
pub fn controller_model(meta: &Meta, report: &ImportReport) -> Option<ParamsFile> {
    let twist = report.streams.iter().any(|s| {
        s.file == "wheels.csv"
            && ["nav_msgs/Odometry", "geometry_msgs/TwistStamped"].contains(&s.ty.as_str())
    });
    let s = meta.separation.filter(|s| s.is_finite() && *s > 0.0)?;
    let source = meta.separation_source.as_deref().unwrap_or("given");
    if !twist {
        return None;
    }
    let json = serde_json::json!({
        "params": {"y_l": s / 2.0, "y_r": -s / 2.0, "x_c": 0.0, "alpha_l": 1.0, "alpha_r": 1.0},
        "source": format!("the controller's odometry model: tread speeds v -/+ w*S/2 with S = {s} m ({}), x_c 0, speed factors 1", super::scale::describe(source)),
        "separation_m": s,
        "separation_source": source,
    });
    // Valid by construction for a finite positive S within the physical
    // ranges; a separation beyond them gives no file rather than a bad one.
    ParamsFile::parse(&json.to_string(), Path::new(CONTROLLER_FILE)).ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::import::StreamReport;

    fn report(ty: &str) -> ImportReport {
        ImportReport {
            streams: vec![StreamReport {
                file: "wheels.csv".into(),
                topic: "/odom".into(),
                ty: ty.into(),
                messages: 1,
                rows: 1,
                rate_hz: 0.0,
                max_gap_s: 0.0,
                gaps: 0,
                left_out: None,
            }],
            ..Default::default()
        }
    }

    #[test]
    fn a_twist_wheel_source_gives_the_controllers_model() {
        let cfg = Meta {
            separation: Some(1.04),
            separation_source: Some("given".into()),
            ..Default::default()
        };
        let p = controller_model(&cfg, &report("nav_msgs/Odometry")).unwrap();
        let q = p.params.unwrap();
        assert_eq!((q.y_l, q.y_r, q.x_c), (0.52, -0.52, 0.0));
        assert_eq!((q.alpha_l, q.alpha_r), (1.0, 1.0));
        assert!(p.extra["source"].as_str().unwrap().contains("S = 1.04 m"));
        // Joint states measure the treads themselves: no controller model.
        assert!(controller_model(&cfg, &report("sensor_msgs/JointState")).is_none());
        assert!(controller_model(&Meta::default(), &report("nav_msgs/Odometry")).is_none());
    }
}
