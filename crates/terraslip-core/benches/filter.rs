//! Speed of one filter step (issue 2: predict <= 200 ns, predict+update <= 1 us).
use criterion::{black_box, criterion_group, criterion_main, Criterion};
use terraslip_core::filter::{Filter, FilterConfig, PoseFix, Variant};
use terraslip_core::model::{self, MatN, State};
use terraslip_core::IcrParams;

fn filter(variant: Variant) -> Filter {
    let mut cfg = FilterConfig::for_track(0.5);
    cfg.variant = variant;
    let x0 = model::state(0.0, 0.0, 0.3, &IcrParams::new(0.3, -0.32, 0.01));
    let p0 = MatN::from_diagonal(&State::from([
        4.0, 4.0, 1e-3, 1e-3, 1e-3, 1e-3, 1e-4, 1e-4, 1e-12,
    ]));
    Filter::new(x0, p0, cfg).expect("valid start")
}

fn bench(c: &mut Criterion) {
    let mut f = filter(Variant::Adaptive);
    c.bench_function("predict", |b| {
        b.iter(|| f.predict(black_box(0.4), black_box(0.6), black_box(0.02)))
    });
    // The turn-rate law on (a learned spread slope, a fixed factor slope).
    let f0 = filter(Variant::Adaptive);
    let mut cfg = *f0.config();
    cfg.rate_k_alpha = -0.02;
    cfg.learn_rate_k_spread = true;
    // As shipped (session 4b): the law's input capped, the factor held.
    cfg.rate_dv_cap = true;
    cfg.hold_alpha_turn = core::f64::consts::PI;
    let mut x0 = f0.state();
    x0[model::RATE_K] = 0.15;
    let mut p0 = f0.covariance();
    p0[(model::RATE_K, model::RATE_K)] = 0.01;
    let mut f = Filter::new(x0, p0, cfg).expect("valid start");
    let mut g = f.clone();
    c.bench_function("predict turn-rate law", |b| {
        b.iter(|| f.predict(black_box(0.4), black_box(0.6), black_box(0.02)))
    });
    let mut t = 0.0;
    c.bench_function("predict+update adaptive turn-rate law", |b| {
        b.iter(|| {
            t += 0.02;
            let _ = g.predict(black_box(0.4), black_box(0.6), 0.02);
            let s = g.state();
            let fix = PoseFix {
                position: Some((s[0] + 0.3, s[1] - 0.2)),
                yaw: Some(s[2] + 0.01),
                std_xy: 2.0,
                std_yaw: 0.0175,
            };
            black_box(g.update(t, &fix))
        })
    });
    for (name, variant) in [
        ("predict+update adaptive", Variant::Adaptive),
        ("predict+update ekf", Variant::Ekf),
        ("predict+update iekf", Variant::Iekf { window: 10 }),
    ] {
        let mut f = filter(variant);
        let mut t = 0.0;
        c.bench_function(name, |b| {
            b.iter(|| {
                t += 0.02;
                let _ = f.predict(black_box(0.4), black_box(0.6), 0.02);
                let s = f.state();
                let fix = PoseFix {
                    position: Some((s[0] + 0.3, s[1] - 0.2)),
                    yaw: Some(s[2] + 0.01),
                    std_xy: 2.0,
                    std_yaw: 0.0175,
                };
                black_box(f.update(t, &fix))
            })
        });
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
