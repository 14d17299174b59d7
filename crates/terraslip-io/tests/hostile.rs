//! Hostile and extreme input to the readers: each is refused (or, where the
//! log format allows it, used) with an error naming the file, the line or
//! field, and what to do.

use std::fs;
use std::path::Path;

use terraslip_io::{DriveLog, LogError, ParamsFile};

fn log_with(files: &[(&str, &str)]) -> tempfile::TempDir {
    let d = tempfile::tempdir().unwrap();
    fs::write(
        d.path().join("wheels.csv"),
        "t,v_left,v_right\n0,0,0\n0.1,1,1\n",
    )
    .unwrap();
    for (name, text) in files {
        fs::write(d.path().join(name), text).unwrap();
    }
    d
}

fn read_err(d: &Path) -> String {
    DriveLog::read(d).expect_err("must be refused").to_string()
}

#[test]
fn a_duplicate_header_column_names_both_columns() {
    let d = log_with(&[("wheels.csv", "t,v_left,v_right,v_left\n0,0,0,1\n")]);
    let e = read_err(d.path());
    assert!(e.contains("wheels.csv:1:"), "{e}");
    assert!(
        e.contains("columns 2 and 4") && e.contains("`v_left`"),
        "{e}"
    );
}

#[test]
fn extreme_finite_values_are_refused_with_file_line_and_column() {
    let d = log_with(&[("wheels.csv", "t,v_left,v_right\n0,0,0\n0.1,1e308,1\n")]);
    let e = read_err(d.path());
    assert!(e.contains("wheels.csv:3:") && e.contains("`v_left`"), "{e}");
    assert!(e.contains("physical range"), "{e}");
    let d = log_with(&[("pose.csv", "t,east,north,yaw\n0,0,0,0\n0.1,1e308,0,0\n")]);
    let e = read_err(d.path());
    assert!(e.contains("pose.csv:3:") && e.contains("`east`"), "{e}");
    let d = log_with(&[("pose.csv", "t,east,north,yaw\n0,0,0,1e300\n")]);
    assert!(read_err(d.path()).contains("`yaw`"));
    let d = log_with(&[("wheels.csv", "t,v_left,v_right\n1.7e18,0,0\n")]);
    assert!(read_err(d.path()).contains("`t`"));
}

#[test]
fn a_pose_row_with_only_east_empty_keeps_its_yaw() {
    let d = log_with(&[(
        "pose.csv",
        "t,east,north,yaw\n0,1,2,0.5\n0.1,,2,0.25\n0.2,,,\n",
    )]);
    let log = DriveLog::read(d.path()).expect("the log format allows it");
    assert_eq!(log.pose.len(), 2);
    assert_eq!((log.pose[1].east, log.pose[1].north), (None, None));
    assert_eq!(log.pose[1].yaw, Some(0.25));
    assert!(
        log.warnings.iter().any(|w| w.contains("pose.csv:3:")),
        "{:?}",
        log.warnings
    );
}

#[test]
fn image_paths_must_stay_inside_the_log_directory() {
    for bad in ["../../etc/passwd", "/etc/passwd", "images/../../x.png"] {
        let d = log_with(&[("images.csv", &format!("t,path\n0,{bad}\n"))]);
        let e = read_err(d.path());
        assert!(
            e.contains("images.csv:2:") && e.contains("leaves the log"),
            "{e}"
        );
    }
    let d = log_with(&[("images.csv", "t,path\n0,images/0001.png\n0.1,./b.png\n")]);
    assert_eq!(DriveLog::read(d.path()).unwrap().images.len(), 2);
}

#[test]
fn meta_toml_refuses_unknown_keys_and_absurd_sizes() {
    let d = log_with(&[("meta.toml", "robot = \"w\"\nwheel_separation = 0.5\n")]);
    let e = read_err(d.path());
    assert!(e.contains("meta.toml:2:"), "{e}");
    assert!(
        e.contains("unknown key `wheel_separation`") && e.contains("track_width"),
        "{e}"
    );
    let d = log_with(&[("meta.toml", "track_width = 1e300\n")]);
    let e = read_err(d.path());
    assert!(
        e.contains("meta.toml") && e.contains("`track_width`"),
        "{e}"
    );
    assert!(!e.contains("wheels.csv"), "{e}");
    // What `terraslip simulate` writes is still read.
    let d = log_with(&[(
        "meta.toml",
        "track_width = 0.5\nscenario = \"papers\"\nseed = 3\n",
    )]);
    DriveLog::read(d.path()).expect("simulated logs are read");
}

#[test]
fn a_missing_file_error_says_the_os_reason_once_and_what_to_do() {
    let d = tempfile::tempdir().unwrap();
    let e = ParamsFile::read(&d.path().join("nope.json")).unwrap_err();
    // The chain as the CLI prints it.
    let mut chain = e.to_string();
    let mut src = std::error::Error::source(&e);
    while let Some(s) = src {
        chain.push_str(&s.to_string());
        src = s.source();
    }
    assert!(chain.contains("nope.json"), "{chain}");
    assert!(chain.contains("check the path"), "{chain}");
    assert!(matches!(e, LogError::Io { .. }));
}

fn params_err(json: &str) -> String {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("params.json");
    fs::write(&p, json).unwrap();
    let e = ParamsFile::read(&p)
        .expect_err("must be refused")
        .to_string();
    assert!(e.contains("params.json"), "{e}");
    e
}

#[test]
fn params_files_are_checked_against_physical_ranges_naming_the_field() {
    let set = |y_l: f64, y_r: f64, a: f64| {
        format!(r#"{{"y_l": {y_l}, "y_r": {y_r}, "x_c": 0.0, "alpha_l": {a}, "alpha_r": 1.0}}"#)
    };
    let e = params_err(&format!(r#"{{"params": {}}}"#, set(1e308, -0.3, 1.0)));
    assert!(e.contains("params.y_l = "), "{e}");
    let e = params_err(&format!(r#"{{"params": {}}}"#, set(0.3, 0.3, 1.0)));
    assert!(e.contains("params.y_l, y_r"), "{e}");
    let e = params_err(&format!(r#"{{"params": {}}}"#, set(-0.3, 0.3, 1.0)));
    assert!(e.contains("params.y_l, y_r"), "{e}");
    let e = params_err(&format!(r#"{{"params": {}}}"#, set(0.3, -0.3, 0.0)));
    assert!(e.contains("params.alpha_l"), "{e}");
    let e = params_err(&format!(
        r#"{{"terrains": {{"sand": {{"params": {}}}}}}}"#,
        set(0.3, -0.3, -1.0)
    ));
    assert!(e.contains("terrains.sand.params.alpha_l"), "{e}");
}
