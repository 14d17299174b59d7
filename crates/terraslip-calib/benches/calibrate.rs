//! Speed targets: Levenberg-Marquardt on a 600 s drive in under 1 s,
//! the GA in under 10 s using all cores.
//!
//! `cargo bench -p terraslip-calib --bench calibrate`

use criterion::{criterion_group, criterion_main, Criterion};
use terraslip_calib::synthetic::{drive, mandow_table1, SynthConfig};
use terraslip_calib::{calibrate, CalibConfig, Method, TimeOffset};

fn bench(c: &mut Criterion) {
    // 600 s at 100 Hz wheels, 5 Hz poses: 60 000 wheel samples, ~600 segments.
    let log = drive(
        &[("asphalt", mandow_table1())],
        &SynthConfig::p3at(600.0, 1),
    );
    let logs = [log];
    let mut g = c.benchmark_group("calibrate_600s_drive");
    g.sample_size(10);
    let lm = CalibConfig {
        method: Some(Method::Lm),
        time_offset: TimeOffset::Fixed(0.0),
        ..Default::default()
    };
    g.bench_function("lm", |b| {
        b.iter(|| calibrate(&logs, &lm, &|_| {}).expect("lm"))
    });
    // What the traction term's fit costs (a third LM fit, 8 free parameters).
    let lm_no_traction = CalibConfig {
        traction: terraslip_calib::RateModel::Off,
        ..lm.clone()
    };
    g.bench_function("lm_no_traction", |b| {
        b.iter(|| calibrate(&logs, &lm_no_traction, &|_| {}).expect("lm"))
    });
    let lm_chained = CalibConfig {
        segment: terraslip_calib::SegmentConfig {
            overlap: None,
            ..lm.segment.clone()
        },
        ..lm.clone()
    };
    g.bench_function("lm_chained", |b| {
        b.iter(|| calibrate(&logs, &lm_chained, &|_| {}).expect("lm"))
    });
    let lm_stride = CalibConfig {
        segment: terraslip_calib::SegmentConfig {
            overlap: Some(0.25),
            ..lm.segment.clone()
        },
        ..lm.clone()
    };
    g.bench_function("lm_stride_0.25", |b| {
        b.iter(|| calibrate(&logs, &lm_stride, &|_| {}).expect("lm"))
    });
    let lm_auto = CalibConfig {
        method: Some(Method::Lm),
        ..Default::default()
    };
    g.bench_function("lm_with_offset_search", |b| {
        b.iter(|| calibrate(&logs, &lm_auto, &|_| {}).expect("lm"))
    });
    // Default GA (48 x 100), all cores; includes the LM pass that sets the
    // inlier set and the offset search.
    let ga = CalibConfig {
        method: Some(Method::Ga),
        ..Default::default()
    };
    g.bench_function("ga_all_cores", |b| {
        b.iter(|| calibrate(&logs, &ga, &|_| {}).expect("ga"))
    });
    let mut ga1 = ga.clone();
    ga1.ga.threads = Some(1);
    g.bench_function("ga_one_thread", |b| {
        b.iter(|| calibrate(&logs, &ga1, &|_| {}).expect("ga"))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
