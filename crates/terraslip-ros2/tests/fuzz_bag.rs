//! Property test over the bag reader: truncated, bit-flipped and spliced
//! MCAP files and random CDR bytes give errors, never panics. Bounded
//! (`PROPTEST_CASES`, default 200 cases each) to stay within seconds.

use proptest::prelude::*;
use terraslip_ros2::out::{EstimateMcap, EstimateSample};
use terraslip_ros2::{import, Bag, TopicsConfig};

fn sample_bag() -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("b.mcap");
    let mut m = EstimateMcap::create(&p).unwrap();
    for k in 0..60u64 {
        let s = EstimateSample {
            stamp_ns: 1_700_000_000_000_000_000 + k * 50_000_000,
            east: k as f64 * 0.1,
            twist: [1.0, 0.0, 0.2],
            icr: [0.5, -0.5, 0.0, 1.0, 1.0],
            ..Default::default()
        };
        m.estimate(&s, Some("grass")).unwrap();
    }
    m.finish().unwrap();
    std::fs::read(&p).unwrap()
}

fn read_all(bytes: &[u8]) {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("f.mcap");
    std::fs::write(&p, bytes).unwrap();
    if let Ok(mut bag) = Bag::open(&p) {
        let _ = bag.for_each(&|_| true, &mut |_, _| Ok(()));
    }
    let cfg: TopicsConfig = toml::from_str("[wheels]\nseparation = 1.0\n").unwrap();
    let _ = import(&p, &cfg, None);
}

fn cases() -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(200)
}

#[test]
fn the_sample_bag_imports() {
    let bytes = sample_bag();
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("f.mcap");
    std::fs::write(&p, &bytes).unwrap();
    let cfg: TopicsConfig = toml::from_str("[wheels]\nseparation = 1.0\n").unwrap();
    let (log, _) = import(&p, &cfg, None).unwrap();
    assert_eq!(log.wheels.len(), 60);
    assert!((log.wheels[0].v_right - 1.1).abs() < 1e-12);
    // Cut in the data section (a recording killed before it closed the
    // file): the whole messages before the cut, and a warning naming the
    // file, once.
    std::fs::write(&p, &bytes[..bytes.len() / 2]).unwrap();
    let (cut, report) = import(&p, &cfg, None).unwrap();
    assert!(!cut.wheels.is_empty() && cut.wheels.len() <= 60);
    let w = report.warnings.join("\n");
    assert_eq!(report.warnings.len(), 1, "{w}");
    assert!(w.contains("ends in the middle of a record"), "{w}");
    assert_eq!(w.matches("f.mcap -o").count(), 1, "{w}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(), failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn truncated_bags_never_panic(cut in 0.0f64..1.0) {
        let b = sample_bag();
        let n = (b.len() as f64 * cut) as usize;
        read_all(&b[..n]);
    }

    #[test]
    fn corrupted_bags_never_panic(flips in proptest::collection::vec((0.0f64..1.0, any::<u8>()), 1..8)) {
        let mut b = sample_bag();
        for (at, v) in flips {
            let i = ((b.len() - 1) as f64 * at) as usize;
            b[i] ^= v | 1;
        }
        read_all(&b);
    }

    #[test]
    fn random_cdr_never_panics(data in proptest::collection::vec(any::<u8>(), 0..400)) {
        let def = terraslip_ros2::defs::definition_of("nav_msgs/msg/Odometry").unwrap();
        let (reg, root) = terraslip_ros2::msg::Registry::parse("nav_msgs/msg/Odometry", &def, None).unwrap();
        let _ = reg.decode(root, &data);
        let mut sel = terraslip_ros2::msg::Selection::default();
        sel.add(&reg.resolve(root, "twist.twist.angular.z").unwrap());
        let _ = reg.decode_selected(root, &data, &sel);
        let def = terraslip_ros2::defs::definition_of("sensor_msgs/msg/JointState").unwrap();
        let (reg, root) = terraslip_ros2::msg::Registry::parse("sensor_msgs/msg/JointState", &def, None).unwrap();
        let _ = reg.decode(root, &data);
    }
}
