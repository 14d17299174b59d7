//! Rough per-step timing without criterion (for quick checks on a busy machine):
//!     cargo run -p terraslip-core --release --example steptime
use std::time::Instant;
use terraslip_core::filter::{Filter, FilterConfig, PoseFix, Variant};
use terraslip_core::model::{self, MatN, State};
use terraslip_core::IcrParams;
fn main() {
    let mut cfg = FilterConfig::for_track(0.5);
    cfg.variant = Variant::Ekf;
    let x0 = model::state(0.0, 0.0, 0.3, &IcrParams::new(0.3, -0.32, 0.01));
    let p0 = MatN::from_diagonal(&State::from([4.0, 4.0, 1e-3, 1e-3, 1e-3, 1e-3, 1e-4, 1e-4]));
    let mut f = Filter::new(x0, p0, cfg).expect("valid start");
    let n = 200_000;
    let t0 = Instant::now();
    for _ in 0..n {
        let _ = f.predict(0.4, 0.6, 0.02);
    }
    let tp = t0.elapsed().as_nanos() as f64 / n as f64;
    let t0 = Instant::now();
    let mut t = 0.0;
    for _ in 0..n {
        t += 0.02;
        let s = *f.state();
        let fix = PoseFix {
            position: Some((s[0] + 0.3, s[1] - 0.2)),
            yaw: Some(s[2] + 0.01),
            std_xy: 2.0,
            std_yaw: 0.0175,
        };
        let _ = std::hint::black_box(f.update(t, &fix));
    }
    let tu = t0.elapsed().as_nanos() as f64 / n as f64;
    let t0 = Instant::now();
    for _ in 0..n {
        t += 0.02;
        let s = *f.state();
        let fix = PoseFix {
            position: None,
            yaw: Some(s[2] + 0.01),
            std_xy: 2.0,
            std_yaw: 0.0175,
        };
        let _ = std::hint::black_box(f.update(t, &fix));
    }
    let ty = t0.elapsed().as_nanos() as f64 / n as f64;
    let t0 = Instant::now();
    for _ in 0..n {
        let _ = std::hint::black_box(f.std());
        let _ = std::hint::black_box(f.state()[2].sin());
    }
    let ts = t0.elapsed().as_nanos() as f64 / n as f64;
    let t0 = Instant::now();
    let mut a = 0.1f64;
    for _ in 0..n {
        a = std::hint::black_box(libm::sin(a) + 0.1);
    }
    let tsin = t0.elapsed().as_nanos() as f64 / n as f64;
    println!("predict {tp:.0} ns, update {tu:.0} ns, yaw-only update {ty:.0} ns, std {ts:.0} ns, libm::sin {tsin:.0} ns");
}
