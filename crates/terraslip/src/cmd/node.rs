//! `terraslip node`: the online estimator on a live ROS 2 graph (RustDDS,
//! no ROS install). Topics are read as `import` reads a bag's, the samples
//! put back in stamp order by the live pipeline, and each estimate row
//! published as `estimate --mcap` writes it.

//!
//! The flags and parameters are [`super::node_args`]'s (served on the
//! parameter services by [`super::node_params`]), the publishers
//! [`super::node_outputs`]'s, `--compensate`'s command path
//! [`super::node_compensate`]'s.

use std::path::Path;
use std::time::{Duration, Instant, SystemTime};

use anyhow::{Context, Result};
use terraslip::live_streams::{start_width, LiveStreams};
use terraslip::pipeline::decide::Decisions;
use terraslip::pipeline::warmup::WarmUp;
use terraslip::pipeline::EstimateRun;
use terraslip_core::compensate::IcrModel;
use terraslip_io::ParamsFile;
use terraslip_node::{Graph, GraphTopic, RosArgs, RosEnv, TopicQos, Wait};
use terraslip_ros2::import::{LiveRow, Settled};

use super::node_args::{apply_node_params, warn_unmatched_remaps, with_params, Args};
use super::node_compensate::{resolve, CommandThread, CMD_IN, CMD_OUT};
use super::node_outputs::{is_ours, BadMessages, Outputs};
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
    // With no topics file the streams are chosen as `import` chooses them,
    // from the data of the warm-up window.
    let choose = matches!(super::bag::topics(), terraslip::bag::Topics::ByType);
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
    let track_width = start_width(args.track_width, &topics_cfg, cfg.init.default_track_width);
    let recalled_delay = start
        .as_ref()
        .and_then(|p| p.extra.get("gyro_delay_s")?.as_f64());

    let stop = terraslip_node::signals::Stop::install().context("signal handlers")?;
    let env = RosEnv::from_env()?;
    let (graph, param_changes) = Graph::join_serving(
        &name,
        &namespace,
        env,
        super::node_params::parameters(&args),
    )?;
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
    let ours = |topic: &str| is_ours(topic, cmd_topics.as_ref());

    // The streams, once the graph shows them.
    let mut said = String::new();
    let window = WarmUp::window(args.warmup, args.lag);
    let (topics, mut streams) = loop {
        if stop.asked() {
            return commands.map_or(Ok(()), CommandThread::finish);
        }
        std::thread::sleep(Duration::from_secs_f64(args.discovery_wait.max(0.1)));
        let running = super::node_params::Running {
            args: &mut args,
            out: None,
            graph: &graph,
            commands: commands.as_ref(),
            next_save: &mut None,
        };
        super::node_params::apply_all(&param_changes, running)?;
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
        match LiveStreams::new(&label, bag_topics, &topics_cfg, choose, window) {
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
    if choose {
        eprintln!(
            "no topics file: every candidate topic is read over the first {window} s of stamp time, and `import` decides from them which feeds which stream"
        );
    }
    for (idx, roles) in streams.subscriptions() {
        let gt = topics[idx].clone();
        // Static transforms and the URDF are published once, latched.
        let qos = if roles == ["tf"]
            || ["/tf_static", "/robot_description"].contains(&gt.name.as_str())
        {
            TopicQos::Latched
        } else {
            TopicQos::Sensor
        };
        eprintln!("reading {} ({}) for {}", gt.name, gt.ty, roles.join(", "));
        readers.push((idx, graph.reader(&gt, qos)?, 0u64, qos));
    }
    let mut wait = Wait::new().context("event poll")?;
    for (k, r) in readers.iter_mut().enumerate() {
        wait.register(&mut r.1, k).context("event poll")?;
    }

    let (name_ref, cfg_ref) = (label.as_str(), &cfg);
    let (lag, span, gyro_delay) = (args.lag, args.warmup, args.gyro_delay);
    // What the pose reference is: the flag (or `-p pose_reference:=`),
    // else the topics file's `[meta]`, as `import` writes it into a log's
    // meta.toml.
    let pose_reference = args.pose_reference.or(topics_cfg.meta.pose_reference);
    let warm_up = move |track_width: f64, start: Option<ParamsFile>| {
        let mut w = WarmUp::new(
            name_ref,
            cfg_ref,
            track_width,
            start,
            lag,
            span,
            gyro_delay,
            recalled_delay,
        )?;
        w.set_pose_reference(pose_reference);
        Ok::<_, terraslip::pipeline::PipelineError>(w)
    };
    // Built once the streams are known (with no topics file, at the end
    // of the window, from what it settled).
    let mut start = Some(start);
    let mut live = match choose {
        true => None,
        false => Some(warm_up(track_width, start.take().flatten())?),
    };
    let widths = (args.track_width, cfg.init.default_track_width);
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
        let running = super::node_params::Running {
            args: &mut args,
            out: Some(&mut out),
            graph: &graph,
            commands: commands.as_ref(),
            next_save: &mut next_save,
        };
        super::node_params::apply_all(&param_changes, running)?;
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
                match streams.message(*idx, recv_ns, &raw.0) {
                    Ok(rows) => batch.extend(rows),
                    Err(e) => bad.note(&e.to_string()),
                }
            }
        }
        if streams.due() {
            batch.extend(streams.decide()?);
        }
        if let Some(width) = settle(&mut streams, &mut out, &mut bad, widths) {
            live = Some(warm_up(width, start.take().flatten())?);
        }
        say_revisited(&mut streams, &mut out);
        out.origin_ns = streams.origin_ns().unwrap_or(0);
        if let Some(live) = live.as_mut().filter(|l| l.decisions().is_none()) {
            // Where the pose reference sits, as `import` reads it.
            let (mount, said) = streams.lever_arm();
            said.into_iter().for_each(|l| eprintln!("decided: {l}"));
            live.set_pose_mount(mount);
        }
        batch.sort_by(|a, b| a.t().total_cmp(&b.t()));
        for r in batch {
            if let LiveRow::Wheels(w) = &r {
                out.wheels.push_back((w.t, w.v_left, w.v_right));
            }
            let live = live
                .as_mut()
                .context("rows before the streams were chosen")?;
            if let Some(d) = live.push(r.into(), &mut out)? {
                say_decided(&d);
            }
        }
        if got {
            last_message = Some(Instant::now());
        }
        out.failed()?;
        // The command thread takes the model of each new estimate.
        if let (Some(c), Some(l), Some(b)) =
            (&commands, live.as_ref().and_then(WarmUp::live), &out.belief)
        {
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
        if let (Some(t), Some(live)) = (out.last_t, &live) {
            if let Some(summary) = live.summary() {
                if out.diagnostics_due.is_none_or(|d| t >= d) {
                    out.diagnostics_due = Some(t + 1.0);
                    out.diagnostics(&summary, live, &bad)?;
                }
                let due = *next_save.get_or_insert(t + args.save_every);
                if t >= due {
                    next_save = Some(t + args.save_every);
                    save(&params_path, &summary, driven_before, live, &out)?;
                }
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
    // A run shorter than the window: decided from what came.
    let mut rest = streams.decide()?;
    if let Some(width) = settle(&mut streams, &mut out, &mut bad, widths) {
        live = Some(warm_up(width, start.take().flatten())?);
    }
    say_revisited(&mut streams, &mut out);
    out.origin_ns = streams.origin_ns().unwrap_or(0);
    rest.sort_by(|a, b| a.t().total_cmp(&b.t()));
    let mut saved = false;
    if let Some(live) = &mut live {
        for r in rest {
            if let LiveRow::Wheels(w) = &r {
                out.wheels.push_back((w.t, w.v_left, w.v_right));
            }
            live.push(r.into(), &mut out)?;
        }
        if let Some(d) = live.flush(&mut out)? {
            say_decided(&d);
        }
        out.failed()?;
        if let Some(summary) = live.summary() {
            out.diagnostics(&summary, live, &bad)?;
            saved = save(&params_path, &summary, driven_before, live, &out)?;
        }
    }
    eprintln!(
        "node: {} estimates published, {} bad messages, late samples {:?}; {}",
        out.published,
        bad.count,
        live.as_ref().map(WarmUp::late).unwrap_or_default(),
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
fn save(
    path: &Path,
    run: &EstimateRun,
    driven_before: f64,
    live: &WarmUp,
    out: &Outputs,
) -> Result<bool> {
    let decided = live.decisions().map(|d| d.to_json());
    super::node_state::save(path, run, driven_before, decided, &out.revisited)
}

/// Prints the decisions made again since the last call and keeps every
/// one for the diagnostics and the parameters file.
fn say_revisited(streams: &mut LiveStreams, out: &mut Outputs) {
    let new = streams.take_revisions();
    if !new.is_empty() {
        new.iter().for_each(|r| eprintln!("decided: {}", r.line));
        out.revisited = streams.revisions();
    }
}

/// Once the warm-up window has settled the streams (with no topics file):
/// prints what it settled as `import` says it, keeps the lines for the
/// diagnostics, notes the held messages that made no row, and returns the
/// track width the model starts from (`widths`: `--track-width` and the
/// default).
fn settle(
    streams: &mut LiveStreams,
    out: &mut Outputs,
    bad: &mut BadMessages,
    widths: (Option<f64>, f64),
) -> Option<f64> {
    for e in streams.take_bad() {
        bad.note(&e);
    }
    let s: Settled = streams.take_settled()?;
    eprint!("{}", s.report.to_text());
    for w in &s.report.warnings {
        eprintln!("warning: {w}");
    }
    let lines = s
        .report
        .streams
        .iter()
        .map(|r| format!("{} ({}) -> {}", r.topic, r.ty, r.file));
    out.settled = lines.chain(s.report.decisions.iter().cloned()).collect();
    Some(start_width(widths.0, &s.topics, widths.1))
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
