use super::*;
use crate::pipeline::{run, EstimateRow, TerrainEvidence, DECISION_SPAN};
use crate::testkit::{drive, SynthSpec};
use terraslip_core::filter::SlipHold;
use terraslip_core::IcrParams;
use terraslip_io::{DriveLog, PoseReference};

/// A drive longer than the warm-up whose wheels are stamped `late` s late
/// against its 100 Hz gyro (the gyro's stamps moved earlier).
fn late_wheels(duration: f64, late: f64) -> DriveLog {
    let icr = IcrParams::new(0.30, -0.31, 0.01);
    let spec = SynthSpec {
        duration,
        terrains: vec![(0.0, "asphalt".into(), icr)],
        ..Default::default()
    };
    let mut log = drive(&spec);
    log.imu = crate::testkit::gyro(icr, duration, 100.0);
    for s in &mut log.imu {
        s.t -= late;
    }
    log
}

/// The log's samples in stamp order, as a recording plays into the node.
fn played(log: &DriveLog) -> Vec<Sample> {
    let mut a: Vec<Sample> = Vec::new();
    a.extend(log.wheels.iter().map(|w| Sample::Wheels(*w)));
    a.extend(log.pose.iter().map(|p| Sample::Pose(*p)));
    a.extend(log.imu.iter().map(|s| Sample::Imu(*s)));
    a.sort_by(|x, y| x.t().total_cmp(&y.t()));
    a
}

#[test]
fn the_warm_up_decides_as_estimate_does_and_loses_no_row() {
    let log = late_wheels(DECISION_SPAN + 60.0, 0.35);
    let cfg = EstimatorConfig::default();
    let offline = run(&log, &cfg, &TerrainEvidence::None, None).unwrap();
    assert!(
        (offline.gyro_delay - 0.35).abs() < 0.02,
        "{}",
        offline.gyro_delay
    );

    let mut w = WarmUp::new("live", &cfg, 0.5, None, 0.3, DECISION_SPAN, None, None).unwrap();
    let mut rows: Vec<EstimateRow> = Vec::new();
    let mut decided_at = None;
    for s in played(&log) {
        let t = s.t();
        if let Some(d) = w.push(s, &mut rows).unwrap() {
            decided_at = Some((t, rows.len(), d));
        }
    }
    w.flush(&mut rows).unwrap();
    // Decided live, before the end, with the offline run's delay and holds.
    let (t, answered, d) = decided_at.expect("decided during the drive");
    assert!(t < DECISION_SPAN + 2.0, "decided at {t} s");
    assert!(answered > 0, "the held rows are answered once decided");
    assert_eq!(d.gyro_delay, offline.gyro_delay);
    assert!(d.fuse_gyro);
    assert_eq!(d.hold, SlipHold::Nothing);
    assert_eq!(w.summary().unwrap().gyro_delay, offline.gyro_delay);
    // Every row, the same as offline.
    assert_eq!(rows.len(), offline.rows.len());
    assert!(
        rows == offline.rows,
        "warm-up rows differ from the replay's"
    );

    // Without the decision (delay 0, as the node ran before a warm-up),
    // the rows differ: the delay matters on this drive.
    let mut plain = Live::new("live", &cfg, 0.5, None, 0.3, 0.0).unwrap();
    let mut undecided: Vec<EstimateRow> = Vec::new();
    for s in played(&log) {
        plain.push(s, &mut undecided).unwrap();
    }
    plain.flush(&mut undecided).unwrap();
    assert!(undecided != offline.rows);
}

#[test]
fn a_drive_shorter_than_the_warm_up_decides_at_its_end() {
    let mut log = late_wheels(60.0, 0.2);
    log.pose.iter_mut().for_each(|p| {
        p.east = None;
        p.north = None;
    });
    let cfg = EstimatorConfig::default();
    let offline = run(&log, &cfg, &TerrainEvidence::None, None).unwrap();
    let mut w = WarmUp::new("live", &cfg, 0.5, None, 0.3, DECISION_SPAN, None, None).unwrap();
    let mut rows: Vec<EstimateRow> = Vec::new();
    for s in played(&log) {
        assert!(w.push(s, &mut rows).unwrap().is_none());
    }
    assert!(rows.is_empty() && w.summary().is_none());
    let d = w.flush(&mut rows).unwrap().expect("decided at the end");
    // Headings but no positions: the position-taught parameters held.
    assert_eq!(d.hold, SlipHold::PositionTaught);
    assert_eq!(d.hold, offline.hold);
    assert!(rows == offline.rows);
    let warnings = w.summary().unwrap().warnings;
    assert!(
        warnings
            .iter()
            .any(|x| x.contains("headings but no positions")),
        "{warnings:?}"
    );
}

#[test]
fn a_given_delay_replaces_the_one_found() {
    let log = late_wheels(DECISION_SPAN + 10.0, 0.35);
    let cfg = EstimatorConfig::default();
    let mut w = WarmUp::new("live", &cfg, 0.5, None, 0.3, 30.0, Some(0.1), Some(0.2)).unwrap();
    let mut rows: Vec<EstimateRow> = Vec::new();
    let mut decided = None;
    for s in played(&log) {
        decided = decided.or(w.push(s, &mut rows).unwrap());
    }
    assert_eq!(decided.unwrap().gyro_delay, 0.1);
    assert!(decided.unwrap().lines()[0].contains("0.100 s late against it (given"));
}

#[test]
fn a_stated_localiser_is_decided_live_as_offline() {
    let mut log = late_wheels(DECISION_SPAN + 60.0, 0.35);
    let cfg = EstimatorConfig::default();
    let unstated = run(&log, &cfg, &TerrainEvidence::None, None).unwrap();
    log.meta.pose_reference = Some(PoseReference::Localiser);
    let offline = run(&log, &cfg, &TerrainEvidence::None, None).unwrap();
    // A localiser's fixes carry no wandering error: the run differs.
    assert!(unstated.noise.correlated_std > 0.0);
    assert_eq!(offline.noise.correlated_std, 0.0);
    assert!(offline.rows != unstated.rows);

    let live = |reference| {
        let mut w = WarmUp::new("live", &cfg, 0.5, None, 0.3, DECISION_SPAN, None, None).unwrap();
        w.set_pose_reference(reference);
        let mut rows: Vec<EstimateRow> = Vec::new();
        for s in played(&log) {
            w.push(s, &mut rows).unwrap();
        }
        w.flush(&mut rows).unwrap();
        (rows, *w.decisions().unwrap())
    };
    let (rows, d) = live(Some(PoseReference::Localiser));
    assert_eq!(d.pose_reference, Some(PoseReference::Localiser));
    assert!(
        d.lines().iter().any(|l| l.contains("localiser")),
        "{:?}",
        d.lines()
    );
    assert!(
        rows == offline.rows,
        "the live localiser differs from estimate's"
    );
    let (rows, _) = live(None);
    assert!(rows == unstated.rows && rows != offline.rows);
}
