//! MCAP reading speed: small messages (geometry_msgs/TwistStamped, zstd
//! chunks) streamed and CDR-decoded. `cargo bench -p terraslip-ros2 --bench read`.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use terraslip_ros2::msg::{CdrWriter, Registry, Selection};
use terraslip_ros2::out::EstimateMcap;
use terraslip_ros2::Bag;

const N: u64 = 200_000;

fn bench(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("small.mcap");
    let ty = "geometry_msgs/msg/TwistStamped";
    let def = terraslip_ros2::defs::definition_of(ty).unwrap();
    let mut m = EstimateMcap::create(&p).unwrap();
    let ch = m.channel("/cmd_vel", ty, &def).unwrap();
    for k in 0..N {
        let mut w = CdrWriter::new();
        w.header(k * 10_000_000, "base_link");
        for v in [1.0, 0.0, 0.0, 0.0, 0.0, 0.1 * (k % 7) as f64] {
            w.f64(v);
        }
        m.write(ch, k * 10_000_000, &w.finish()).unwrap();
    }
    m.finish().unwrap();
    let (reg, root) = Registry::parse(ty, &def, None).unwrap();
    let wz = reg.resolve(root, "twist.angular.z").unwrap();
    let mut sel = Selection::default();
    sel.add(&wz);
    let mut g = c.benchmark_group("mcap");
    g.throughput(Throughput::Elements(N));
    g.sample_size(10);
    g.bench_function("read_decode_twist_stamped", |b| {
        b.iter(|| {
            let mut bag = Bag::open(&p).unwrap();
            let mut sum = 0.0;
            bag.for_each(&|_| true, &mut |_, m| {
                let v = reg.decode(root, m.data).unwrap();
                sum += v.f64_at(&wz).unwrap_or(0.0);
                Ok(())
            })
            .unwrap();
            sum
        })
    });
    g.bench_function("read_decode_selected", |b| {
        b.iter(|| {
            let mut bag = Bag::open(&p).unwrap();
            let mut sum = 0.0;
            bag.for_each(&|_| true, &mut |_, m| {
                let v = reg.decode_selected(root, m.data, &sel).unwrap();
                sum += v.f64_at(&wz).unwrap_or(0.0);
                Ok(())
            })
            .unwrap();
            sum
        })
    });
    g.bench_function("read_raw", |b| {
        b.iter(|| {
            let mut bag = Bag::open(&p).unwrap();
            let mut n = 0u64;
            bag.for_each(&|_| true, &mut |_, m| {
                n += m.data.len() as u64;
                Ok(())
            })
            .unwrap();
            n
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
