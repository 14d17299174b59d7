//! What an import settled that its topics file left open (each stream's
//! topic, the tread speeds' scale, an IMU's mounting found from the data, a
//! heading left out), written back as the topics file that states it: the
//! live node decides on its warm-up window with `import`'s code, then reads
//! the graph with that file.

use super::config::{TopicsConfig, WheelsConfig};
use super::frames::{rpy_of, Quat};

/// The topic each stream was read from (`None`: none), with what was
/// decided about them.
pub(super) struct Streams<'a> {
    pub wheels: &'a str,
    /// The wheel settings the tread speeds were made with.
    pub wheels_cfg: &'a WheelsConfig,
    pub pose: Option<&'a str>,
    /// The heading topic, when it was read and kept.
    pub heading: Option<&'a str>,
    pub imu: Option<&'a str>,
    /// The IMU's mounting, when found from the data (`base ← sensor`).
    pub imu_mount: Option<Quat>,
    pub tf: Option<&'a str>,
}

/// `cfg` with every stream's topic named (`""`: none), the scale and a
/// mounting found from the data stated.
pub(super) fn topics_file(cfg: &TopicsConfig, s: &Streams) -> TopicsConfig {
    let named = |t: Option<&str>| Some(t.unwrap_or_default().to_string());
    let mut out = cfg.clone();
    out.wheels = s.wheels_cfg.clone();
    out.wheels.topic = Some(s.wheels.to_string());
    out.pose.topic = named(s.pose);
    out.heading.topic = named(s.heading);
    out.imu.topic = named(s.imu);
    out.tf.topic = named(s.tf);
    if let Some(q) = s.imu_mount {
        out.imu.mount_rpy_deg = Some(rpy_of(q).map(f64::to_degrees));
    }
    out
}
