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

/// With the pose on time or 0.3 s late, noise stated or not, the default
/// learns the slip (spread to 1 cm, speed factors to 0.005), the clock
/// offset to 20 ms and the pose noise to 15 %.
#[test]
fn learns_slip_clock_and_pose_noise() {
    let t = truth();
    for (delay, stated) in [(0.0, true), (0.0, false), (0.3, true), (0.3, false)] {
        let mut s = spec(t);
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
        let case = format!(
            "delay {delay} stated {stated}: {p:?} clock {:?} noise {:?}",
            r.clock_offset, r.noise
        );
        assert!(
            ((p.y_l - p.y_r) - (t.y_l - t.y_r)).abs() < 0.01,
            "spread: {case}"
        );
        assert!(
            (0.5 * (p.y_l + p.y_r) - 0.5 * (t.y_l + t.y_r)).abs() < 0.01,
            "centre: {case}"
        );
        // On a drive at 0.5-1 m/s, x_c at rest and the centripetal term
        // `k_x_speed` share the lateral slip: the x_c in effect at the
        // drive's speed (the rows') is what the positions show.
        let (c, sd, _) = r.centripetal;
        let x_c = r.rows.last().unwrap().x_c;
        assert!(
            (x_c - t.x_c).abs() < 0.015,
            "x_c {x_c}, {c:?} +- {sd:?}: {case}"
        );
        assert!(
            c.k_x_speed.abs() < 3.0 * sd.k_x_speed,
            "k_x_speed {c:?} +- {sd:?}: {case}"
        );
        assert!(
            (p.alpha_l - t.alpha_l).abs() < 0.005 && (p.alpha_r - t.alpha_r).abs() < 0.005,
            "alpha: {case}"
        );
        let clock = r.clock_offset.0;
        assert!((clock - delay).abs() < 0.02, "clock: {case}");
        assert!(
            (r.noise.std_xy / s.std_xy - 1.0).abs() < 0.15,
            "std_xy: {case}"
        );
        assert!(
            (r.noise.std_yaw / s.std_yaw - 1.0).abs() < 0.15,
            "std_yaw: {case}"
        );
    }
}
