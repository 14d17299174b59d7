//! The live pipeline (`terraslip node` without its transport): one hour of
//! 50 Hz wheels + 100 Hz IMU + 10 Hz GNSS pushed sample by sample.
//!
//! Prints, before criterion's figures, the latency from a wheels sample's
//! arrival to its estimate row with `lag = 0` (p50, p99, max over the hour,
//! one core), and per 10 minutes of the hour the time, the samples held and
//! the process's resident memory (flat: nothing grows with the drive). Criterion then times the whole
//! hour with the default lag (0.3 s).
use std::time::Instant;

use criterion::{criterion_group, criterion_main, Criterion};
use terraslip::config::EstimatorConfig;
use terraslip::pipeline::live::{Live, Sample};
use terraslip::pipeline::EstimateRow;
use terraslip::testkit::{drive, gyro, SynthSpec};
use terraslip_core::IcrParams;

/// The hour's samples in arrival (stamp) order.
fn hour() -> Vec<Sample> {
    let spec = SynthSpec {
        duration: 3600.0,
        pose_hz: 10.0,
        terrains: vec![(0.0, "asphalt".into(), IcrParams::new(0.30, -0.31, 0.01))],
        ..Default::default()
    };
    let log = drive(&spec);
    let mut s: Vec<Sample> = Vec::new();
    s.extend(log.wheels.iter().map(|w| Sample::Wheels(*w)));
    s.extend(log.pose.iter().map(|p| Sample::Pose(*p)));
    s.extend(
        gyro(spec.terrains[0].2, 3600.0, 100.0)
            .into_iter()
            .map(Sample::Imu),
    );
    s.sort_by(|a, b| a.t().total_cmp(&b.t()));
    s
}

/// Keeps only the last row (what a node publishes and forgets).
struct Last(Option<EstimateRow>, u64);
impl terraslip::pipeline::RowSink for Last {
    fn row(
        &mut self,
        _: &[String],
        r: &EstimateRow,
    ) -> Result<(), terraslip::pipeline::PipelineError> {
        self.0 = Some(*r);
        self.1 += 1;
        Ok(())
    }
}

/// The process's resident memory, MiB (`VmRSS` of /proc/self/status;
/// NaN where there is no /proc).
fn resident_mib() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("VmRSS:"))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
        })
        .map_or(f64::NAN, |kib| kib / 1024.0)
}

fn latency(samples: &[Sample], cfg: &EstimatorConfig) {
    let mut live = Live::new("bench", cfg, 0.5, None, 0.0, 0.0).expect("builds");
    let mut sink = Last(None, 0);
    // Written once so its pages are resident before the hour: its filling
    // must not show as growth of the resident memory.
    let mut lat: Vec<f64> = vec![f64::NAN; 180_001];
    lat.clear();
    eprintln!(
        "  resident before the hour (its samples loaded): {:.1} MiB",
        resident_mib()
    );
    let mut chunk = Instant::now();
    let mut next = 600.0;
    for s in samples {
        let wheels = matches!(s, Sample::Wheels(_));
        let before = sink.1;
        let t0 = Instant::now();
        live.push(s.clone(), &mut sink).expect("runs");
        if wheels {
            assert_eq!(
                sink.1,
                before + 1,
                "lag 0: a wheels sample is answered at once"
            );
            lat.push(t0.elapsed().as_secs_f64());
        }
        if s.t() >= next {
            eprintln!(
                "  {:>4.0}-{:>4.0} s of drive: {:.0} ms, {} samples held, resident {:.1} MiB",
                next - 600.0,
                next,
                chunk.elapsed().as_secs_f64() * 1e3,
                live.held(),
                resident_mib()
            );
            chunk = Instant::now();
            next += 600.0;
        }
    }
    lat.sort_by(f64::total_cmp);
    let q = |p: f64| lat[((lat.len() - 1) as f64 * p) as usize] * 1e6;
    eprintln!(
        "arrival -> row, lag 0, {} wheels samples: p50 {:.1} µs, p99 {:.1} µs, max {:.1} µs",
        lat.len(),
        q(0.5),
        q(0.99),
        q(1.0)
    );
}

fn bench(c: &mut Criterion) {
    let samples = hour();
    let cfg = EstimatorConfig::default();
    latency(&samples, &cfg);
    let mut g = c.benchmark_group("live 1 h");
    g.sample_size(10);
    g.bench_function("180k wheels + 360k IMU + 36k GNSS, lag 0.3 s", |b| {
        b.iter(|| {
            let mut live = Live::new("bench", &cfg, 0.5, None, 0.3, 0.0).expect("builds");
            let mut sink = Last(None, 0);
            for s in &samples {
                live.push(s.clone(), &mut sink).expect("runs");
            }
            live.flush(&mut sink).expect("runs");
            sink.1
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
