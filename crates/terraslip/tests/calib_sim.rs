//! The simulated calibration target, end to end through the binaries: a P3-AT
//! drive from `terraslip simulate p3at-calib` (Mandow Table I kinematics,
//! RTK-grade reference) calibrated by `terraslip calibrate` must recover
//! y_l, y_r within 1 cm, x_c within 2 cm and the alphas within 1 %.

use assert_cmd::Command;

#[test]
fn p3at_calib_scenario_recovers_table1() {
    let d = tempfile::tempdir().expect("tempdir");
    let log = d.path().join("p3at");
    let run = |args: &[&std::ffi::OsStr]| {
        let out = Command::cargo_bin("terraslip")
            .expect("binary")
            .args(args)
            .output()
            .expect("runs");
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        out
    };
    let arg = std::ffi::OsStr::new;
    run(&[
        arg("simulate"),
        arg("p3at-calib"),
        arg("--seed"),
        arg("7"),
        arg("--out"),
        log.as_os_str(),
    ]);
    let params = d.path().join("p.json");
    let out = run(&[
        arg("calibrate"),
        log.as_os_str(),
        arg("--out"),
        params.as_os_str(),
        arg("--json"),
    ]);
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).expect("json");
    let set = &j["terrains"]["asphalt"];
    let p = |k: &str| set["params"][k].as_f64().expect(k);
    // Mandow et al. 2007 Table I, 20 psi, in REP-103.
    assert!((p("y_l") - 0.2553).abs() < 0.01, "y_l {}", p("y_l"));
    assert!((p("y_r") + 0.3071).abs() < 0.01, "y_r {}", p("y_r"));
    assert!((p("x_c") + 0.012).abs() < 0.02, "x_c {}", p("x_c"));
    assert!(
        (p("alpha_l") / 0.9271 - 1.0).abs() < 0.01,
        "alpha_l {}",
        p("alpha_l")
    );
    assert!(
        (p("alpha_r") / 0.9049 - 1.0).abs() < 0.01,
        "alpha_r {}",
        p("alpha_r")
    );
    // Table I indexes: chi = 0.7112, e = 0.0921.
    assert!((set["chi"].as_f64().expect("chi") - 0.7112).abs() < 0.02);
    assert!((set["e"].as_f64().expect("e") - 0.0921).abs() < 0.03);
    assert_ne!(
        set["method"], "symmetric",
        "the asymmetric fit must win on an asymmetric robot"
    );
}
