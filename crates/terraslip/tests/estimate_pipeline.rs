//! The pipeline on small exact-model drives (terraslip::testkit): learning,
//! terrain memory, outage, failure modes.

use terraslip::config::EstimatorConfig;
use terraslip::metrics;
use terraslip::pipeline::{self, RunOptions, TerrainEvidence};
use terraslip::testkit::{drive, SynthSpec};

fn all_finite(run: &terraslip::EstimateRun) -> bool {
    run.rows.iter().all(|r| {
        [
            r.east,
            r.north,
            r.yaw,
            r.y_l,
            r.y_r,
            r.x_c,
            r.std_spread,
            r.nis,
            r.q_scale,
        ]
        .iter()
        .chain(r.std.iter())
        .all(|v| v.is_finite())
    })
}

/// The default estimator without terrain evidence.
fn run_plain(log: &terraslip_io::DriveLog) -> terraslip::EstimateRun {
    pipeline::run(
        log,
        &EstimatorConfig::default(),
        &TerrainEvidence::None,
        None,
    )
    .unwrap()
}

fn assert_warns(run: &terraslip::EstimateRun, needle: &str) {
    assert!(
        run.warnings.iter().any(|w| w.contains(needle)),
        "{:?}",
        run.warnings
    );
}

#[test]
fn default_learns_and_recalls_terrains() {
    let log = drive(&SynthSpec::default());
    let ev = TerrainEvidence::Labels(log.terrain.clone());
    let run = pipeline::run(&log, &EstimatorConfig::default(), &ev, None).unwrap();
    assert_eq!(run.rows.len(), log.wheels.len());
    assert!(all_finite(&run));
    let card = metrics::scorecard(&run, &log.truth, &log.terrain, None, 20.0);
    eprintln!("{card:#?}");
    assert!(card.rms.d < 0.01, "rms d {}", card.rms.d);
    let rec = &card.reconvergence;
    assert_eq!(rec.len(), 2);
    assert!(!rec[0].revisit && rec[1].revisit);
    assert!(rec[0].seconds.is_some_and(|s| s < 20.0), "{rec:?}");
    assert_eq!(
        rec[1].seconds,
        Some(0.0),
        "revisit must be recalled: {rec:?}"
    );
    assert_eq!(
        run.changes[2].action,
        terraslip_core::ChangeAction::Recalled
    );
}

#[test]
fn every_preset_runs_finite() {
    let log = drive(&SynthSpec {
        duration: 120.0,
        ..Default::default()
    });
    let ev = TerrainEvidence::Labels(log.terrain.clone());
    for (name, cfg) in EstimatorConfig::presets() {
        let run = pipeline::run(&log, &cfg, &ev, None).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(all_finite(&run), "{name}");
    }
}

#[test]
fn outage_drops_fixes_and_dead_reckons() {
    let log = drive(&SynthSpec::default());
    let ev = TerrainEvidence::Labels(log.terrain.clone());
    let opts = RunOptions {
        outage: Some((150.0, 180.0)),
    };
    let run = pipeline::run_with(
        &log,
        &EstimatorConfig::default(),
        &ev,
        None,
        opts,
        &mut |_, _| {},
    )
    .unwrap();
    assert_eq!(run.stats.dropped_fixes, 30);
    let d = metrics::outage_drift(&run, &log.truth, 150.0, 180.0).unwrap();
    assert!(d.distance > 15.0, "{d:?}");
    // Pure dead reckoning: the window ends before the fix at 180 s (1.39 %
    // measured; the former < 1 % included that 5 cm fix in the end point).
    assert!(d.t1 < 180.0, "{d:?}");
    assert!(d.percent < 1.5, "{d:?}");
    // The no-slip model drifts far more.
    let ns = EstimatorConfig::preset("no-slip").unwrap();
    let run = pipeline::run_with(&log, &ns, &ev, None, opts, &mut |_, _| {}).unwrap();
    let dn = metrics::outage_drift(&run, &log.truth, 150.0, 180.0).unwrap();
    assert!(dn.percent > 3.0 * d.percent, "{dn:?} vs {d:?}");
}

#[test]
fn multipath_jump_is_rejected() {
    let mut spec = SynthSpec::default();
    spec.terrains.truncate(1);
    let mut log = drive(&spec);
    let k = log.pose.len() / 2;
    let e = log.pose[k].east.unwrap();
    log.pose[k].east = Some(e + 30.0);
    let t = log.pose[k].t;
    let run = run_plain(&log);
    let gated: Vec<f64> = run.rows.iter().filter(|r| r.gated).map(|r| r.t).collect();
    assert_eq!(
        run.stats.fixes.position_gated, 1,
        "{:?} gated at {gated:?}, jump at {t}",
        run.stats
    );
    // Gated at its time (or the next row: the fix waits for the wheels to
    // reach its time on their clock).
    assert!(run
        .rows
        .iter()
        .any(|r| r.gated && r.t >= t && r.t < t + 0.1));
    let row = run.rows.iter().find(|r| r.t >= t).unwrap();
    let truth = metrics::truth_at(&log.truth, row.t).unwrap();
    assert!((row.east - truth.east).abs() < 1.0);
}

#[test]
fn standing_still_log_warns_and_keeps_initial_icrs() {
    let mut log = drive(&SynthSpec {
        duration: 30.0,
        ..Default::default()
    });
    for w in &mut log.wheels {
        w.v_left = 0.0;
        w.v_right = 0.0;
    }
    let run = run_plain(&log);
    assert_warns(&run, "never moves");
    assert!((run.final_icr.y_l - 0.25).abs() < 1e-9 && (run.final_icr.y_r + 0.25).abs() < 1e-9);
    assert!(all_finite(&run));
}

#[test]
fn iekf_runs_and_reports_instead_of_nan() {
    let log = drive(&SynthSpec {
        duration: 200.0,
        ..Default::default()
    });
    let mut cfg = EstimatorConfig::default();
    cfg.filter.variant = terraslip_core::Variant::InnovationAdaptive;
    let run = pipeline::run(
        &log,
        &cfg,
        &TerrainEvidence::Labels(log.terrain.clone()),
        None,
    )
    .unwrap();
    assert!(all_finite(&run));
}

#[test]
fn wheel_gap_is_not_integrated_with_held_speeds() {
    let mut log = drive(&SynthSpec {
        duration: 60.0,
        ..Default::default()
    });
    // Remove 20 s of wheels rows: the robot keeps moving in the truth.
    log.wheels.retain(|w| !(20.0..40.0).contains(&w.t));
    let run = run_plain(&log);
    assert_warns(&run, "without tread speeds");
    assert!(all_finite(&run));
    // The first fix after the gap is taken (not gated) and the pose is back.
    let row = run.rows.iter().find(|r| r.t >= 41.0).unwrap();
    let truth = metrics::truth_at(&log.truth, row.t).unwrap();
    let err = ((row.east - truth.east).powi(2) + (row.north - truth.north).powi(2)).sqrt();
    assert!(err < 0.5, "position error after the gap {err}");
    assert_eq!(run.stats.fixes.position_gated, 0, "{:?}", run.stats);
}

/// A classifier's frames over asphalt and grass (grass from 100 s to
/// 200 s, asphalt before and after), one every `hop` s up to 300 s, each
/// giving the true ground probability `right`.
fn grass_from_100_to_200(hop: f64, right: f64) -> Vec<(f64, Vec<f64>)> {
    (1..)
        .map(|i| hop * i as f64)
        .take_while(|t| *t < 300.0)
        .map(|t| {
            let p = if (100.0..200.0).contains(&t) {
                vec![1.0 - right, right]
            } else {
                vec![right, 1.0 - right]
            };
            (t, p)
        })
        .collect()
}

/// A weak classifier (0.65 on the true terrain, a frame a second) with and
/// without camera change detections half a second after each change: the
/// belief needs several frames to follow each change, and the change is
/// declared where the run of frames that convinced it began (the first
/// frame on the new ground), detections or not; no change is declared
/// where there is none.
#[test]
fn a_weak_classifiers_change_is_declared_where_it_began() {
    let log = drive(&SynthSpec::default());
    let classes = vec!["asphalt".to_string(), "grass".to_string()];
    let frames = grass_from_100_to_200(1.0, 0.65);
    let declared = |changes: Vec<f64>| {
        let ev = TerrainEvidence::Likelihoods {
            classes: classes.clone(),
            frames: frames.clone(),
            changes,
        };
        let run = pipeline::run(&log, &EstimatorConfig::default(), &ev, None).unwrap();
        assert!(all_finite(&run));
        run.changes
            .iter()
            .map(|c| (c.t, c.terrain))
            .collect::<Vec<_>>()
    };
    let without = declared(Vec::new());
    let with = declared(vec![100.5, 200.5]);
    eprintln!("without {without:?}\nwith {with:?}");
    // Both declare asphalt at the start, then grass, then asphalt again.
    let terrains = |d: &[(f64, usize)]| d.iter().map(|c| c.1).collect::<Vec<_>>();
    assert_eq!(terrains(&without), vec![0, 1, 0]);
    assert_eq!(terrains(&with), vec![0, 1, 0]);
    for k in 1..3 {
        let true_t = 100.0 * k as f64;
        assert_eq!(with[k].0, true_t, "{with:?}");
        assert_eq!(without[k].0, true_t, "{without:?}");
    }
}

/// The default estimator on `log` given a classifier's `frames` over
/// asphalt and grass; its result and the changes it declared `(t, terrain)`.
fn classified(
    log: &terraslip_io::DriveLog,
    frames: Vec<(f64, Vec<f64>)>,
) -> (terraslip::EstimateRun, Vec<(f64, usize)>) {
    let ev = TerrainEvidence::Likelihoods {
        classes: vec!["asphalt".to_string(), "grass".to_string()],
        frames,
        changes: Vec::new(),
    };
    let run = pipeline::run(log, &EstimatorConfig::default(), &ev, None).unwrap();
    assert!(all_finite(&run));
    let declared = run.changes.iter().map(|c| (c.t, c.terrain)).collect();
    (run, declared)
}

/// A classifier right at 0.9, a frame every 0.5 s, on grass from 100 s to
/// 200 s: the belief's filter and vote take a few frames, but each change is
/// declared at the first frame that reads the new ground.
#[test]
fn a_classifiers_change_is_declared_at_the_first_frame_that_reads_it() {
    let log = drive(&SynthSpec::default());
    let (run, declared) = classified(&log, grass_from_100_to_200(0.5, 0.9));
    assert_eq!(declared, vec![(0.5, 0), (100.0, 1), (200.0, 0)]);
    // The rows follow: the row just after the change holds the new ground.
    let at = |t: f64| run.rows.iter().find(|r| r.t >= t).unwrap().terrain;
    assert_eq!(at(100.0), Some(1));
    assert_eq!(at(200.0), Some(0));
}

/// The classifier of [`grass_from_100_to_200`] at 0.9, a frame every
/// 0.5 s, that also reads asphalt as grass, confidently, from 230 s to
/// 260 s.
fn asphalt_read_as_grass_from_230_to_260() -> Vec<(f64, Vec<f64>)> {
    let mut frames = grass_from_100_to_200(0.5, 0.9);
    for (t, p) in &mut frames {
        if (230.0..260.0).contains(t) {
            *p = vec![0.1, 0.9];
        }
    }
    frames
}

/// The estimator on `log` given [`asphalt_read_as_grass_from_230_to_260`]:
/// the right changes are kept, the misread undone within 15 s of its start
/// and not taken up again.
fn misread_undone(log: &terraslip_io::DriveLog) -> terraslip::EstimateRun {
    let (run, declared) = classified(log, asphalt_read_as_grass_from_230_to_260());
    eprintln!("{declared:?}");
    let at = |t: f64| run.rows.iter().find(|r| r.t >= t).unwrap();
    assert_eq!(at(150.0).terrain, Some(1));
    assert_eq!(at(215.0).terrain, Some(0));
    assert_eq!(at(245.0).terrain, Some(0), "{declared:?}");
    assert_eq!(at(258.0).terrain, Some(0), "{declared:?}");
    assert!(run
        .changes
        .iter()
        .any(|c| c.action == terraslip_core::ChangeAction::Undone));
    run
}

/// A classifier right at 0.9, a frame every 0.5 s, that reads asphalt as
/// grass, confidently, from 230 s to 260 s: believed, the grass set would
/// be recalled on asphalt. The fixes contradict it, so the change is
/// undone and the estimator goes on with the asphalt it was learning;
/// the right changes (grass at 100 s, asphalt again at 200 s) are kept.
#[test]
fn a_recall_the_fixes_contradict_is_undone() {
    let log = drive(&SynthSpec::default());
    let run = misread_undone(&log);
    let at = |t: f64| run.rows.iter().find(|r| r.t >= t).unwrap();
    // The slip the rows hold on asphalt stays asphalt's (spread 0.61 m,
    // grass 0.73 m).
    let spread = |t: f64| at(t).y_l - at(t).y_r;
    assert!((spread(255.0) - 0.61).abs() < 0.03, "{}", spread(255.0));
}

/// The misread of [`a_recall_the_fixes_contradict_is_undone`] on a drive
/// with no fixes at all: the gyro's windows contradict the grass set's
/// turn, so the change is undone all the same, and the right changes are
/// kept.
#[test]
fn a_recall_the_gyro_contradicts_is_undone_without_fixes() {
    // The default drive without its pose reference, with a noiseless
    // yaw-rate gyro at 50 Hz that turns as each stretch's ground does (as
    // on BorealTC: IMU and wheels, no pose).
    let spec = SynthSpec::default();
    let mut log = drive(&spec);
    log.pose.clear();
    log.imu = terraslip::testkit::terrain_gyro(&spec, 50.0);
    misread_undone(&log);
}

/// Two calibrated terrain sets, as `terraslip calibrate` writes them.
fn two_sets() -> terraslip_io::ParamsFile {
    let mut pf = terraslip_io::ParamsFile::default();
    for (name, d) in [("asphalt", 0.61), ("grass", 0.73)] {
        pf.terrains.insert(
            name.into(),
            terraslip_io::ParamEntry::new(terraslip_core::IcrParams::new(0.5 * d, -0.5 * d, 0.0)),
        );
    }
    pf
}

#[test]
fn init_with_terrain_sets_starts_from_the_terrain_the_log_names() {
    let mut spec = SynthSpec::default();
    spec.terrains.truncate(1);
    let log = drive(&spec);
    assert_eq!(log.terrain.len(), 1);
    let pf = two_sets();
    let run = pipeline::run(
        &log,
        &EstimatorConfig::default(),
        &TerrainEvidence::None,
        Some(&pf),
    )
    .unwrap();
    assert_eq!(run.init_source, "init:asphalt");
    // Several terrains and nothing to pick one: the prior, with a warning.
    let mut log = drive(&SynthSpec::default());
    log.terrain.push(terraslip_io::TerrainLabel {
        t: 250.0,
        terrain: "grass".into(),
    });
    let run = pipeline::run(
        &log,
        &EstimatorConfig::default(),
        &TerrainEvidence::None,
        Some(&pf),
    )
    .unwrap();
    assert_eq!(run.init_source, "prior");
    assert_warns(&run, "one set per terrain");
}

#[test]
fn the_outage_yardstick_dead_reckons_the_estimate_beside_no_slip() {
    // A slipping robot (exact ICR model): after the warm-up the learned
    // model dead-reckons far closer than no-slip odometry, and its own
    // covariance spans the error it makes.
    let spec = SynthSpec {
        terrains: SynthSpec::default().terrains[1..2]
            .iter()
            .map(|(_, n, p)| (0.0, n.clone(), *p))
            .collect(),
        ..Default::default()
    };
    let log = drive(&spec);
    let run = run_plain(&log);
    let o = run.outage.as_ref().expect("an outage score");
    let stats = |name: &str| terraslip_calib::outage::OutageStats::all(o.ends(name).unwrap());
    let (online, no_slip) = (stats("online"), stats("no-slip"));
    assert_eq!(online.len(), 3, "{online:?}");
    // Starts every 10 s from 60 s while the horizon ends before the last
    // wheels row (just short of 300 s).
    let n: Vec<usize> = online.iter().map(|s| s.segments).collect();
    assert_eq!(n, [23, 22, 19]);
    for (a, b) in online.iter().zip(&no_slip) {
        assert!(b.segments >= a.segments);
        assert!(a.mean_m < 0.1 * b.mean_m, "{a:?} {b:?}");
        let nees = a.nees_median.unwrap();
        assert!(nees > 0.0 && nees < 5.0, "{a:?}");
    }
    // No gyro in the log: no odometry + gyro.
    assert!(o.ends("odometry + gyro").is_none());
    let js = o.to_json();
    assert_eq!(js["models"]["online"][1]["horizon_s"], 30.0);
}

#[test]
fn every_outage_model_sets_out_from_the_estimate_not_the_reference() {
    // One wild reference fix at the first start: the robot never was
    // there, so no model dead-reckons from it. Every model sets out from
    // the estimate's pose, so its end from that start moves no more than
    // the estimate's start did.
    let log = drive(&SynthSpec::default());
    let plain = run_plain(&log);
    let s0 = plain.outage.as_ref().expect("an outage score").starts[0];
    let k = log
        .pose
        .iter()
        .enumerate()
        .min_by(|a, b| {
            let d = |p: &terraslip_io::PoseObs| (p.t - s0.t - s0.clock).abs();
            d(a.1).total_cmp(&d(b.1))
        })
        .map(|(k, _)| k)
        .unwrap();
    let mut wild = log.clone();
    wild.pose[k].north = wild.pose[k].north.map(|n| n + 10.0);
    let wild = run_plain(&wild);
    let s1 = wild.outage.as_ref().unwrap().starts[0];
    assert_eq!(s0.t, s1.t);
    let moved = (s1.east - s0.east).hypot(s1.north - s0.north);
    assert!(
        moved < 5.0,
        "the estimate followed the wild fix {moved:.2} m"
    );
    let end = |run: &terraslip::EstimateRun, model: &str| {
        run.outage
            .as_ref()
            .unwrap()
            .ends(model)
            .unwrap()
            .iter()
            .find(|e| e.t == s0.t && e.horizon == 10.0)
            .copied()
            .expect("an end 10 s after the first start")
    };
    for model in ["online", "no-slip"] {
        let (e0, e1) = (end(&plain, model), end(&wild, model));
        assert!(
            (e1.error - e0.error).abs() <= moved + 0.05,
            "{model}: the estimate's start moved {moved:.2} m, the end error {:.2} -> {:.2} m",
            e0.error,
            e1.error
        );
    }
}
