//! One simulated drive of the default estimator, traced against the truth:
//! where a large outage drift or a slow change comes from.
//!
//!     cargo run -p terraslip --release --example estimator_trace -- SCENARIO SEED [T0 T1] [--step S]
//!
//! Prints, every `S` s (default 2) in `[T0, T1]` (default the whole drive):
//! the true turn rate and tread speed difference, the spread in effect
//! (estimate, truth, error), the common speed factor, the factor difference
//! per unit spread `z = (alpha_l - alpha_r)/d` (estimate, truth), the
//! learned slope, and the sensors' own errors over the bin (compass: mean
//! of observed minus true yaw; GNSS: mean east / north error; fixes fused
//! and gated). Then, over the scenario's GNSS outage, the heading change
//! error split exactly into what the spread, the common factor and the
//! factor difference in effect contribute (the measured tread speeds
//! through the estimated ICRs against the same speeds through the true
//! ones), and the rest (encoder quantisation, the simulator's lag): the
//! integral of `omega_est - omega_true` over the rows. `TUNE=file.toml`
//! overrides the default configuration.

use terraslip::config::EstimatorConfig;
use terraslip::metrics;
use terraslip::pipeline::{self, RunOptions, TerrainEvidence};
use terraslip_core::angle;
use terraslip_sim::{simulate, Scenario};

fn main() -> anyhow::Result<()> {
    let mut pos: Vec<String> = Vec::new();
    let mut step = 2.0;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--step" => step = args.next().and_then(|s| s.parse().ok()).unwrap_or(2.0),
            _ => pos.push(a),
        }
    }
    let name = pos.first().cloned().unwrap_or_else(|| "papers-icr3".into());
    let seed: u64 = pos.get(1).and_then(|s| s.parse().ok()).unwrap_or(1);
    let mut cfg = EstimatorConfig::default();
    if let Ok(path) = std::env::var("TUNE") {
        cfg = EstimatorConfig::from_toml(&std::fs::read_to_string(&path)?)?;
    }
    let sc = Scenario::resolve(&name)?;
    let sim = simulate(&sc, seed)?;
    let log = &sim.log;
    let ev = TerrainEvidence::Labels(log.terrain.clone());
    let outage = metrics::find_position_outage(&log.pose, 20.0);
    let run = pipeline::run_with(log, &cfg, &ev, None, RunOptions { outage }, &mut |_, _| {})?;
    let t_end = run.rows.last().map_or(0.0, |r| r.t);
    let t0: f64 = pos.get(2).and_then(|s| s.parse().ok()).unwrap_or(0.0);
    let t1: f64 = pos.get(3).and_then(|s| s.parse().ok()).unwrap_or(t_end);
    let truth_at = |t: f64| {
        &sim.truth[sim
            .truth
            .partition_point(|s| s.t < t)
            .min(sim.truth.len() - 1)]
    };

    println!("## {name} seed {seed}: outage {outage:?}");
    for (k, l) in log.terrain.iter().enumerate() {
        if k == 0 || l.terrain != log.terrain[k - 1].terrain {
            println!("terrain {} from {:.1} s", l.terrain, l.t);
        }
    }
    println!("\n| t (s) | terrain | omega true (rad/s) | dv (m/s) | V (m/s) | d est (cm) | d true (cm) | d err (cm) | alpha est | alpha true | z est (1/m) | z true | k (s/m) | compass err (deg) | GNSS err e/n (m) | fused / gated |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut b = t0;
    while b < t1 {
        let e = (b + step).min(t1);
        let rows: Vec<_> = run.rows.iter().filter(|r| r.t >= b && r.t < e).collect();
        if rows.is_empty() {
            b = e;
            continue;
        }
        let n = rows.len() as f64;
        let mean =
            |f: &dyn Fn(&pipeline::EstimateRow) -> f64| rows.iter().map(|r| f(r)).sum::<f64>() / n;
        let tmean = |f: &dyn Fn(&terraslip_sim::TruthState) -> f64| {
            rows.iter().map(|r| f(truth_at(r.t))).sum::<f64>() / n
        };
        let d_e = mean(&|r| r.y_l - r.y_r);
        let d_t = tmean(&|s| s.icr.y_l - s.icr.y_r);
        let a_e = mean(&|r| 0.5 * (r.alpha_l + r.alpha_r));
        let a_t = tmean(&|s| 0.5 * (s.icr.alpha_l + s.icr.alpha_r));
        let z_e = mean(&|r| (r.alpha_l - r.alpha_r) / (r.y_l - r.y_r));
        let z_t = tmean(&|s| (s.icr.alpha_l - s.icr.alpha_r) / (s.icr.y_l - s.icr.y_r));
        let om = tmean(&|s| s.twist.omega);
        let dv = tmean(&|s| s.v_right - s.v_left);
        let vm = tmean(&|s| 0.5 * (s.v_right + s.v_left));
        let k = rows.last().map_or(0.0, |r| r.k_spread);
        let fused = rows.iter().filter(|r| r.fused).count();
        let gated = rows.iter().filter(|r| r.gated).count();
        let fixes: Vec<_> = log.pose.iter().filter(|p| p.t >= b && p.t < e).collect();
        let (mut cy, mut ny, mut ce, mut cn, mut np) = (0.0, 0, 0.0, 0.0, 0);
        for p in &fixes {
            let Some(tr) = metrics::truth_at(&log.truth, p.t) else {
                continue;
            };
            if let Some(y) = p.yaw {
                cy += angle::wrap(y - tr.yaw);
                ny += 1;
            }
            if let (Some(pe), Some(pn)) = (p.east, p.north) {
                ce += pe - tr.east;
                cn += pn - tr.north;
                np += 1;
            }
        }
        let compass = if ny > 0 {
            format!("{:+.2}", (cy / ny as f64).to_degrees())
        } else {
            "-".into()
        };
        let gnss = if np > 0 {
            format!("{:+.2} / {:+.2}", ce / np as f64, cn / np as f64)
        } else {
            "-".into()
        };
        println!(
            "| {b:.0} | {} | {om:+.3} | {dv:+.3} | {vm:.2} | {:.2} | {:.2} | {:+.2} | {a_e:.4} | {a_t:.4} | {z_e:+.4} | {z_t:+.4} | {k:+.3} | {compass} | {gnss} | {fused} / {gated} |",
            rows[0].terrain.and_then(|i| run.terrains.get(i)).map_or("-", |s| s.as_str()),
            100.0 * d_e,
            100.0 * d_t,
            100.0 * (d_e - d_t),
        );
        b = e;
    }

    // The heading change error over the outage, split by ICR coordinate.
    if let Some((o0, o1)) = outage {
        let i0 = run.rows.partition_point(|r| r.t < o0);
        let i1 = run.rows.partition_point(|r| r.t < o1).saturating_sub(1);
        let (mut p_d, mut p_a, mut p_z, mut rest, mut est) = (0.0, 0.0, 0.0, 0.0, 0.0);
        let mut true_turn = 0.0;
        // The spread part split by turn regime: |dv| below / above 0.1 m/s.
        let (mut p_d_low, mut p_d_high) = (0.0, 0.0);
        for i in (i0 + 1)..=i1.min(run.rows.len() - 1) {
            let (r, w) = (&run.rows[i], &log.wheels[i]);
            let dt = r.t - run.rows[i - 1].t;
            let s = truth_at(r.t);
            let (vl, vr) = (w.v_left, w.v_right);
            let (d_e, d_t) = (r.y_l - r.y_r, s.icr.y_l - s.icr.y_r);
            let n_t = s.icr.alpha_r * vr - s.icr.alpha_l * vl;
            let pd = n_t * (1.0 / d_e - 1.0 / d_t) * dt;
            p_d += pd;
            if (vr - vl).abs() < 0.1 {
                p_d_low += pd;
            } else {
                p_d_high += pd;
            }
            let da = 0.5 * (r.alpha_l + r.alpha_r) - 0.5 * (s.icr.alpha_l + s.icr.alpha_r);
            p_a += da * (vr - vl) / d_e * dt;
            let dz = (r.alpha_l - r.alpha_r) - (s.icr.alpha_l - s.icr.alpha_r);
            p_z -= dz * 0.5 * (vr + vl) / d_e * dt;
            let yaw_true = angle::wrap(s.yaw - truth_at(run.rows[i - 1].t).yaw);
            rest += n_t / d_t * dt - yaw_true;
            true_turn += yaw_true;
            est += angle::wrap(r.yaw - run.rows[i - 1].yaw);
        }
        // The fastest turns (|dv|, m/s) before the outage and in it: the law
        // is linear in |dv| and extrapolates beyond what it learned from.
        let max_dv = |a: f64, b: f64| {
            sim.truth
                .iter()
                .filter(|s| s.t >= a && s.t < b)
                .map(|s| (s.v_right - s.v_left).abs())
                .fold(0.0, f64::max)
        };
        let a_at = |t: f64| {
            let r = &run.rows[run
                .rows
                .partition_point(|r| r.t < t)
                .min(run.rows.len() - 1)];
            0.5 * (r.alpha_l + r.alpha_r)
        };
        println!(
            "\nsummary seed {seed}: alpha est at 30 s {:.4}, at the outage {:.4} (true {:.4}); max |dv| before the outage {:.3}, in it {:.3} m/s",
            a_at(30.0),
            a_at(o0),
            0.5 * (truth_at(o0).icr.alpha_l + truth_at(o0).icr.alpha_r),
            max_dv(0.0, o0),
            max_dv(o0, o1)
        );
        let drift = metrics::outage_drift(&run, &log.truth, o0, o1);
        println!("\nOutage {o0:.1}-{o1:.1} s: heading change error (deg), estimate minus truth:");
        if let Some(dr) = drift {
            println!(
                "  total {:+.2} (drift {:.2} %, along {:+.2} %, across {:+.2} %)",
                dr.yaw_error.to_degrees(),
                dr.percent,
                100.0 * dr.along / dr.distance,
                100.0 * dr.cross / dr.distance
            );
        }
        println!(
            "  spread {:+.2} (|dv| < 0.1 m/s {:+.2}, above {:+.2}), common factor {:+.2}, factor difference {:+.2}, encoders and lag {:+.2}; sum {:+.2}, the rows' own {:+.2}; true heading change {:+.1}",
            p_d.to_degrees(),
            p_d_low.to_degrees(),
            p_d_high.to_degrees(),
            p_a.to_degrees(),
            p_z.to_degrees(),
            rest.to_degrees(),
            (p_d + p_a + p_z + rest).to_degrees(),
            (est - (true_turn)).to_degrees(),
            true_turn.to_degrees()
        );
    }
    Ok(())
}
