//! The pose stream's clock offset on a real drive whose lidar pose is
//! stamped late (DRIVE's Warthog on sand, `data/warthog_sand_a`).

use terraslip::pipeline::{self, TerrainEvidence};
use terraslip::{EstimatorConfig, Timed};
use terraslip_io::DriveLog;

fn sand() -> DriveLog {
    terraslip::testkit::repo_drive("warthog_sand_a")
}

/// The default estimator on `log`, started with `--init pf`.
fn run_with(
    log: &DriveLog,
    pf: &terraslip_io::ParamsFile,
) -> Result<pipeline::EstimateRun, pipeline::PipelineError> {
    pipeline::run(
        log,
        &EstimatorConfig::default(),
        &TerrainEvidence::None,
        Some(pf),
    )
}

/// A plausible sand set to start from.
fn sand_set() -> terraslip_io::ParamEntry {
    terraslip_io::ParamEntry::new(terraslip_core::IcrParams {
        y_l: 1.1,
        y_r: -1.1,
        x_c: 0.02,
        alpha_l: 0.82,
        alpha_r: 0.83,
    })
}

#[test]
fn the_learned_clock_offset_does_not_depend_on_its_start_and_the_prediction_uses_it() {
    let log = sand();
    let run_from = |start: f64| {
        let mut cfg = EstimatorConfig::default();
        cfg.measurement.clock_offset = start;
        pipeline::run(&log, &cfg, &TerrainEvidence::None, None).unwrap()
    };
    let (a, b) = (run_from(0.0), run_from(0.35));
    let ((ca, sa), (cb, sb)) = (a.clock_offset, b.clock_offset);
    // The two ends agree within their stated uncertainty (0.16 +- 0.014 s
    // from 0, 0.22 +- 0.019 s from 0.35 s): the fixes, not the start,
    // set the offset.
    assert!(
        (ca - cb).abs() < 3.0 * sa.hypot(sb),
        "from 0: {ca:.3} +- {sa:.3} s, from 0.35: {cb:.3} +- {sb:.3} s"
    );

    // summary.json's prediction reads the pose with the learned offset:
    // the same as scoring the rows with their clock, and better than the
    // pose stamps read as they are.
    let scored = terraslip::prediction_score(&log, &a).unwrap();
    let run_pred = a.prediction.clone().unwrap();
    assert_eq!(run_pred.segments, scored.segments);
    let as_stamped: Vec<(f64, Timed)> = a
        .rows
        .iter()
        .map(|r| (r.t, Timed::on_time(r.icr())))
        .collect();
    let as_stamped = terraslip::prediction_of(&log, a.track_width, &as_stamped).unwrap();
    assert!(
        run_pred.stats.mean_m < as_stamped.stats.mean_m,
        "{:?} vs {:?}",
        run_pred.stats,
        as_stamped.stats
    );
}

/// `--init` from `calibrate` carries the clock offset it found
/// (`time_offset_s`): the filter holds it over the whole drive (the
/// drive's own fixes would move it, to 0.19 s here).
#[test]
fn init_holds_the_calibrated_clock_offset() {
    let log = sand();
    let mut pf = terraslip_io::ParamsFile::default();
    let mut entry = sand_set();
    entry
        .extra
        .insert("time_offset_s".into(), serde_json::json!(0.4));
    pf.terrains.insert("sand".into(), entry);
    let r = run_with(&log, &pf).unwrap();
    let first = r.first_row.unwrap().clock_offset;
    assert!((first - 0.4).abs() < 0.02, "started at {first:.3} s");
    let (end, _) = r.clock_offset;
    assert!((end - 0.4).abs() < 1e-9, "ended at {end:.4} s");
}

/// A parameters file the node wrote carries the offset the filter had
/// learned (`clock_offset_s`): `--init` and the node's recall start the
/// clock there and go on learning it, rather than starting again from 0.
#[test]
fn init_from_a_node_file_resumes_its_learned_clock_offset() {
    let log = sand();
    let mut pf = terraslip_io::ParamsFile::default();
    pf.terrains.insert("default".into(), sand_set());
    pf.extra
        .insert("clock_offset_s".into(), serde_json::json!(0.3));
    let r = run_with(&log, &pf).unwrap();
    let first = r.first_row.unwrap().clock_offset;
    assert!((first - 0.3).abs() < 0.02, "started at {first:.3} s");
    let (end, std) = r.clock_offset;
    assert!(
        std > 0.0,
        "the offset is still learned: ended at {end:.3} +- {std:.4} s"
    );
}

/// An offset beyond what the filter carries is refused, naming the key.
#[test]
fn init_refuses_a_clock_offset_out_of_bounds() {
    let log = sand();
    for (key, v) in [
        ("clock_offset_s", serde_json::json!(5.0)),
        ("clock_offset_s", serde_json::json!("late")),
        ("time_offset_s", serde_json::json!(-3.0)),
    ] {
        let mut pf = terraslip_io::ParamsFile::default();
        pf.terrains.insert("default".into(), sand_set());
        pf.extra.insert(key.into(), v.clone());
        let e = run_with(&log, &pf)
            .err()
            .unwrap_or_else(|| panic!("{key} = {v} was accepted"));
        assert!(e.to_string().contains(key), "{key} = {v}: {e}");
    }
}
