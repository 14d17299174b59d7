//! Feature extraction speed (issue 4 targets): SFTA of a 640x480 frame
//! < 10 ms, RGB histograms + LBP < 3 ms, vibration features of a 1 s window
//! (100 Hz, six channels, full set, with motor currents) < 20 µs.
//!
//! `cargo bench -p terraslip-terrain --bench features`

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use terraslip_io::{MotorCurrent, WheelSample};
use terraslip_terrain::synth::texture;
use terraslip_terrain::vibration::{SpeedStats, VibrationExtractor};
use terraslip_terrain::vision::{grey, lbp_histogram, rgb_histograms, sfta};
use terraslip_terrain::VibrationConfig;

fn vision(c: &mut Criterion) {
    let img = texture(2, 640, 480, 1, 1.0);
    let (w, h) = (640usize, 480usize);
    c.bench_function("sfta_640x480_nt4", |b| {
        let mut out = Vec::with_capacity(24);
        b.iter(|| {
            out.clear();
            let g = grey(black_box(&img));
            sfta(&g, w, h, 4, &mut out);
            black_box(&out);
        })
    });
    c.bench_function("hist_lbp_640x480", |b| {
        let mut out = Vec::with_capacity(60);
        b.iter(|| {
            out.clear();
            rgb_histograms(black_box(&img), 16, &mut out);
            let g = grey(&img);
            lbp_histogram(&g, w, h, &mut out);
            black_box(&out);
        })
    });
}

fn vibration(c: &mut Criterion) {
    let cfg = VibrationConfig {
        window_s: 1.0,
        ..Default::default()
    };
    let with_currents = VibrationConfig {
        currents: true,
        ..cfg.clone()
    };
    let mut ex = VibrationExtractor::new(&cfg, 100.0).expect("valid settings");
    let mut ex_c = VibrationExtractor::new(&with_currents, 100.0).expect("valid settings");
    let ch: Vec<Vec<f64>> = (0..6)
        .map(|k| {
            (0..100)
                .map(|i| ((i * (k + 3)) as f64 * 0.37).sin())
                .collect()
        })
        .collect();
    let slices: [&[f64]; 6] = std::array::from_fn(|k| ch[k].as_slice());
    let speed = SpeedStats {
        speed: 0.5,
        ..Default::default()
    };
    // 6.5 Hz wheels with currents over 10 s; the window is the last second.
    let wheels: Vec<WheelSample> = (0..65)
        .map(|i| WheelSample {
            t: i as f64 / 6.5,
            v_left: 0.4,
            v_right: 0.5 + 0.1 * (i as f64 * 0.3).sin(),
        })
        .collect();
    let currents: Vec<MotorCurrent> = wheels
        .iter()
        .enumerate()
        .map(|(i, w)| MotorCurrent {
            t: w.t,
            left: 4.0 + (i as f64 * 0.7).sin(),
            right: 5.0 + (i as f64 * 0.4).cos(),
        })
        .collect();
    c.bench_function("vibration_full_1s_100hz_6ch", |b| {
        let mut out = Vec::with_capacity(200);
        b.iter(|| {
            out.clear();
            ex.features(black_box(&slices), speed, &[], &mut out)
                .expect("window length matches");
            black_box(&out);
        })
    });
    c.bench_function("vibration_full_currents_1s_100hz_6ch", |b| {
        let mut out = Vec::with_capacity(200);
        b.iter(|| {
            out.clear();
            let cur = terraslip_terrain::current::features(black_box(&currents), &wheels, 8.9, 9.9)
                .expect("currents in the window");
            ex_c.features(black_box(&slices), speed, &cur, &mut out)
                .expect("window length matches");
            black_box(&out);
        })
    });
}

criterion_group!(benches, vision, vibration);
criterion_main!(benches);
