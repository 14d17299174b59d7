//! `terraslip node --compensate`: the velocity commands a path follower
//! sends, answered with the command the drive controller must receive for
//! the robot to move as desired under the live slip estimate
//! ([`terraslip_core::compensate`]). The answers come from a thread of
//! their own, so a command never waits for the estimator; the estimator's
//! side hands it the model and whether it is believed.
//!
//! One answer per command and only then: when the commands stop, nothing
//! is published, and the controller's own timeout stops the robot.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime};

use anyhow::{bail, Context, Result};
use terraslip_core::compensate::{
    correction, CompensateConfig, Compensator, IcrModel, PassReason, Status,
};
use terraslip_core::Twist;
use terraslip_node::{Graph, GraphTopic, Reader, TopicQos, Wait, Writer};
use terraslip_ros2::out::{diagnostics_message, DiagnosticLevel};
use terraslip_ros2::twist::{TwistCodec, TwistMsg};

/// The desired twist's topic (Nav2's controller output, remap it with
/// `--ros-args -r cmd_vel_nav:=...`).
pub const CMD_IN: &str = "cmd_vel_nav";
/// The compensated command's topic (the drive controller's input).
pub const CMD_OUT: &str = "cmd_vel";
/// Seconds without an estimate row after which the estimate is not
/// believed (the sensors stopped).
const ESTIMATE_STALE: f64 = 1.0;

/// The `--compensate` flags (and ROS parameters of the same names).
#[derive(clap::Args, Debug, Clone)]
pub struct CompensateArgs {
    /// Answer each velocity command on cmd_vel_nav with the slip-compensated
    /// command on cmd_vel (both remappable), passing it through unchanged
    /// while the estimate is not believed.
    #[arg(long)]
    pub compensate: bool,
    /// The commands read are geometry_msgs/TwistStamped (else Twist).
    #[arg(long)]
    pub cmd_in_stamped: bool,
    /// The commands written are geometry_msgs/TwistStamped (else Twist).
    #[arg(long)]
    pub cmd_out_stamped: bool,
    /// The drive controller's wheel_separation, m [default: `[wheels]
    /// separation` of --topics, else the track width].
    #[arg(long, value_name = "M")]
    pub wheel_separation: Option<f64>,
    /// The drive controller's wheel_separation_multiplier (the one tuned
    /// by hand): commands are expressed in the controller's model of
    /// separation wheel_separation x this, so a command passed through is
    /// driven as the tuned controller drives it.
    #[arg(long, value_name = "X", default_value_t = 1.0)]
    pub wheel_separation_multiplier: f64,
    /// The controller's largest forward speed, m/s [default: none].
    #[arg(long, value_name = "M/S")]
    pub max_speed: Option<f64>,
    /// The controller's largest yaw rate, rad/s [default: none].
    #[arg(long, value_name = "RAD/S")]
    pub max_yaw_rate: Option<f64>,
    /// The controller's largest forward acceleration, m/s^2 [default: none].
    #[arg(long, value_name = "M/S2")]
    pub max_acceleration: Option<f64>,
    /// The controller's largest yaw acceleration, rad/s^2 [default: none].
    #[arg(long, value_name = "RAD/S2")]
    pub max_yaw_acceleration: Option<f64>,
    /// Fastest change of the (dimensionless) correction, per second: how
    /// fast a new estimate reaches the commands.
    #[arg(long, value_name = "1/S", default_value_t = 0.5)]
    pub correction_rate: f64,
    /// Seconds the estimate must be believed without a break before it is
    /// applied (the model applied before is held meanwhile).
    #[arg(long, value_name = "S", default_value_t = CompensateConfig::new(1.0).engage_after)]
    pub engage_after: f64,
    /// Largest correction applied (an entry of the dimensionless correction
    /// minus the identity); a larger one passes the command through.
    #[arg(long, value_name = "X", default_value_t = 2.0)]
    pub max_correction: f64,
    /// The controller's cmd_vel_timeout, s: commands further apart are not
    /// acceleration-limited against each other.
    #[arg(long, value_name = "S", default_value_t = 0.5)]
    pub cmd_timeout: f64,
    /// The estimate is believed when the spread's std is at most this
    /// fraction of the spread.
    #[arg(long, value_name = "X", default_value_t = terraslip::belief::CONFIDENT_SPREAD_STD)]
    pub confident_spread_std: f64,
    /// Seconds (stamp time) the estimate is not believed after a detected
    /// slip change.
    #[arg(long, value_name = "S", default_value_t = terraslip::belief::HOLD_AFTER_CHANGE)]
    pub hold_after_change: f64,
    /// SCHED_FIFO priority (1-99) the command thread asks for, as
    /// ros2_control's controller_manager does; when refused it says how to
    /// permit it and runs at normal priority. 0: do not ask.
    #[arg(long, value_name = "P", default_value_t = super::realtime::DEFAULT_PRIORITY,
          value_parser = clap::value_parser!(u8).range(0..=99))]
    pub thread_priority: u8,
}

/// The `--ros-args -p` names that set the flags above.
pub const PARAMS: [&str; 16] = [
    "compensate",
    "cmd_in_stamped",
    "cmd_out_stamped",
    "wheel_separation",
    "wheel_separation_multiplier",
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
    "thread_priority",
];

impl CompensateArgs {
    /// Sets the flag of ROS parameter `key` (one of [`PARAMS`]) to `v`.
    pub fn apply(&mut self, key: &str, v: &toml::Value) -> Result<()> {
        let num = || {
            v.as_float()
                .or(v.as_integer().map(|i| i as f64))
                .with_context(|| format!("--ros-args parameter {key} = {v}: expected a number"))
        };
        let flag = || {
            v.as_bool().with_context(|| {
                format!("--ros-args parameter {key} = {v}: expected true or false")
            })
        };
        match key {
            "compensate" => self.compensate = flag()?,
            "cmd_in_stamped" => self.cmd_in_stamped = flag()?,
            "cmd_out_stamped" => self.cmd_out_stamped = flag()?,
            "wheel_separation" => self.wheel_separation = Some(num()?),
            "wheel_separation_multiplier" => self.wheel_separation_multiplier = num()?,
            "thread_priority" => {
                let p = v.as_integer().filter(|p| (0..=99).contains(p));
                self.thread_priority = p.with_context(|| {
                    format!("--ros-args parameter {key} = {v}: expected an integer 0-99")
                })? as u8;
            }
            "max_speed" => self.max_speed = Some(num()?),
            "max_yaw_rate" => self.max_yaw_rate = Some(num()?),
            "max_acceleration" => self.max_acceleration = Some(num()?),
            "max_yaw_acceleration" => self.max_yaw_acceleration = Some(num()?),
            "correction_rate" => self.correction_rate = num()?,
            "engage_after" => self.engage_after = num()?,
            "max_correction" => self.max_correction = num()?,
            "cmd_timeout" => self.cmd_timeout = num()?,
            "confident_spread_std" => self.confident_spread_std = num()?,
            "hold_after_change" => self.hold_after_change = num()?,
            _ => bail!("{key} is not a compensation parameter"),
        }
        Ok(())
    }

    /// The separation of the controller's model, m: its wheel_separation
    /// (`default` when not given) times its multiplier.
    pub fn controller_separation(&self, default: f64) -> f64 {
        self.wheel_separation.unwrap_or(default) * self.wheel_separation_multiplier
    }

    /// The compensator's settings for a controller of wheel separation
    /// `separation` (m), checked.
    pub fn config(&self, separation: f64) -> Result<CompensateConfig> {
        let unlimited = |x: Option<f64>| x.unwrap_or(f64::INFINITY);
        let cfg = CompensateConfig {
            separation,
            max_speed: unlimited(self.max_speed),
            max_yaw_rate: unlimited(self.max_yaw_rate),
            max_acceleration: unlimited(self.max_acceleration),
            max_yaw_acceleration: unlimited(self.max_yaw_acceleration),
            max_correction_rate: self.correction_rate,
            engage_after: self.engage_after,
            max_correction: self.max_correction,
            command_timeout: self.cmd_timeout,
        };
        cfg.validate()
            .map_err(|e| anyhow::anyhow!("--compensate: {e}"))?;
        if !(self.confident_spread_std > 0.0 && self.hold_after_change >= 0.0) {
            bail!("--compensate: confident_spread_std must be > 0 and hold_after_change >= 0");
        }
        Ok(cfg)
    }
}

/// What the estimator's side hands the command thread.
#[derive(Debug, Default)]
struct Latest {
    /// The model, whether it is believed (else why not), and when.
    estimate: Option<(IcrModel, Result<(), String>, Instant)>,
    /// New settings and body frame, not yet taken.
    retune: Option<(CompensateArgs, String)>,
}

/// The running command thread.
pub struct CommandThread {
    latest: Arc<Mutex<Latest>>,
    done: Arc<AtomicBool>,
    thread: JoinHandle<Result<()>>,
}

impl CommandThread {
    /// Subscribes to `cmd_in`, advertises `cmd_out` and starts answering.
    pub fn start(
        graph: &Graph,
        args: &CompensateArgs,
        topics: (&str, &str),
        separation: f64,
        base_frame: &str,
    ) -> Result<Self> {
        let compensator = Compensator::new(args.config(separation)?)
            .map_err(|e| anyhow::anyhow!("--compensate: {e}"))?;
        let (codec_in, codec_out) = (
            TwistCodec::new(args.cmd_in_stamped),
            TwistCodec::new(args.cmd_out_stamped),
        );
        let topic = |name: &str, ty: &str| GraphTopic {
            name: name.into(),
            ty: ty.into(),
        };
        let reader = graph.reader(&topic(topics.0, codec_in.ty()), TopicQos::Sensor)?;
        let writer = graph.writer(&topic(topics.1, codec_out.ty()))?;
        let diagnostics = graph.writer(&topic(
            "/diagnostics",
            "diagnostic_msgs/msg/DiagnosticArray",
        ))?;
        eprintln!(
            "compensating: {} ({}) -> {} ({}), controller wheel separation {separation:.4} m",
            topics.0,
            codec_in.ty(),
            topics.1,
            codec_out.ty()
        );
        let latest = Arc::new(Mutex::new(Latest::default()));
        let done = Arc::new(AtomicBool::new(false));
        let mut answers = Answers {
            compensator,
            codec_in,
            codec_out,
            writer,
            diagnostics,
            base_frame: base_frame.to_string(),
            latest: Arc::clone(&latest),
            start: Instant::now(),
            counts: Counts::default(),
            said: None,
            said_at: None,
            scheduling: super::realtime::Scheduling::NotAsked,
        };
        let stop = Arc::clone(&done);
        let priority = args.thread_priority;
        let thread = std::thread::Builder::new()
            .name("compensate".into())
            .spawn(move || {
                answers.scheduling = super::realtime::request(priority);
                if let super::realtime::Scheduling::Refused(why) = &answers.scheduling {
                    eprintln!("{why}");
                }
                answers.serve(reader, &stop)
            })
            .context("starting the command thread")?;
        Ok(Self {
            latest,
            done,
            thread,
        })
    }

    /// Hands over the estimator's model now and whether it is believed.
    pub fn update(&self, model: IcrModel, verdict: Result<(), String>) {
        if let Ok(mut l) = self.latest.lock() {
            l.estimate = Some((model, verdict, Instant::now()));
        }
    }

    /// Hands over new settings (the controller's separation kept) and the
    /// body frame, taken before the next command.
    pub fn retune(&self, args: &CompensateArgs, base_frame: &str) {
        if let Ok(mut l) = self.latest.lock() {
            l.retune = Some((args.clone(), base_frame.to_string()));
        }
    }

    /// Stops answering; the thread's error, if it met one.
    pub fn finish(self) -> Result<()> {
        self.done.store(true, Ordering::Relaxed);
        match self.thread.join() {
            Ok(r) => r,
            Err(_) => bail!("the command thread panicked"),
        }
    }
}

/// What the thread counted, for the diagnostics.
#[derive(Debug, Default)]
struct Counts {
    commands: u64,
    passed: u64,
    /// Compensated under the model last applied, the estimate not believed.
    held: u64,
    unreadable: u64,
    /// Longest time from a command's arrival to its answer's writing, s.
    slowest: f64,
}

/// The command thread's state.
struct Answers {
    compensator: Compensator,
    codec_in: TwistCodec,
    codec_out: TwistCodec,
    writer: Writer,
    diagnostics: Writer,
    base_frame: String,
    latest: Arc<Mutex<Latest>>,
    start: Instant,
    counts: Counts,
    /// The last status reported, with the reason's detail.
    said: Option<(Status, String)>,
    said_at: Option<Instant>,
    /// How this thread is scheduled.
    scheduling: super::realtime::Scheduling,
}

impl Answers {
    /// Answers every command until `done`.
    fn serve(&mut self, mut reader: Reader, done: &AtomicBool) -> Result<()> {
        let mut wait = Wait::new().context("event poll")?;
        wait.register(&mut reader, 0).context("event poll")?;
        while !done.load(Ordering::Relaxed) {
            self.take_retune();
            while let Some((raw, _)) = reader.take()? {
                self.answer(&raw.0)?;
            }
            if self
                .said_at
                .is_some_and(|t| t.elapsed() >= Duration::from_secs(1))
            {
                self.report()?;
            }
            wait.wait(Duration::from_millis(100))
                .context("event poll")?;
        }
        Ok(())
    }

    /// Takes the settings handed over by [`CommandThread::retune`].
    fn take_retune(&mut self) {
        let Some((args, frame)) = self.latest.lock().ok().and_then(|mut l| l.retune.take()) else {
            return;
        };
        let separation = self.compensator.config().separation;
        if let Err(e) = args
            .config(separation)
            .and_then(|c| self.compensator.set_config(c).map_err(anyhow::Error::msg))
        {
            eprintln!("warning: compensation settings not changed: {e:#}");
        }
        self.base_frame = frame;
    }

    /// The estimate as the compensator takes it, and why it is not
    /// believed.
    fn estimate(&self) -> (Option<(IcrModel, bool)>, String) {
        let Ok(l) = self.latest.lock() else {
            return (None, "estimator side failed".into());
        };
        match &l.estimate {
            None => (None, "no estimate yet".into()),
            Some((m, _, at)) if at.elapsed().as_secs_f64() > ESTIMATE_STALE => (
                Some((*m, false)),
                format!("no estimate for {:.1} s", at.elapsed().as_secs_f64()),
            ),
            Some((m, Ok(()), _)) => (Some((*m, true)), String::new()),
            Some((m, Err(why), _)) => (Some((*m, false)), why.clone()),
        }
    }

    /// Answers one command.
    fn answer(&mut self, data: &[u8]) -> Result<()> {
        let arrived = Instant::now();
        let msg = match self.codec_in.decode(data) {
            Ok(m) => m,
            Err(e) => {
                self.counts.unreadable += 1;
                if self.counts.unreadable <= 5 {
                    eprintln!("warning: command skipped: {e}");
                }
                return Ok(());
            }
        };
        let (estimate, why) = self.estimate();
        let t = self.start.elapsed().as_secs_f64();
        let command = self.compensator.command(t, desired(&msg), estimate);
        let out = reply(&msg, command.twist, command.status, &self.base_frame);
        self.writer.write(self.codec_out.encode(&out))?;
        self.counts.commands += 1;
        match command.status {
            Status::Compensating => {}
            Status::Holding(_) => self.counts.held += 1,
            Status::PassThrough(_) => self.counts.passed += 1,
        }
        self.counts.slowest = self.counts.slowest.max(arrived.elapsed().as_secs_f64());
        let now = (command.status, why);
        if self.said.as_ref() != Some(&now) {
            self.said = Some(now);
            self.report()?;
        }
        Ok(())
    }

    /// Publishes the compensation's state on /diagnostics.
    fn report(&mut self) -> Result<()> {
        self.said_at = Some(Instant::now());
        let Some((status, why)) = &self.said else {
            return Ok(());
        };
        let (level, message) = match status {
            Status::Compensating => (DiagnosticLevel::Ok, "compensating".to_string()),
            Status::PassThrough(PassReason::NonFiniteCommand) => (
                DiagnosticLevel::Error,
                PassReason::NonFiniteCommand.as_str().to_string(),
            ),
            Status::Holding(r) => (
                DiagnosticLevel::Warn,
                reason("holding the last believed estimate", *r, why),
            ),
            Status::PassThrough(r) => (DiagnosticLevel::Warn, reason("passing through", *r, why)),
        };
        let c = &self.counts;
        let f = |x: f64| format!("{x:.6}");
        let s = self.compensator.config().separation;
        let mut values: Vec<(String, String)> = vec![
            ("commands".into(), c.commands.to_string()),
            ("passed_through".into(), c.passed.to_string()),
            ("held".into(), c.held.to_string()),
            ("unreadable_commands".into(), c.unreadable.to_string()),
            ("slowest_answer_s".into(), f(c.slowest)),
            ("wheel_separation_m".into(), f(s)),
            ("scheduling".into(), self.scheduling.describe()),
        ];
        if let Some(m) = self.compensator.applied() {
            if let Some(n) = correction(m, s, 0.0, 0.0) {
                for (k, x) in n.iter().flatten().enumerate() {
                    values.push((format!("correction_{}{}", k / 2, k % 2), f(*x)));
                }
            }
            values.push(("applied_spread_m".into(), f(m.icr.spread())));
            values.push(("applied_alpha_l".into(), f(m.icr.alpha_l)));
            values.push(("applied_alpha_r".into(), f(m.icr.alpha_r)));
        }
        let m = diagnostics_message(
            now_ns(),
            "terraslip: slip compensation",
            level,
            &message,
            &values,
        );
        self.diagnostics.write(m.data)?;
        Ok(())
    }
}

/// `what`, why (`r`) and its detail (`why`, may be empty).
fn reason(what: &str, r: PassReason, why: &str) -> String {
    if why.is_empty() {
        format!("{what}: {}", r.as_str())
    } else {
        format!("{what}: {}: {why}", r.as_str())
    }
}

/// The desired twist of a command (REP-103 body frame).
fn desired(m: &TwistMsg) -> Twist {
    Twist {
        v_x: m.linear[0],
        v_y: m.linear[1],
        omega: m.angular[2],
    }
}

/// The answer to command `m`: the command unchanged when passed through,
/// else the compensated twist (forward speed and yaw rate only); the
/// command's stamp and frame, or now and `base_frame` when it had none.
fn reply(m: &TwistMsg, twist: Twist, status: Status, base_frame: &str) -> TwistMsg {
    let mut out = match status {
        Status::Compensating
        | Status::Holding(_)
        | Status::PassThrough(PassReason::NonFiniteCommand) => TwistMsg {
            linear: [twist.v_x, 0.0, 0.0],
            angular: [0.0, 0.0, twist.omega],
            ..m.clone()
        },
        Status::PassThrough(_) => m.clone(),
    };
    if out.stamp_ns.is_none() {
        out.stamp_ns = Some(now_ns());
        out.frame = base_frame.to_string();
    }
    out
}

fn now_ns() -> u64 {
    SystemTime::now()
        .duration_since(SystemTime::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64)
}

/// `name` as the node resolves it: remapped, then in `namespace` unless
/// absolute.
pub fn resolve(ros: &terraslip_node::RosArgs, name: &str, namespace: &str) -> String {
    let n = ros.remap(name);
    if n.starts_with('/') {
        n
    } else {
        format!("{}/{n}", namespace.trim_end_matches('/'))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_passed_command_is_the_command_a_compensated_one_only_turns() {
        let m = TwistMsg {
            stamp_ns: Some(42),
            frame: "base_link".into(),
            linear: [0.4, 0.1, 0.2],
            angular: [0.3, 0.0, -0.2],
        };
        let t = Twist {
            v_x: 0.41,
            v_y: 0.0,
            omega: -0.26,
        };
        assert_eq!(
            reply(&m, t, Status::PassThrough(PassReason::NotConfident), "x"),
            m
        );
        let c = reply(&m, t, Status::Compensating, "x");
        assert_eq!((c.linear, c.angular), ([0.41, 0.0, 0.0], [0.0, 0.0, -0.26]));
        assert_eq!((c.stamp_ns, c.frame.as_str()), (Some(42), "base_link"));
        // An unstamped command's answer is stamped now, in the body frame.
        let plain = TwistMsg {
            stamp_ns: None,
            frame: String::new(),
            ..m
        };
        let c = reply(&plain, t, Status::Compensating, "base_link");
        assert!(c.stamp_ns.unwrap() > 1_600_000_000_000_000_000);
        assert_eq!(c.frame, "base_link");
    }

    #[test]
    fn parameters_set_the_flags_and_bad_settings_are_named() {
        let mut a = CompensateArgs {
            compensate: false,
            cmd_in_stamped: false,
            cmd_out_stamped: false,
            wheel_separation: None,
            wheel_separation_multiplier: 1.0,
            max_speed: None,
            max_yaw_rate: None,
            max_acceleration: None,
            max_yaw_acceleration: None,
            correction_rate: 0.5,
            engage_after: 0.0,
            max_correction: 2.0,
            cmd_timeout: 0.5,
            confident_spread_std: 0.05,
            hold_after_change: 3.0,
            thread_priority: 50,
        };
        a.apply("compensate", &toml::Value::Boolean(true)).unwrap();
        a.apply("max_speed", &toml::Value::Integer(1)).unwrap();
        a.apply("max_yaw_rate", &toml::Value::Float(0.8)).unwrap();
        assert!(a.compensate && a.max_speed == Some(1.0) && a.max_yaw_rate == Some(0.8));
        let e = a.apply("max_speed", &toml::Value::String("fast".into()));
        assert!(format!("{:#}", e.unwrap_err()).contains("max_speed"));
        let cfg = a.config(0.55).unwrap();
        // The controller's model: its wheel_separation times its multiplier.
        assert_eq!(a.controller_separation(0.55), 0.55);
        a.apply("wheel_separation_multiplier", &toml::Value::Float(1.5))
            .unwrap();
        a.apply("wheel_separation", &toml::Value::Float(0.6))
            .unwrap();
        assert!((a.controller_separation(0.55) - 0.9).abs() < 1e-12);
        a.apply("thread_priority", &toml::Value::Integer(80))
            .unwrap();
        assert_eq!(a.thread_priority, 80);
        assert!(a
            .apply("thread_priority", &toml::Value::Integer(100))
            .is_err());
        assert_eq!((cfg.max_speed, cfg.max_acceleration), (1.0, f64::INFINITY));
        a.correction_rate = -1.0;
        assert!(format!("{:#}", a.config(0.55).unwrap_err()).contains("max_correction_rate"));
        // Every listed parameter is one it takes.
        for p in PARAMS {
            let v = if p.contains("stamped") || p == "compensate" {
                toml::Value::Boolean(true)
            } else if p == "thread_priority" {
                toml::Value::Integer(10)
            } else {
                toml::Value::Float(1.0)
            };
            a.apply(p, &v).unwrap();
        }
    }

    #[test]
    fn names_resolve_in_the_namespace_after_the_remaps() {
        let ros = terraslip_node::RosArgs::parse(
            &["-r".into(), "cmd_vel:=/husky/cmd_vel".into()],
            "terraslip",
        )
        .unwrap();
        assert_eq!(resolve(&ros, CMD_OUT, "/robot"), "/husky/cmd_vel");
        assert_eq!(resolve(&ros, CMD_IN, "/robot"), "/robot/cmd_vel_nav");
        assert_eq!(resolve(&ros, CMD_IN, "/"), "/cmd_vel_nav");
    }
}
