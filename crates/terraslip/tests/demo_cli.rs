//! `terraslip demo` end to end: table, plots, report.

use assert_cmd::Command;

const VARIANTS: [&str; 7] = [
    "no-slip",
    "ekf-qmin",
    "ekf-qmax",
    "ta-ekf-boost",
    "ta-iekf",
    "ekf-reset",
    "terraslip",
];

/// `terraslip demo --out TMP/demo`, which must succeed.
fn demo() -> (tempfile::TempDir, std::process::Output) {
    let dir = tempfile::tempdir().unwrap();
    let o = Command::cargo_bin("terraslip")
        .unwrap()
        .args(["demo", "--out"])
        .arg(dir.path().join("demo"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    (dir, o)
}

#[test]
fn demo_writes_table_plots_and_report_for_every_variant() {
    let (dir, o) = demo();
    let out = dir.path().join("demo");
    let stdout = String::from_utf8_lossy(&o.stdout);
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    let table = std::fs::read_to_string(out.join("table.md")).unwrap();
    for v in VARIANTS {
        assert!(
            stdout.lines().any(|l| l.starts_with(v)),
            "{v} not in the printed table:\n{stdout}"
        );
        assert!(table.contains(&format!("| {v} |")), "{v} not in table.md");
        assert!(
            report.contains(v) && html.contains(v),
            "{v} not in the report"
        );
    }
    for h in [
        "re-conv. to grass",
        "re-conv. to asphalt",
        "RMS d [cm]",
        "outage drift [%]",
    ] {
        assert!(
            stdout.contains(h) && table.contains(h),
            "column {h} missing"
        );
    }
    for svg in [
        "spread.svg",
        "icr-terraslip.svg",
        "icr-ta-iekf.svg",
        "trajectory.svg",
        "outage.svg",
    ] {
        let text = std::fs::read_to_string(out.join(svg)).unwrap();
        assert!(text.starts_with("<svg") && text.contains("</svg>"), "{svg}");
        assert!(
            report.contains(svg) && html.contains(svg),
            "{svg} not in the report"
        );
        assert!(
            text.contains("time [s]") || text.contains("east [m]"),
            "{svg} axes unlabelled"
        );
    }
    // Every variant's numbers are in the summary, and they are numbers.
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let vars = summary["variants"].as_array().unwrap();
    assert_eq!(vars.len(), VARIANTS.len());
    for v in vars {
        let d = v["rms_m"]["d"].as_f64().unwrap();
        assert!((0.0..1.0).contains(&d), "{v}");
        assert_eq!(v["reconvergence_s"].as_array().unwrap().len(), 2);
        assert!(v["outage_drift"]["percent"].as_f64().unwrap() >= 0.0);
        // Pure dead reckoning: the window ends before the first fix after
        // the outage (300-330 s) is fused.
        let (t0, t1) = (
            v["outage_drift"]["t0"].as_f64().unwrap(),
            v["outage_drift"]["t1"].as_f64().unwrap(),
        );
        assert!(t0 >= 300.0 && t1 < 330.0 && t1 > 329.0, "{t0} {t1}");
    }
    // The no-slip model cannot follow slip: its spread is off by centimetres.
    let no_slip = vars.iter().find(|v| v["name"] == "no-slip").unwrap();
    assert!(no_slip["rms_m"]["d"].as_f64().unwrap() > 0.05);
    // The simulated log is there to play with.
    let log = terraslip_io::DriveLog::read(out.join("log")).unwrap();
    assert_eq!(log.terrain_names(), ["soil", "grass", "asphalt"]);

    // A second run replaces the first; a foreign directory is refused.
    let o = Command::cargo_bin("terraslip")
        .unwrap()
        .args(["demo", "--seed", "2", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success());
    let other = dir.path().join("other");
    std::fs::create_dir(&other).unwrap();
    std::fs::write(other.join("notes.txt"), "mine").unwrap();
    let o = Command::cargo_bin("terraslip")
        .unwrap()
        .args(["demo", "--out"])
        .arg(&other)
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("refusing"));
}

/// A re-convergence of 0 s (the estimate never left the tolerance) or none
/// at all, and a variant whose fixes were refused, are each explained on
/// the page, from the run.
#[test]
fn the_page_says_why_a_reconvergence_is_zero_or_missing_and_why_a_variant_stops_learning() {
    let (dir, _) = demo();
    let out = dir.path().join("demo");
    let report = std::fs::read_to_string(out.join("report.md")).unwrap();
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    let changes = summary["terrain_changes"].as_array().unwrap();
    let mut explained = 0;
    for v in summary["variants"].as_array().unwrap() {
        let name = v["name"].as_str().unwrap();
        for (r, c) in v["reconvergence_s"].as_array().unwrap().iter().zip(changes) {
            let terrain = c["terrain"].as_str().unwrap();
            let said = match r.as_f64() {
                Some(0.0) => format!("`{name}`, re-conv. to {terrain} 0.0 s: "),
                None => format!("`{name}`, re-conv. to {terrain}: "),
                Some(_) => continue,
            };
            assert!(report.contains(&said), "no note {said:?} in:\n{report}");
            explained += 1;
        }
    }
    assert!(
        explained > 0,
        "the demo's run has no 0 s or missing re-convergence to explain"
    );
    // The papers' innovation-adaptive variant refuses fixes on this drive.
    assert!(
        report.contains("`ta-iekf`: ") && report.contains("could not be fused"),
        "{report}"
    );
    assert!(html.contains("On this run:"), "the HTML page has no notes");
}
