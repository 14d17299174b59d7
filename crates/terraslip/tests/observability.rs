//! A log teaches only what its sensors see: without positions the common
//! speed factor and the ICR centre offsets are held at their starting
//! values (the turning is learned from the gyro), without positions and a
//! gyro every slip parameter is held; `summary.json` says which.

use terraslip::config::EstimatorConfig;
use terraslip::estimate::summary_json;
use terraslip::pipeline::{self, EstimateRun, TerrainEvidence};
use terraslip_core::IcrParams;
use terraslip_sim::family::{world, Subset};
use terraslip_sim::{simulate, SimRun};

const SEED: u64 = 2;

fn sim() -> SimRun {
    let w = world(SEED, Subset::All).with_gyro(SEED);
    simulate(&w.scenario, SEED).unwrap()
}

fn run(sim: &SimRun) -> (EstimateRun, serde_json::Value) {
    let cfg = EstimatorConfig::default();
    let r = pipeline::run(&sim.log, &cfg, &TerrainEvidence::None, None).unwrap();
    let summary = summary_json(&sim.log, &r, &cfg);
    (r, summary)
}

/// The prior the run starts from (as the band keeps it).
fn prior(r: &EstimateRun) -> IcrParams {
    let cfg = EstimatorConfig::default();
    r.band.project(&cfg.prior(r.track_width).icr).0
}

fn speed_factor(p: &IcrParams) -> f64 {
    0.5 * (p.alpha_l + p.alpha_r)
}

fn learning<'a>(s: &'a serde_json::Value, group: &str) -> &'a str {
    s["learning"][group].as_str().unwrap()
}

#[test]
fn gyro_without_positions_holds_the_speed_factor_and_learns_the_turning() {
    let mut sim = sim();
    sim.log.pose.clear();
    assert!(sim.log.imu.iter().any(|s| s.gyro_z.is_some()));
    let (r, summary) = run(&sim);
    let p0 = prior(&r);
    let p = r.final_icr;
    assert_eq!(speed_factor(&p), speed_factor(&p0), "speed factor moved");
    assert_eq!(p.x_c, p0.x_c, "x_c moved");
    assert!(
        ((p.y_l - p.y_r) - (p0.y_l - p0.y_r)).abs() > 1e-3,
        "the spread was not learned from the gyro: {p:?} vs {p0:?}"
    );
    assert!(learning(&summary, "speed_factor").starts_with("held (no position"));
    assert!(learning(&summary, "icr_centre_offsets").starts_with("held"));
    assert_eq!(learning(&summary, "spread"), "learned");
    assert_eq!(learning(&summary, "speed_factor_difference"), "learned");
    let warned = r
        .warnings
        .iter()
        .any(|w| w.contains("common speed factor") && w.contains("not learned"));
    assert!(
        warned,
        "no warning about the held speed factor: {:?}",
        r.warnings
    );
}

#[test]
fn nothing_measuring_the_motion_holds_every_slip_parameter() {
    let mut sim = sim();
    sim.log.pose.clear();
    sim.log.imu.clear();
    let (r, summary) = run(&sim);
    let (p0, p) = (prior(&r), r.final_icr);
    assert_eq!(
        [p.y_l, p.y_r, p.x_c, p.alpha_l, p.alpha_r],
        [p0.y_l, p0.y_r, p0.x_c, p0.alpha_l, p0.alpha_r]
    );
    for group in [
        "spread",
        "speed_factor_difference",
        "speed_factor",
        "icr_centre_offsets",
    ] {
        assert!(
            learning(&summary, group).starts_with("held (no position, heading or gyro"),
            "{group}: {}",
            learning(&summary, group)
        );
    }
    assert!(r.warnings.iter().any(|w| w.contains("none is learned")));
}

#[test]
fn positions_still_teach_the_speed_factor() {
    let sim = sim();
    let (r, summary) = run(&sim);
    let p0 = prior(&r);
    assert!(
        (speed_factor(&r.final_icr) - speed_factor(&p0)).abs() > 1e-3,
        "speed factor not learned: {:?}",
        r.final_icr
    );
    for group in ["spread", "speed_factor", "icr_centre_offsets"] {
        assert_eq!(learning(&summary, group), "learned", "{group}");
    }
    assert!(!r.warnings.iter().any(|w| w.contains("not learned")));
}
