//! Frames and orientations: unit quaternions, the static transform tree
//! between frames, and the headings they give.
//!
//! Quaternions are `[x, y, z, w]` (the ROS order) and rotate vectors from
//! the child frame into the parent: `v_parent = q v_child q*`. Frame names
//! follow REP-103 (base: x forward, y left, z up).

use std::collections::HashMap;

use super::config::HeadingConfig;

/// A unit quaternion `[x, y, z, w]`.
pub type Quat = [f64; 4];

pub const IDENTITY: Quat = [0.0, 0.0, 0.0, 1.0];

/// The rotation of roll, pitch, yaw (rad) about fixed x, y, z in that order,
/// `Rz(yaw) Ry(pitch) Rx(roll)`: the convention of URDF `<origin rpy>` and
/// `static_transform_publisher`.
pub fn from_rpy(roll: f64, pitch: f64, yaw: f64) -> Quat {
    let (sr, cr) = (roll / 2.0).sin_cos();
    let (sp, cp) = (pitch / 2.0).sin_cos();
    let (sy, cy) = (yaw / 2.0).sin_cos();
    [
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    ]
}

/// Roll, pitch, yaw (rad) of a rotation, the inverse of [`from_rpy`].
pub fn rpy_of(q: Quat) -> [f64; 3] {
    let [x, y, z, w] = q;
    let roll = (2.0 * (w * x + y * z)).atan2(1.0 - 2.0 * (x * x + y * y));
    let pitch = (2.0 * (w * y - z * x)).clamp(-1.0, 1.0).asin();
    let yaw = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z));
    [roll, pitch, yaw]
}

/// `a ⊗ b`: first `b`, then `a`.
pub fn mul(a: Quat, b: Quat) -> Quat {
    let [ax, ay, az, aw] = a;
    let [bx, by, bz, bw] = b;
    [
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ]
}

pub fn conj(q: Quat) -> Quat {
    [-q[0], -q[1], -q[2], q[3]]
}

/// `q`, scaled to unit length (`None` when it has none).
pub fn normalized(q: Quat) -> Option<Quat> {
    let n = q.iter().map(|a| a * a).sum::<f64>().sqrt();
    (n.is_finite() && n > 1e-9).then(|| q.map(|a| a / n))
}

/// `v` rotated by unit quaternion `q`.
pub fn rotate(q: Quat, v: [f64; 3]) -> [f64; 3] {
    let u = [q[0], q[1], q[2]];
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let t = cross(u, v).map(|c| 2.0 * c);
    let ut = cross(u, t);
    [
        v[0] + q[3] * t[0] + ut[0],
        v[1] + q[3] * t[1] + ut[1],
        v[2] + q[3] * t[2] + ut[2],
    ]
}

/// A frame name as tf2 compares them (no leading `/`).
fn frame(name: &str) -> &str {
    name.trim_start_matches('/')
}

/// The static transforms of a bag: each child frame's parent, the rotation
/// parent ← child and the child's origin in the parent, m.
#[derive(Debug, Clone, Default)]
pub struct StaticTf {
    parents: HashMap<String, (String, Quat, [f64; 3])>,
}

impl StaticTf {
    /// Adds the rotation `parent` ← `child` (the child's origin at the
    /// parent's); a later transform of the same child wins, as in tf2.
    pub fn add(&mut self, parent: &str, child: &str, q: Quat) {
        self.add_transform(parent, child, q, [0.0; 3]);
    }

    /// Adds `parent` ← `child`: rotation `q`, the child's origin at `origin`
    /// (m, parent frame).
    pub fn add_transform(&mut self, parent: &str, child: &str, q: Quat, origin: [f64; 3]) {
        self.parents.insert(
            frame(child).to_string(),
            (frame(parent).to_string(), q, origin),
        );
    }

    pub fn is_empty(&self) -> bool {
        self.parents.is_empty()
    }

    /// The rotation `base` ← `sensor` and the sensor's origin in `base` (m),
    /// following parents up from `sensor`; `None` when the chain does not
    /// reach `base`.
    pub fn transform(&self, base: &str, sensor: &str) -> Option<(Quat, [f64; 3])> {
        let (base, mut cur) = (frame(base), frame(sensor));
        let (mut q, mut p) = (IDENTITY, [0.0; 3]);
        for _ in 0..64 {
            if cur == base {
                return Some((q, p));
            }
            let (parent, r, t) = self.parents.get(cur)?;
            q = mul(*r, q);
            let rp = rotate(*r, p);
            p = [rp[0] + t[0], rp[1] + t[1], rp[2] + t[2]];
            cur = parent;
        }
        None
    }

    /// The rotation `base` ← `sensor` (see [`StaticTf::transform`]).
    pub fn rotation(&self, base: &str, sensor: &str) -> Option<Quat> {
        self.transform(base, sensor).map(|(q, _)| q)
    }
}

/// Yaw (rad, counter-clockwise about z) of a quaternion.
pub fn yaw_of(x: f64, y: f64, z: f64, w: f64) -> f64 {
    (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z))
}

/// The logged heading of an orientation: its yaw with the configured offset
/// and declination, wrapped.
pub(super) fn heading_yaw(h: &HeadingConfig, q: Quat) -> f64 {
    wrap(yaw_of(q[0], q[1], q[2], q[3]) + (h.yaw_offset_deg - h.declination_deg).to_radians())
}

/// An angle wrapped into (-π, π].
pub(super) fn wrap(a: f64) -> f64 {
    let mut a = a % std::f64::consts::TAU;
    if a > std::f64::consts::PI {
        a -= std::f64::consts::TAU;
    } else if a <= -std::f64::consts::PI {
        a += std::f64::consts::TAU;
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quaternion_yaw_and_wrap() {
        let a: f64 = 2.5;
        let (s, c) = (a / 2.0).sin_cos();
        assert!((yaw_of(0.0, 0.0, s, c) - a).abs() < 1e-12);
        assert!((wrap(3.0 * std::f64::consts::PI) - std::f64::consts::PI).abs() < 1e-12);
        assert!((wrap(-0.5) + 0.5).abs() < 1e-15);
    }

    #[test]
    fn a_chain_of_static_transforms_places_a_frame() {
        // base -> mast: 0.1 m ahead, 0.4 m up, yawed 90°; mast -> gps: 0.2 m
        // to the mast's right (base's forward), 0.3 m up.
        let mut tf = StaticTf::default();
        tf.add_transform(
            "base_link",
            "mast",
            from_rpy(0.0, 0.0, std::f64::consts::FRAC_PI_2),
            [0.1, 0.0, 0.4],
        );
        tf.add_transform("/mast", "gps_link", IDENTITY, [0.0, -0.2, 0.3]);
        let (_, p) = tf.transform("base_link", "gps_link").unwrap();
        for (a, b) in p.iter().zip([0.3, 0.0, 0.7]) {
            assert!((a - b).abs() < 1e-12, "{p:?}");
        }
        assert_eq!(
            tf.transform("base_link", "base_link"),
            Some((IDENTITY, [0.0; 3]))
        );
        assert!(tf.transform("odom", "gps_link").is_none());
    }
}
