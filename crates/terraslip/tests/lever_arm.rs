//! A pose reference mounted off the wheel axle (a GNSS antenna 0.3 m
//! ahead of it): stated in meta.toml's `[pose]`, it is reported as the
//! reference's lever arm and x_c stays near its true value.

use terraslip::config::EstimatorConfig;
use terraslip::pipeline::{run, EstimateRun, TerrainEvidence};
use terraslip::testkit::{drive, SynthSpec};
use terraslip_core::IcrParams;
use terraslip_io::PoseMount;

const TRUE_X_C: f64 = 0.01;

fn spec() -> SynthSpec {
    SynthSpec {
        duration: 300.0,
        pose_hz: 10.0,
        std_xy: 0.02,
        terrains: vec![(0.0, "asphalt".into(), IcrParams::new(0.30, -0.31, TRUE_X_C))],
        lever_arm: (0.3, 0.0),
        ..Default::default()
    }
}

fn estimate(stated: bool) -> EstimateRun {
    let mut log = drive(&spec());
    if stated {
        log.meta.pose = Some(PoseMount {
            lever_arm_x: 0.3,
            lever_arm_y: 0.0,
        });
    }
    let cfg = EstimatorConfig::default();
    run(&log, &cfg, &TerrainEvidence::None, None).unwrap()
}

#[test]
fn an_antenna_off_the_axle_unstated_and_unlearned_is_read_as_x_c() {
    // What the lever arm is for: the reference's offset pins x_c.
    let run = estimate(false);
    assert!(run.final_icr.x_c.abs() > 0.2, "{:?}", run.final_icr);
    assert_eq!(run.lever_arm.source, "config");
}

#[test]
fn a_stated_lever_arm_keeps_x_c_at_its_value() {
    let run = estimate(true);
    assert!(
        (run.final_icr.x_c - TRUE_X_C).abs() < 0.05,
        "{:?}",
        run.final_icr
    );
    assert_eq!(run.lever_arm.source, "stated");
    assert_eq!((run.lever_arm.x, run.lever_arm.y), (0.3, 0.0));
}

#[test]
fn meta_toml_states_where_the_pose_reference_sits() {
    let dir = std::env::temp_dir().join(format!("terraslip-lever-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("meta.toml");
    std::fs::write(&path, "track_width = 0.5\n[pose]\nlever_arm_x = -0.25\n").unwrap();
    let meta = terraslip_io::read_meta(&path).unwrap();
    assert_eq!(
        meta.pose,
        Some(PoseMount {
            lever_arm_x: -0.25,
            lever_arm_y: 0.0
        })
    );
    // Beyond a robot's size, or an unknown key of the table: refused.
    std::fs::write(&path, "[pose]\nlever_arm_x = 80.0\n").unwrap();
    let e = terraslip_io::read_meta(&path).unwrap_err().to_string();
    assert!(e.contains("lever_arm_x"), "{e}");
    std::fs::write(&path, "[pose]\nlever_arm_z = 1.0\n").unwrap();
    assert!(terraslip_io::read_meta(&path).is_err());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A simulated papers world whose RTK antenna (10 Hz) sits 0.3 m ahead of
/// the axle: the simulator records the mount in meta.toml's `[pose]`.
fn simulated_antenna(seed: u64) -> terraslip_sim::SimRun {
    use terraslip_sim::family::{world, Subset};
    let mut w = world(seed, Subset::Papers);
    w.scenario.gnss = terraslip_sim::scenario::Gnss::rtk(10.0);
    w.scenario.gnss.lever_arm = [0.3, 0.0];
    terraslip_sim::simulate(&w.scenario, seed).unwrap()
}

#[test]
fn a_simulated_antenna_off_the_axle_is_reported_apart_from_x_c() {
    let cfg = EstimatorConfig::default();
    for seed in [3, 4] {
        let sim = simulated_antenna(seed);
        assert_eq!(
            sim.log.meta.pose,
            Some(PoseMount {
                lever_arm_x: 0.3,
                lever_arm_y: 0.0
            })
        );
        let truth = sim.truth.last().unwrap().icr.x_c;
        let stated = run(&sim.log, &cfg, &TerrainEvidence::None, None).unwrap();
        let summary = terraslip::estimate::summary_json(&sim.log, &stated, &cfg);
        assert_eq!(summary["pose_lever_arm_m"]["x"], 0.3);
        assert_eq!(summary["pose_lever_arm_m"]["source"], "stated");
        let mut unstated_log = sim.log.clone();
        unstated_log.meta.pose = None;
        let unstated = run(&unstated_log, &cfg, &TerrainEvidence::None, None).unwrap();
        let (e_stated, e_unstated) = (
            (stated.final_icr.x_c - truth).abs(),
            (unstated.final_icr.x_c - truth).abs(),
        );
        eprintln!(
            "seed {seed}: x_c truth {truth:.3}, stated {:.3}, unstated {:.3}",
            stated.final_icr.x_c, unstated.final_icr.x_c
        );
        assert!(e_stated < 0.05, "seed {seed}: {e_stated} ({truth})");
        assert!(e_unstated > 0.2, "seed {seed}: {e_unstated} ({truth})");
    }
}

/// `calibrate` fits the axle's path: the simulated antenna's fixes, moved
/// onto the axle, lie on the true path within the receiver's centimetres
/// (0.3 m off it before).
#[test]
fn calibrate_sees_the_axle_of_a_simulated_antenna_off_it() {
    let sim = simulated_antenna(3);
    let off = |log: &terraslip_io::DriveLog| {
        let (mut sum, mut n) = (0.0, 0.0);
        for p in &log.pose {
            let (Some(e), Some(nn)) = (p.east, p.north) else {
                continue;
            };
            let i = sim
                .truth
                .partition_point(|s| s.t < p.t)
                .min(sim.truth.len() - 1);
            sum += (e - sim.truth[i].east).hypot(nn - sim.truth[i].north);
            n += 1.0;
        }
        sum / n
    };
    let before = off(&sim.log);
    let mut log = sim.log.clone();
    assert_eq!(
        terraslip_calib::lever_arm::move_fixes_to_axle(&mut log),
        None
    );
    let after = off(&log);
    assert!(before > 0.25 && after < 0.05, "{before} -> {after}");
}
