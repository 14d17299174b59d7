//! Speed augmentation on grounds with a spatial texture: a ground's
//! vibration frequency is its texture (cycles per metre) times the tread
//! speed, so ground A driven fast rings like ground B driven slowly.

use terraslip_io::{DriveLog, ImuSample, TerrainLabel, WheelSample};
use terraslip_terrain::augment::{speed_copy, SpeedAugmentation, SpeedLaw};
use terraslip_terrain::classify::SplitMix64;
use terraslip_terrain::vibration::log_windows;
use terraslip_terrain::*;

/// Texture of the two grounds, cycles per metre.
const TEXTURE: [(&str, f64); 2] = [("gravel", 20.0), ("tiles", 32.0)];

/// `secs` of straight driving at `v` m/s on ground `k`: 100 Hz IMU whose
/// vertical vibration is the ground's texture at `TEXTURE[k].1 · v` Hz
/// plus noise, 10 Hz tread speeds.
fn drive(k: usize, v: f64, secs: f64, seed: u64) -> DriveLog {
    let mut rng = SplitMix64(seed);
    let mut gauss = move || (0..12).map(|_| rng.uniform()).sum::<f64>() - 6.0;
    let mut log = DriveLog {
        terrain: vec![TerrainLabel {
            t: 0.0,
            terrain: TEXTURE[k].0.into(),
        }],
        ..Default::default()
    };
    let f = TEXTURE[k].1 * v;
    for i in 0..(secs * 100.0) as usize {
        let t = i as f64 / 100.0;
        let vib = (2.0 * std::f64::consts::PI * f * t).sin() + 0.3 * gauss();
        log.imu.push(ImuSample {
            t,
            accel_z: 9.81 + vib,
            accel_x: Some(0.2 * gauss()),
            accel_y: Some(0.2 * gauss()),
            gyro_x: Some(0.05 * vib),
            gyro_y: Some(0.02 * gauss()),
            gyro_z: Some(0.01 * gauss()),
        });
        if i % 10 == 0 {
            log.wheels.push(WheelSample {
                t,
                v_left: v,
                v_right: v,
            });
        }
    }
    log.meta.track_width = Some(0.5);
    log
}

fn opts(augment: Option<Vec<f64>>) -> TrainOptions {
    let mut o = TrainOptions::default();
    o.vibration.window_s = 2.0;
    o.classifier.boost.rounds = 40;
    o.speed_floor = Some(0.1);
    o.speed_augmentation = augment.map(|factors| SpeedAugmentation { factors });
    o
}

/// Both grounds trained at 0.28-0.32 m/s only; gravel then driven at
/// 0.48 m/s vibrates at 9.6 Hz like tiles at 0.3 m/s. Without speed copies
/// the model reads it as tiles; with copies 1.6 times as fast it reads
/// gravel, and still reads tiles driven at 0.48 m/s as tiles.
#[test]
fn speed_copies_teach_a_ground_at_a_speed_it_was_not_driven_at() {
    let train: Vec<DriveLog> = (0..6)
        .map(|i| drive(i % 2, 0.28 + 0.01 * (i / 2) as f64 * 2.0, 40.0, i as u64))
        .collect();
    let fast_gravel = drive(0, 0.48, 40.0, 100);
    let fast_tiles = drive(1, 0.48, 40.0, 101);
    let plain = TerrainModel::train(&train, &opts(None)).unwrap();
    let augmented = TerrainModel::train(&train, &opts(Some(vec![1.6]))).unwrap();
    let acc = |m: &TerrainModel, log: &DriveLog| score_log(m, log).unwrap().raw.accuracy();
    assert!(
        acc(&plain, &fast_gravel) < 0.5,
        "plain: {}",
        acc(&plain, &fast_gravel)
    );
    assert!(
        acc(&augmented, &fast_gravel) > 0.9,
        "augmented: {}",
        acc(&augmented, &fast_gravel)
    );
    assert!(acc(&augmented, &fast_tiles) > 0.9);
    // The envelope still holds the recorded speeds only: the fast drive is
    // flagged as unfamiliar driving.
    let tl = augmented.classify_log(&fast_gravel).unwrap();
    assert!(tl.outside_envelope_share().unwrap() > 0.9);
}

/// The windows of a copy driven r times as fast carry the features of a
/// drive at r times the speed: tread speed, dominant band and zero
/// crossings, not those of the original.
#[test]
fn a_speed_copy_has_the_features_of_the_faster_drive() {
    let cfg = VibrationConfig {
        window_s: 2.0,
        ..Default::default()
    };
    let names = cfg.feature_names();
    let at = |n: &str| names.iter().position(|m| m == n).unwrap();
    let median = |log: &DriveLog, j: usize| {
        let (_, w) = log_windows(log, &cfg).unwrap();
        let mut v: Vec<f64> = w.iter().map(|(_, f)| f[j]).collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let slow = drive(0, 0.3, 40.0, 1);
    let fast = drive(0, 0.48, 40.0, 2);
    let copy = speed_copy(&slow, 1.6, &SpeedLaw::default());
    // 6 Hz at 0.3 m/s is in band 1 (4.2-8.3 Hz of 12 bands to 50 Hz); 9.6 Hz
    // at 0.48 m/s in band 2.
    for feature in [
        "tread_speed",
        "accel_z_zcr",
        "accel_z_band2_share",
        "accel_z_band1_share",
    ] {
        let j = at(feature);
        let (s, f, c) = (median(&slow, j), median(&fast, j), median(&copy, j));
        assert!(
            (c - f).abs() < 0.25 * (s - f).abs(),
            "{feature}: slow {s}, fast {f}, copy {c}"
        );
    }
}
