//! Speed of `estimate` over one hour of 50 Hz wheels + 1 Hz pose (target: under 1 s).
use criterion::{criterion_group, criterion_main, Criterion};
use terraslip::config::EstimatorConfig;
use terraslip::pipeline::{self, TerrainEvidence};
use terraslip::testkit::{drive, SynthSpec};

fn bench(c: &mut Criterion) {
    let spec = SynthSpec {
        duration: 3600.0,
        ..Default::default()
    };
    let log = drive(&spec);
    let labels = TerrainEvidence::Labels(log.terrain.clone());
    let cfg = EstimatorConfig::default();
    let mut g = c.benchmark_group("estimate 1 h");
    g.sample_size(10);
    g.bench_function("pipeline 180k wheels + 3.6k pose", |b| {
        b.iter(|| pipeline::run(&log, &cfg, &labels, None).expect("runs"))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
