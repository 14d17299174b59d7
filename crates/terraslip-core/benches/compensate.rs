//! Speed of one slip-compensated command (`Compensator::command`): the
//! model inverted at the command (Newton on the tread speeds), the
//! correction slewed towards the estimate, the limits applied.
//!
//! `cargo bench -p terraslip-core --bench compensate` (figures in
//! docs/figures/compensate.md).
use criterion::{black_box, criterion_group, criterion_main, Criterion};
use terraslip_core::compensate::{CompensateConfig, Compensator, IcrModel};
use terraslip_core::Twist;

/// A sandy ground with both turn laws and the centripetal terms.
fn sand() -> IcrModel {
    IcrModel::EXAMPLE_SAND
}

fn bench(c: &mut Criterion) {
    let mut cfg = CompensateConfig::new(0.55);
    cfg.engage_after = 0.0;
    cfg.max_speed = 1.0;
    cfg.max_yaw_rate = 2.0;
    cfg.max_acceleration = 2.0;
    cfg.max_yaw_acceleration = 4.0;
    let cases = [
        ("constant model", IcrModel::constant(sand().icr)),
        ("turn laws and centripetal terms", sand()),
    ];
    for (name, model) in cases {
        let mut comp = Compensator::new(cfg).expect("valid settings");
        let mut t = 0.0;
        let mut k = 0u32;
        c.bench_function(&format!("compensate one command, {name}"), |b| {
            b.iter(|| {
                t += 0.02;
                k = k.wrapping_add(1);
                let desired = Twist {
                    v_x: 0.6,
                    v_y: 0.0,
                    omega: if k.is_multiple_of(2) { 0.8 } else { -0.5 },
                };
                black_box(comp.command(t, black_box(desired), Some((model, true))))
            })
        });
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
