//! Which fit segments recover known parameters best: simulated 600 s P3-AT
//! drives (Mandow Table I, 5 Hz poses with 1 cm / 0.005 rad noise, 100 Hz
//! wheels), calibrated by LM with the time offset fixed at 0 on chained
//! segments, overlapping ones at several strides, and one from every pose;
//! and the same drives with noise-free poses, which separates the pose
//! noise from everything else.
//!
//! `cargo run --release -p terraslip-calib --example fit_segments -- [SEEDS]`
//!
//! Prints, per segmentation, the RMS over seeds of the error of y_l, y_r,
//! x_c (mm) and of the alphas (%), the worst single error, and the mean
//! wall time of one `calibrate()`; then, for the noisy drives, the mean
//! reported 1-sigma next to the RMS error per parameter, and their ratio.

use terraslip_calib::synthetic::{drive, mandow_table1, SynthConfig};
use terraslip_calib::*;

fn main() {
    let seeds: u64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(10);
    let truth = mandow_table1();
    let modes: [(&str, Option<f64>); 5] = [
        ("chained", None),
        ("stride 1.0 s", Some(1.0)),
        ("stride 0.5 s", Some(0.5)),
        ("stride 0.25 s", Some(0.25)),
        ("every pose", Some(0.0)),
    ];
    let mut honesty = Vec::new();
    println!("| pose noise | fit segments | RMS y_l, y_r, x_c (mm) | RMS alpha_l, alpha_r (%) | worst (mm) | s per fit |");
    println!("|---|---|---|---|---|---|");
    for noisy in [true, false] {
        let logs: Vec<_> = (1..=seeds)
            .map(|seed| {
                let mut c = SynthConfig::p3at(600.0, seed);
                if !noisy {
                    c.pose_noise_xy = 0.0;
                    c.pose_noise_yaw = 0.0;
                }
                drive(&[("asphalt", truth)], &c)
            })
            .collect();
        for (name, overlap) in modes {
            let cfg = CalibConfig {
                method: Some(Method::Lm),
                time_offset: TimeOffset::Fixed(0.0),
                segment: SegmentConfig {
                    overlap,
                    ..CalibConfig::default().segment
                },
                ..Default::default()
            };
            let mut sq = [0.0f64; 5];
            let mut sd = [0.0f64; 5];
            let mut worst = 0.0f64;
            let t = std::time::Instant::now();
            for log in &logs {
                let cal = match calibrate(std::slice::from_ref(log), &cfg, &|_| {}) {
                    Ok(c) => c,
                    Err(e) => {
                        eprintln!("{name}: {e}");
                        continue;
                    }
                };
                let p = cal.sets[0].best.params;
                let e = [
                    1e3 * (p.y_l - truth.y_l),
                    1e3 * (p.y_r - truth.y_r),
                    1e3 * (p.x_c - truth.x_c),
                    1e2 * (p.alpha_l / truth.alpha_l - 1.0),
                    1e2 * (p.alpha_r / truth.alpha_r - 1.0),
                ];
                let std = cal.sets[0].best.std;
                let unit = [1e3, 1e3, 1e3, 1e2 / truth.alpha_l, 1e2 / truth.alpha_r];
                for k in 0..5 {
                    sq[k] += e[k] * e[k];
                    sd[k] += unit[k] * std[k];
                }
                worst = worst.max(e[0].abs()).max(e[1].abs()).max(e[2].abs());
            }
            let secs = t.elapsed().as_secs_f64() / logs.len() as f64;
            let rms: Vec<f64> = sq.iter().map(|s| (s / logs.len() as f64).sqrt()).collect();
            if noisy {
                let mean: Vec<f64> = sd.iter().map(|s| s / logs.len() as f64).collect();
                honesty.push((name, mean, rms.clone()));
            }
            println!(
                "| {} | {name} | {:.2}, {:.2}, {:.2} | {:.3}, {:.3} | {:.2} | {:.2} |",
                if noisy { "1 cm, 0.005 rad" } else { "none" },
                rms[0],
                rms[1],
                rms[2],
                rms[3],
                rms[4],
                worst,
                secs
            );
        }
    }
    println!();
    println!("| fit segments | reported 1-sigma / RMS error: y_l, y_r, x_c (mm) | alpha_l, alpha_r (%) | ratio per parameter |");
    println!("|---|---|---|---|");
    for (name, mean, rms) in honesty {
        let f = |k: usize, d: usize| format!("{:.*} / {:.*}", d, mean[k], d, rms[k]);
        let ratio: Vec<String> = (0..5).map(|k| format!("{:.2}", mean[k] / rms[k])).collect();
        println!(
            "| {name} | {}, {}, {} | {}, {} | {} |",
            f(0, 2),
            f(1, 2),
            f(2, 2),
            f(3, 3),
            f(4, 3),
            ratio.join(", ")
        );
    }
}
