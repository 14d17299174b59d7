use std::path::Path;

use terraslip_io::*;

fn log_with(files: &[(&str, &str)]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for (name, body) in files {
        std::fs::write(dir.path().join(name), body).unwrap();
    }
    dir
}

const WHEELS: &str = "t,v_left,v_right\n0,0.1,0.2\n0.1,0.1,0.2\n";

fn parse_err(dir: &Path) -> (String, u64, String) {
    match DriveLog::read(dir) {
        Err(LogError::Parse { path, line, reason }) => (
            path.file_name().unwrap().to_string_lossy().into_owned(),
            line,
            reason,
        ),
        other => panic!("expected a parse error, got {other:?}"),
    }
}

#[test]
fn reads_columns_in_any_order_and_ignores_unknown_ones() {
    let d = log_with(&[
        (
            "wheels.csv",
            "v_right,extra,t,v_left\n0.2,x,0,0.1\n0.3,y,0.5,0.1\n",
        ),
        (
            "pose.csv",
            "t,yaw,north,east\n0,7.0,2,1\n0.5,,,\n1.0,,3,4\n",
        ),
        ("terrain.csv", "t,terrain\n0,grass\n0.3,soil\n"),
        ("meta.toml", "track_width = 0.4\n"),
    ]);
    let log = DriveLog::read(d.path()).unwrap();
    assert_eq!(log.wheels.len(), 2);
    assert_eq!(log.wheels[1].v_right, 0.3);
    // yaw is wrapped, empty row skipped with a warning
    assert_eq!(log.pose.len(), 2);
    let yaw = log.pose[0].yaw.unwrap();
    assert!((yaw - (7.0 - 2.0 * std::f64::consts::PI)).abs() < 1e-12);
    assert_eq!(log.pose[1].yaw, None);
    assert_eq!(log.pose[1].east, Some(4.0));
    assert!(
        log.warnings.iter().any(|w| w.contains("pose.csv:3")),
        "{:?}",
        log.warnings
    );
    assert_eq!(log.terrain_at(0.1), Some("grass"));
    assert_eq!(log.terrain_at(0.3), Some("soil"));
    assert_eq!(log.terrain_at(-1.0), Some("grass"));
    assert_eq!(log.meta.track_width, Some(0.4));
}

#[test]
fn missing_wheels_file_is_named() {
    let d = log_with(&[("pose.csv", "t,east,north,yaw\n")]);
    match DriveLog::read(d.path()) {
        Err(LogError::MissingFile { path }) => assert!(path.ends_with("wheels.csv")),
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_path_that_does_not_exist_says_so() {
    let d = tempfile::tempdir().unwrap();
    let typo = d.path().join("warthog_gravle");
    let e = DriveLog::read(&typo).unwrap_err().to_string();
    assert_eq!(
        e,
        format!("{}: does not exist; check the path", typo.display())
    );
    std::fs::write(&typo, "").unwrap();
    let e = DriveLog::read(&typo).unwrap_err().to_string();
    assert!(e.contains("not a log directory"), "{e}");
}

#[test]
fn missing_column_names_column_and_file() {
    let d = log_with(&[("wheels.csv", "t,v_left\n0,1\n")]);
    let err = DriveLog::read(d.path()).unwrap_err();
    assert!(matches!(err, LogError::MissingColumn { ref column, .. } if column == "v_right"));
    assert!(err.to_string().contains("wheels.csv"));
}

#[test]
fn non_numeric_cell_reports_line() {
    let d = log_with(&[("wheels.csv", "t,v_left,v_right\n0,0,0\n0.1,fast,0\n")]);
    let (file, line, reason) = parse_err(d.path());
    assert_eq!((file.as_str(), line), ("wheels.csv", 3));
    assert!(reason.contains("fast"), "{reason}");
}

#[test]
fn nan_and_infinite_cells_are_rejected() {
    for bad in ["NaN", "inf", "-inf"] {
        let d = log_with(&[("wheels.csv", &format!("t,v_left,v_right\n0,0,{bad}\n"))]);
        let (_, line, reason) = parse_err(d.path());
        assert_eq!(line, 2);
        assert!(reason.contains("not finite"), "{reason}");
    }
}

#[test]
fn time_going_backwards_is_an_error_with_both_lines() {
    let d = log_with(&[
        ("wheels.csv", WHEELS),
        (
            "pose.csv",
            "t,east,north,yaw\n1,0,0,0\n2,0,0,0\n1.5,0,0,0\n",
        ),
    ]);
    let (file, line, reason) = parse_err(d.path());
    assert_eq!((file.as_str(), line), ("pose.csv", 4));
    assert!(
        reason.contains("backwards") && reason.contains("line 3"),
        "{reason}"
    );
}

#[test]
fn duplicate_timestamps_are_dropped_with_a_warning() {
    let d = log_with(&[(
        "wheels.csv",
        "t,v_left,v_right\n0,0,0\n0.1,1,1\n0.1,2,2\n0.2,1,1\n",
    )]);
    let log = DriveLog::read(d.path()).unwrap();
    assert_eq!(log.wheels.len(), 3);
    assert_eq!(log.wheels[1].v_left, 1.0);
    assert!(
        log.warnings[0].contains("wheels.csv:4"),
        "{:?}",
        log.warnings
    );
}

#[test]
fn binary_file_is_not_csv() {
    let d = tempfile::tempdir().unwrap();
    std::fs::write(
        d.path().join("wheels.csv"),
        [0xff, 0xfe, 0x00, 0x81, b'\n', 0x90],
    )
    .unwrap();
    let err = DriveLog::read(d.path()).unwrap_err();
    assert!(err.to_string().contains("wheels.csv"), "{err}");
}

#[test]
fn ragged_rows_and_empty_files_are_errors() {
    let d = log_with(&[("wheels.csv", "t,v_left,v_right\n0,1\n")]);
    let (_, line, reason) = parse_err(d.path());
    assert_eq!(line, 2);
    assert!(reason.contains("fields"), "{reason}");
    let d = log_with(&[("wheels.csv", "t,v_left,v_right\n")]);
    assert!(matches!(
        DriveLog::read(d.path()),
        Err(LogError::Invalid { .. })
    ));
}

#[test]
fn bad_meta_is_reported() {
    let d = log_with(&[("wheels.csv", WHEELS), ("meta.toml", "track_width = -1\n")]);
    assert!(DriveLog::read(d.path())
        .unwrap_err()
        .to_string()
        .contains("track_width"));
    let d = log_with(&[
        ("wheels.csv", WHEELS),
        ("meta.toml", "track_width = \"wide\"\n"),
    ]);
    assert!(matches!(
        DriveLog::read(d.path()),
        Err(LogError::Parse { .. })
    ));
}

#[test]
fn the_pose_reference_is_read_and_a_kind_not_known_is_named() {
    for (stated, kind) in [
        ("gnss", PoseReference::Gnss),
        ("localiser", PoseReference::Localiser),
        ("localizer", PoseReference::Localiser),
    ] {
        let meta = format!("track_width = 1.1\npose_reference = \"{stated}\"\n");
        let d = log_with(&[("wheels.csv", WHEELS), ("meta.toml", &meta)]);
        assert_eq!(
            DriveLog::read(d.path()).unwrap().meta.pose_reference,
            Some(kind)
        );
    }
    let d = log_with(&[
        ("wheels.csv", WHEELS),
        (
            "meta.toml",
            "track_width = 1.1\npose_reference = \"lidar\"\n",
        ),
    ]);
    let (file, line, reason) = parse_err(d.path());
    assert_eq!((file.as_str(), line), ("meta.toml", 2));
    assert!(
        reason.contains("lidar") && reason.contains("localiser"),
        "{reason}"
    );
}

#[test]
fn write_then_read_round_trips() {
    let log = DriveLog {
        wheels: vec![
            WheelSample {
                t: 0.0,
                v_left: 0.1,
                v_right: 0.2,
            },
            WheelSample {
                t: 0.02,
                v_left: 0.123456789012345,
                v_right: -0.2,
            },
        ],
        pose: vec![PoseObs {
            t: 0.0,
            east: Some(1.5),
            north: Some(-2.0),
            yaw: None,
            std_xy: Some(2.0),
            std_yaw: None,
        }],
        terrain: vec![TerrainLabel {
            t: 0.0,
            terrain: "soil".into(),
        }],
        truth: vec![TruthSample {
            t: 0.0,
            east: 1.0,
            north: 2.0,
            yaw: 0.5,
            y_l: 0.3,
            y_r: -0.3,
            x_c: 0.01,
        }],
        meta: Meta {
            track_width: Some(0.4),
            ..Default::default()
        },
        ..Default::default()
    };
    let d = tempfile::tempdir().unwrap();
    log.write(d.path()).unwrap();
    let back = DriveLog::read(d.path()).unwrap();
    assert_eq!(back.wheels, log.wheels);
    assert_eq!(back.pose, log.pose);
    assert_eq!(back.terrain, log.terrain);
    assert_eq!(back.truth, log.truth);
    assert_eq!(back.meta, log.meta);
}

#[test]
fn params_file_round_trips_and_validates() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("params.json");
    let mut pf = ParamsFile {
        params: Some(terraslip_core::IcrParams::new(0.3, -0.3, 0.0)),
        ..Default::default()
    };
    pf.terrains.insert(
        "ice".into(),
        ParamEntry::new(terraslip_core::IcrParams::new(0.5, -0.5, 0.1)),
    );
    pf.write(&p).unwrap();
    let back = ParamsFile::read(&p).unwrap();
    assert_eq!(back, pf);
    assert_eq!(back.for_terrain(Some("ice")).unwrap().y_l, 0.5);
    assert_eq!(back.for_terrain(Some("sand")).unwrap().y_l, 0.3);

    std::fs::write(&p, r#"{"params": {"y_l": 0.1, "y_r": 0.2, "x_c": 0}}"#).unwrap();
    assert!(ParamsFile::read(&p)
        .unwrap_err()
        .to_string()
        .contains("spread"));
    std::fs::write(&p, r#"{"other": 1}"#).unwrap();
    assert!(matches!(
        ParamsFile::read(&p),
        Err(LogError::Invalid { .. })
    ));
    std::fs::write(&p, "{not json").unwrap();
    assert!(matches!(ParamsFile::read(&p), Err(LogError::Parse { .. })));
}

#[test]
fn reads_the_shared_real_logs() {
    let Some(root) = terraslip_io::shared::shared_data("") else {
        return;
    };
    let log = DriveLog::read(root.join("drive/warthog_ice")).unwrap();
    assert!(log.wheels.len() > 10_000 && log.pose.len() > 3_000);
    assert_eq!(log.meta.track_width, Some(1.10));
    let log = DriveLog::read(root.join("borealtc/snow_borealtc_07")).unwrap();
    assert!(log.imu.len() > 5_000 && log.imu[0].gyro_z.is_some());
    assert_eq!(log.terrain_at(1.0), Some("snow"));
}
