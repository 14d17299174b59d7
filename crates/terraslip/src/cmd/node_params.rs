//! `terraslip node`'s own parameters on the ROS 2 parameter services
//! (`ros2 param list/get/set`): the parameters `--ros-args -p` sets the
//! flags with, each at its value in use, which of them a `ros2 param set`
//! changes while the node runs ([`LIVE`]), and how a change is applied.
//!
//! Every other parameter sizes something made at start (the warm-up and
//! the reorder buffer, the model's start, the command path), so a new
//! value is refused with that reason and `ros2 param get` keeps showing the
//! value in use. The configuration's keys (`filter.still_speed`, ...) are
//! read at start only and not served.

use anyhow::Result;
use terraslip_node::{Change, Changes, Graph, Parameters};

use super::node_args::{apply_node_params, Args, NODE_PARAMS};
use super::node_compensate::{CommandThread, PARAMS as COMPENSATE_PARAMS};
use super::node_outputs::Outputs;

/// The parameters a `ros2 param set` changes while the node runs.
pub const LIVE: [&str; 14] = [
    "save_every",
    "publish_tf",
    "odom_frame",
    "base_frame",
    "max_speed",
    "max_yaw_rate",
    "max_acceleration",
    "max_yaw_acceleration",
    "correction_rate",
    "engage_after",
    "max_correction",
    "cmd_timeout",
    "confident_spread_std",
    "hold_after_change",
];

/// A controller separation to check the compensation's other settings
/// against (m): each of them is checked on its own, and the separation is
/// not changed live.
const PROBE_SEPARATION: f64 = 1.0;

/// The ROS type of a parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Bool,
    Integer,
    Double,
    String,
}

impl Kind {
    fn of(v: &toml::Value) -> Option<Self> {
        Some(match v {
            toml::Value::Boolean(_) => Kind::Bool,
            toml::Value::Integer(_) => Kind::Integer,
            toml::Value::Float(_) => Kind::Double,
            toml::Value::String(_) => Kind::String,
            _ => return None,
        })
    }

    fn name(self) -> &'static str {
        match self {
            Kind::Bool => "a bool",
            Kind::Integer => "an integer",
            Kind::Double => "a double",
            Kind::String => "a string",
        }
    }
}

/// The node's own parameters, in the order `ros2 param list` sorts apart.
fn names() -> impl Iterator<Item = &'static str> {
    NODE_PARAMS.into_iter().chain(COMPENSATE_PARAMS)
}

fn kind(name: &str) -> Option<Kind> {
    Some(match name {
        "publish_tf" | "compensate" | "cmd_in_stamped" | "cmd_out_stamped" => Kind::Bool,
        "odom_frame" | "base_frame" | "pose_reference" => Kind::String,
        "thread_priority" => Kind::Integer,
        n if names().any(|p| p == n) => Kind::Double,
        _ => return None,
    })
}

/// The value of parameter `name` in `args` (`None`: not given, or not a
/// parameter).
pub fn value(args: &Args, name: &str) -> Option<toml::Value> {
    use toml::Value::{Boolean, Float, Integer, String};
    let c = &args.compensate;
    Some(match name {
        "lag" => Float(args.lag),
        "save_every" => Float(args.save_every),
        "track_width" => Float(args.track_width?),
        "gyro_delay" => Float(args.gyro_delay?),
        "pose_reference" => String(args.pose_reference?.name().into()),
        "publish_tf" => Boolean(!args.no_tf),
        "odom_frame" => String(args.odom_frame.clone()),
        "base_frame" => String(args.base_frame.clone()),
        "compensate" => Boolean(c.compensate),
        "cmd_in_stamped" => Boolean(c.cmd_in_stamped),
        "cmd_out_stamped" => Boolean(c.cmd_out_stamped),
        "wheel_separation" => Float(c.wheel_separation?),
        "wheel_separation_multiplier" => Float(c.wheel_separation_multiplier),
        "max_speed" => Float(c.max_speed?),
        "max_yaw_rate" => Float(c.max_yaw_rate?),
        "max_acceleration" => Float(c.max_acceleration?),
        "max_yaw_acceleration" => Float(c.max_yaw_acceleration?),
        "correction_rate" => Float(c.correction_rate),
        "engage_after" => Float(c.engage_after),
        "max_correction" => Float(c.max_correction),
        "cmd_timeout" => Float(c.cmd_timeout),
        "confident_spread_std" => Float(c.confident_spread_std),
        "hold_after_change" => Float(c.hold_after_change),
        "thread_priority" => Integer(i64::from(c.thread_priority)),
        _ => return None,
    })
}

/// The parameters to serve: each at its value in `args`, a new value
/// judged by [`check`] against `args`.
pub fn parameters(args: &Args) -> Parameters {
    let start = args.clone();
    Parameters {
        declared: names().map(|n| (n.to_string(), value(args, n))).collect(),
        rule: Box::new(move |name, v| check(&start, name, v)),
    }
}

/// Whether parameter `name` may become `v` (`None`: unset) while the node
/// runs with the values of `start`; else why not, as the setter is told.
pub fn check(start: &Args, name: &str, v: Option<&toml::Value>) -> Result<(), String> {
    let Some(kind) = kind(name) else {
        return Err(format!(
            "{name} is not a parameter of this node; its parameters are {} (the configuration's keys, such as filter.still_speed, are read at start only: --ros-args -p)",
            names().collect::<Vec<_>>().join(", ")
        ));
    };
    let now = value(start, name);
    // The value in use (the parameter store checks each at start).
    if v == now.as_ref() {
        return Ok(());
    }
    let Some(v) = v else {
        return Err(format!("{name} cannot be unset"));
    };
    if Kind::of(v) != Some(kind) {
        let hint = match (kind, v) {
            (Kind::Double, toml::Value::Integer(i)) => format!(" (write {i}.0)"),
            _ => String::new(),
        };
        return Err(format!("{name} is {}, not {v}{hint}", kind.name()));
    }
    if !LIVE.contains(&name) {
        let now = now.map_or("not set".to_string(), |n| n.to_string());
        return Err(format!(
            "{name} is read at start only ({}; it stays {now}): restart the node with --ros-args -p {name}:={v}; these change while it runs: {}",
            made_from(name),
            LIVE.join(", ")
        ));
    }
    let mut probe = start.clone();
    set(&mut probe, name, v).map_err(|e| format!("{e:#}"))
}

/// What a parameter read at start only is made into.
fn made_from(name: &str) -> &'static str {
    match name {
        "lag" => "the warm-up window and the reorder buffer are sized from it",
        "track_width" => "the model starts from it",
        "gyro_delay" | "pose_reference" => "the warm-up decides from it",
        _ => "the command path is made from it",
    }
}

/// Sets parameter `name` of `args` to `v` as `--ros-args -p` does, and
/// checks the compensation's settings with it.
fn set(args: &mut Args, name: &str, v: &toml::Value) -> Result<()> {
    let mut table = toml::Table::new();
    table.insert(name.to_string(), v.clone());
    apply_node_params(args, &mut table)?;
    if COMPENSATE_PARAMS.contains(&name) {
        args.compensate.config(PROBE_SEPARATION)?;
    }
    Ok(())
}

/// Where a change takes effect in the running node.
pub struct Running<'a> {
    pub args: &'a mut Args,
    /// The publishers, once made (before, they are made from `args`).
    pub out: Option<&'a mut Outputs>,
    pub graph: &'a Graph,
    pub commands: Option<&'a CommandThread>,
    /// When the parameters are next saved (s of stamp time).
    pub next_save: &'a mut Option<f64>,
}

/// Applies the changes the parameter services took since the last call.
pub fn apply_all(changes: &Changes, mut run: Running) -> Result<()> {
    for c in changes.take() {
        apply(&c, &mut run)?;
    }
    Ok(())
}

/// Applies a change the parameter services took (checked by [`check`]) and
/// says what changed.
fn apply(c: &Change, run: &mut Running) -> Result<()> {
    let (Some(v), was) = (&c.value, value(run.args, &c.name)) else {
        return Ok(());
    };
    if was.as_ref() == Some(v) {
        return Ok(());
    }
    let name = c.name.as_str();
    set(run.args, name, v)?;
    let args = &*run.args;
    let out = run.out.as_deref_mut();
    let effect = match (name, out) {
        ("save_every", _) => {
            *run.next_save = None;
            "the next save is this long after the next estimate"
        }
        ("publish_tf", Some(out)) => {
            out.set_publish_tf(run.graph, !args.no_tf)?;
            "from the next estimate"
        }
        ("odom_frame" | "base_frame", Some(out)) => {
            out.frames.odom = args.odom_frame.clone();
            out.frames.base = args.base_frame.clone();
            "from the next estimate"
        }
        ("confident_spread_std" | "hold_after_change", Some(out)) => {
            let c = &args.compensate;
            if let Some(b) = out.belief.as_mut() {
                b.retune(c.confident_spread_std, c.hold_after_change);
            }
            "from the next estimate"
        }
        ("publish_tf" | "odom_frame" | "base_frame", None) => "from the first estimate",
        ("confident_spread_std" | "hold_after_change", None) => "from the first estimate",
        _ => "from the next command",
    };
    let commanding = COMPENSATE_PARAMS.contains(&name) || name == "base_frame";
    let effect = match run.commands {
        Some(cmd) if commanding => {
            cmd.retune(&args.compensate, &args.base_frame);
            effect
        }
        None if COMPENSATE_PARAMS.contains(&name) => {
            "used when the node compensates (--compensate)"
        }
        _ => effect,
    };
    let was = was.map_or("not set".to_string(), |w| w.to_string());
    eprintln!("parameter {name} = {v} (was {was}), set through the parameter services: {effect}");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use toml::Value::{Boolean, Float, Integer, String};

    fn args() -> Args {
        #[derive(clap::Parser)]
        struct Cli {
            #[command(flatten)]
            args: Args,
        }
        <Cli as clap::Parser>::try_parse_from(["terraslip", "--lag", "0.5"])
            .unwrap()
            .args
    }

    #[test]
    fn every_parameter_is_declared_at_its_value_in_use() {
        let a = args();
        let p = parameters(&a);
        let declared: Vec<&str> = p.declared.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(declared, names().collect::<Vec<_>>());
        let v = |n: &str| p.declared.iter().find(|(m, _)| m == n).unwrap().1.clone();
        assert_eq!(v("lag"), Some(Float(0.5)));
        assert_eq!(v("publish_tf"), Some(Boolean(true)));
        assert_eq!(v("odom_frame"), Some(String("odom".into())));
        assert_eq!(v("max_speed"), None);
        assert_eq!(v("thread_priority"), Some(Integer(50)));
        // The store checks every declared value with the rule at start.
        for (n, v) in &p.declared {
            (p.rule)(n, v.as_ref()).unwrap_or_else(|e| panic!("{n}: {e}"));
        }
        for n in LIVE {
            assert!(kind(n).is_some(), "{n}");
        }
    }

    #[test]
    fn unknown_names_wrong_types_and_start_only_values_are_refused_with_the_reason() {
        let a = args();
        let e = check(&a, "lagg", Some(&Float(0.5))).unwrap_err();
        assert!(e.contains("lagg") && e.contains("save_every") && e.contains("max_speed"));
        let e = check(&a, "save_every", Some(&Integer(60))).unwrap_err();
        assert!(e.contains("a double") && e.contains("60.0"), "{e}");
        let e = check(&a, "publish_tf", Some(&String("no".into()))).unwrap_err();
        assert!(e.contains("a bool"), "{e}");
        let e = check(&a, "lag", Some(&Float(1.0))).unwrap_err();
        assert!(e.contains("start only") && e.contains("0.5"), "{e}");
        assert!(e.contains("reorder buffer"), "{e}");
        let e = check(&a, "track_width", Some(&Float(0.6))).unwrap_err();
        assert!(e.contains("not set"), "{e}");
        let e = check(&a, "save_every", Some(&Float(-1.0))).unwrap_err();
        assert!(e.contains("save_every"), "{e}");
        let e = check(&a, "max_speed", Some(&Float(0.0))).unwrap_err();
        assert!(e.contains("max_speed"), "{e}");
        let e = check(&a, "odom_frame", None).unwrap_err();
        assert!(e.contains("unset"), "{e}");
        assert!(check(&a, "odom_frame", Some(&String(std::string::String::new()))).is_err());
    }

    #[test]
    fn live_values_are_taken() {
        let a = args();
        for (n, v) in [
            ("save_every", Float(60.0)),
            ("publish_tf", Boolean(false)),
            ("base_frame", String("base_footprint".into())),
            ("max_speed", Float(1.0)),
            ("hold_after_change", Float(0.0)),
        ] {
            check(&a, n, Some(&v)).unwrap_or_else(|e| panic!("{n}: {e}"));
        }
        // The value in use is no change, live or not.
        check(&a, "lag", Some(&Float(0.5))).unwrap();
        check(&a, "max_speed", None).unwrap();
    }

    #[test]
    fn the_pose_reference_is_a_string_read_at_start() {
        let mut a = args();
        assert_eq!(value(&a, "pose_reference"), None);
        set(&mut a, "pose_reference", &String("localizer".into())).unwrap();
        assert_eq!(
            a.pose_reference,
            Some(terraslip_io::PoseReference::Localiser)
        );
        assert_eq!(
            value(&a, "pose_reference"),
            Some(String("localiser".into()))
        );
        let e = set(&mut a, "pose_reference", &String("lidar".into())).unwrap_err();
        assert!(format!("{e:#}").contains("`lidar` is not a kind"), "{e:#}");
        let e = check(&a, "pose_reference", Some(&String("gnss".into()))).unwrap_err();
        assert!(e.contains("start only") && e.contains("warm-up"), "{e}");
    }

    #[test]
    fn a_change_sets_the_flag_as_the_command_line_does() {
        let mut a = args();
        set(&mut a, "save_every", &Float(60.0)).unwrap();
        set(&mut a, "publish_tf", &Boolean(false)).unwrap();
        set(&mut a, "max_yaw_rate", &Float(1.5)).unwrap();
        assert_eq!(a.save_every, 60.0);
        assert!(a.no_tf);
        assert_eq!(a.compensate.max_yaw_rate, Some(1.5));
        assert_eq!(value(&a, "max_yaw_rate"), Some(Float(1.5)));
    }
}
