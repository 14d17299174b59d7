//! Speed of one filter step and of one estimator event.
//!
//! `cargo bench -p terraslip-core --bench filter` (figures in docs/benchmarks.md).
use criterion::{black_box, criterion_group, criterion_main, Criterion};
use terraslip_core::estimator::Estimator;
use terraslip_core::filter::{
    Filter, FilterConfig, IcrBand, MeasurementConfig, PoseFix, Prior, SlipStd, Variant,
};
use terraslip_core::schedule::{NoiseSchedule, ScheduleConfig};
use terraslip_core::{Chart, IcrParams};

fn filter(cfg: FilterConfig) -> Filter {
    let prior = Prior {
        icr: IcrParams::new(0.3, -0.32, 0.01),
        std: SlipStd {
            spread: 0.1,
            centre: 0.02,
            x_c: 0.05,
            alpha: 0.1,
            alpha_diff: 0.01,
        },
        turn_law: 0.0,
        turn_law_std: 0.1,
        centripetal: terraslip_core::kinematics::CentripetalSlopes::NONE,
        centripetal_std: terraslip_core::kinematics::CentripetalSlopes::NONE,
        speed_law: 0.0,
        speed_law_std: 0.0,
    };
    let band = IcrBand {
        min_spread: 0.2,
        max_spread: 2.0,
        max_centre: 0.1,
        max_x_c: 0.2,
        alpha_range: (0.3, 1.5),
    };
    Filter::new(&prior, cfg, MeasurementConfig::default(), band).expect("valid start")
}

fn anchored(cfg: FilterConfig) -> Filter {
    let mut f = filter(cfg);
    let fix = PoseFix {
        position: Some((0.0, 0.0)),
        yaw: Some(0.3),
        std_xy: 2.0,
        std_yaw: 0.0175,
        stated: true,
    };
    f.update(0.0, 0.0, &fix).expect("anchor");
    f
}

fn bench(c: &mut Criterion) {
    let papers = FilterConfig {
        chart: Chart::Tread,
        update_iterations: 1,
        learn_alpha: false,
        learn_clock: false,
        change_window: 0.0,
        noise_memory: 0.0,
        ..Default::default()
    };
    let iae = FilterConfig {
        variant: Variant::InnovationAdaptive,
        ..papers
    };
    for (name, cfg) in [
        ("default", FilterConfig::default()),
        ("ekf-qmin", papers),
        ("ta-iekf", iae),
    ] {
        let mut f = anchored(cfg);
        c.bench_function(&format!("predict {name}"), |b| {
            b.iter(|| f.predict(black_box(0.4), black_box(0.6), black_box(0.02)))
        });
        let mut f = anchored(cfg);
        let mut t = 0.0;
        c.bench_function(&format!("predict+update {name}"), |b| {
            b.iter(|| {
                t += 0.02;
                let _ = f.predict(black_box(0.4), black_box(0.6), 0.02);
                let (e, n, y) = f.pose();
                let fix = PoseFix {
                    position: Some((e + 0.3, n - 0.2)),
                    yaw: Some(y + 0.01),
                    std_xy: 2.0,
                    std_yaw: 0.0175,
                    stated: true,
                };
                black_box(f.update(t, 0.0, &fix))
            })
        });
    }
    // One wheels event of the online API (what a robot or the Python
    // binding calls at the wheel rate).
    let mut est = Estimator::new(
        anchored(FilterConfig::default()),
        NoiseSchedule::new(ScheduleConfig::default()),
        1.0,
    );
    let mut t = 0.0;
    c.bench_function("estimator on_wheels", |b| {
        b.iter(|| {
            t += 0.02;
            est.on_wheels(black_box(t), black_box(0.4), black_box(0.6))
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
