//! The estimator over the family of worlds (`terraslip_sim::family`):
//! distributions of its figures per estimator.
//!
//!     cargo run -p terraslip --release --example family -- --worlds 50 [--subset gnss2m] [--estimator NAME|config:FILE]...

use std::sync::Mutex;

use terraslip::config::EstimatorConfig;
use terraslip::metrics::{self, ReconvergenceSpec};
use terraslip::pipeline::{self, RunOptions, TerrainEvidence};
use terraslip_sim::family::{world, Subset};
use terraslip_sim::{simulate, SimRun};

#[derive(Debug, Clone, Default)]
struct Figures {
    rms_d_cm: f64,
    rms_y_cm: f64,
    rms_alpha_pct: f64,
    reconv_from_turn: Option<f64>,
    drift_pct: f64,
    pred_m: f64,
    nees_pose: f64,
    nees_icr: f64,
    /// Per component: east, north, yaw, d, alpha, x_c.
    nees_parts: [f64; 6],
}

fn pred_error(run: &pipeline::EstimateRun, sim: &SimRun) -> f64 {
    let tr = &sim.truth;
    let w = &sim.log.wheels;
    let t0 = w[0].t + 60.0;
    let mut errs = Vec::new();
    let mut t = t0;
    let end = tr.last().map_or(0.0, |s| s.t) - 2.0;
    let at = |t: f64| {
        let i = tr.partition_point(|s| s.t < t).min(tr.len() - 1);
        tr[i]
    };
    while t < end {
        let k = run.rows.partition_point(|r| r.t <= t).max(1) - 1;
        let r = &run.rows[k];
        let p = terraslip_core::IcrParams {
            y_l: r.y_l,
            y_r: r.y_r,
            x_c: r.x_c,
            alpha_l: r.alpha_l,
            alpha_r: r.alpha_r,
        };
        let s0 = at(t);
        let (mut e, mut n, mut y) = (s0.east, s0.north, s0.yaw);
        let mut i = w.partition_point(|x| x.t <= t);
        let mut tc = t;
        while i < w.len() && tc < t + 2.0 {
            let tn = w[i].t.min(t + 2.0);
            let dt = tn - tc;
            let tw = p.twist(w[i].v_left, w[i].v_right);
            e += dt * (tw.v_x * y.cos() - tw.v_y * y.sin());
            n += dt * (tw.v_x * y.sin() + tw.v_y * y.cos());
            y += dt * tw.omega;
            tc = tn;
            if tn >= w[i].t {
                i += 1;
            }
        }
        let s1 = at(t + 2.0);
        errs.push((e - s1.east).hypot(n - s1.north));
        t += 1.0;
    }
    errs.iter().sum::<f64>() / errs.len().max(1) as f64
}

fn figures(run: &pipeline::EstimateRun, sim: &SimRun, outage: (f64, f64)) -> Figures {
    let log = &sim.log;
    let rms = metrics::steady_state_rms(run, &log.truth, &log.terrain, 20.0);
    let spec = ReconvergenceSpec {
        turn_angle: 0.5,
        ..Default::default()
    };
    let rec = metrics::reconvergence(run, &log.truth, &log.terrain, spec);
    let worst = rec
        .iter()
        .fold(Some(0.0f64), |w, r| match (w, r.from_turn) {
            (Some(a), Some(b)) => Some(a.max(b)),
            (w, None) if r.first_turn.is_none() => w,
            _ => None,
        });
    let drift = metrics::outage_drift(run, &log.truth, outage.0, outage.1);
    // alpha RMS and NEES every 1 s after 20 s.
    let (mut sa, mut n, mut nees_p, mut nees_i, mut nn) = (0.0, 0, 0.0, 0.0, 0);
    let mut parts = [0.0; 6];
    let mut next = run.rows[0].t + 20.0;
    let changes: Vec<f64> = log
        .terrain
        .windows(2)
        .filter(|w| w[0].terrain != w[1].terrain)
        .map(|w| w[1].t)
        .collect();
    for r in &run.rows {
        if r.t < next || changes.iter().any(|c| r.t >= *c && r.t < c + 20.0) {
            continue;
        }
        next = r.t + 1.0;
        let i = sim
            .truth
            .partition_point(|s| s.t < r.t)
            .min(sim.truth.len() - 1);
        let s = &sim.truth[i];
        let ea = 0.5 * (r.alpha_l + r.alpha_r) - 0.5 * (s.icr.alpha_l + s.icr.alpha_r);
        sa += ea * ea;
        n += 1;
        let (dx, dy) = (r.east - s.east, r.north - s.north);
        let dyaw = terraslip_core::angle::wrap(r.yaw - s.yaw);
        nees_p += (dx / r.std[0]).powi(2) + (dy / r.std[1]).powi(2) + (dyaw / r.std[2]).powi(2);
        nees_i += ((r.y_l - s.icr.y_l) / r.std[3]).powi(2)
            + ((r.y_r - s.icr.y_r) / r.std[4]).powi(2)
            + ((r.x_c - s.icr.x_c) / r.std[5]).powi(2);
        let ed = (r.y_l - r.y_r) - (s.icr.y_l - s.icr.y_r);
        let sa_ = 0.5 * (r.std[6] + r.std[7]);
        for (k, v) in [
            dx / r.std[0],
            dy / r.std[1],
            dyaw / r.std[2],
            ed / r.std_spread,
            ea / sa_,
            (r.x_c - s.icr.x_c) / r.std[5],
        ]
        .into_iter()
        .enumerate()
        {
            parts[k] += v * v;
        }
        nn += 1;
    }
    Figures {
        rms_d_cm: 100.0 * rms.d,
        rms_y_cm: 100.0 * rms.y_l.max(rms.y_r),
        rms_alpha_pct: 100.0 * (sa / n.max(1) as f64).sqrt(),
        reconv_from_turn: worst,
        drift_pct: drift.map_or(f64::NAN, |d| d.percent),
        pred_m: pred_error(run, sim),
        nees_pose: nees_p / nn.max(1) as f64,
        nees_icr: nees_i / nn.max(1) as f64,
        nees_parts: parts.map(|v| v / nn.max(1) as f64),
    }
}

fn quant(v: &mut [f64], q: f64) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    if v.is_empty() {
        return f64::NAN;
    }
    v[((v.len() - 1) as f64 * q).round() as usize]
}

fn main() -> anyhow::Result<()> {
    let mut worlds = 20u64;
    let mut first = 1u64;
    let mut subset = Subset::All;
    let mut names: Vec<String> = Vec::new();
    let mut verbose = false;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--worlds" => worlds = args.next().and_then(|s| s.parse().ok()).unwrap_or(20),
            "--first-seed" => first = args.next().and_then(|s| s.parse().ok()).unwrap_or(1),
            "--subset" => {
                subset = match args.next().as_deref() {
                    Some("gnss2m") => Subset::Gnss2m,
                    _ => Subset::All,
                }
            }
            "--estimator" => names.extend(args.next()),
            "--verbose" => verbose = true,
            "--write" => {
                // Writes world --first-seed to DIR and exits.
                let dir = args.next().unwrap_or_default();
                let w = world(first, subset);
                let mut sim = simulate(&w.scenario, first)?;
                for p in &mut sim.log.pose {
                    p.t += w.clock_offset;
                    if !w.stated_std {
                        p.std_xy = None;
                        p.std_yaw = None;
                    }
                }
                sim.write(&dir)?;
                // Re-write pose.csv with the offset and the columns decided above.
                let mut text = String::from(if w.stated_std {
                    "t,east,north,yaw,std_xy,std_yaw\n"
                } else {
                    "t,east,north,yaw\n"
                });
                let o = |v: Option<f64>| v.map_or(String::new(), |x| x.to_string());
                for p in &sim.log.pose {
                    if w.stated_std {
                        text.push_str(&format!(
                            "{},{},{},{},{},{}\n",
                            p.t,
                            o(p.east),
                            o(p.north),
                            o(p.yaw),
                            o(p.std_xy),
                            o(p.std_yaw)
                        ));
                    } else {
                        text.push_str(&format!(
                            "{},{},{},{}\n",
                            p.t,
                            o(p.east),
                            o(p.north),
                            o(p.yaw)
                        ));
                    }
                }
                std::fs::write(format!("{dir}/pose.csv"), text)?;
                println!(
                    "outage {:?} (+ clock offset {:.3})",
                    w.outage, w.clock_offset
                );
                return Ok(());
            }
            other => anyhow::bail!("unknown argument {other}"),
        }
    }
    if names.is_empty() {
        names = vec!["terraslip".into(), "ekf-qmin".into(), "no-slip".into()];
    }
    let cfgs: Vec<(String, EstimatorConfig)> = names
        .iter()
        .map(|n| {
            let c = match n.strip_prefix("config:") {
                Some(path) => EstimatorConfig::from_toml(&std::fs::read_to_string(path)?)?,
                None => EstimatorConfig::preset(n).ok_or_else(|| anyhow::anyhow!("preset {n}"))?,
            };
            Ok((n.clone(), c))
        })
        .collect::<anyhow::Result<_>>()?;
    let results: Mutex<Vec<(u64, usize, Figures)>> = Mutex::new(Vec::new());
    let seeds: Vec<u64> = (first..first + worlds).collect();
    let next = Mutex::new(0usize);
    std::thread::scope(|s| {
        for _ in 0..2 {
            s.spawn(|| loop {
                let k = {
                    let mut g = next.lock().unwrap();
                    let k = *g;
                    *g += 1;
                    k
                };
                let Some(&seed) = seeds.get(k) else { break };
                let w = world(seed, subset);
                let mut sim = simulate(&w.scenario, seed).expect("family world simulates");
                for p in &mut sim.log.pose {
                    p.t += w.clock_offset;
                    if !w.stated_std {
                        p.std_xy = None;
                        p.std_yaw = None;
                    }
                }
                let outage = (w.outage.0 + w.clock_offset, w.outage.1 + w.clock_offset);
                for (i, (_, cfg)) in cfgs.iter().enumerate() {
                    let run = pipeline::run_with(
                        &sim.log,
                        cfg,
                        &TerrainEvidence::None,
                        None,
                        RunOptions {
                            outage: Some(outage),
                        },
                        &mut |_, _| {},
                    )
                    .expect("run");
                    let f = figures(&run, &sim, w.outage);
                    if verbose {
                        eprintln!(
                            "seed {seed:3} gnss {:.2} m tau {:4.0} compass {} stated {} clock {:+.2} | {:12} d {:6.2} y {:6.2} a {:5.2}% rec {:>6} drift {:6.2}% pred {:.3} nees {:.1}/{:.1}",
                            w.gnss_std,
                            w.scenario.gnss.markov_tau * (w.scenario.gnss.markov_std > 0.0) as u8 as f64,
                            w.scenario.compass.rate > 0.0,
                            w.stated_std,
                            w.clock_offset,
                            names[i],
                            f.rms_d_cm,
                            f.rms_y_cm,
                            f.rms_alpha_pct,
                            f.reconv_from_turn.map_or("never".into(), |v| format!("{v:.1}")),
                            f.drift_pct,
                            f.pred_m,
                            f.nees_pose,
                            f.nees_icr
                        );
                    }
                    results.lock().unwrap().push((seed, i, f));
                }
            });
        }
    });
    let results = results.into_inner().unwrap();
    println!("{} worlds ({:?}), median / p90 / worst", worlds, subset);
    for (i, name) in names.iter().enumerate() {
        let mine: Vec<&Figures> = results.iter().filter(|r| r.1 == i).map(|r| &r.2).collect();
        let col = |f: &dyn Fn(&Figures) -> f64| {
            let mut v: Vec<f64> = mine
                .iter()
                .map(|x| f(x))
                .filter(|x| x.is_finite())
                .collect();
            format!(
                "{:.2} / {:.2} / {:.2}",
                quant(&mut v, 0.5),
                quant(&mut v, 0.9),
                quant(&mut v, 1.0)
            )
        };
        println!("{name}");
        println!("  RMS d cm          {}", col(&|f| f.rms_d_cm));
        println!("  RMS y cm          {}", col(&|f| f.rms_y_cm));
        println!("  RMS alpha %       {}", col(&|f| f.rms_alpha_pct));
        println!(
            "  reconv s          {}  (never: {})",
            col(&|f| f.reconv_from_turn.unwrap_or(f64::INFINITY)),
            mine.iter().filter(|f| f.reconv_from_turn.is_none()).count()
        );
        println!("  drift %           {}", col(&|f| f.drift_pct));
        println!("  pred 2 s m        {}", col(&|f| f.pred_m));
        println!("  NEES pose (3)     {}", col(&|f| f.nees_pose));
        println!("  NEES icr (3)      {}", col(&|f| f.nees_icr));
        for (k, name) in ["east", "north", "yaw", "d", "alpha", "x_c"]
            .iter()
            .enumerate()
        {
            println!("    NEES {name:6} (1) {}", col(&|f| f.nees_parts[k]));
        }
    }
    Ok(())
}
