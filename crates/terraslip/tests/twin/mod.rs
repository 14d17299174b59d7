//! Synthetic twins of other robots' recordings: a robot's topic layout
//! (docs/figures/robots.md lists them with their sources) written as an
//! MCAP bag of a known drive.
#![allow(dead_code)]

use std::f64::consts::PI;
use std::path::Path;

use terraslip_ros2::defs::definition_of;
use terraslip_ros2::msg::{build, CdrWriter};
use terraslip_ros2::out::EstimateMcap;

pub const T0: u64 = 1_700_000_000_000_000_000;
pub const HZ: u64 = 20;
pub const SECONDS: u64 = 90;

/// The true motion at `t` s: forward speed (m/s), yaw rate (rad/s). Legs
/// of 8 s, each followed by a turn of 4 s; a spin in place at 40-44 s.
pub fn motion(t: f64) -> (f64, f64) {
    let v = 0.5 + 0.2 * (2.0 * PI * t / 7.0).sin();
    match t % 12.0 {
        _ if (40.0..44.0).contains(&t) => (0.0, 0.8),
        x if x >= 8.0 => (v, 0.4),
        _ => (v, 0.0),
    }
}

/// An odometry topic of the twin: its name, `header.frame_id`, and how it
/// is made (`lateral`: a lateral velocity, as a filter fusing an IMU has;
/// `yaw_scale`: its turn against the true one).
#[derive(Clone, Copy)]
pub struct Odom {
    pub topic: &'static str,
    pub frame: &'static str,
    pub lateral: f64,
    pub yaw_scale: f64,
}

/// JointState wheels: joint names and what is filled in.
#[derive(Clone, Copy)]
pub struct Joints {
    pub left: &'static str,
    pub right: &'static str,
    pub velocity: bool,
    pub position: bool,
    /// Positions wrapped into (-π, π].
    pub wrapped: bool,
    /// Stamps jittered by up to ± this many s; every 7th stamp repeated.
    pub jitter: f64,
}

#[derive(Clone, Default)]
pub struct Twin {
    pub odoms: Vec<Odom>,
    pub joints: Option<Joints>,
    pub imu: Option<&'static str>,
    /// The gyro's turn against the true one (a tracked vehicle's treads
    /// turn it less than their speed difference says).
    pub gyro_scale: f64,
    pub urdf: Option<&'static str>,
    /// Seconds recorded (0: [`SECONDS`]).
    pub seconds: u64,
    /// From this time on (s), the IMU lies on its left side (turned 90°
    /// about its x axis: gravity along +y, the yaw rate about -y).
    pub remounted_at: Option<f64>,
}

pub const WHEEL_R: f64 = 0.033;

pub fn write_twin(p: &Path, k: &Twin) {
    let mut m = EstimateMcap::create(p).unwrap();
    let ch = |m: &mut EstimateMcap, topic: &str, ty: &str| {
        m.channel(topic, ty, &definition_of(ty).unwrap()).unwrap()
    };
    let odoms: Vec<_> = k
        .odoms
        .iter()
        .map(|o| ch(&mut m, o.topic, "nav_msgs/msg/Odometry"))
        .collect();
    let js = k
        .joints
        .map(|_| ch(&mut m, "/joint_states", "sensor_msgs/msg/JointState"));
    let imu = k.imu.map(|t| ch(&mut m, t, "sensor_msgs/msg/Imu"));
    if let Some(u) = k.urdf {
        let c = ch(&mut m, "/robot_description", "std_msgs/msg/String");
        let mut w = CdrWriter::new();
        w.string(u);
        m.write(c, T0, &w.finish()).unwrap();
    }
    let sep = 0.3;
    let (mut x, mut y, mut yaw) = (0.0f64, 0.0f64, 0.0f64);
    let (mut ql, mut qr) = (1.0f64, -2.0f64);
    let dt = 1.0 / HZ as f64;
    let mut last_js = 0u64;
    let seconds = if k.seconds == 0 { SECONDS } else { k.seconds };
    for i in 0..seconds * HZ {
        let t = i as f64 * dt;
        let ns = T0 + i * (1_000_000_000 / HZ);
        let (v, wz) = motion(t);
        x += dt * v * yaw.cos();
        y += dt * v * yaw.sin();
        yaw += dt * wz;
        ql += dt * (v - wz * sep / 2.0) / WHEEL_R;
        qr += dt * (v + wz * sep / 2.0) / WHEEL_R;
        for (o, &c) in k.odoms.iter().zip(&odoms) {
            let twist = [v, o.lateral * wz, 0.0, 0.0, 0.0, wz * o.yaw_scale];
            let msg = build::odometry(ns, o.frame, [x, y, yaw], 0.01, twist, 0.01);
            m.write(c, ns, &msg).unwrap();
        }
        if let (Some(c), Some(j)) = (js, k.joints) {
            let jit = (j.jitter * 1e9 * ((i * 7919 % 13) as f64 / 6.0 - 1.0)) as i64;
            let stamp = if i % 7 == 3 {
                last_js
            } else {
                (ns as i64 + jit) as u64
            };
            last_js = stamp;
            let wrap = |a: f64| {
                if j.wrapped {
                    (a + PI).rem_euclid(2.0 * PI) - PI
                } else {
                    a
                }
            };
            let position = [wrap(ql), wrap(qr)];
            let velocity = [
                (v - wz * sep / 2.0) / WHEEL_R,
                (v + wz * sep / 2.0) / WHEEL_R,
            ];
            let msg = build::joint_state(
                stamp,
                &[j.left, j.right],
                if j.position { &position } else { &[] },
                if j.velocity { &velocity } else { &[] },
            );
            m.write(c, ns, &msg).unwrap();
        }
        if let Some(c) = imu {
            let mut w = CdrWriter::new();
            w.header(ns, "imu_link");
            let (sz, cz) = (yaw / 2.0).sin_cos();
            for c in [0.0, 0.0, sz, cz] {
                w.f64(c);
            }
            for _ in 0..9 {
                w.f64(0.0);
            }
            let side = k.remounted_at.is_some_and(|r| t >= r);
            // On its side, the sensor's (x, y, z) is the base's (x, -z, y).
            let on = |[x, y, z]: [f64; 3]| if side { [x, z, -y] } else { [x, y, z] };
            for c in on([0.0, 0.0, wz * k.gyro_scale]) {
                w.f64(c);
            }
            for _ in 0..9 {
                w.f64(0.0);
            }
            for c in on([0.0, v * wz, 9.81]) {
                w.f64(c);
            }
            for _ in 0..9 {
                w.f64(0.0);
            }
            m.write(c, ns, &w.finish()).unwrap();
        }
    }
    m.finish().unwrap();
}

/// A base driver's or drive controller's wheel odometry.
pub const fn wheel_odom(topic: &'static str) -> Odom {
    Odom {
        topic,
        frame: "odom",
        lateral: 0.0,
        yaw_scale: 1.0,
    }
}

/// A filter's fused odometry (robot_localization, a vendor's fusion node).
pub const fn filter_odom(topic: &'static str, frame: &'static str) -> Odom {
    Odom {
        topic,
        frame,
        lateral: 0.05,
        yaw_scale: 1.0,
    }
}

/// A TurtleBot 4's URDF (Create 3 base): its wheels on prismatic
/// wheel-drop joints, 0.233 m apart.
pub const TB4_URDF: &str = r#"<robot name="tb4">
  <link name="base_footprint"/><link name="base_link"/><link name="wheel_drop_left"/><link name="wheel_drop_right"/>
  <link name="left_wheel"/><link name="right_wheel"/>
  <joint name="base_joint" type="fixed"><parent link="base_footprint"/><child link="base_link"/><origin xyz="0 0 0.0061"/></joint>
  <joint name="wheel_drop_left_joint" type="prismatic"><parent link="base_link"/><child link="wheel_drop_left"/><origin xyz="0 0.1165 0.0402"/></joint>
  <joint name="wheel_drop_right_joint" type="prismatic"><parent link="base_link"/><child link="wheel_drop_right"/><origin xyz="0 -0.1165 0.0402"/></joint>
  <joint name="left_wheel_joint" type="continuous"><parent link="wheel_drop_left"/><child link="left_wheel"/><origin xyz="0 0 0" rpy="-1.5708 0 0"/></joint>
  <joint name="right_wheel_joint" type="continuous"><parent link="wheel_drop_right"/><child link="right_wheel"/><origin xyz="0 0 0" rpy="-1.5708 0 0"/></joint>
</robot>"#;
