//! A pose reference mounted off the wheel axle (a GNSS antenna 0.3 m
//! ahead of it): stated in meta.toml's `[pose]`, or recorded in a bag's
//! `/tf_static`, it is reported as the reference's lever arm and x_c stays
//! near its true value.

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
    // ... and the run says what to state, not only that x_c is odd.
    assert!(
        run.warnings
            .iter()
            .any(|w| w.contains("x_c ended at") && w.contains("[pose] lever_arm")),
        "{:?}",
        run.warnings
    );
}

#[test]
fn a_stated_lever_arm_keeps_x_c_at_its_value() {
    let run = estimate(true);
    assert!(
        (run.final_icr.x_c - TRUE_X_C).abs() < 0.05,
        "{:?}",
        run.final_icr
    );
    assert!(
        !run.warnings.iter().any(|w| w.contains("[pose] lever_arm")),
        "{:?}",
        run.warnings
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

/// The same antenna recorded in a bag, placed by its `/tf_static` (through
/// an intermediate mast frame) or by the topics file: `import` writes it to
/// meta.toml's `[pose]` with a `decided:` line, and `estimate` and
/// `calibrate` on the bag keep x_c at its value.
#[cfg(feature = "ros2")]
mod cli;

#[cfg(feature = "ros2")]
mod recorded {
    use std::path::Path;

    use super::cli::terraslip;
    use super::{spec, TRUE_X_C};

    use terraslip::testkit::drive;
    use terraslip_ros2::defs::definition_of;
    use terraslip_ros2::msg::CdrWriter;
    use terraslip_ros2::out::EstimateMcap;

    const T0: u64 = 1_700_000_000_000_000_000;
    /// The wheel radius `import` assumes when nothing tells it, m: joint
    /// velocities are written in its scale so that the tread speeds are true.
    const DEFAULT_RADIUS: f64 = 0.1;

    fn vec3(w: &mut CdrWriter, v: [f64; 3]) {
        for c in v {
            w.f64(c);
        }
    }

    /// base_link -> mast (0.1 m ahead, 0.4 m up, yawed 90°) -> gps_link (0.2 m
    /// to the mast's right, 0.3 m up): the antenna at (0.3, 0, 0.7) m.
    fn tf_static(w: &mut CdrWriter, ns: u64) {
        let (s, c) = (std::f64::consts::FRAC_PI_4).sin_cos();
        w.u32(2);
        w.header(ns, "base_link").string("mast");
        vec3(w, [0.1, 0.0, 0.4]);
        vec3(w, [0.0, 0.0, s]);
        w.f64(c);
        w.header(ns, "mast").string("gps_link");
        vec3(w, [0.0, -0.2, 0.3]);
        vec3(w, [0.0, 0.0, 0.0]);
        w.f64(1.0);
    }

    /// East, north (m) to latitude, longitude (degrees) about (0, 0): WGS-84's
    /// radii of curvature at the equator (millimetres over the drive).
    fn geodetic(east: f64, north: f64) -> (f64, f64) {
        let a = 6_378_137.0;
        let e2 = 6.694_379_990_14e-3;
        (
            (north / (a * (1.0 - e2))).to_degrees(),
            (east / a).to_degrees(),
        )
    }

    /// The drive as a bag: JointState wheel velocities (50 Hz), NavSatFix of
    /// `gps_link` and an Imu heading 3 ms after each (10 Hz), and `/tf_static`
    /// when `tf`.
    fn write_bag(p: &Path, tf: bool) {
        let log = drive(&spec());
        let mut m = EstimateMcap::create(p).unwrap();
        let ch = |m: &mut EstimateMcap, topic: &str, ty: &str| {
            m.channel(topic, ty, &definition_of(ty).unwrap()).unwrap()
        };
        let js = ch(&mut m, "/joint_states", "sensor_msgs/msg/JointState");
        let fix = ch(&mut m, "/fix", "sensor_msgs/msg/NavSatFix");
        let imu = ch(&mut m, "/imu/data", "sensor_msgs/msg/Imu");
        let ns = |t: f64| T0 + (t * 1e9).round() as u64;
        if tf {
            let c = ch(&mut m, "/tf_static", "tf2_msgs/msg/TFMessage");
            let mut w = CdrWriter::new();
            tf_static(&mut w, T0);
            m.write(c, T0, &w.finish()).unwrap();
        }
        for s in &log.wheels {
            let mut w = CdrWriter::new();
            w.header(ns(s.t), "base_link");
            w.u32(2).string("left_wheel").string("right_wheel");
            w.u32(0);
            w.u32(2)
                .f64(s.v_left / DEFAULT_RADIUS)
                .f64(s.v_right / DEFAULT_RADIUS);
            w.u32(0);
            m.write(js, ns(s.t), &w.finish()).unwrap();
        }
        for p in &log.pose {
            let t = ns(p.t);
            let (lat, lon) = geodetic(p.east.unwrap(), p.north.unwrap());
            let mut w = CdrWriter::new();
            w.header(t, "gps_link");
            // status 2 (GBAS fix) at an odd offset (after "gps_link"), then
            // uint16 service 1, already aligned to 2.
            w.u8(2).u8(1).u8(0);
            w.f64(lat).f64(lon).f64(0.0);
            let v = 0.02f64.powi(2);
            for c in [v, 0.0, 0.0, 0.0, v, 0.0, 0.0, 0.0, 4.0 * v] {
                w.f64(c);
            }
            w.u8(2);
            m.write(fix, t, &w.finish()).unwrap();

            // The heading and the true yaw rate, in base_link, 3 ms after the
            // fix (a row of pose.csv per stamp).
            let t = t + 3_000_000;
            let k = log
                .truth
                .partition_point(|r| r.t < p.t)
                .clamp(1, log.truth.len() - 1);
            let (a, b) = (&log.truth[k - 1], &log.truth[k]);
            let rate = terraslip_core::angle::wrap(b.yaw - a.yaw) / (b.t - a.t);
            let (s, c) = (p.yaw.unwrap() / 2.0).sin_cos();
            let mut w = CdrWriter::new();
            w.header(t, "base_link");
            vec3(&mut w, [0.0, 0.0, s]);
            w.f64(c);
            for k in 0..9 {
                w.f64(if k == 8 { 1e-4 } else { 0.0 });
            }
            vec3(&mut w, [0.0, 0.0, rate]);
            for _ in 0..9 {
                w.f64(0.0);
            }
            vec3(&mut w, [0.0, 0.0, 9.81]);
            for _ in 0..9 {
                w.f64(0.0);
            }
            m.write(imu, t, &w.finish()).unwrap();
        }
        m.finish().unwrap();
    }

    /// What `import`, `estimate` and `calibrate` made of the bag: import's
    /// terminal output, the log's meta.toml, estimate's summary.json and
    /// calibrate's parameters file.
    struct Made {
        said: String,
        meta: terraslip_io::Meta,
        summary: serde_json::Value,
        params: serde_json::Value,
    }

    fn run(tf: bool, topics: Option<&str>) -> Made {
        let d = tempfile::tempdir().unwrap();
        let bag = d.path().join("drive.mcap");
        write_bag(&bag, tf);
        let s = |p: &Path| p.to_str().unwrap().to_string();
        let mut pre: Vec<String> = Vec::new();
        if let Some(text) = topics {
            let f = d.path().join("topics.toml");
            std::fs::write(&f, text).unwrap();
            pre = vec!["--topics".into(), s(&f)];
        }
        let args = |rest: &[String]| pre.iter().chain(rest).cloned().collect::<Vec<_>>();
        let (log, est) = (d.path().join("log"), d.path().join("est"));
        let call = |a: Vec<String>| terraslip(&a.iter().map(String::as_str).collect::<Vec<_>>());
        let said = call(args(&["import".into(), s(&bag), "--out".into(), s(&log)]));
        call(args(&["estimate".into(), s(&bag), "--out".into(), s(&est)]));
        let cal = d.path().join("params.json");
        call(args(&[
            "calibrate".into(),
            s(&bag),
            "--out".into(),
            s(&cal),
        ]));
        // No meta.toml: nothing to say of the robot.
        let meta_file = log.join("meta.toml");
        let meta = match meta_file.exists() {
            true => terraslip_io::read_meta(&meta_file).unwrap(),
            false => terraslip_io::Meta::default(),
        };
        let json = |p: &Path| -> serde_json::Value {
            serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
        };
        Made {
            said,
            meta,
            summary: json(&est.join("summary.json")),
            params: json(&cal),
        }
    }

    /// Estimate's final x_c.
    fn x_c(m: &Made) -> f64 {
        m.summary["icr"]["x_c"].as_f64().unwrap()
    }

    /// Calibrate's x_c.
    fn calibrated_x_c(m: &Made) -> f64 {
        m.params["params"]["x_c"].as_f64().unwrap()
    }

    #[test]
    fn an_antenna_placed_by_tf_static_is_a_lever_arm_not_x_c() {
        let m = run(true, None);
        let pose = m.meta.pose.expect("meta.toml [pose] from /tf_static");
        assert!((pose.lever_arm_x - 0.3).abs() < 1e-9, "{pose:?}");
        assert!(pose.lever_arm_y.abs() < 1e-9, "{pose:?}");
        assert!(
            m.said.lines().any(|l| l.contains("decided:")
                && l.contains("gps_link")
                && l.contains("/tf_static")
                && l.contains("[pose] lever_arm")),
            "{}",
            m.said
        );
        assert_eq!(m.summary["pose_lever_arm_m"]["source"], "stated");
        assert_eq!(m.params["pose_lever_arm_m"]["x"], 0.3);
        // Measured: estimate -0.001, calibrate 0.0095 (truth 0.01); with no
        // transform -0.25 (its limit) and -0.290.
        assert!((x_c(&m) - TRUE_X_C).abs() < 0.05, "x_c {}", x_c(&m));
        let cal = calibrated_x_c(&m);
        assert!((cal - TRUE_X_C).abs() < 0.02, "calibrated x_c {cal}");
    }

    #[test]
    fn the_topics_file_states_the_lever_arm_and_wins_over_tf_static() {
        let m = run(false, Some("[pose]\nlever_arm = [0.3, 0.0]\n"));
        assert_eq!(m.meta.pose.map(|p| p.lever_arm_x), Some(0.3));
        assert!((x_c(&m) - TRUE_X_C).abs() < 0.05, "x_c {}", x_c(&m));
        // Stated at the axle, the recorded mount is not used: x_c absorbs it.
        let m = run(true, Some("[pose]\nlever_arm = [0.0, 0.0]\n"));
        assert!(m.said.contains("the topics file"), "{}", m.said);
        assert!((x_c(&m) - TRUE_X_C).abs() > 0.2, "x_c {}", x_c(&m));
    }

    #[test]
    fn a_localiser_stated_in_the_topics_file_reaches_meta_toml_and_the_estimate() {
        let m = run(true, Some("[meta]\npose_reference = \"localiser\"\n"));
        let localiser = Some(terraslip_io::PoseReference::Localiser);
        assert_eq!(m.meta.pose_reference, localiser);
        assert_eq!(m.summary["pose_noise"]["reference"], "localiser");
        assert_eq!(m.summary["pose_noise"]["correlated_std_m"], 0.0);
        assert!(
            m.said
                .contains("is a localiser, as the topics file's [meta] states"),
            "{}",
            m.said
        );
        // Unstated, a NavSatFix is a GNSS receiver: its wander is carried.
        let m = run(true, None);
        assert_eq!(
            m.meta.pose_reference,
            Some(terraslip_io::PoseReference::Gnss)
        );
        assert_eq!(m.summary["pose_noise"]["reference"], "gnss");
        assert!(
            m.said.contains("is a GNSS receiver (a NavSatFix)"),
            "{}",
            m.said
        );
        let wander = m.summary["pose_noise"]["correlated_std_m"]
            .as_f64()
            .unwrap();
        assert!(wander > 0.0, "{wander}");
    }

    #[test]
    fn with_no_transform_the_antenna_is_taken_at_the_axle_and_said_so() {
        let m = run(false, None);
        assert_eq!(m.meta.pose, None);
        assert!(
            m.said
                .lines()
                .any(|l| l.contains("decided:") && l.contains("gps_link") && l.contains("axle")),
            "{}",
            m.said
        );
        // What the lever arm is for: unstated, the offset pins x_c.
        assert!((x_c(&m) - TRUE_X_C).abs() > 0.2, "x_c {}", x_c(&m));
        let cal = calibrated_x_c(&m);
        assert!((cal - TRUE_X_C).abs() > 0.2, "calibrated x_c {cal}");
    }

    /// The bag played message by message through the node's live path
    /// (live import, warm-up, live estimator; no DDS): the lever arm comes
    /// from `/tf_static` or the topics file as `import` reads it, and the
    /// live estimate is the offline one.
    #[test]
    fn the_live_path_places_the_antenna_as_import_does() {
        use terraslip::config::EstimatorConfig;
        use terraslip::pipeline::warmup::WarmUp;
        use terraslip::pipeline::{run, EstimateRow, TerrainEvidence, DECISION_SPAN};
        use terraslip_ros2::{import, TopicsConfig};

        let cfg = EstimatorConfig::default();
        for (tf, topics, from) in [
            (true, "", "/tf_static"),
            (false, "[pose]\nlever_arm = [0.3, 0.0]\n", "topics file"),
        ] {
            let d = tempfile::tempdir().unwrap();
            let bag = d.path().join("drive.mcap");
            write_bag(&bag, tf);
            let topics: TopicsConfig = toml::from_str(topics).unwrap();
            let (log, _) = import(&bag, &topics, None).unwrap();
            let offline = run(&log, &cfg, &TerrainEvidence::None, None).unwrap();

            let (mut live, mut samples) = terraslip::testkit::play_bag(&bag, &topics);
            // In stamp order, as the node hands each poll's messages on
            // (the bag holds the wheels' messages before the fixes').
            samples.sort_by(|a, b| a.t().total_cmp(&b.t()));
            let (mount, said) = live.lever_arm();
            assert_eq!(mount, log.meta.pose, "{from}");
            let said = said.expect("a decided line");
            assert!(said.contains(from) && said.contains("lever arm"), "{said}");
            // Asked again: the same answer, said once.
            assert_eq!(live.lever_arm(), (mount, None));

            let track = offline.track_width;
            let play = |mount: Option<terraslip_io::PoseMount>| -> Vec<EstimateRow> {
                let mut node =
                    WarmUp::new("graph", &cfg, track, None, 0.3, DECISION_SPAN, None, None)
                        .unwrap();
                node.set_pose_mount(mount);
                let mut rows: Vec<EstimateRow> = Vec::new();
                for s in samples.iter().cloned() {
                    node.push(s, &mut rows).unwrap();
                }
                node.flush(&mut rows).unwrap();
                rows
            };
            let rows = play(mount);
            assert_eq!(rows.len(), offline.rows.len(), "{from}");
            let (a, b) = (rows.last().unwrap(), offline.rows.last().unwrap());
            assert!(
                (a.x_c - b.x_c).abs() < 0.01,
                "{from}: live {} offline {}",
                a.x_c,
                b.x_c
            );
            let gap = (a.east - b.east).hypot(a.north - b.north);
            assert!(gap < 0.05, "{from}: live {gap} m from offline at the end");
            assert!((a.x_c - TRUE_X_C).abs() < 0.05, "{from}: x_c {}", a.x_c);
            // Control: with no lever arm the live x_c takes the offset.
            let unstated = play(None);
            let x = unstated.last().unwrap().x_c;
            assert!((x - TRUE_X_C).abs() > 0.2, "{from}: unstated x_c {x}");
        }
    }
}
