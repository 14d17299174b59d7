//! The outlier gate on a real drive: a multipath jump in the pose reference
//! must be gated, whatever the noise adaptation has learnt. The gate is a
//! chi-square test at 99.9 %; the jumped fixes are 30 m off, hundreds of
//! standard deviations of the lidar pose.

use std::path::Path;

use terraslip::config::EstimatorConfig;
use terraslip::pipeline::{self, EstimateRun, TerrainEvidence};
use terraslip_io::DriveLog;

fn gravel() -> DriveLog {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/warthog_gravel");
    DriveLog::read(&dir).unwrap()
}

fn run(log: &DriveLog) -> EstimateRun {
    pipeline::run(
        log,
        &EstimatorConfig::default(),
        &TerrainEvidence::None,
        None,
    )
    .unwrap()
}

/// Largest position difference between two runs over rows in `[t0, t1]`, m.
fn max_gap(a: &EstimateRun, b: &EstimateRun, t0: f64, t1: f64) -> f64 {
    a.rows
        .iter()
        .zip(&b.rows)
        .filter(|(r, _)| (t0..=t1).contains(&r.t))
        .map(|(r, s)| (r.east - s.east).hypot(r.north - s.north))
        .fold(0.0, f64::max)
}

/// Single fixes (and a short burst) moved by 30 m, at three points of the
/// drive: the estimate within 10 s of each stays within 1 m of the run on
/// the untouched log.
#[test]
#[ignore = "a 30 m jump at t = 136.6 s gets 22 genuine fixes after it gated, one at \
            t = 290.4 s moves the estimate by 1.2 m: the adaptive noise widens the gate \
            (terraslip-core filter); run with \
            `cargo test -p terraslip --test outlier_gate -- --ignored`"]
fn multipath_jumps_on_a_real_drive_are_not_fused() {
    let clean = gravel();
    let base = run(&clean);
    let n = clean.pose.len();
    for (k, burst) in [(n / 4, 1), (n / 2, 1), (3 * n / 4, 3)] {
        let mut log = clean.clone();
        for p in &mut log.pose[k..k + burst] {
            p.east = p.east.map(|e| e + 30.0);
        }
        let t = log.pose[k].t;
        let jumped = run(&log);
        let gap = max_gap(&base, &jumped, t - 1.0, t + 10.0);
        let gated = jumped.stats.fixes.position_gated - base.stats.fixes.position_gated;
        assert!(
            gap < 1.0 && gated == burst,
            "a 30 m jump at t = {t:.1} s (fix {k}, {burst} row(s)) moved the estimate by \
             {gap:.2} m and gated {gated} more fixes than the untouched run (want {burst})"
        );
    }
}

/// On the untouched drive the gate keeps its meaning: a fused fix (position
/// and heading, 3 degrees of freedom) has a NIS above the chi-square's
/// 99.9 % point (16.3; the position gate alone is 13.8 with 2) about once
/// in a thousand, so well under 1 % of them.
#[test]
#[ignore = "396 of 2323 fused fixes have a NIS above 16.3: the gate is \
            applied after the adaptive noise widened it (terraslip-core filter); \
            run with `cargo test -p terraslip --test outlier_gate -- --ignored`"]
fn fused_fixes_pass_the_gate_at_its_stated_level() {
    let base = run(&gravel());
    let fused: Vec<f64> = base
        .rows
        .iter()
        .filter(|r| r.fused)
        .map(|r| r.nis)
        .collect();
    let over = fused.iter().filter(|&&n| n > 16.3).count();
    assert!(
        over * 100 < fused.len(),
        "{over} of {} fused fixes have a NIS above the 99.9 % point 16.3",
        fused.len()
    );
}

/// The same with the pose of 1e308 m the reader refuses: it never reaches
/// the filter (docs/log-format.md, physical ranges).
#[test]
fn an_absurd_pose_value_never_reaches_the_filter() {
    let tmp = tempfile::tempdir().unwrap();
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/warthog_gravel");
    for f in ["wheels.csv", "meta.toml", "terrain.csv"] {
        std::fs::copy(src.join(f), tmp.path().join(f)).unwrap();
    }
    let pose = std::fs::read_to_string(src.join("pose.csv")).unwrap();
    let mut lines: Vec<String> = pose.lines().map(String::from).collect();
    let cols: Vec<String> = lines[100].split(',').map(String::from).collect();
    lines[100] = format!("{},1e308,{},{}", cols[0], cols[2], cols[3]);
    std::fs::write(tmp.path().join("pose.csv"), lines.join("\n") + "\n").unwrap();
    let e = DriveLog::read(tmp.path()).unwrap_err().to_string();
    assert!(e.contains("pose.csv:101:") && e.contains("`east`"), "{e}");
}
