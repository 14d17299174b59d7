//! The flags and ROS parameters of `terraslip node`: the command line,
//! `--ros-args -p` parameters moved onto the flags, the rest overlaid on
//! the estimator's configuration, and the remaps checked against the
//! topics the node reads.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use terraslip_node::RosArgs;

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
#[derive(clap::Args, Debug, Clone)]
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
    #[arg(long, value_name = "S", default_value_t = terraslip::pipeline::warmup::LAG)]
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
    /// What the pose reference is: `gnss` (part of its error wanders
    /// slowly) or `localiser` (lidar or visual localisation, motion
    /// capture: no wandering error); else the topics file's `[meta]
    /// pose_reference`, else taken to wander as a GNSS's does.
    #[arg(long, value_name = "KIND")]
    pub pose_reference: Option<terraslip_io::PoseReference>,
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
    #[command(flatten)]
    pub compensate: super::node_compensate::CompensateArgs,
}

const AFTER_HELP: &str = "\
ROS 2 conventions: --ros-args after the node's own flags takes -r from:=to
(remaps of the topics named in --topics, a remap matching none of them is
warned of; and __node:=, __ns:=), -p name:=value
and --params-file FILE.yaml (`ros__parameters` of /** or of the node). The
parameters lag, save_every, track_width, gyro_delay, pose_reference,
odom_frame, base_frame, publish_tf (bool) and those of --compensate (compensate, max_speed,
wheel_separation, ...) set the flags of the same name; any other is a key of
the TOML configuration (`filter.still_speed` is [filter] still_speed).
The node's own parameters are also served to `ros2 param list/get/set`:
save_every, publish_tf, the frames and the compensation's limits change
while it runs; the others are read at start only.

--compensate reads the desired twist on cmd_vel_nav and answers each with the
command for the drive controller on cmd_vel (remap both with -r, e.g.
-r cmd_vel_nav:=/cmd_vel_smoothed -r cmd_vel:=/diff_drive_controller/cmd_vel).

Examples:
  terraslip node --topics husky.toml
  terraslip node --topics husky.toml --params /var/lib/terraslip/params.json
  terraslip node --topics husky.toml --fresh --warmup 60
  terraslip node --topics husky.toml --ros-args -p lag:=0.5 -r __node:=husky_slip
  ROS_DOMAIN_ID=7 ROS_LOCALHOST_ONLY=1 terraslip node --no-tf
  terraslip node --topics husky.toml --compensate --max-speed 1.0 --max-yaw-rate 2.0

docs/user-guide.md \"Live on the robot\" has a launch file, a systemd unit and
the Foxglove view.";

/// Parameters of the node itself (the rest are configuration keys).
pub const NODE_PARAMS: [&str; 8] = [
    "lag",
    "save_every",
    "track_width",
    "gyro_delay",
    "pose_reference",
    "publish_tf",
    "odom_frame",
    "base_frame",
];

/// Moves the node's own parameters out of `table` into `args`.
pub fn apply_node_params(args: &mut Args, table: &mut toml::Table) -> Result<()> {
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
            "pose_reference" => {
                let kind = v.as_str().with_context(|| {
                    format!("--ros-args parameter pose_reference = {v}: expected gnss or localiser")
                })?;
                args.pose_reference =
                    Some(kind.parse().map_err(|e| {
                        anyhow::anyhow!("--ros-args parameter pose_reference: {e}")
                    })?);
            }
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
    for key in super::node_compensate::PARAMS {
        if let Some(v) = table.remove(key) {
            args.compensate.apply(key, &v)?;
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

/// The configuration with the `--ros-args` parameters that are not the
/// node's own over it; an unknown name's error lists the node's own too.
pub fn with_params(
    cfg: terraslip::config::EstimatorConfig,
    table: &toml::Table,
) -> Result<terraslip::config::EstimatorConfig> {
    let text = toml::to_string(table).context("--ros-args parameters")?;
    let cfg = terraslip::estimate::overlay(cfg, &text, "--ros-args parameters").with_context(|| {
        format!(
            "the node's own parameters are {}; any other name is a key of the configuration (`terraslip estimate --print-config`)",
            NODE_PARAMS
                .iter()
                .chain(super::node_compensate::PARAMS.iter())
                .copied()
                .collect::<Vec<_>>()
                .join(", ")
        )
    })?;
    cfg.validate()?;
    Ok(cfg)
}

/// Warns of each `-r` remap that names no topic the topics file names nor
/// one of `also` (the command topics, when compensating).
pub fn warn_unmatched_remaps(ros: &RosArgs, topics: &terraslip_ros2::TopicsConfig, also: &[&str]) {
    for w in unmatched_remaps(ros, topics, also) {
        eprintln!("warning: {w}");
    }
}

/// The `-r` remaps that name no topic the topics file names (only those
/// are remapped; a topic chosen by its type is not), each explained.
fn unmatched_remaps(
    ros: &RosArgs,
    topics: &terraslip_ros2::TopicsConfig,
    also: &[&str],
) -> Vec<String> {
    let named: Vec<&str> = [
        &topics.wheels.topic,
        &topics.pose.topic,
        &topics.heading.topic,
        &topics.imu.topic,
        &topics.tf.topic,
    ]
    .into_iter()
    .filter_map(|t| t.as_deref().filter(|n| !n.is_empty()))
    .chain(also.iter().copied())
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
        let w = unmatched_remaps(&ros, &topics, &[]);
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
        for p in NODE_PARAMS
            .iter()
            .chain(super::super::node_compensate::PARAMS.iter())
        {
            assert!(text.contains(p), "{p} missing from: {text}");
        }
    }

    #[test]
    fn the_command_topics_remap_when_compensating() {
        let topics: terraslip_ros2::TopicsConfig =
            toml::from_str("[wheels]\nseparation = 1.04\n").unwrap();
        let ros = RosArgs::parse(
            &["-r".into(), "cmd_vel_nav:=/cmd_vel_smoothed".into()],
            "terraslip",
        )
        .unwrap();
        assert_eq!(unmatched_remaps(&ros, &topics, &[]).len(), 1);
        let cmd = super::super::node_compensate::CMD_IN;
        assert!(unmatched_remaps(&ros, &topics, &[cmd]).is_empty());
    }

    #[test]
    fn compensation_parameters_set_its_flags() {
        #[derive(clap::Parser)]
        struct Cli {
            #[command(flatten)]
            args: Args,
        }
        let mut args = <Cli as clap::Parser>::try_parse_from(["terraslip"])
            .unwrap()
            .args;
        let mut table = toml::Table::new();
        table.insert("compensate".into(), toml::Value::Boolean(true));
        table.insert("max_yaw_rate".into(), toml::Value::Float(1.5));
        table.insert("filter".into(), toml::Value::Table(toml::Table::new()));
        apply_node_params(&mut args, &mut table).unwrap();
        assert!(args.compensate.compensate);
        assert_eq!(args.compensate.max_yaw_rate, Some(1.5));
        // Only the configuration's keys are left.
        assert_eq!(table.keys().collect::<Vec<_>>(), ["filter"]);
    }
}
