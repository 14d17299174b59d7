//! Prints a summary of a simulated drive:
//! `cargo run -p terraslip-sim --release --example inspect -- papers 1 [OUTDIR] [--trace]`;
//! `--trace` adds the truth every 100 samples.
use terraslip_sim::{simulate, Scenario};

fn main() {
    let trace = std::env::args().any(|a| a == "--trace");
    let args: Vec<String> = std::env::args().filter(|a| a != "--trace").collect();
    let name = args.get(1).map(String::as_str).unwrap_or("papers");
    let seed: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1);
    let sc = match Scenario::resolve(name) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("{e}");
            std::process::exit(1)
        }
    };
    let t0 = std::time::Instant::now();
    let run = simulate(&sc, seed).expect("simulate");
    println!("simulated {} s in {:?}", sc.duration(), t0.elapsed());
    let tr = &run.truth;
    let mut dist = 0.0;
    let mut far: f64 = 0.0;
    let mut turning = 0;
    let mut stopped = 0;
    for w in tr.windows(2) {
        dist += (w[1].east - w[0].east).hypot(w[1].north - w[0].north);
        far = far.max(w[1].east.hypot(w[1].north));
        if w[1].twist.omega.abs() > 0.1 {
            turning += 1;
        }
        if w[1].twist.v_x.abs() < 0.02 && w[1].twist.omega.abs() < 0.02 {
            stopped += 1;
        }
    }
    println!(
        "distance {dist:.1} m, farthest {far:.1} m, turning {:.0} %, stopped {:.0} %",
        100.0 * turning as f64 / tr.len() as f64,
        100.0 * stopped as f64 / tr.len() as f64
    );
    for (i, ter) in run.terrains.iter().enumerate() {
        let d: Vec<f64> = tr
            .iter()
            .filter(|s| s.terrain == i)
            .map(|s| s.icr.y_l - s.icr.y_r)
            .collect();
        let mn = d.iter().cloned().fold(f64::MAX, f64::min);
        let mx = d.iter().cloned().fold(f64::MIN, f64::max);
        let p = ter.icr(&sc.robot);
        let mean = d.iter().sum::<f64>() / d.len() as f64;
        let sd = (d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / d.len() as f64).sqrt();
        println!("{:>9}: spread mean {mean:.4} m, std about the mean {:.2} cm (a constant estimate's floor)", ter.name, 100.0 * sd);
        println!(
            "{:>9}: nominal y_l {:.4} y_r {:.4} x_c {:.4} alpha {:.3}/{:.3}  spread {:.4}..{:.4}",
            ter.name, p.y_l, p.y_r, p.x_c, p.alpha_l, p.alpha_r, mn, mx
        );
    }
    let mut errs = Vec::new();
    for p in &run.log.pose {
        if let (Some(e), Some(n)) = (p.east, p.north) {
            if let Some(s) = run.truth_at(p.t) {
                errs.push((e - s.east, n - s.north));
            }
        }
    }
    let rms =
        (errs.iter().map(|e| e.0 * e.0 + e.1 * e.1).sum::<f64>() / (2 * errs.len()) as f64).sqrt();
    let big = errs.iter().filter(|e| e.0.hypot(e.1) > 15.0).count();
    println!(
        "pose rows {}, fixes {}, gnss rms/axis {rms:.2} m, jumps {big}",
        run.log.pose.len(),
        errs.len()
    );
    println!(
        "wheels {}, imu {}, frames {}",
        run.log.wheels.len(),
        run.log.imu.len(),
        run.frames.len()
    );
    if trace {
        for s in tr.iter().step_by(100) {
            println!(
                "{:6.1} {:>8} e {:7.2} n {:7.2} r {:5.1} vx {:5.2} w {:6.3}",
                s.t,
                run.terrains[s.terrain].name,
                s.east,
                s.north,
                s.east.hypot(s.north),
                s.twist.v_x,
                s.twist.omega
            );
        }
    }
    if let Some(out) = args.get(3) {
        let t0 = std::time::Instant::now();
        run.write(out).expect("write");
        println!("written to {out} in {:?}", t0.elapsed());
    }
}
