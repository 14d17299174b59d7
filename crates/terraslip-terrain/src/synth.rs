//! Small synthetic labelled logs for tests, examples and benchmarks: IMU
//! vibration with a per-terrain spectrum, and ground-camera textures with a
//! per-terrain colour and structure. Deterministic for a given seed.

use std::path::Path;

use image::{Rgb, RgbImage};
use terraslip_io::{
    DriveLog, ImageRef, ImuSample, LogError, MotorCurrent, TerrainLabel, WheelSample,
};

use crate::vibration::STANDARD_GRAVITY;
use terraslip_core::rng::SplitMix64;

/// Vibration signature of synthetic terrain `k`: (dominant frequency Hz,
/// amplitude m/s², broadband noise m/s²).
fn signature(k: usize) -> (f64, f64, f64) {
    const S: [(f64, f64, f64); 5] = [
        (6.0, 0.3, 0.15),
        (14.0, 0.6, 0.3),
        (24.0, 0.4, 0.6),
        (35.0, 1.0, 0.2),
        (9.0, 1.2, 0.9),
    ];
    S[k % S.len()]
}

/// A log driving over `segments` (terrain index into `names`, seconds) at
/// a constant 0.5 m/s: 100 Hz IMU with all six channels, 10 Hz wheels with
/// motor currents (3 + 1.5 k A, noisy) and `terrain.csv` labels. Time
/// starts at `t0`.
pub fn vibration_log(names: &[&str], segments: &[(usize, f64)], seed: u64, t0: f64) -> DriveLog {
    let mut rng = SplitMix64(seed);
    let mut gauss = move || {
        // Irwin-Hall: good enough for test noise, no extra dependency.
        (0..12).map(|_| rng.uniform()).sum::<f64>() - 6.0
    };
    let rate = 100.0;
    let mut log = DriveLog::default();
    let mut t_start = t0;
    let mut phase = 0.0f64;
    for &(k, dur) in segments {
        log.terrain.push(TerrainLabel {
            t: t_start,
            terrain: names[k % names.len()].to_string(),
        });
        let (f, a, noise) = signature(k);
        let n = (dur * rate).round() as usize;
        for i in 0..n {
            let t = t_start + i as f64 / rate;
            phase += 2.0 * std::f64::consts::PI * f / rate;
            let v = a * phase.sin() + noise * gauss();
            log.imu.push(ImuSample {
                t,
                accel_z: STANDARD_GRAVITY + v,
                accel_x: Some(0.5 * noise * gauss()),
                accel_y: Some(0.5 * noise * gauss()),
                gyro_x: Some(0.1 * v + 0.01 * gauss()),
                gyro_y: Some(0.05 * v + 0.01 * gauss()),
                gyro_z: Some(0.01 * gauss()),
            });
            if i % 10 == 0 {
                log.wheels.push(WheelSample {
                    t,
                    v_left: 0.5,
                    v_right: 0.5,
                });
                let c = 3.0 + 1.5 * (k % 5) as f64;
                log.currents.push(MotorCurrent {
                    t,
                    left: c + 0.3 * gauss(),
                    right: c + 0.3 * gauss(),
                });
            }
        }
        t_start += n as f64 / rate;
    }
    log.meta.track_width = Some(0.5);
    log
}

/// A `w` x `h` ground texture of synthetic terrain `k` (0..4: gravel
/// speckle, grass blades, soil clods, paving joints), brightness `gain`.
pub fn texture(k: usize, w: u32, h: u32, seed: u64, gain: f64) -> RgbImage {
    let mut rng = SplitMix64(seed.wrapping_mul(0x9E37_79B9).wrapping_add(k as u64));
    let base: [[f64; 3]; 4] = [
        [120.0, 120.0, 118.0],
        [70.0, 130.0, 50.0],
        [110.0, 80.0, 50.0],
        [150.0, 140.0, 130.0],
    ];
    let b = base[k % 4];
    let (ox, oy) = ((rng.next_u64() % 64) as u32, (rng.next_u64() % 64) as u32);
    let mut img = RgbImage::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let (xx, yy) = (x + ox, y + oy);
            let n = rng.uniform() - 0.5;
            let s = match k % 4 {
                0 => 90.0 * n,
                1 => {
                    let blade = ((xx as f64 * 0.9 + (yy as f64 * 0.15).sin() * 3.0) % 6.0) < 2.0;
                    let shade = if blade { 40.0 } else { -25.0 };
                    shade + 30.0 * n
                }
                2 => {
                    let cell = ((xx / 12 * 7 + yy / 12 * 13) % 5) as f64;
                    12.0 * cell - 24.0 + 20.0 * n
                }
                _ => {
                    if xx % 32 < 2 || yy % 16 < 2 {
                        -70.0
                    } else {
                        10.0 * n
                    }
                }
            };
            let px = b.map(|c| ((c + s) * gain).clamp(0.0, 255.0) as u8);
            img.put_pixel(x, y, Rgb(px));
        }
    }
    img
}

/// Writes a camera log to `dir`: one `w` x `h` PNG per second for each
/// segment (terrain index, frames), with lighting varying 0.7..1.3, plus
/// wheels and labels. Returns the log as read back.
pub fn camera_log(
    dir: &Path,
    names: &[&str],
    segments: &[(usize, usize)],
    seed: u64,
    w: u32,
    h: u32,
) -> Result<DriveLog, LogError> {
    let mut rng = SplitMix64(seed);
    let mut log = DriveLog::default();
    let img_dir = dir.join("images");
    std::fs::create_dir_all(&img_dir).map_err(|e| LogError::Io {
        path: img_dir.clone(),
        source: e,
    })?;
    let mut t = 0.0;
    for &(k, frames) in segments {
        log.terrain.push(TerrainLabel {
            t,
            terrain: names[k % names.len()].to_string(),
        });
        for _ in 0..frames {
            let i = log.images.len();
            let rel = format!("images/{i:05}.png");
            let gain = 0.7 + 0.6 * rng.uniform();
            let img = texture(k, w, h, rng.next_u64(), gain);
            let mut png = Vec::new();
            img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
                .map_err(|e| LogError::Invalid {
                    path: dir.join(&rel),
                    reason: e.to_string(),
                })?;
            terraslip_io::write_atomic(dir.join(&rel), &png)?;
            log.images.push(ImageRef {
                t,
                path: rel.into(),
            });
            log.wheels.push(WheelSample {
                t,
                v_left: 0.5,
                v_right: 0.5,
            });
            t += 1.0;
        }
    }
    log.write(dir)?;
    DriveLog::read(dir)
}
