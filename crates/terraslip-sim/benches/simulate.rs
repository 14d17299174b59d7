//! Simulator speed: a whole papers drive without camera, and one camera frame.
//! `cargo bench -p terraslip-sim --bench simulate`

use criterion::{criterion_group, criterion_main, Criterion};
use terraslip_sim::{simulate, Scenario};

fn bench(c: &mut Criterion) {
    let mut papers = Scenario::builtin("papers").expect("builtin");
    papers.camera.rate = 0.0;
    let mut g = c.benchmark_group("simulate");
    g.sample_size(10);
    g.bench_function("papers_360s_no_camera", |b| {
        b.iter(|| simulate(&papers, 1).expect("simulate"))
    });
    g.finish();

    let with_cam = simulate(&Scenario::builtin("wang4").expect("builtin"), 1).expect("simulate");
    let mut g = c.benchmark_group("camera");
    g.sample_size(20);
    // One frame per texture family: soil, grass, asphalt, paving.
    for (name, t) in [
        ("soil", 10.0),
        ("grass", 150.0),
        ("asphalt", 250.0),
        ("paving", 350.0),
    ] {
        let i = with_cam.frames.partition_point(|f| f.t < t);
        g.bench_function(format!("render_320x240_{name}"), |b| {
            b.iter(|| with_cam.render_frame(i).expect("frame"))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
