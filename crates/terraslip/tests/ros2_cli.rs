//! ROS 2 on the command line: `import`, a bag in place of a LOG (identical
//! results), `estimate --mcap`, and refusals that name the problem.
#![cfg(feature = "ros2")]

use std::path::Path;

use assert_cmd::Command;
use terraslip_ros2::defs::definition_of;
use terraslip_ros2::msg::CdrWriter;
use terraslip_ros2::out::{EstimateMcap, EstimateSample};

const T0: u64 = 1_700_000_000_000_000_000;

/// 60 s on a circle (1 m/s, 0.2 rad/s): odometry twist at 20 Hz, a
/// PoseStamped reference at 5 Hz.
fn write_bag(p: &Path) {
    let mut m = EstimateMcap::create(p).unwrap();
    let ty = "geometry_msgs/msg/PoseStamped";
    let pose = m.channel("/ref", ty, &definition_of(ty).unwrap()).unwrap();
    for k in 0..1200u64 {
        let t = k as f64 * 0.05;
        let ns = T0 + k * 50_000_000;
        let yaw = 0.2 * t;
        let (x, y) = (5.0 * yaw.sin(), 5.0 * (1.0 - yaw.cos()));
        let s = EstimateSample {
            stamp_ns: ns,
            twist: [1.0, 0.0, 0.2],
            ..Default::default()
        };
        m.estimate(&s, None).unwrap();
        if k % 4 == 0 {
            let mut w = CdrWriter::new();
            w.header(ns, "map");
            let (sz, cz) = (yaw / 2.0).sin_cos();
            for v in [x, y, 0.0, 0.0, 0.0, sz, cz] {
                w.f64(v);
            }
            m.write(pose, ns, &w.finish()).unwrap();
        }
    }
    m.finish().unwrap();
}

fn run(args: &[&str]) -> std::process::Output {
    Command::cargo_bin("terraslip")
        .unwrap()
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn a_bag_and_its_imported_log_give_the_same_estimate() {
    let d = tempfile::tempdir().unwrap();
    let bag = d.path().join("drive.mcap");
    write_bag(&bag);
    let topics = d.path().join("t.toml");
    std::fs::write(
        &topics,
        "[wheels]\ntopic = \"/terraslip/odom\"\nseparation = 0.6\n[meta]\ntrack_width = 0.5\n",
    )
    .unwrap();
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let (log, e1, e2, mc) = (
        d.path().join("log"),
        d.path().join("e1"),
        d.path().join("e2"),
        d.path().join("e.mcap"),
    );

    // Without the separation: a nominal one (nothing in the bag tells it),
    // said so, and the estimate's controller factor in its scale.
    let e0 = d.path().join("e0");
    let out = run(&["estimate", &s(&bag), "--out", &s(&e0)]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("decided: separation S = 1 m") && err.contains("/terraslip/odom"),
        "{err}"
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(e0.join("summary.json")).unwrap()).unwrap();
    let c = &summary["controller"];
    assert_eq!(c["separation_source"], "default");
    assert!(c["wheel_separation_m"].is_null());
    assert!(c["separation_factor"].as_f64().unwrap() > 0.0);
    // 60 s of drive: the prediction's warm-up shortened to leave 20 s of
    // starts, and said so.
    let w = summary["prediction"]["warmup_s"].as_f64().unwrap();
    assert!((30.0..=40.0).contains(&w), "{}", summary["prediction"]);
    assert!(!err.contains("no 2 s prediction figure"), "{err}");
    // The bag states no track width: the warning says where a bag's goes.
    assert!(
        err.contains("no track width") && err.contains("`[meta] track_width` in the --topics file"),
        "{err}"
    );

    let out = run(&[
        "import",
        &s(&bag),
        "--out",
        &s(&log),
        "--topics",
        &s(&topics),
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(report["time_origin_ns"], T0);
    let text = String::from_utf8_lossy(&out.stderr);
    assert!(
        text.contains(
            "/terraslip/odom (nav_msgs/Odometry) -> wheels.csv: 1200 of 1200 messages, 20.0 Hz"
        ),
        "{text}"
    );
    assert!(
        text.contains("/ref (geometry_msgs/PoseStamped) -> pose.csv"),
        "{text}"
    );
    let wheels = std::fs::read_to_string(log.join("wheels.csv")).unwrap();
    // v -/+ w S / 2 = 1 -/+ 0.06
    assert!(
        wheels.lines().nth(1).unwrap().starts_with("0,0.94,1.06"),
        "{wheels}"
    );
    // The controller's model beside it, as an --init file: spread S.
    let model = log.join("controller.json");
    let p = terraslip_io::ParamsFile::read(&model)
        .unwrap()
        .params
        .unwrap();
    assert_eq!((p.y_l, p.y_r, p.alpha_l), (0.3, -0.3, 1.0));
    assert!(text.contains("controller.json"), "{text}");

    let out = run(&[
        "estimate",
        &s(&bag),
        "--topics",
        &s(&topics),
        "--out",
        &s(&e1),
        "--mcap",
        &s(&mc),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = run(&["estimate", &s(&log), "--out", &s(&e2)]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let a = std::fs::read(e1.join("estimate.csv")).unwrap();
    assert_eq!(a, std::fs::read(e2.join("estimate.csv")).unwrap());
    assert_eq!(a.iter().filter(|&&b| b == b'\n').count(), 1201);

    // The MCAP holds the estimate and the two input topics.
    let mut b = terraslip_ros2::Bag::open(&mc).unwrap();
    b.for_each(&|_| true, &mut |_, _| Ok(())).unwrap();
    let count = |name: &str| b.topics[b.topic(name).unwrap()].count;
    assert_eq!(count("/terraslip/icr"), 1200);
    assert_eq!(count("/ref"), 300);
    // The input's /terraslip/odom is passed through beside the estimate's own.
    assert_eq!(count("/terraslip/odom"), 2400);

    // Never into the bag.
    let bagdir = d.path().join("bagdir");
    std::fs::create_dir(&bagdir).unwrap();
    std::fs::write(bagdir.join("metadata.yaml"), "x").unwrap();
    let out = run(&[
        "import",
        &s(&bag),
        "--out",
        &s(&bagdir),
        "--topics",
        &s(&topics),
    ]);
    assert!(!out.status.success());
}

#[test]
fn a_bag_directory_without_metadata_is_read_from_its_storage_files() {
    // `ros2 bag record` writes metadata.yaml when it closes the bag: a
    // recording that was killed, or copied without it, is a directory of
    // storage files alone.
    let d = tempfile::tempdir().unwrap();
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let bag = d.path().join("run 1");
    std::fs::create_dir(&bag).unwrap();
    write_bag(&bag.join("run_0.mcap"));
    let (from_dir, from_file) = (d.path().join("a"), d.path().join("b"));
    for (input, out) in [
        (bag.clone(), &from_dir),
        (bag.join("run_0.mcap"), &from_file),
    ] {
        let o = run(&["import", &s(&input), "--out", &s(out)]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let wheels = std::fs::read(from_dir.join("wheels.csv")).unwrap();
    assert_eq!(wheels, std::fs::read(from_file.join("wheels.csv")).unwrap());
    assert_eq!(wheels.iter().filter(|&&b| b == b'\n').count(), 1201);
    // Every command takes it as a bag, not as a log missing wheels.csv.
    let o = run(&["estimate", &s(&bag), "--out", &s(&d.path().join("e"))]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn ros2_params_without_a_wheel_radius_leave_the_controllers_own() {
    // An odometry twist carries tread speeds, not wheel angular rates: the
    // bag does not tell the wheel radius, and a made-up one would be pasted
    // into the controller's configuration.
    let d = tempfile::tempdir().unwrap();
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let bag = d.path().join("drive.mcap");
    write_bag(&bag);
    let topics = d.path().join("t.toml");
    let yaml = d.path().join("ddc.yaml");
    // The diff_drive_controller file `calibrate` writes with `[meta]` ...
    let ddc = |meta: &str| {
        std::fs::write(
            &topics,
            format!("[wheels]\nseparation = 0.6\n[meta]\n{meta}"),
        )
        .unwrap();
        let o = run(&[
            "calibrate",
            &s(&bag),
            "--topics",
            &s(&topics),
            "--out",
            &s(&d.path().join("p.json")),
            "--ros2-params",
            &s(&yaml),
            "--allow-partial",
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        std::fs::read_to_string(&yaml).unwrap()
    };
    let y = ddc("track_width = 0.5\n");
    assert!(!y.contains("    wheel_radius:"), "{y}");
    assert!(
        y.contains("keep the controller's own\n# wheel_radius"),
        "{y}"
    );
    assert!(y.contains("    wheel_separation: 0.500000"), "{y}");
    assert!(y.contains("    left_wheel_radius_multiplier:"), "{y}");
    // The block is named after the controller of the wheels' odometry
    // topic, /terraslip/odom.
    assert!(y.contains("\nterraslip:\n  ros__parameters:"), "{y}");
    // Stated, it is written.
    let y = ddc("track_width = 0.5\nwheel_radius = 0.165\n");
    assert!(y.contains("    wheel_radius: 0.165000"), "{y}");
    assert!(!y.contains("keep the controller's own"), "{y}");
}

#[cfg(not(any(feature = "node", feature = "node-humble")))]
#[test]
fn node_in_a_build_without_it_says_how_to_get_it() {
    // README: `terraslip node` right after `cargo install --path crates/terraslip`.
    for args in [
        &["node"][..],
        &[
            "node",
            "--topics",
            "husky.toml",
            "--ros-args",
            "-p",
            "lag:=0.5",
        ][..],
    ] {
        let o = run(args);
        assert!(!o.status.success());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            err.contains("cargo install --path crates/terraslip --features node")
                && err.contains("--features node-humble"),
            "{err}"
        );
    }
}

#[test]
fn a_truncated_mcap_is_read_up_to_the_cut_with_a_warning() {
    // A recording killed mid-write: the file stops inside a record and has
    // no summary or footer.
    let d = tempfile::tempdir().unwrap();
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let bag = d.path().join("killed.mcap");
    write_bag(&bag);
    let whole = std::fs::read(&bag).unwrap();
    let cut = whole.len() * 2 / 3;
    std::fs::write(&bag, &whole[..cut]).unwrap();
    let est = d.path().join("est");
    let o = run(&["estimate", &s(&bag), "--out", &s(&est)]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains(&format!(
            "warning: {}: the file ends in the middle of a record at byte {cut}",
            bag.display()
        )) && err.contains("the rest is lost")
            && err.contains("`mcap recover"),
        "{err}"
    );
    let read: u64 = err
        .split("read the ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no message count in {err}"));
    // 1200 estimates of several messages each and 300 poses in the whole file.
    assert!(read > 0, "{err}");
    let rows = std::fs::read_to_string(est.join("estimate.csv"))
        .unwrap()
        .lines()
        .count()
        - 1;
    assert!(rows > 100 && rows < 1200, "{rows} rows");
    // Said once, though the bag is read more than once.
    assert_eq!(err.matches("the rest is lost").count(), 1, "{err}");
}

#[test]
fn every_log_argument_says_it_takes_a_rosbag2() {
    for args in [
        &["estimate", "--help"][..],
        &["calibrate", "--help"],
        &["calibrate", "validate", "--help"],
        &["report", "--help"],
    ] {
        let o = run(args);
        assert!(o.status.success());
        let text = String::from_utf8_lossy(&o.stdout);
        // The LOG argument's help: its line to the next blank line.
        let lines: Vec<&str> = text.lines().collect();
        let start = lines
            .iter()
            .position(|l| {
                let l = l.trim_start();
                l.starts_with("[LOG]") || l.starts_with("<LOG>") || l.starts_with("--log <LOG>")
            })
            .unwrap_or_else(|| panic!("{args:?}: no LOG argument in\n{text}"));
        let help: String = lines[start..]
            .iter()
            .take_while(|l| !l.trim().is_empty())
            .copied()
            .collect::<Vec<_>>()
            .join(" ");
        assert!(
            help.contains("rosbag2")
                && help.contains("MCAP")
                && help.contains("sqlite3")
                && help.contains("--topics"),
            "{args:?}: {help}"
        );
    }
}

#[test]
fn two_outputs_of_one_run_on_one_path_are_refused_before_any_work() {
    let d = tempfile::tempdir().unwrap();
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let bag = d.path().join("drive.mcap");
    write_bag(&bag);
    let est = d.path().join("est");
    for (mcap, clash) in [
        (est.join("summary.json"), est.join("summary.json")),
        (est.join("./estimate.csv"), est.join("estimate.csv")),
        (est.clone(), est.clone()),
    ] {
        let o = run(&["estimate", &s(&bag), "--out", &s(&est), "--mcap", &s(&mcap)]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{err}");
        assert!(
            err.contains(&format!("--mcap {}", mcap.display()))
                && err.contains(&format!("{}, which --out writes", clash.display())),
            "{err}"
        );
        assert!(!est.exists(), "{err}");
    }
    let p = d.path().join("p.json");
    let o = run(&[
        "calibrate",
        &s(&bag),
        "--out",
        &s(&p),
        "--ros2-params",
        &s(&p),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{err}");
    assert!(
        err.contains(&format!("--ros2-params {}", p.display()))
            && err.contains(&format!("{}, which --out writes", p.display())),
        "{err}"
    );
}

fn run_in(dir: &Path, args: &[&str]) -> std::process::Output {
    Command::cargo_bin("terraslip")
        .unwrap()
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn report_finds_the_log_from_anywhere_and_names_it_when_it_moved() {
    // The estimate is run on a relative path; report runs elsewhere.
    let d = tempfile::tempdir().unwrap();
    let s = |p: &Path| p.to_str().unwrap().to_string();
    write_bag(&d.path().join("drive.mcap"));
    let o = run_in(d.path(), &["estimate", "drive.mcap", "--out", "est"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let elsewhere = d.path().join("elsewhere");
    std::fs::create_dir(&elsewhere).unwrap();
    let est = d.path().join("est");
    let o = run_in(&elsewhere, &["report", &s(&est)]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(!err.contains("without the pose reference"), "{err}");

    // Moved: the path recorded is named, and how to point at it.
    std::fs::rename(d.path().join("drive.mcap"), d.path().join("moved.mcap")).unwrap();
    let o = run_in(&elsewhere, &["report", &s(&est)]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    let recorded = std::path::absolute(d.path().join("drive.mcap")).unwrap();
    assert!(
        err.contains(&format!(
            "{} (recorded in {}) no longer exists",
            recorded.display(),
            est.join("summary.json").display()
        )) && err.contains("--log"),
        "{err}"
    );
}
