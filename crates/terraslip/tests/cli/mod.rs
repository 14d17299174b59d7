//! Running the `terraslip` binary as a user does.

use assert_cmd::Command;

/// Runs `terraslip ARGS`, which must succeed; returns what it printed on
/// stderr (its report to the user).
pub fn terraslip(args: &[&str]) -> String {
    let out = Command::cargo_bin("terraslip")
        .unwrap()
        .args(args)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{args:?}: {err}");
    err
}
