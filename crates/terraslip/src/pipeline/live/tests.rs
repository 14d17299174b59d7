use super::*;
use crate::pipeline::{gyro_delay, run_with, EstimateRow, GyroClock};
use crate::testkit::{drive, SynthSpec};
use terraslip_core::IcrParams;

/// A 120 s synthetic drive: wheels at 50 Hz, pose at 1 Hz, and a gyro at
/// 100 Hz that reads the body's yaw rate.
fn drive_with_gyro(duration: f64) -> DriveLog {
    let spec = SynthSpec {
        duration,
        terrains: vec![(0.0, "asphalt".into(), IcrParams::new(0.30, -0.31, 0.01))],
        ..Default::default()
    };
    let mut log = drive(&spec);
    log.imu = crate::testkit::gyro(spec.terrains[0].2, duration, 100.0);
    log
}

/// The log's samples, each with the time it arrives at.
fn arrivals(log: &DriveLog) -> Vec<(f64, Sample)> {
    let mut a: Vec<(f64, Sample)> = Vec::new();
    a.extend(log.wheels.iter().map(|w| (w.t, Sample::Wheels(*w))));
    a.extend(log.pose.iter().map(|p| (p.t, Sample::Pose(*p))));
    a.extend(log.imu.iter().map(|s| (s.t, Sample::Imu(*s))));
    a
}

/// The rows `run` makes of `log`, and the gyro delay it used.
fn offline(log: &DriveLog, cfg: &EstimatorConfig) -> (Vec<EstimateRow>, f64) {
    let mut wheels = log.wheels.iter().copied().map(Ok);
    let mut gyro = log
        .imu
        .iter()
        .filter_map(|s| s.gyro_z.map(|g| Ok((s.t, g))));
    let delay = match gyro_delay(&mut wheels, &mut gyro) {
        GyroClock::Delay { wheels_late_by, .. } => wheels_late_by,
        other => panic!("the synthetic gyro is the yaw rate: {other:?}"),
    };
    let run = run_with(
        log,
        cfg,
        &TerrainEvidence::None,
        None,
        RunOptions::default(),
        &mut |_, _| {},
    )
    .unwrap();
    (run.rows, delay)
}

/// Plays `arrivals` (in arrival order) into a live estimator.
fn live(
    arrivals: &[(f64, Sample)],
    cfg: &EstimatorConfig,
    lag: f64,
    delay: f64,
) -> (Vec<EstimateRow>, LateCounts) {
    let mut order: Vec<&(f64, Sample)> = arrivals.iter().collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut l = Live::new("live", cfg, 0.5, None, lag, delay).unwrap();
    let mut rows: Vec<EstimateRow> = Vec::new();
    for (_, s) in order {
        l.push(s.clone(), &mut rows).unwrap();
    }
    l.flush(&mut rows).unwrap();
    (rows, l.late())
}

/// A deterministic uniform in [0, 1) from an index and a seed.
fn uniform(i: usize, seed: u64) -> f64 {
    let mut x = (i as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ seed;
    x ^= x >> 33;
    x = x.wrapping_mul(0xff51_afd7_ed55_8ccd);
    x ^= x >> 33;
    (x >> 11) as f64 / (1u64 << 53) as f64
}

#[test]
fn samples_in_order_give_the_rows_of_a_replay() {
    let log = drive_with_gyro(120.0);
    let cfg = EstimatorConfig::default();
    let (want, delay) = offline(&log, &cfg);
    let (got, late) = live(&arrivals(&log), &cfg, 0.3, delay);
    assert_eq!(late, LateCounts::default());
    assert_eq!(got.len(), want.len());
    assert!(got == want, "live rows differ from the replay's");
}

#[test]
fn samples_late_by_up_to_the_lag_and_out_of_order_give_the_same_rows() {
    let log = drive_with_gyro(120.0);
    let cfg = EstimatorConfig::default();
    let (want, delay) = offline(&log, &cfg);
    // Each sample arrives up to 0.3 s after its stamp, the streams
    // interleaved out of stamp order.
    let mut a = arrivals(&log);
    for (i, (at, _)) in a.iter_mut().enumerate() {
        *at += 0.3 * uniform(i, 7);
    }
    let (got, late) = live(&a, &cfg, 0.3, delay);
    assert_eq!(late, LateCounts::default());
    assert!(got == want, "live rows differ from the replay's");
    // With a shorter lag than the disorder, samples come late and the rows
    // differ: the lag is what buys the equality.
    let (short, late) = live(&a, &cfg, 0.05, delay);
    assert!(late.wheels + late.pose + late.gyro > 0, "{late:?}");
    assert!(short != want);
}

#[test]
fn five_percent_dropped_gives_the_rows_of_the_samples_that_came() {
    let log = drive_with_gyro(120.0);
    let cfg = EstimatorConfig::default();
    let mut kept = log.clone();
    let keep = |i: usize, salt: u64| uniform(i, salt) >= 0.05;
    let mut i = 0;
    kept.wheels.retain(|_| {
        i += 1;
        keep(i, 11)
    });
    kept.pose.retain(|_| {
        i += 1;
        keep(i, 11)
    });
    kept.imu.retain(|_| {
        i += 1;
        keep(i, 11)
    });
    assert!(kept.wheels.len() < log.wheels.len() * 97 / 100);
    let (want, delay) = offline(&kept, &cfg);
    let (got, _) = live(&arrivals(&kept), &cfg, 0.3, delay);
    // Every wheels row that came is answered, as a replay of what came.
    assert_eq!(got.len(), kept.wheels.len());
    assert!(got == want, "live rows differ from the replay's");
}

#[test]
fn a_60_s_gnss_gap_keeps_rows_coming_with_growing_covariance() {
    let log = drive_with_gyro(200.0);
    let cfg = EstimatorConfig::default();
    let (_, delay) = offline(&log, &cfg);
    let mut a = arrivals(&log);
    a.retain(|(_, s)| !matches!(s, Sample::Pose(p) if p.t >= 60.0 && p.t < 120.0));
    let mut order: Vec<&(f64, Sample)> = a.iter().collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut l = Live::new("live", &cfg, 0.5, None, 0.3, delay).unwrap();
    let mut rows: Vec<EstimateRow> = Vec::new();
    let mut newest = f64::NEG_INFINITY;
    for (_, s) in order {
        l.push(s.clone(), &mut rows).unwrap();
        newest = newest.max(s.t());
        // Output never waits for the silent stream: inside the gap each
        // wheels row is answered once the lag has passed, not at its end.
        if newest > 61.0 && newest < 119.0 {
            let last = rows.last().unwrap().t;
            assert!(last >= newest - 0.3 - 0.021, "at {newest}: last row {last}");
        }
    }
    let in_gap = rows.iter().filter(|r| r.t >= 60.0 && r.t < 120.0).count();
    assert_eq!(in_gap, 3000);
    let std_at = |t: f64| {
        let r = rows.iter().find(|r| r.t >= t).unwrap();
        assert!(r.east.is_finite() && r.north.is_finite());
        r.std[0].hypot(r.std[1])
    };
    let (s60, s80, s100, s119, s140) = (
        std_at(60.5),
        std_at(80.0),
        std_at(100.0),
        std_at(119.9),
        std_at(140.0),
    );
    assert!(
        s60 < s80 && s80 < s100 && s100 < s119,
        "{s60} {s80} {s100} {s119}"
    );
    assert!(s119 > 2.0 * s60, "{s60} -> {s119}");
    assert!(s140 < 0.5 * s119, "fixes back: {s119} -> {s140}");
}

#[test]
fn a_restart_from_the_written_parameters_starts_where_the_run_ended() {
    let log = drive_with_gyro(120.0);
    let cfg = EstimatorConfig::default();
    let (_, delay) = offline(&log, &cfg);
    let mut order = arrivals(&log);
    order.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut l = Live::new("live", &cfg, 0.5, None, 0.3, delay).unwrap();
    let mut rows: Vec<EstimateRow> = Vec::new();
    for (_, s) in &order {
        l.push(s.clone(), &mut rows).unwrap();
    }
    l.flush(&mut rows).unwrap();
    let run = l.summary();
    let pf = run.params_file();
    // Through the file's text, as a restart reads it.
    let text = serde_json::to_string_pretty(&pf).unwrap();
    let back = ParamsFile::parse(&text, std::path::Path::new("params.json")).unwrap();
    assert_eq!(back.extra["gyro_delay_s"], serde_json::json!(delay));
    // The gyro's learned scale, which `--init` starts from.
    assert!(
        run.gyro.scale_learned && run.gyro.scale != 1.0,
        "{:?}",
        run.gyro
    );
    assert_eq!(back.extra["gyro_scale"], serde_json::json!(run.gyro.scale));
    // The speed factors' turn law it learned describes the straight-line
    // set's speed factors in turns.
    assert!(run.speed_law.0 != 0.0, "{:?}", run.speed_law);
    assert_eq!(
        back.extra["rate_model"]["k_alpha"],
        serde_json::json!(run.speed_law.0)
    );
    let again = Live::new("live", &cfg, 0.5, Some(&back), 0.3, delay).unwrap();
    let s = again.summary();
    assert_eq!(s.init_source, "init:params");
    let (a, b) = (run.final_icr, s.final_icr);
    for (x, y) in [
        (a.y_l, b.y_l),
        (a.y_r, b.y_r),
        (a.x_c, b.x_c),
        (a.alpha_l, b.alpha_l),
        (a.alpha_r, b.alpha_r),
    ] {
        assert!((x - y).abs() < 1e-9, "{a:?} vs {b:?}");
    }
    // A fresh start is at the prior, which the drive moved away from.
    let fresh = Live::new("live", &cfg, 0.5, None, 0.3, delay)
        .unwrap()
        .summary();
    assert!((fresh.final_icr.y_l - a.y_l).abs() > 1e-3);
}
