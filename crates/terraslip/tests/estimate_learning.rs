//! What the default estimator learns on exact-model drives: slip
//! parameters (speed factor included) from lidar-grade poses, the pose
//! stream's clock offset, and the pose noise when pose.csv states none.

use terraslip::config::EstimatorConfig;
use terraslip::pipeline::{run, TerrainEvidence};
use terraslip::testkit::{drive, SynthSpec};
use terraslip_core::IcrParams;

fn spec(truth: IcrParams) -> SynthSpec {
    SynthSpec {
        duration: 200.0,
        pose_hz: 5.0,
        std_xy: 0.03,
        std_yaw: 0.005,
        terrains: vec![(0.0, "ground".into(), truth)],
        ..Default::default()
    }
}

fn truth() -> IcrParams {
    IcrParams {
        y_l: 0.52,
        y_r: -0.50,
        x_c: 0.03,
        alpha_l: 0.82,
        alpha_r: 0.83,
    }
}

#[test]
fn debug_learning() {
    for (delay, stated) in [(0.0, true), (0.0, false), (0.3, true), (0.3, false)] {
        let mut s = spec(truth());
        s.pose_delay = delay;
        s.stated_std = stated;
        let log = drive(&s);
        let r = run(
            &log,
            &EstimatorConfig::default(),
            &TerrainEvidence::None,
            None,
        )
        .unwrap();
        let p = r.final_icr;
        println!(
            "delay {delay} stated {stated}: d {:.4} yc {:.4} xc {:.4} al {:.4} ar {:.4} clock {:.3?} noise {:?} stats {:?}",
            p.y_l - p.y_r, 0.5 * (p.y_l + p.y_r), p.x_c, p.alpha_l, p.alpha_r, r.clock_offset, r.noise, r.stats.fixes
        );
    }
}
