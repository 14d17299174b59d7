//! The Husky recording the repository ships (`data/husky_test1`) played
//! message by message into [`LiveImport`] makes the rows `import` makes of
//! it.

use terraslip_ros2::import::{LiveImport, LiveRow};
use terraslip_ros2::{import, Bag, TopicsConfig};

#[test]
fn a_recording_played_live_makes_the_rows_import_makes() {
    let path = terraslip_io::shared::repo_data("husky_test1");
    // The import leaves out a heading that disagrees with the GNSS course,
    // which a live graph cannot check before it starts: no heading here.
    let cfg: TopicsConfig = toml::from_str(
        "[wheels]\nseparation = 1.040625\n[imu]\nmount_rpy_deg = [90, 0, -90]\n[heading]\ntopic = \"\"\n",
    )
    .unwrap();
    let (log, report) = import(&path, &cfg, None).unwrap();

    let mut bag = Bag::open(&path).unwrap();
    let mut live = LiveImport::new("ROS 2 graph", bag.topics.clone(), &cfg).unwrap();
    let mut rows: Vec<LiveRow> = Vec::new();
    bag.for_each(&|_| true, &mut |_, m| {
        rows.extend(live.message(m.topic, m.recv_ns, m.data).unwrap());
        Ok(())
    })
    .unwrap();
    rows.sort_by(|a, b| a.t().total_cmp(&b.t()));
    // The two time bases differ by whole seconds at most.
    let shift = (live.origin_ns().unwrap() as f64 - report.time_origin_ns as f64) * 1e-9;
    assert_eq!(shift.fract(), 0.0);
    let t = |x: f64| x + shift;
    let wheels: Vec<_> = rows
        .iter()
        .filter_map(|r| match r {
            LiveRow::Wheels(w) => Some(*w),
            _ => None,
        })
        .collect();
    let pose: Vec<_> = rows
        .iter()
        .filter_map(|r| match r {
            LiveRow::Pose(p) => Some(*p),
            _ => None,
        })
        .collect();
    let imu: Vec<_> = rows
        .iter()
        .filter_map(|r| match r {
            LiveRow::Imu(s) => Some(*s),
            _ => None,
        })
        .collect();
    assert_eq!(wheels.len(), log.wheels.len());
    assert_eq!(pose.len(), log.pose.len());
    assert_eq!(imu.len(), log.imu.len());
    for (a, b) in wheels.iter().zip(&log.wheels) {
        assert!((t(a.t) - b.t).abs() < 1e-6, "{} {}", t(a.t), b.t);
        assert_eq!((a.v_left, a.v_right), (b.v_left, b.v_right));
    }
    for (a, b) in imu.iter().zip(&log.imu) {
        assert!((t(a.t) - b.t).abs() < 1e-6);
        assert_eq!((a.gyro_z, a.accel_z), (b.gyro_z, b.accel_z));
    }
    for (a, b) in pose.iter().zip(&log.pose) {
        assert!((t(a.t) - b.t).abs() < 1e-6);
        assert_eq!((a.east, a.north, a.yaw), (b.east, b.north, b.yaw));
        assert_eq!((a.std_xy, a.std_yaw), (b.std_xy, b.std_yaw));
    }
    assert_eq!(live.enu_origin(), report.enu_origin);
    assert_eq!(live.report.mounts, report.mounts);
}

#[test]
fn a_graph_without_a_wheel_source_is_refused_with_what_it_has() {
    let topics = vec![terraslip_ros2::Topic {
        name: "/fix".into(),
        ty: "sensor_msgs/msg/NavSatFix".into(),
        definition: String::new(),
        count: 0,
    }];
    let cfg = TopicsConfig::default();
    let e = LiveImport::new("ROS 2 graph, domain 0", topics, &cfg)
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("no usable wheel source") && e.contains("/fix"),
        "{e}"
    );
}
