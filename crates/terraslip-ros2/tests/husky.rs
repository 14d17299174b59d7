//! The Husky recording the repository ships (`data/husky_test1`), in both
//! storage formats (its sqlite3 copy written at test time).

mod support;

use support::{husky_db3, husky_mcap};
use terraslip_ros2::{import, import_within, TopicsConfig};

fn cfg() -> TopicsConfig {
    // The heading named: kept without the course check.
    toml::from_str("[wheels]\nseparation = 1.040625\n[heading]\ntopic = \"/imu/data\"\n").unwrap()
}

#[test]
fn both_storage_formats_give_the_same_log() {
    let tmp = tempfile::tempdir().unwrap();
    let (m, d) = (husky_mcap(), husky_db3(tmp.path()));
    let (a, ra) = import(&m, &cfg(), None).unwrap();
    let (b, rb) = import(&d, &cfg(), None).unwrap();
    assert_eq!(a.wheels, b.wheels);
    assert_eq!(a.pose, b.pose);
    assert_eq!(a.imu, b.imu);
    assert_eq!(ra.time_origin_ns, rb.time_origin_ns);
    print!("{}", ra.to_text());
    assert_eq!(a.wheels.len(), 3952);
    assert_eq!(a.imu.len(), 11865);
    let fixes = a.pose.iter().filter(|p| p.east.is_some()).count();
    assert!(fixes > 900 && fixes <= 989, "{fixes}");
    let yaws = a.pose.iter().filter(|p| p.yaw.is_some()).count();
    assert_eq!(yaws, 11865);
    // The first good fix is the ENU origin; a 395 s drive stays within a few hundred metres.
    let first = a.pose.iter().find(|p| p.east.is_some()).unwrap();
    assert!(first.east.unwrap().abs() < 1e-6 && first.north.unwrap().abs() < 1e-6);
    for p in a.pose.iter().filter(|p| p.east.is_some()) {
        assert!(p.east.unwrap().hypot(p.north.unwrap()) < 1000.0);
        let s = p.std_xy.expect("covariance type approximated (1)");
        assert!(s > 0.1 && s < 5.0, "{s}");
    }
}

#[test]
fn with_no_topics_file_the_scale_mounting_and_heading_are_decided_and_said() {
    let m = husky_mcap();
    let (log, report) = import(&m, &TopicsConfig::default(), None).unwrap();
    let text = report.to_text();
    print!("{text}");
    // No /robot_description, no track width: the default separation.
    assert_eq!(log.meta.separation_source.as_deref(), Some("default"));
    assert!(text.contains("decided: separation S = 1 m"), "{text}");
    // The IMU is mounted y-up (robot_localization's test launch): found
    // from gravity, and its gyro follows the treads once rotated.
    assert!(
        text.contains("/imu/data: mounted roll 90.0°, pitch 0.0°")
            && text.contains("from the data"),
        "{text}"
    );
    let n = log.imu.len() as f64;
    let g = log.imu.iter().map(|s| s.accel_z).sum::<f64>() / n;
    assert!((g - 9.8).abs() < 0.1, "{g}");
    assert!(!report.warnings.iter().any(|w| w.contains("not along +z")));
    // The magnetometer heading is off by different amounts in different
    // directions: left out, with a warning.
    assert!(
        report
            .warnings
            .iter()
            .any(|w| w.contains("/imu/data: heading left out")),
        "{:?}",
        report.warnings
    );
    assert!(log.pose.iter().all(|p| p.yaw.is_none() && p.east.is_some()));
}

#[test]
fn a_zstd_file_compressed_sqlite_bag_reads_the_same() {
    let plain = tempfile::tempdir().unwrap();
    let d = husky_db3(plain.path());
    let tmp = tempfile::tempdir().unwrap();
    let raw = std::fs::read(d.join("husky_test1.db3")).unwrap();
    let z = zstd::encode_all(&raw[..], 3).unwrap();
    std::fs::write(tmp.path().join("husky_test1.db3.zstd"), z).unwrap();
    let meta = std::fs::read_to_string(d.join("metadata.yaml"))
        .unwrap()
        .replace("- husky_test1.db3", "- husky_test1.db3.zstd")
        .replace("compression_format: ''", "compression_format: zstd")
        .replace("compression_mode: ''", "compression_mode: FILE");
    std::fs::write(tmp.path().join("metadata.yaml"), meta).unwrap();
    let (a, _) = import(&d, &cfg(), None).unwrap();
    let (b, _) = import(tmp.path(), &cfg(), None).unwrap();
    assert_eq!(a.wheels, b.wheels);
    assert_eq!(a.pose, b.pose);
}

#[test]
fn a_per_message_zstd_sqlite_bag_reads_the_same() {
    let plain = tempfile::tempdir().unwrap();
    let d = husky_db3(plain.path());
    let tmp = tempfile::tempdir().unwrap();
    let db = tmp.path().join("husky_test1.db3");
    std::fs::copy(d.join("husky_test1.db3"), &db).unwrap();
    {
        let conn = rusqlite::Connection::open(&db).unwrap();
        let rows: Vec<(i64, Vec<u8>)> = conn
            .prepare("SELECT id, data FROM messages")
            .unwrap()
            .query_map([], |r| Ok((r.get(0)?, r.get(1)?)))
            .unwrap()
            .map(Result::unwrap)
            .collect();
        let tx = conn.unchecked_transaction().unwrap();
        for (id, data) in rows {
            let z = zstd::encode_all(&data[..], 1).unwrap();
            tx.execute(
                "UPDATE messages SET data = ?1 WHERE id = ?2",
                rusqlite::params![z, id],
            )
            .unwrap();
        }
        tx.commit().unwrap();
    }
    let meta = std::fs::read_to_string(d.join("metadata.yaml"))
        .unwrap()
        .replace("compression_format: ''", "compression_format: zstd")
        .replace("compression_mode: ''", "compression_mode: MESSAGE");
    std::fs::write(tmp.path().join("metadata.yaml"), meta).unwrap();
    let (a, _) = import(&d, &cfg(), None).unwrap();
    let (b, _) = import(tmp.path(), &cfg(), None).unwrap();
    assert_eq!(a.wheels, b.wheels);
    assert_eq!(a.pose, b.pose);
    assert_eq!(a.imu, b.imu);
}

#[test]
fn the_shipped_recording_reads_as_the_shared_one_in_both_formats() {
    let (Some(m), Some(d)) = (
        terraslip_io::shared::shared_data("ros2/husky_test1_mcap"),
        terraslip_io::shared::shared_data("ros2/husky_test1_db3"),
    ) else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let pairs = [(m, husky_mcap()), (d, husky_db3(tmp.path()))];
    for (shared, shipped) in pairs {
        let (a, ra) = import(&shared, &cfg(), None).unwrap();
        let (b, rb) = import(&shipped, &cfg(), None).unwrap();
        let what = shipped.display();
        assert_eq!(a.wheels, b.wheels, "{what}");
        assert_eq!(a.pose, b.pose, "{what}");
        assert_eq!(a.imu, b.imu, "{what}");
        assert_eq!(ra.time_origin_ns, rb.time_origin_ns, "{what}");
        assert_eq!(ra.warnings, rb.warnings, "{what}");
    }
}

/// Decided from its first 200 s, the Husky recording (395 s) is read whole
/// with what they settled, and says so; the scale and its source are the
/// window's. A window longer than the recording decides from all of it,
/// as [`import`] does.
#[test]
fn decided_from_a_first_window_the_whole_recording_is_read() {
    let m = husky_mcap();
    let none = TopicsConfig::default();
    let (whole, rw) = import(&m, &none, None).unwrap();
    let (win, r) = import_within(&m, &none, None, 200.0).unwrap();
    assert!(
        r.decisions[0].starts_with("decided from the first 200 s"),
        "{:?}",
        r.decisions
    );
    assert!(r.to_text().contains("from the data"), "{}", r.to_text());
    assert_eq!(win.meta.separation_source.as_deref(), Some("default"));
    assert_eq!(win.wheels.len(), whole.wheels.len());
    assert_eq!(win.imu.len(), whole.imu.len());
    let (long, rl) = import_within(&m, &none, None, 1e6).unwrap();
    assert_eq!(rl.decisions, rw.decisions);
    assert_eq!(long.pose.len(), whole.pose.len());
}
