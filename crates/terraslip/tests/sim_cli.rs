//! `terraslip simulate` as scripts call it.

use assert_cmd::Command;

fn terraslip() -> Command {
    Command::cargo_bin("terraslip").unwrap()
}

fn stderr(out: &std::process::Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// A short scenario so the tests stay fast.
const SHORT: &str = r#"
name = "short"
description = "two short segments"
[[segment]]
terrain = "soil"
duration = 15.0
[[segment]]
terrain = "gravel"
duration = 15.0
[camera]
rate = 0.2
width = 64
height = 48
"#;

#[test]
fn list_names_every_builtin_with_a_description() {
    let out = terraslip().args(["simulate", "--list"]).output().unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    for name in ["papers", "papers-rtk", "wang4", "p3at-calib", "gnss-outage"] {
        let line = text
            .lines()
            .find(|l| l.split_whitespace().next() == Some(name))
            .unwrap_or_else(|| panic!("{name} missing from:\n{text}"));
        assert!(line.len() > name.len() + 20, "no description: {line}");
    }
}

#[test]
fn writes_a_readable_log_reproducibly() {
    let dir = tempfile::tempdir().unwrap();
    let scen = dir.path().join("short.toml");
    std::fs::write(&scen, SHORT).unwrap();
    let a = dir.path().join("a");
    let b = dir.path().join("b");
    for out in [&a, &b] {
        let o = terraslip()
            .args(["simulate", scen.to_str().unwrap(), "--seed", "5", "--out"])
            .arg(out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let log = terraslip_io::DriveLog::read(&a).unwrap();
    assert_eq!(log.terrain_names(), ["soil", "gravel"]);
    assert_eq!(log.images.len(), 7);
    assert!(log.truth.len() > 1000 && !log.pose.is_empty() && !log.imu.is_empty());
    for f in ["wheels.csv", "pose.csv", "truth.csv", "images/000003.png"] {
        assert_eq!(
            std::fs::read(a.join(f)).unwrap(),
            std::fs::read(b.join(f)).unwrap(),
            "{f}"
        );
    }
    // No staging directory is left behind.
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(names.iter().all(|n| !n.starts_with('.')), "{names:?}");
}

#[test]
fn replaces_a_log_but_refuses_anything_else() {
    let dir = tempfile::tempdir().unwrap();
    let scen = dir.path().join("short.toml");
    std::fs::write(&scen, SHORT).unwrap();
    let out = dir.path().join("log");
    for seed in ["1", "2"] {
        let o = terraslip()
            .args([
                "simulate",
                scen.to_str().unwrap(),
                "--no-camera",
                "--seed",
                seed,
                "--out",
            ])
            .arg(&out)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
    }
    assert!(
        !out.join("images").exists(),
        "old log's images survived the replacement"
    );
    let precious = dir.path().join("precious");
    std::fs::create_dir(&precious).unwrap();
    std::fs::write(precious.join("thesis.tex"), "x").unwrap();
    let o = terraslip()
        .args(["simulate", "papers", "--no-camera", "--out"])
        .arg(&precious)
        .output()
        .unwrap();
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("refusing") && e.lines().count() == 1, "{e}");
    assert_eq!(std::fs::read_dir(&precious).unwrap().count(), 1);
}

#[test]
fn bad_scenarios_exit_nonzero_with_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.toml");
    std::fs::write(
        &bad,
        "[[segment]]\nterrain = \"soil\"\nduration = 10\n[wheels]\nticks = 5\n",
    )
    .unwrap();
    let o = terraslip()
        .args(["simulate", bad.to_str().unwrap(), "--out"])
        .arg(dir.path().join("x"))
        .output()
        .unwrap();
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("bad.toml:5") && e.contains("ticks"), "{e}");
    assert_eq!(e.trim_end().lines().count(), 1, "{e}");
    assert!(!dir.path().join("x").exists());

    let o = terraslip()
        .args(["simulate", "no-such-scenario", "--out"])
        .arg(dir.path().join("y"))
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(stderr(&o).contains("papers"), "{}", stderr(&o));
    let o = terraslip()
        .args(["simulate", "papers", "--camera-rate", "-1", "--out"])
        .arg(dir.path().join("z"))
        .output()
        .unwrap();
    assert!(!o.status.success());
}

#[test]
fn print_scenario_round_trips() {
    let dir = tempfile::tempdir().unwrap();
    let o = terraslip()
        .args(["simulate", "papers", "--print-scenario"])
        .output()
        .unwrap();
    assert!(o.status.success());
    let p = dir.path().join("p.toml");
    std::fs::write(&p, &o.stdout).unwrap();
    let back = terraslip_sim::Scenario::from_toml_file(&p).unwrap();
    assert_eq!(back, terraslip_sim::Scenario::builtin("papers").unwrap());
}
