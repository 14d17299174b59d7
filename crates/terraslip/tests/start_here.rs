//! The "Start here" steps of `terraslip --help`, run as written, in order,
//! in an empty directory: each must succeed and leave its output.

use assert_cmd::Command;

/// The commands listed under "Start here:" (comments removed).
fn steps(help: &str) -> Vec<Vec<String>> {
    help.lines()
        .skip_while(|l| !l.starts_with("Start here:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.trim().strip_prefix("terraslip "))
        .map(|l| {
            let cmd = l.split('#').next().unwrap_or("");
            cmd.split_whitespace().map(String::from).collect()
        })
        .collect()
}

#[test]
fn the_start_here_steps_of_help_pass_as_written() {
    let help = Command::cargo_bin("terraslip")
        .unwrap()
        .arg("--help")
        .output()
        .unwrap();
    let help = String::from_utf8(help.stdout).unwrap();
    let steps = steps(&help);
    assert!(steps.len() >= 4, "{help}");
    let dir = tempfile::tempdir().unwrap();
    for args in &steps {
        let out = Command::cargo_bin("terraslip")
            .unwrap()
            .args(args)
            .current_dir(dir.path())
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "`terraslip {}` failed: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr)
        );
        // Every --out the step names is there afterwards.
        if let Some(k) = args.iter().position(|a| a == "--out") {
            assert!(dir.path().join(&args[k + 1]).exists(), "{args:?}");
        }
    }
    assert!(dir.path().join("demo-out/report.html").is_file());
    assert!(dir.path().join("out/est/report.html").is_file());
}
