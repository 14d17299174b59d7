//! `terraslip node`: the online estimator on a live ROS 2 graph (RustDDS,
//! no ROS install). Topics are read as `import` reads a bag's, the samples
//! put back in stamp order by the live pipeline, and each estimate row
//! published as `estimate --mcap` writes it.

use std::collections::VecDeque;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant, SystemTime};

use anyhow::{bail, Context, Result};
use terraslip::pipeline::decide::Decisions;
use terraslip::pipeline::live::Sample;
use terraslip::pipeline::warmup::WarmUp;
use terraslip::pipeline::{EstimateRow, EstimateRun, PipelineError, RowSink};
use terraslip_io::ParamsFile;
use terraslip_node::{Graph, GraphTopic, RosArgs, RosEnv, TopicQos, Wait, Writer};
use terraslip_ros2::import::{LiveImport, LiveRow};
use terraslip_ros2::out::{diagnostics_message, estimate_messages, DiagnosticLevel};

/// Run the online estimator as a ROS 2 node on the live graph.
///
/// Joins the ROS 2 graph (domain ROS_DOMAIN_ID; ROS_LOCALHOST_ONLY=1 or
/// ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST keep it on this host) with no
/// ROS install, picks the wheel, pose, heading and IMU topics as `import`
/// picks a bag's (by type when unique, or from --topics), and publishes for
/// each wheels message /terraslip/odom (nav_msgs/Odometry with covariance,
/// odom -> base_link), /tf, /terraslip/icr, /terraslip/innovation,
/// /terraslip/terrain, and once a second /diagnostics (learned parameters,
/// pose noise, clock offset, warnings). All timing comes from the header
/// stamps: samples wait --lag seconds of stamp time for late ones, so a
/// recording played in gives what `terraslip estimate` gives of it.
///
/// The first --warmup seconds of stamp time are held back while the node
/// decides what `estimate` decides from a recording's start (the gyro's
/// delay, whether it is the yaw rate, the slip parameters the sensors can
/// teach; each printed as a `decided:` line), then answered.
///
/// The learned parameters are written (atomically) to --params (default:
/// the user's state directory) at the end (SIGINT, SIGTERM) and every
/// --save-every seconds of drive; the next start recalls them from there
/// (--fresh: not).
#[derive(clap::Args, Debug)]
#[command(after_help = AFTER_HELP)]
pub struct Args {
    #[command(flatten)]
    pub estimator: super::estimate::EstimatorArgs,
    /// The node's parameters file: recalled at start when it exists (unless
    /// --init or --fresh is given), written at the end and every
    /// --save-every s [default: $XDG_STATE_HOME/terraslip/NODE_NAME.json,
    /// else ~/.local/state/terraslip/NODE_NAME.json].
    #[arg(long, value_name = "FILE")]
    pub params: Option<PathBuf>,
    /// Start clean: do not recall the parameters file (it is still written).
    #[arg(long)]
    pub fresh: bool,
    /// Seconds of stamp time held back at the start to decide from, as
    /// `estimate` decides from a recording's first 300 s; the held samples
    /// are answered once decided.
    #[arg(long, value_name = "S", default_value_t = terraslip::pipeline::DECISION_SPAN)]
    pub warmup: f64,
    /// Seconds of drive (stamp time) between writes of --params.
    #[arg(long, value_name = "S", default_value_t = 300.0)]
    pub save_every: f64,
    /// Seconds of stamp time a sample waits for earlier ones of other topics.
    #[arg(long, value_name = "S", default_value_t = 0.3)]
    pub lag: f64,
    /// Track width, m (else `[meta] track_width` of --topics, else the
    /// configuration's `init.default_track_width`).
    #[arg(long, value_name = "M")]
    pub track_width: Option<f64>,
    /// How late the wheels are stamped against the gyro, s (else what the
    /// warm-up finds, else --init's or --params' `gyro_delay_s`, else 0;
    /// `estimate` reports it as `gyro.wheels_late_by_s`).
    #[arg(long, value_name = "S")]
    pub gyro_delay: Option<f64>,
    /// Do not publish odom -> base_link on /tf (when another node does).
    #[arg(long)]
    pub no_tf: bool,
    /// The odometry's fixed frame (REP-105): header of /terraslip/odom and
    /// parent of the published transform.
    #[arg(long, value_name = "FRAME", default_value = "odom")]
    pub odom_frame: String,
    /// The robot's body frame (REP-105): child frame of /terraslip/odom
    /// (the twist's frame) and of the published transform.
    #[arg(long, value_name = "FRAME", default_value = "base_link")]
    pub base_frame: String,
    /// Node name.
    #[arg(long, default_value = "terraslip")]
    pub name: String,
    /// Seconds (wall clock) to wait for the sensor topics to be discovered
    /// before each new look at the graph.
    #[arg(long, value_name = "S", default_value_t = 2.0)]
    pub discovery_wait: f64,
    /// End after this many seconds (wall clock) without a message, once
    /// messages came (for replays; default: run until SIGINT/SIGTERM).
    #[arg(long, value_name = "S")]
    pub idle_exit: Option<f64>,
}

const AFTER_HELP: &str = "\
ROS 2 conventions: --ros-args after the node's own flags takes -r from:=to
(remaps of the topics named in --topics, a remap matching none of them is
warned of; and __node:=, __ns:=), -p name:=value
and --params-file FILE.yaml (`ros__parameters` of /** or of the node). The
parameters lag, save_every, track_width, gyro_delay, odom_frame, base_frame,
publish_tf (bool) set the flags of the same name; any other is a key of the TOML configuration
(`filter.still_speed` is [filter] still_speed).

Examples:
  terraslip node --topics husky.toml
  terraslip node --topics husky.toml --params /var/lib/terraslip/params.json
  terraslip node --topics husky.toml --fresh --warmup 60
  terraslip node --topics husky.toml --ros-args -p lag:=0.5 -r __node:=husky_slip
  ROS_DOMAIN_ID=7 ROS_LOCALHOST_ONLY=1 terraslip node --no-tf

docs/user-guide.md \"Live on the robot\" has a launch file, a systemd unit and
the Foxglove view.";

/// Parameters of the node itself (the rest are configuration keys).
const NODE_PARAMS: [&str; 7] = [
    "lag",
    "save_every",
    "track_width",
    "gyro_delay",
    "publish_tf",
    "odom_frame",
    "base_frame",
];

pub fn run(mut args: Args, ros_args: &[String]) -> Result<()> {
    let ros = RosArgs::parse(ros_args, &args.name)?;
    let name = ros.node_name.clone().unwrap_or_else(|| args.name.clone());
    let namespace = ros.namespace.clone().unwrap_or_else(|| "/".into());
    let mut table = ros.params_table();
    apply_node_params(&mut args, &mut table)?;
    let params_path = match &args.params {
        Some(p) => p.clone(),
        None => super::node_state::default_path_from_env(&name)?,
    };
    let mut cfg = args.estimator.load()?;
    if !table.is_empty() {
        cfg = with_params(cfg, &table)?;
    }
    super::inputs_with(
        &[],
        &[
            ("--init", args.estimator.init.as_deref()),
            args.estimator.input(),
        ],
    )
    .check("--params", &params_path)?;
    let recall = args.estimator.init.is_none() && !args.fresh && params_path.is_file();
    let start = match &args.estimator.init {
        Some(p) => Some(ParamsFile::read(p).with_context(|| "--init")?),
        None if recall => {
            let pf = ParamsFile::read(&params_path).with_context(|| "--params")?;
            eprintln!("{}", super::node_state::recalled(&params_path, &pf));
            Some(pf)
        }
        None => None,
    };
    let driven_before = super::node_state::driven(start.as_ref().filter(|_| recall));
    let mut topics_cfg = super::bag::topics().config()?;
    warn_unmatched_remaps(&ros, &topics_cfg);
    for t in [
        &mut topics_cfg.wheels.topic,
        &mut topics_cfg.pose.topic,
        &mut topics_cfg.heading.topic,
        &mut topics_cfg.imu.topic,
        &mut topics_cfg.tf.topic,
    ] {
        if let Some(n) = t.as_mut().filter(|n| !n.is_empty()) {
            *n = ros.remap(n);
        }
    }
    // As `estimate` starts: the track width, else the separation the
    // tread speeds are made with (the controller's own scale).
    let track_width = args
        .track_width
        .or(topics_cfg.meta.track_width)
        .or(topics_cfg
            .wheels
            .separation
            .filter(|s| s.is_finite() && *s > 0.0))
        .unwrap_or(cfg.init.default_track_width);
    let recalled_delay = start
        .as_ref()
        .and_then(|p| p.extra.get("gyro_delay_s")?.as_f64());

    let stop = terraslip_node::signals::Stop::install().context("signal handlers")?;
    let env = RosEnv::from_env()?;
    let graph = Graph::join(&name, &namespace, env)?;
    let label = format!(
        "ROS 2 graph (domain {}, {})",
        env.domain_id,
        terraslip_node::DISTRO
    );
    eprintln!(
        "node {}/{name} joined domain {} ({:?} discovery, built for {}); looking for the sensor topics",
        namespace.trim_end_matches('/'),
        env.domain_id,
        env.range,
        terraslip_node::DISTRO
    );

    // The streams, once the graph shows them.
    let mut said = String::new();
    let (topics, mut import) = loop {
        if stop.asked() {
            return Ok(());
        }
        std::thread::sleep(Duration::from_secs_f64(args.discovery_wait.max(0.1)));
        // Topics someone writes, other than ours.
        let found: Vec<GraphTopic> = graph
            .topics()
            .into_iter()
            .filter(|(t, writers)| *writers > 0 && !OUTPUT_TOPICS.iter().any(|o| o.0 == t.name))
            .map(|(t, _)| t)
            .collect();
        let bag_topics: Vec<terraslip_ros2::Topic> = found
            .iter()
            .map(|t| terraslip_ros2::Topic {
                name: t.name.clone(),
                ty: t.ty.clone(),
                definition: String::new(),
                count: 0,
            })
            .collect();
        match LiveImport::new(&label, bag_topics, &topics_cfg) {
            Ok(i) => break (found, i),
            Err(e) => {
                let e = e.to_string();
                if e != said {
                    eprintln!("waiting: {e}");
                    said = e;
                }
            }
        }
    };
    let mut readers = Vec::new();
    for (t, roles) in import.subscriptions() {
        let gt = GraphTopic {
            name: t.name.clone(),
            ty: t.ty.clone(),
        };
        let qos = if roles == ["tf"] {
            TopicQos::Latched
        } else {
            TopicQos::Sensor
        };
        let idx = topics
            .iter()
            .position(|x| *x == gt)
            .context("a chosen topic vanished")?;
        eprintln!("reading {} ({}) for {}", gt.name, gt.ty, roles.join(", "));
        readers.push((idx, graph.reader(&gt, qos)?, 0u64, qos));
    }
    let mut wait = Wait::new().context("event poll")?;
    for (k, r) in readers.iter_mut().enumerate() {
        wait.register(&mut r.1, k).context("event poll")?;
    }

    let mut live = WarmUp::new(
        &label,
        &cfg,
        track_width,
        start,
        args.lag,
        args.warmup,
        args.gyro_delay,
        recalled_delay,
    )?;
    eprintln!(
        "warming up: the first {} s of stamp time are held back to decide from",
        args.warmup
    );
    let frames = terraslip_ros2::out::Frames {
        odom: args.odom_frame.clone(),
        base: args.base_frame.clone(),
    };
    let mut out = Outputs::new(&graph, !args.no_tf, frames)?;
    let mut bad = BadMessages::default();
    let subscribed = Instant::now();
    let mut warned_unmatched = false;
    let mut last_message: Option<Instant> = None;
    let mut next_save: Option<f64> = None;
    loop {
        let mut got = false;
        // What every reader holds, put in stamp order before it goes on:
        // after a stall (the warm-up's rows being published) one topic's
        // backlog must not push the others' past the lag.
        let mut batch: Vec<LiveRow> = Vec::new();
        for (idx, reader, count, _) in readers.iter_mut() {
            while let Some((raw, source_ns)) = reader.take()? {
                got = true;
                *count += 1;
                let recv_ns = if source_ns > 0 { source_ns } else { now_ns() };
                match import.message(*idx, recv_ns, &raw.0) {
                    Ok(rows) => batch.extend(rows),
                    Err(e) => bad.note(&e.to_string()),
                }
            }
        }
        out.origin_ns = import.origin_ns().unwrap_or(0);
        batch.sort_by(|a, b| a.t().total_cmp(&b.t()));
        for r in batch {
            let s = match r {
                LiveRow::Wheels(w) => {
                    out.wheels.push_back((w.t, w.v_left, w.v_right));
                    Sample::Wheels(w)
                }
                LiveRow::Pose(p) => Sample::Pose(p),
                LiveRow::Imu(i) => Sample::Imu(i),
            };
            if let Some(d) = live.push(s, &mut out)? {
                say_decided(&d);
            }
        }
        if got {
            last_message = Some(Instant::now());
        }
        out.failed()?;
        // Diagnostics once a second and the parameters every
        // --save-every s, of stamp time.
        if let (Some(t), Some(summary)) = (out.last_t, live.summary()) {
            if out.diagnostics_due.is_none_or(|d| t >= d) {
                out.diagnostics_due = Some(t + 1.0);
                out.diagnostics(&summary, &live, &bad)?;
            }
            let due = *next_save.get_or_insert(t + args.save_every);
            if t >= due {
                next_save = Some(t + args.save_every);
                save(&params_path, &summary, driven_before, &live)?;
            }
        }
        if !warned_unmatched && subscribed.elapsed() > Duration::from_secs(5) {
            warned_unmatched = true;
            for (idx, reader, count, qos) in &readers {
                if *count == 0 {
                    let t = &topics[*idx];
                    let why = graph.unmatchable_writers(&t.name, &t.ty, *qos);
                    eprintln!(
                        "warning: {} ({}): no message in 5 s{}",
                        reader.topic.name,
                        t.ty,
                        if why.is_empty() {
                            String::new()
                        } else {
                            format!(": writers that cannot match: {}", why.join("; "))
                        }
                    );
                }
            }
        }
        let idle = last_message.map_or(Duration::ZERO, |m| m.elapsed());
        if stop.asked() || args.idle_exit.is_some_and(|s| idle.as_secs_f64() > s) {
            break;
        }
        if !got {
            wait.wait(Duration::from_millis(100))
                .context("event poll")?;
        }
    }
    if let Some(d) = live.flush(&mut out)? {
        say_decided(&d);
    }
    out.failed()?;
    let saved = match live.summary() {
        Some(summary) => {
            out.diagnostics(&summary, &live, &bad)?;
            save(&params_path, &summary, driven_before, &live)?
        }
        None => false,
    };
    eprintln!(
        "node: {} estimates published, {} bad messages, late samples {:?}; {}",
        out.published,
        bad.count,
        live.late(),
        if saved {
            format!("parameters saved to {}", params_path.display())
        } else {
            format!(
                "no estimate made, so no parameters saved ({} unchanged)",
                params_path.display()
            )
        }
    );
    Ok(())
}

/// Moves the node's own parameters out of `table` into `args`.
fn apply_node_params(args: &mut Args, table: &mut toml::Table) -> Result<()> {
    for key in NODE_PARAMS {
        let Some(v) = table.remove(key) else { continue };
        let num = || {
            v.as_float()
                .or(v.as_integer().map(|i| i as f64))
                .with_context(|| format!("--ros-args parameter {key} = {v}: expected a number"))
        };
        match key {
            "lag" => args.lag = num()?,
            "save_every" => args.save_every = num()?,
            "track_width" => args.track_width = Some(num()?),
            "gyro_delay" => args.gyro_delay = Some(num()?),
            "odom_frame" | "base_frame" => {
                let frame = v
                    .as_str()
                    .filter(|f| !f.is_empty())
                    .with_context(|| {
                        format!("--ros-args parameter {key} = {v}: expected a frame name")
                    })?
                    .to_string();
                if key == "odom_frame" {
                    args.odom_frame = frame;
                } else {
                    args.base_frame = frame;
                }
            }
            "publish_tf" => {
                args.no_tf = !v.as_bool().with_context(|| {
                    format!("--ros-args parameter publish_tf = {v}: expected true or false")
                })?
            }
            _ => {}
        }
    }
    if !(args.lag.is_finite() && args.lag >= 0.0) {
        bail!("lag = {}: expected seconds >= 0", args.lag);
    }
    if !(args.save_every.is_finite() && args.save_every > 0.0) {
        bail!("save_every = {}: expected seconds > 0", args.save_every);
    }
    Ok(())
}

/// Writes the learned parameters atomically, with the decisions; `false`
/// when there is nothing to save yet.
fn save(path: &Path, run: &EstimateRun, driven_before: f64, live: &WarmUp) -> Result<bool> {
    let decided = live.decisions().map(|d| d.to_json());
    super::node_state::save(path, run, driven_before, decided)
}

/// Prints the warm-up's decisions.
fn say_decided(d: &Decisions) {
    for line in d.lines() {
        eprintln!("decided: {line}");
    }
}

/// The configuration with the `--ros-args` parameters that are not the
/// node's own over it; an unknown name's error lists the node's own too.
fn with_params(
    cfg: terraslip::config::EstimatorConfig,
    table: &toml::Table,
) -> Result<terraslip::config::EstimatorConfig> {
    let text = toml::to_string(table).context("--ros-args parameters")?;
    let cfg = terraslip::estimate::overlay(cfg, &text, "--ros-args parameters").with_context(|| {
        format!(
            "the node's own parameters are {}; any other name is a key of the configuration (`terraslip estimate --print-config`)",
            NODE_PARAMS.join(", ")
        )
    })?;
    cfg.validate()?;
    Ok(cfg)
}

/// Warns of each `-r` remap that names no topic the topics file names.
fn warn_unmatched_remaps(ros: &RosArgs, topics: &terraslip_ros2::TopicsConfig) {
    for w in unmatched_remaps(ros, topics) {
        eprintln!("warning: {w}");
    }
}

/// The `-r` remaps that name no topic the topics file names (only those
/// are remapped; a topic chosen by its type is not), each explained.
fn unmatched_remaps(ros: &RosArgs, topics: &terraslip_ros2::TopicsConfig) -> Vec<String> {
    let named: Vec<&str> = [
        &topics.wheels.topic,
        &topics.pose.topic,
        &topics.heading.topic,
        &topics.imu.topic,
        &topics.tf.topic,
    ]
    .into_iter()
    .filter_map(|t| t.as_deref().filter(|n| !n.is_empty()))
    .collect();
    ros.remaps
        .iter()
        .filter(|(from, _)| !named.iter().any(|n| ros_matches(from, n)))
        .map(|(from, to)| {
            format!(
                "--ros-args -r {from}:={to} matches no topic this node reads: remaps apply to the topics the topics file names ({}); name the topic there (`[wheels] topic = \"{from}\"`) to remap it",
                if named.is_empty() {
                    "it names none".to_string()
                } else {
                    named.join(", ")
                }
            )
        })
        .collect()
}

/// Whether remap source `from` names `topic` (with or without the
/// leading slash), as [`RosArgs::remap`] matches.
fn ros_matches(from: &str, topic: &str) -> bool {
    RosArgs {
        remaps: vec![(from.to_string(), String::new())],
        ..Default::default()
    }
    .remap(topic)
    .is_empty()
}

fn now_ns() -> u64 {
    SystemTime::now()
        .duration_since(SystemTime::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64)
}

/// Messages that could not be decoded: counted, the first few printed.
#[derive(Default)]
struct BadMessages {
    count: u64,
    last: Option<String>,
}

impl BadMessages {
    fn note(&mut self, e: &str) {
        self.count += 1;
        if self.count <= 5 {
            eprintln!("warning: message skipped: {e}");
        }
        self.last = Some(e.to_string());
    }
}

/// The node's publishers, fed the estimate rows.
struct Outputs {
    writers: Vec<Writer>,
    publish_tf: bool,
    frames: terraslip_ros2::out::Frames,
    origin_ns: u64,
    /// Tread speeds of the wheels rows not yet answered: `(t, left, right)`.
    wheels: VecDeque<(f64, f64, f64)>,
    last_terrain: Option<String>,
    last_t: Option<f64>,
    diagnostics_due: Option<f64>,
    published: u64,
    error: Option<anyhow::Error>,
}

const OUTPUT_TOPICS: [(&str, &str); 6] = [
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
    fn new(graph: &Graph, publish_tf: bool, frames: terraslip_ros2::out::Frames) -> Result<Self> {
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
        })
    }

    fn send(&self, topic: &str, data: Vec<u8>) -> Result<()> {
        if let Some(w) = self.writers.iter().find(|w| w.topic.name == topic) {
            w.write(data)?;
        }
        Ok(())
    }

    fn stamp(&self, t: f64) -> u64 {
        (self.origin_ns as i128 + (t * 1e9).round() as i128).max(0) as u64
    }

    /// A publishing error met inside the sink, now.
    fn failed(&mut self) -> Result<()> {
        match self.error.take() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    fn diagnostics(&self, run: &EstimateRun, live: &WarmUp, bad: &BadMessages) -> Result<()> {
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
        self.published += 1;
        self.last_t = Some(r.t);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_remap_that_matches_no_named_topic_is_named() {
        let topics: terraslip_ros2::TopicsConfig =
            toml::from_str("[wheels]\nseparation = 1.04\n[imu]\ntopic = \"/imu/data\"\n").unwrap();
        let ros = RosArgs::parse(
            &[
                "-r".into(),
                "/odom:=/husky_velocity_controller/odom".into(),
                "-r".into(),
                "imu/data:=/imu2".into(),
            ],
            "terraslip",
        )
        .unwrap();
        let w = unmatched_remaps(&ros, &topics);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(
            w[0].contains("/odom:=") && w[0].contains("/imu/data"),
            "{}",
            w[0]
        );
    }

    #[test]
    fn an_unknown_parameter_lists_the_nodes_own() {
        let mut table = toml::Table::new();
        table.insert("lagg".into(), toml::Value::Float(0.5));
        let e = with_params(Default::default(), &table).unwrap_err();
        let text = format!("{e:#}");
        assert!(text.contains("lagg"), "{text}");
        for p in NODE_PARAMS {
            assert!(text.contains(p), "{p} missing from: {text}");
        }
    }
}
