//! `terraslip node`: the online estimator on a live ROS 2 graph (RustDDS,
//! no ROS install). Topics are read as `import` reads a bag's, the samples
//! put back in stamp order by the live pipeline, and each estimate row
//! published as `estimate --mcap` writes it.

//!
//! The flags and parameters are [`super::node_args`]'s, the publishers
//! [`super::node_outputs`]'s, `--compensate`'s command path
//! [`super::node_compensate`]'s.

use std::path::Path;
use std::time::{Duration, Instant, SystemTime};

use anyhow::{Context, Result};
use terraslip::pipeline::decide::Decisions;
use terraslip::pipeline::live::Sample;
use terraslip::pipeline::warmup::WarmUp;
use terraslip::pipeline::EstimateRun;
use terraslip_core::compensate::IcrModel;
use terraslip_io::ParamsFile;
use terraslip_node::{Graph, GraphTopic, RosArgs, RosEnv, TopicQos, Wait};
use terraslip_ros2::import::{LiveImport, LiveRow};

use super::node_args::{apply_node_params, warn_unmatched_remaps, with_params, Args};
use super::node_compensate::{resolve, CommandThread, CMD_IN, CMD_OUT};
use super::node_outputs::{BadMessages, Outputs, OUTPUT_TOPICS};
use terraslip::belief::Belief;

pub fn run(mut args: Args, ros_args: &[String]) -> Result<()> {
    let ros = RosArgs::parse(ros_args, &args.name)?;
    let name = ros.node_name.clone().unwrap_or_else(|| args.name.clone());
    let namespace = ros.namespace.clone().unwrap_or_else(|| "/".into());
    let mut table = ros.params_table();
    apply_node_params(&mut args, &mut table)?;
    // The command topics of --compensate, remapped and resolved.
    let cmd_topics = args.compensate.compensate.then(|| {
        (
            resolve(&ros, CMD_IN, &namespace),
            resolve(&ros, CMD_OUT, &namespace),
        )
    });
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
    let cmd_names: &[&str] = if cmd_topics.is_some() {
        &[CMD_IN, CMD_OUT]
    } else {
        &[]
    };
    warn_unmatched_remaps(&ros, &topics_cfg, cmd_names);
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
    // Commands are answered from now on, before the sensors are found.
    let commands = match &cmd_topics {
        Some((cmd_in, cmd_out)) => {
            let separation = args.compensate.controller_separation(
                topics_cfg
                    .wheels
                    .separation
                    .filter(|s| s.is_finite() && *s > 0.0)
                    .unwrap_or(track_width),
            );
            Some(CommandThread::start(
                &graph,
                &args.compensate,
                (cmd_in, cmd_out),
                separation,
                &args.base_frame,
            )?)
        }
        None => None,
    };
    let ours = |topic: &str| {
        OUTPUT_TOPICS.iter().any(|o| o.0 == topic)
            || cmd_topics
                .as_ref()
                .is_some_and(|(i, o)| i == topic || o == topic)
    };

    // The streams, once the graph shows them.
    let mut said = String::new();
    let (topics, mut import) = loop {
        if stop.asked() {
            return commands.map_or(Ok(()), CommandThread::finish);
        }
        std::thread::sleep(Duration::from_secs_f64(args.discovery_wait.max(0.1)));
        // Topics someone writes, other than ours.
        let found: Vec<GraphTopic> = graph
            .topics()
            .into_iter()
            .filter(|(t, writers)| *writers > 0 && !ours(&t.name))
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
    if commands.is_some() {
        let c = &args.compensate;
        out.belief = Some(Belief::new(c.confident_spread_std, c.hold_after_change));
    }
    let mut handed = 0;
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
        // The command thread takes the model of each new estimate.
        if let (Some(c), Some(l), Some(b)) = (&commands, live.live(), &out.belief) {
            if out.published > handed {
                handed = out.published;
                c.update(
                    IcrModel::of_filter(l.estimator().filter()),
                    b.verdict.clone(),
                );
            }
        }
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
    commands.map_or(Ok(()), CommandThread::finish)
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

fn now_ns() -> u64 {
    SystemTime::now()
        .duration_since(SystemTime::UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64)
}
