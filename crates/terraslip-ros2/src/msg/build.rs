//! Whole CDR messages of the types a robot's recording carries, for
//! writing synthetic bags (tests, twins of other robots' recordings).

use super::CdrWriter;

/// A diagonal 6×6 covariance (row-major, `float64[36]`) of `var` on every
/// axis.
fn diagonal(w: &mut CdrWriter, var: f64) {
    for k in 0..36 {
        w.f64(if k % 7 == 0 { var } else { 0.0 });
    }
}

/// `nav_msgs/Odometry` stamped `ns` (ns since the epoch) in `frame`, child
/// `base_link`: a planar `pose` (x, y in m, yaw in rad) and a body-frame
/// `twist` (vx, vy, vz in m/s, wx, wy, wz in rad/s), each with a diagonal
/// covariance of `pose_var` and `twist_var`.
pub fn odometry(
    ns: u64,
    frame: &str,
    pose: [f64; 3],
    pose_var: f64,
    twist: [f64; 6],
    twist_var: f64,
) -> Vec<u8> {
    let mut w = CdrWriter::new();
    w.header(ns, frame).string("base_link");
    let (sz, cz) = (pose[2] / 2.0).sin_cos();
    for c in [pose[0], pose[1], 0.0, 0.0, 0.0, sz, cz] {
        w.f64(c);
    }
    diagonal(&mut w, pose_var);
    for c in twist {
        w.f64(c);
    }
    diagonal(&mut w, twist_var);
    w.finish()
}

/// `sensor_msgs/JointState` stamped `ns` (ns since the epoch): joint
/// `names`, their `position` (rad) and `velocity` (rad/s), either empty;
/// no efforts.
pub fn joint_state(ns: u64, names: &[&str], position: &[f64], velocity: &[f64]) -> Vec<u8> {
    let mut w = CdrWriter::new();
    w.header(ns, "");
    w.u32(names.len() as u32);
    for n in names {
        w.string(n);
    }
    for values in [position, velocity] {
        w.u32(values.len() as u32);
        for &v in values {
            w.f64(v);
        }
    }
    w.u32(0);
    w.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::defs::definition_of;
    use crate::msg::Registry;

    #[test]
    fn the_messages_decode_with_their_definitions() {
        for (ty, data, field, want) in [
            (
                "nav_msgs/msg/Odometry",
                odometry(
                    7,
                    "odom",
                    [1.0, 2.0, 0.5],
                    0.01,
                    [0.4, 0.0, 0.0, 0.0, 0.0, 0.3],
                    0.0,
                ),
                "twist.twist.angular.z",
                0.3,
            ),
            (
                "sensor_msgs/msg/JointState",
                joint_state(7, &["l", "r"], &[], &[1.5, 2.5]),
                "velocity",
                2.5,
            ),
        ] {
            let (reg, root) =
                Registry::parse(ty, &definition_of(ty).unwrap(), Some(crate::defs::BUILTIN))
                    .unwrap();
            let v = reg.decode(root, &data).unwrap();
            let p = reg.resolve(root, field).unwrap();
            let got = match v.at(&p).unwrap() {
                crate::msg::Value::Nums(n) => n[n.len() - 1],
                x => x.as_f64().unwrap(),
            };
            assert_eq!(got, want);
        }
    }
}
