//! The node's parameters on the ROS 2 parameter services (`ros2 param
//! list/get/set/describe`), served by `ros2-client`'s node spinner on a
//! thread of its own. The caller declares each parameter with its value
//! and gives the rule a new value must pass; a value the rule accepts is
//! stored (so `ros2 param get` shows it) and handed to the caller's loop
//! as a [`Change`], to be applied there.
//!
//! Values are TOML values, as `--ros-args -p` gives them ([`crate::args`]):
//! a ROS bool, integer, double and string are a TOML boolean, integer,
//! float and string; `None` is a parameter declared without a value (ROS
//! `NOT_SET`). Arrays are not taken.
//!
//! `ros2-client` 0.12.1 serves the services in the RPC-over-DDS
//! "enhanced" mapping (the request identity in the sample's own identity,
//! no header in the payload), which `rmw_fastrtps` (the default middleware
//! of Humble and Jazzy) and `rmw_connextdds` speak; `rmw_cyclonedds`
//! puts a 16-byte request header in the payload, which the spinner does
//! not read.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{channel, Receiver, Sender};
use std::sync::{Arc, Mutex};

use ros2_client::dds::Node;
use ros2_client::{NodeOptions, ParameterValue};

use crate::NodeError;

/// The rule a new value must pass: `Err` carries the reason the setter is
/// told. Called with each declared value at start too.
pub type Rule = dyn Fn(&str, Option<&toml::Value>) -> Result<(), String> + Send + Sync;

/// The parameters a node serves.
pub struct Parameters {
    /// Each name with its value now (`None`: declared without a value).
    pub declared: Vec<(String, Option<toml::Value>)>,
    /// Whether a new value is taken, and why not.
    pub rule: Box<Rule>,
}

/// A new value a parameter service took.
#[derive(Debug, Clone, PartialEq)]
pub struct Change {
    pub name: String,
    /// `None`: the parameter was unset.
    pub value: Option<toml::Value>,
}

/// The changes taken, for the node's loop.
pub struct Changes(Receiver<Change>);

impl Changes {
    /// The changes taken since the last call, in the order they were set.
    pub fn take(&self) -> Vec<Change> {
        self.0.try_iter().collect()
    }
}

/// A TOML value as a ROS parameter value.
pub fn to_ros(v: Option<&toml::Value>) -> Result<ParameterValue, String> {
    Ok(match v {
        None => ParameterValue::NotSet,
        Some(toml::Value::Boolean(b)) => ParameterValue::Boolean(*b),
        Some(toml::Value::Integer(i)) => ParameterValue::Integer(*i),
        Some(toml::Value::Float(x)) => ParameterValue::Double(*x),
        Some(toml::Value::String(s)) => ParameterValue::String(s.clone()),
        Some(other) => return Err(format!("{other} is not a parameter value this node takes")),
    })
}

/// A ROS parameter value as a TOML value (`None`: not set).
pub fn from_ros(v: &ParameterValue) -> Result<Option<toml::Value>, String> {
    Ok(Some(match v {
        ParameterValue::NotSet => return Ok(None),
        ParameterValue::Boolean(b) => toml::Value::Boolean(*b),
        ParameterValue::Integer(i) => toml::Value::Integer(*i),
        ParameterValue::Double(x) => toml::Value::Float(*x),
        ParameterValue::String(s) => toml::Value::String(s.clone()),
        other => {
            return Err(format!(
                "a value of type {:?}: this node takes a bool, an integer, a double or a string",
                other.to_parameter_type()
            ))
        }
    }))
}

/// A callback of ros2-client's parameter store.
pub type StoreFn = dyn Fn(&str, &ParameterValue) -> Result<(), String> + Send + Sync;

/// What the parameter store calls: the rule, and the action that hands a
/// taken value to the node's loop once `armed` (the declared values the
/// store takes at start are not changes).
pub struct Handlers {
    pub validator: Box<StoreFn>,
    pub set_action: Box<StoreFn>,
    pub armed: Arc<AtomicBool>,
}

impl Handlers {
    /// The handlers of `rule`, and the receiving end of their changes.
    pub fn new(rule: Box<Rule>) -> (Self, Changes) {
        let (tx, rx): (Sender<Change>, Receiver<Change>) = channel();
        let tx = Mutex::new(tx);
        let armed = Arc::new(AtomicBool::new(false));
        let on = Arc::clone(&armed);
        let validator = Box::new(move |name: &str, v: &ParameterValue| {
            rule(
                name,
                from_ros(v).map_err(|e| format!("{name}: {e}"))?.as_ref(),
            )
        });
        let set_action = Box::new(move |name: &str, v: &ParameterValue| {
            if on.load(Ordering::SeqCst) {
                let change = Change {
                    name: name.to_string(),
                    value: from_ros(v)?,
                };
                // The loop gone means the node is ending: nothing to apply.
                let _ = tx.lock().map(|tx| tx.send(change));
            }
            Ok(())
        });
        (
            Self {
                validator,
                set_action,
                armed,
            },
            Changes(rx),
        )
    }
}

/// `options` with the parameter services on and `params` declared; the
/// switch that arms the handlers once the node exists, and the changes.
pub(crate) fn with_parameters(
    options: NodeOptions,
    params: Parameters,
) -> Result<(NodeOptions, Arc<AtomicBool>, Changes), NodeError> {
    let (handlers, changes) = Handlers::new(params.rule);
    // Every name and type is the rule's to judge (it names the node's own
    // parameters when it refuses one), so the store lets any through to it.
    let mut options = options
        .start_parameter_services(true)
        .allow_undeclared_parameters(true)
        .parameter_validator(handlers.validator)
        .parameter_set_action(handlers.set_action);
    for (name, value) in params.declared {
        let v = to_ros(value.as_ref()).map_err(|reason| NodeError::Args {
            arg: name.clone(),
            reason,
        })?;
        options = options.declare_parameter(&name, v);
    }
    Ok((options, handlers.armed, changes))
}

/// Serves the parameter services of `node` from a thread of its own, until
/// the node is dropped.
pub(crate) fn serve(node: &mut Node) -> Result<(), NodeError> {
    let spinner = node
        .spinner()
        .map_err(|e| NodeError::Dds(format!("parameter services: {e}")))?;
    std::thread::Builder::new()
        .name("ros-parameters".into())
        .spawn(move || {
            if let Err(e) = futures::executor::block_on(spinner.spin()) {
                eprintln!("warning: the parameter services stopped: {e}");
            }
        })
        .map_err(|e| NodeError::Dds(format!("parameter services thread: {e}")))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn only_positive_gain() -> Box<Rule> {
        Box::new(|name, v| match (name, v) {
            ("gain", Some(toml::Value::Float(x))) if *x > 0.0 => Ok(()),
            ("gain", _) => Err("gain is a double > 0".into()),
            _ => Err(format!("unknown parameter {name}")),
        })
    }

    #[test]
    fn a_taken_value_reaches_the_loop_once_armed() {
        let (h, changes) = Handlers::new(only_positive_gain());
        // The store's start: declared values are checked, not changes.
        (h.validator)("gain", &ParameterValue::Double(1.0)).unwrap();
        (h.set_action)("gain", &ParameterValue::Double(1.0)).unwrap();
        assert!(changes.take().is_empty());
        h.armed.store(true, Ordering::SeqCst);
        (h.set_action)("gain", &ParameterValue::Double(2.5)).unwrap();
        assert_eq!(
            changes.take(),
            [Change {
                name: "gain".into(),
                value: Some(toml::Value::Float(2.5))
            }]
        );
        assert!(changes.take().is_empty());
    }

    #[test]
    fn the_rule_gives_its_reason_and_arrays_are_named() {
        let (h, _) = Handlers::new(only_positive_gain());
        let e = (h.validator)("gain", &ParameterValue::Double(-1.0)).unwrap_err();
        assert!(e.contains("> 0"), "{e}");
        let e = (h.validator)("gian", &ParameterValue::Double(1.0)).unwrap_err();
        assert!(e.contains("unknown parameter gian"), "{e}");
        let e = (h.validator)("gain", &ParameterValue::DoubleArray(vec![1.0])).unwrap_err();
        assert!(e.contains("gain") && e.contains("DoubleArray"), "{e}");
    }

    #[test]
    fn values_map_both_ways() {
        for v in [
            None,
            Some(toml::Value::Boolean(true)),
            Some(toml::Value::Integer(-3)),
            Some(toml::Value::Float(0.25)),
            Some(toml::Value::String("odom".into())),
        ] {
            assert_eq!(from_ros(&to_ros(v.as_ref()).unwrap()).unwrap(), v);
        }
        assert!(to_ros(Some(&toml::Value::Array(vec![]))).is_err());
    }
}
