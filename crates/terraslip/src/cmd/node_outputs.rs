//! What `terraslip node` publishes of the estimate: each row's odometry,
//! transform, ICRs, innovation and terrain, and once a second its
//! diagnostics; and the messages it could not read.

use std::collections::VecDeque;

use anyhow::Result;
use terraslip::pipeline::warmup::WarmUp;
use terraslip::pipeline::{EstimateRow, EstimateRun, PipelineError, RowSink};
use terraslip_node::{Graph, GraphTopic, Writer};
use terraslip_ros2::out::{diagnostics_message, estimate_messages, DiagnosticLevel};

/// Messages that could not be decoded: counted, the first few printed.
#[derive(Default)]
pub struct BadMessages {
    pub count: u64,
    pub last: Option<String>,
}

impl BadMessages {
    pub fn note(&mut self, e: &str) {
        self.count += 1;
        if self.count <= 5 {
            eprintln!("warning: message skipped: {e}");
        }
        self.last = Some(e.to_string());
    }
}

/// The node's publishers, fed the estimate rows.
pub struct Outputs {
    pub writers: Vec<Writer>,
    pub publish_tf: bool,
    pub frames: terraslip_ros2::out::Frames,
    pub origin_ns: u64,
    /// Tread speeds of the wheels rows not yet answered: `(t, left, right)`.
    pub wheels: VecDeque<(f64, f64, f64)>,
    pub last_terrain: Option<String>,
    pub last_t: Option<f64>,
    pub diagnostics_due: Option<f64>,
    pub published: u64,
    pub error: Option<anyhow::Error>,
    /// Whether the estimate is believed, for `--compensate`.
    pub belief: Option<terraslip::belief::Belief>,
    /// What the warm-up settled about the streams (with no topics file:
    /// each stream's topic, the scale, the mountings), one line each.
    pub settled: Vec<String>,
    /// Decisions made from the data and made again when later windows
    /// contradicted them, one line each.
    pub revisited: Vec<String>,
}

/// Topics every ROS 2 node writes (this one too, through its parameter
/// services and log): never a sensor stream, so never listed as one.
pub const ROS_NODE_TOPICS: [&str; 2] = ["/parameter_events", "/rosout"];

/// Whether the graph's `topic` is one this node writes (its outputs, the
/// compensated command pair `cmd_topics`) or one every node writes: not a
/// sensor topic to choose from or to list as found.
pub fn is_ours(topic: &str, cmd_topics: Option<&(String, String)>) -> bool {
    OUTPUT_TOPICS.iter().any(|o| o.0 == topic)
        || ROS_NODE_TOPICS.contains(&topic)
        || cmd_topics.is_some_and(|(i, o)| i == topic || o == topic)
}

pub const OUTPUT_TOPICS: [(&str, &str); 6] = [
    ("/terraslip/odom", "nav_msgs/msg/Odometry"),
    ("/tf", "tf2_msgs/msg/TFMessage"),
    ("/terraslip/icr", terraslip_ros2::out::ICR_TYPE),
    (
        "/terraslip/innovation",
        terraslip_ros2::out::INNOVATION_TYPE,
    ),
    ("/terraslip/terrain", "std_msgs/msg/String"),
    ("/diagnostics", "diagnostic_msgs/msg/DiagnosticArray"),
];

impl Outputs {
    pub fn new(
        graph: &Graph,
        publish_tf: bool,
        frames: terraslip_ros2::out::Frames,
    ) -> Result<Self> {
        let mut writers = Vec::new();
        for (name, ty) in OUTPUT_TOPICS {
            if name == "/tf" && !publish_tf {
                continue;
            }
            writers.push(graph.writer(&GraphTopic {
                name: name.into(),
                ty: ty.into(),
            })?);
        }
        Ok(Self {
            writers,
            publish_tf,
            frames,
            origin_ns: 0,
            wheels: VecDeque::new(),
            last_terrain: None,
            last_t: None,
            diagnostics_due: None,
            published: 0,
            error: None,
            belief: None,
            settled: Vec::new(),
            revisited: Vec::new(),
        })
    }

    /// Publishes odom -> base_link on /tf from the next estimate on (`on`),
    /// or stops; the /tf writer is made when first needed.
    pub fn set_publish_tf(&mut self, graph: &Graph, on: bool) -> Result<()> {
        if on && !self.writers.iter().any(|w| w.topic.name == "/tf") {
            let (name, ty) = OUTPUT_TOPICS[1];
            self.writers.push(graph.writer(&GraphTopic {
                name: name.into(),
                ty: ty.into(),
            })?);
        }
        self.publish_tf = on;
        Ok(())
    }

    pub fn send(&self, topic: &str, data: Vec<u8>) -> Result<()> {
        if let Some(w) = self.writers.iter().find(|w| w.topic.name == topic) {
            w.write(data)?;
        }
        Ok(())
    }

    pub fn stamp(&self, t: f64) -> u64 {
        (self.origin_ns as i128 + (t * 1e9).round() as i128).max(0) as u64
    }

    /// A publishing error met inside the sink, now.
    pub fn failed(&mut self) -> Result<()> {
        match self.error.take() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    pub fn diagnostics(&self, run: &EstimateRun, live: &WarmUp, bad: &BadMessages) -> Result<()> {
        let Some(t) = self.last_t else { return Ok(()) };
        let p = run.final_icr;
        let f = |x: f64| format!("{x:.6}");
        let mut values: Vec<(String, String)> = vec![
            ("y_l_m".into(), f(p.y_l)),
            ("y_r_m".into(), f(p.y_r)),
            ("x_c_m".into(), f(p.x_c)),
            ("alpha_l".into(), f(p.alpha_l)),
            ("alpha_r".into(), f(p.alpha_r)),
            ("turn_law_s_per_m".into(), f(run.turn_law.0)),
            ("pose_noise_std_xy_m".into(), f(run.noise.std_xy)),
            ("pose_noise_std_yaw_rad".into(), f(run.noise.std_yaw)),
            ("clock_offset_s".into(), f(run.clock_offset.0)),
            ("gyro_delay_s".into(), f(run.gyro_delay)),
            ("rows".into(), run.row_count.to_string()),
            ("fixes_used".into(), run.stats.fixes_used.to_string()),
            ("late_samples".into(), format!("{:?}", live.late())),
            ("held_samples".into(), live.held().to_string()),
            ("bad_messages".into(), bad.count.to_string()),
        ];
        if let Some(e) = &bad.last {
            values.push(("last_bad_message".into(), e.clone()));
        }
        for (k, line) in live
            .decisions()
            .map(|d| d.lines())
            .unwrap_or_default()
            .into_iter()
            .enumerate()
        {
            values.push((format!("decided_{k}"), line));
        }
        for (k, line) in self.settled.iter().enumerate() {
            values.push((format!("streams_{k}"), line.clone()));
        }
        for (k, line) in self.revisited.iter().enumerate() {
            values.push((format!("revisited_{k}"), line.clone()));
        }
        for (k, w) in run.warnings.iter().enumerate() {
            values.push((format!("warning_{k}"), w.clone()));
        }
        let (level, message) = if run.warnings.is_empty() && bad.count == 0 {
            (DiagnosticLevel::Ok, "estimating".to_string())
        } else {
            (
                DiagnosticLevel::Warn,
                run.warnings
                    .first()
                    .cloned()
                    .unwrap_or_else(|| format!("{} messages could not be read", bad.count)),
            )
        };
        let m = diagnostics_message(
            self.stamp(t),
            "terraslip: slip estimator",
            level,
            &message,
            &values,
        );
        self.send(m.topic, m.data)
    }
}

impl RowSink for Outputs {
    fn row(&mut self, terrains: &[String], r: &EstimateRow) -> Result<(), PipelineError> {
        while self.wheels.front().is_some_and(|w| w.0 < r.t) {
            self.wheels.pop_front();
        }
        let w = self
            .wheels
            .front()
            .filter(|w| w.0 == r.t)
            .map(|w| (w.1, w.2));
        let s = super::ros2out::sample(r, self.stamp(r.t), w);
        let terrain = r.terrain.and_then(|k| terrains.get(k)).map(String::as_str);
        for m in estimate_messages(&s, &self.frames, terrain, &mut self.last_terrain) {
            if m.topic == "/tf" && !self.publish_tf {
                continue;
            }
            if let Err(e) = self.send(m.topic, m.data) {
                self.error.get_or_insert(e);
            }
        }
        if let Some(b) = &mut self.belief {
            b.row(r, terrains);
        }
        self.published += 1;
        self.last_t = Some(r.t);
        Ok(())
    }
}

#[cfg(test)]
mod graph_tests {
    use super::is_ours;

    #[test]
    fn the_topics_every_node_writes_are_not_sensor_candidates() {
        let cmd = ("/cmd_vel_nav".to_string(), "/cmd_vel".to_string());
        for topic in [
            "/parameter_events",
            "/rosout",
            "/terraslip/odom",
            "/cmd_vel",
        ] {
            assert!(is_ours(topic, Some(&cmd)), "{topic}");
        }
        for topic in ["/odom", "/imu/data", "/fix", "/joint_states"] {
            assert!(!is_ours(topic, Some(&cmd)), "{topic}");
        }
        assert!(!is_ours("/cmd_vel", None));
    }
}
