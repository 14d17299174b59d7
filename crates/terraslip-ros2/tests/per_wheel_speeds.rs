//! A bag whose wheel speeds come only in messages `import` does not read,
//! laid out as the AgileX Scout 2.0 recording of Politecnico di Milano's
//! robotics course (docs/figures/robots.md): four `robotics_hw1/MotorSpeed`
//! topics (a header and the motor's rpm) and a motion-capture `/gt_pose`.
//! The refusal says how to go on: the log directory, and the pose
//! reference's place in it.

use std::path::Path;

use terraslip_ros2::defs::definition_of;
use terraslip_ros2::msg::CdrWriter;
use terraslip_ros2::out::EstimateMcap;
use terraslip_ros2::{import, TopicsConfig};

const T0: u64 = 1_617_791_999_000_000_000;
const MOTOR_SPEED: &str = "std_msgs/Header header\nfloat64 rpm\n";

fn header(w: &mut CdrWriter, ns: u64, frame: &str) {
    w.u32((ns / 1_000_000_000) as u32);
    w.u32((ns % 1_000_000_000) as u32);
    w.string(frame);
}

fn write(p: &Path) {
    let mut m = EstimateMcap::create(p).unwrap();
    let motors: Vec<u16> = ["fl", "fr", "rl", "rr"]
        .iter()
        .map(|w| {
            let topic = format!("/motor_speed_{w}");
            m.channel(&topic, "robotics_hw1/msg/MotorSpeed", MOTOR_SPEED)
                .unwrap()
        })
        .collect();
    let pose_ty = "geometry_msgs/msg/PoseStamped";
    let pose = m
        .channel("/gt_pose", pose_ty, &definition_of(pose_ty).unwrap())
        .unwrap();
    for k in 0..100u64 {
        let ns = T0 + k * 20_000_000;
        for (i, &c) in motors.iter().enumerate() {
            let mut w = CdrWriter::new();
            header(&mut w, ns, "");
            w.f64(if i % 2 == 0 { -1000.0 } else { 1000.0 });
            m.write(c, ns, &w.finish()).unwrap();
        }
        let mut w = CdrWriter::new();
        header(&mut w, ns, "world");
        for v in [k as f64 * 0.01, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0] {
            w.f64(v);
        }
        m.write(pose, ns, &w.finish()).unwrap();
    }
    m.finish().unwrap();
}

#[test]
fn per_wheel_motor_speeds_in_a_message_import_does_not_read_are_refused_with_the_way_on() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("scout.mcap");
    write(&p);
    let e = import(&p, &TopicsConfig::default(), None)
        .map(|_| ())
        .unwrap_err()
        .to_string();
    assert!(e.contains("no usable wheel source"), "{e}");
    assert!(
        e.contains("/motor_speed_fl (robotics_hw1/msg/MotorSpeed)"),
        "{e}"
    );
    assert!(e.contains("wheels.csv"), "the log directory's wheels: {e}");
    assert!(e.contains("docs/log-format.md"), "{e}");
    assert!(
        e.contains("/gt_pose as pose.csv"),
        "the pose reference's place: {e}"
    );
}
