//! What explains the worst held-out segments of a time split? Calibrates on
//! one half of a drive (default pipeline), scores the other half like
//! `validate` (chained 1 s segments, stored offset, written model) and
//! describes every scored segment by what the wheels and the reference did:
//!
//! * `acc`: mean |d/dt| of the mean tread speed over the segment (m/s^2,
//!   differences across five wheel samples, 0.25 s at 20 Hz);
//! * `v`: mean |mean tread speed| (m/s), `dv`: mean |v_r - v_l| (m/s),
//!   `turn`: sign of `int (v_r - v_l) dt`;
//! * `ref/tread`: reference distance over `int |v_mean| dt`;
//! * `gap`: longest interval between raw pose rows inside the segment (s);
//! * `jump`: the largest ratio, over consecutive raw poses inside the
//!   segment, of the pose speed to the faster tread's speed there (a
//!   reference no tread motion can produce is over about 1.4).
//!
//! Prints the worst segments, then the share of the MSE they make and the
//! feature means of the worst `N` against the rest, for every split.
//!
//! `cargo run --release -p terraslip-calib --example residual_diag -- DATA_DIR [DRIVE_SUBSTRING] [N_WORST]`

use terraslip_calib::validate as validate_mod;
use terraslip_calib::*;
use terraslip_io::DriveLog;

mod common;

#[derive(Default, Clone, Copy)]
struct Feat {
    err2: f64,
    nom2: f64,
    along: f64,
    acc: f64,
    acc_signed: f64,
    v: f64,
    dv: f64,
    turn: f64,
    ratio: f64,
    gap: f64,
    jump: f64,
    cross: f64,
    dur: f64,
    dref: f64,
    dpred: f64,
    dtread: f64,
    /// `int max(|v_l|, |v_r|) dt`, m: how far the faster tread went.
    dfast: f64,
}

/// The reference moved farther than any tread: over 1.2x the faster
/// tread's travel + 0.2 m (the calibration gate's bound is 1.4x + 0.3 m).
/// Uses only the wheels and the reference, so it treats every model alike.
fn too_far(f: &Feat) -> bool {
    f.dref > 1.2 * f.dfast + 0.2
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dir = common::data_dir(&args);
    let only = args.get(1).cloned().unwrap_or_default();
    let n_worst: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(25);
    let logs = common::drives(&dir, &only);
    println!("| drive | split | N | worst-N share of MSE | worst-N: acc, v, dv, ref/tread, gap, jump>1.4, left turns | rest: acc, v, dv, ref/tread, gap, jump>1.4, left turns | corr(err2, acc) | corr(along err, signed acc) |");
    println!("|---|---|---|---|---|---|---|---|");
    let mut detail = String::new();
    let mut accel = String::from("\nStraight segments (|v_r - v_l| < 0.3 m/s): median reference distance over mean tread travel, steady (|a| < 0.1 m/s^2) vs accelerating or braking (|a| > 0.5), and the mean longest pose interval\n\n| drive | split | N steady | ref/tread steady | pose gap steady s | N accelerating | ref/tread accelerating | pose gap accelerating s |\n|---|---|---|---|---|---|---|---|\n");
    let mut protocol = String::from("\nScoring protocol: all segments vs without those whose reference moved over 1.2x the faster tread's travel + 0.2 m\n\n| drive | split | N | flagged | flagged share of written-model MSE | ratio, all segments | ratio, without flagged |\n|---|---|---|---|---|---|---|\n");
    for log in &logs {
        if log.name().contains("grass") {
            continue;
        }
        let (a, b) = (log.pose[0].t, log.pose[log.pose.len() - 1].t);
        let mid = 0.5 * (a + b);
        for (name, train, test) in [
            ("1st -> 2nd", (a, mid), (mid, b)),
            ("2nd -> 1st", (mid, b), (a, mid)),
        ] {
            let mut c = CalibConfig {
                method: Some(Method::Lm),
                ..Default::default()
            };
            (c.segment.t_min, c.segment.t_max) = train;
            let Ok(cal) = calibrate(std::slice::from_ref(log), &c, &|_| {}) else {
                continue;
            };
            let pf = cal.params_file();
            let mut v = ValidateConfig::default();
            (v.segment.t_min, v.segment.t_max) = test;
            let Ok(val) = validate(std::slice::from_ref(log), &pf, &v) else {
                continue;
            };
            let off = val.offsets[0];

            let feats: Vec<Feat> = val.segments.iter().map(|s| features(log, s, off)).collect();
            let mut order: Vec<usize> = (0..feats.len()).collect();
            order.sort_by(|&i, &j| feats[j].err2.total_cmp(&feats[i].err2));
            let total: f64 = feats.iter().map(|f| f.err2).sum();
            let worst: Vec<Feat> = order[..n_worst.min(order.len())]
                .iter()
                .map(|&i| feats[i])
                .collect();
            let rest: Vec<Feat> = order[n_worst.min(order.len())..]
                .iter()
                .map(|&i| feats[i])
                .collect();
            let share = worst.iter().map(|f| f.err2).sum::<f64>() / total;
            let summary = |fs: &[Feat]| {
                let n = fs.len().max(1) as f64;
                let m = |g: &dyn Fn(&Feat) -> f64| fs.iter().map(g).sum::<f64>() / n;
                format!(
                    "{:.2}, {:.2}, {:.2}, {:.2}, {:.2}, {:.0} %, {:.0} %",
                    m(&|f| f.acc),
                    m(&|f| f.v),
                    m(&|f| f.dv),
                    m(&|f| f.ratio),
                    m(&|f| f.gap),
                    100.0 * m(&|f| f64::from(u8::from(f.jump > 1.4))),
                    100.0 * m(&|f| f64::from(u8::from(f.turn > 0.0)))
                )
            };
            println!(
                "| {} | {name} | {} | {:.0} % | {} | {} | {:.2} | {:.2} |",
                log.name(),
                feats.len(),
                100.0 * share,
                summary(&worst),
                summary(&rest),
                corr(&feats, |f| f.err2, |f| f.acc),
                corr(&feats, |f| f.along, |f| f.acc_signed),
            );
            let kept: Vec<&Feat> = feats.iter().filter(|f| !too_far(f)).collect();
            let sum = |v: &[&Feat], g: &dyn Fn(&Feat) -> f64| v.iter().map(|f| g(f)).sum::<f64>();
            let all: Vec<&Feat> = feats.iter().collect();
            protocol += &format!(
                "| {} | {name} | {} | {} | {:.0} % | {:.3} | {:.3} |\n",
                log.name(),
                feats.len(),
                feats.len() - kept.len(),
                100.0 * (1.0 - sum(&kept, &|f| f.err2) / sum(&all, &|f| f.err2)),
                sum(&all, &|f| f.nom2) / sum(&all, &|f| f.err2),
                sum(&kept, &|f| f.nom2) / sum(&kept, &|f| f.err2),
            );
            let straight = |lo: f64, hi: f64| {
                let mut v: Vec<&Feat> = feats
                    .iter()
                    .filter(|f| f.dv < 0.3 && f.acc >= lo && f.acc < hi)
                    .collect();
                v.sort_by(|a, b| a.ratio.total_cmp(&b.ratio));
                let n = v.len();
                let med = v.get(n / 2).map_or(f64::NAN, |f| f.ratio);
                let gap = v.iter().map(|f| f.gap).sum::<f64>() / n.max(1) as f64;
                (n, med, gap)
            };
            let (s0, s1) = (straight(0.0, 0.1), straight(0.5, f64::INFINITY));
            accel += &format!(
                "| {} | {name} | {} | {:.2} | {:.2} | {} | {:.2} | {:.2} |\n",
                log.name(),
                s0.0,
                s0.1,
                s0.2,
                s1.0,
                s1.1,
                s1.2
            );
            if log.name().contains("asphalt") && name.starts_with("1st") {
                detail += &format!(
                    "\n{} {name}: worst {n_worst} segments\n\n| t0 (pose clock, s) | duration s | err² m² | no-slip err² m² | along, cross error m | ref, predicted, tread distance m | mean abs acc, signed acc m/s² | v, dv m/s | turn | ref/tread | pose gap s | jump | reference too far |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
                    log.name()
                );
                for &i in order.iter().take(n_worst) {
                    let (s, f) = (&val.segments[i], feats[i]);
                    detail += &format!(
                        "| {:.2} | {:.2} | {:.2} | {:.2} | {:+.2}, {:+.2} | {:.2}, {:.2}, {:.2} | {:.2}, {:+.2} | {:.2}, {:.2} | {:+.0} | {:.2} | {:.2} | {:.2} | {} |\n",
                        s.t0, f.dur, f.err2, f.nom2, f.along, f.cross, f.dref, f.dpred, f.dtread, f.acc, f.acc_signed, f.v, f.dv, f.turn, f.ratio, f.gap, f.jump, if too_far(&f) { "yes" } else { "" }
                    );
                }
                // Error by acceleration quartile: is it the traction?
                let mut by_acc: Vec<Feat> = feats.clone();
                by_acc.sort_by(|x, y| x.acc.total_cmp(&y.acc));
                detail += "\nacc quartile | mean acc | MSE written | MSE no-slip | ratio | mean along err\n";
                for q in 0..4 {
                    let part = &by_acc[q * by_acc.len() / 4..(q + 1) * by_acc.len() / 4];
                    let n = part.len() as f64;
                    let m = |g: &dyn Fn(&Feat) -> f64| part.iter().map(g).sum::<f64>() / n;
                    detail += &format!(
                        "{} | {:.2} | {:.3} | {:.3} | {:.2} | {:+.3}\n",
                        q + 1,
                        m(&|f| f.acc),
                        m(&|f| f.err2),
                        m(&|f| f.nom2),
                        m(&|f| f.nom2) / m(&|f| f.err2),
                        m(&|f| f.along)
                    );
                }
                // Straight segments: distance ratio by acceleration.
                detail += "\nstraight (dv < 0.3 m/s) | N | median ref/tread | median along err m | MSE written\n";
                for (lab, lo, hi) in [
                    ("braking < -0.5", f64::NEG_INFINITY, -0.5),
                    ("-0.5..-0.1", -0.5, -0.1),
                    ("steady -0.1..0.1", -0.1, 0.1),
                    ("0.1..0.5", 0.1, 0.5),
                    ("accelerating > 0.5", 0.5, f64::INFINITY),
                ] {
                    let part: Vec<&Feat> = feats
                        .iter()
                        .filter(|f| f.dv < 0.3 && f.acc_signed >= lo && f.acc_signed < hi)
                        .collect();
                    let med = |g: &dyn Fn(&Feat) -> f64| {
                        let mut x: Vec<f64> = part.iter().map(|f| g(f)).collect();
                        x.sort_by(f64::total_cmp);
                        x.get(x.len() / 2).copied().unwrap_or(f64::NAN)
                    };
                    detail += &format!(
                        "{lab} | {} | {:.3} | {:+.3} | {:.3}\n",
                        part.len(),
                        med(&|f| f.ratio),
                        med(&|f| f.along),
                        part.iter().map(|f| f.err2).sum::<f64>() / part.len().max(1) as f64
                    );
                }
                // Signed: accelerating vs braking.
                detail += "\nsigned acc | N | mean along err (ref - pred, m) | MSE written\n";
                for (lab, lo, hi) in [
                    ("braking < -0.5", f64::NEG_INFINITY, -0.5),
                    ("-0.5..0.5", -0.5, 0.5),
                    ("accelerating > 0.5", 0.5, f64::INFINITY),
                ] {
                    let part: Vec<&Feat> = feats
                        .iter()
                        .filter(|f| f.acc_signed >= lo && f.acc_signed < hi)
                        .collect();
                    let n = part.len().max(1) as f64;
                    detail += &format!(
                        "{lab} | {} | {:+.3} | {:.3}\n",
                        part.len(),
                        part.iter().map(|f| f.along).sum::<f64>() / n,
                        part.iter().map(|f| f.err2).sum::<f64>() / n
                    );
                }
            }
        }
    }
    println!("{detail}");
    println!("{protocol}");
    println!("{accel}");
}

fn corr(f: &[Feat], x: impl Fn(&Feat) -> f64, y: impl Fn(&Feat) -> f64) -> f64 {
    let n = f.len() as f64;
    let (mx, my) = (
        f.iter().map(&x).sum::<f64>() / n,
        f.iter().map(&y).sum::<f64>() / n,
    );
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for g in f {
        let (a, b) = (x(g) - mx, y(g) - my);
        sxy += a * b;
        sxx += a * a;
        syy += b * b;
    }
    sxy / (sxx * syy).sqrt().max(1e-300)
}

fn features(log: &DriveLog, s: &validate_mod::SegmentScore, off: f64) -> Feat {
    let w = &log.wheels;
    let e = [
        s.reference.dx - s.predicted.dx,
        s.reference.dy - s.predicted.dy,
    ];
    let en = [s.reference.dx - s.nominal.dx, s.reference.dy - s.nominal.dy];
    // Along-track error: component along the reference displacement.
    let d = s.reference.dx.hypot(s.reference.dy).max(1e-9);
    let along = (e[0] * s.reference.dx + e[1] * s.reference.dy) / d;
    let (wa, wb) = (s.t0 - off, s.t1 - off);
    let mean = |i: usize| 0.5 * (w[i].v_left + w[i].v_right);
    // Smoothed acceleration of the mean tread speed at wheel sample i.
    let acc_at = |i: usize| {
        let (lo, hi) = (i.saturating_sub(2), (i + 3).min(w.len() - 1));
        if hi <= lo {
            return 0.0;
        }
        (mean(hi) - mean(lo)) / (w[hi].t - w[lo].t).max(1e-6)
    };
    let (mut f, mut n) = (Feat::default(), 0.0);
    let (mut dist, mut idiff) = (0.0, 0.0);
    let mut prev_t = None;
    for (i, x) in w.iter().enumerate() {
        if x.t < wa || x.t > wb {
            continue;
        }
        let a = acc_at(i);
        let sign = mean(i).signum();
        f.acc += a.abs();
        f.acc_signed += a * sign; // > 0: speeding up in the driving direction
        f.v += mean(i).abs();
        f.dv += (w[i].v_right - w[i].v_left).abs();
        if let Some(tp) = prev_t {
            let dt: f64 = w[i].t - tp;
            dist += mean(i).abs() * dt;
            f.dfast += w[i].v_left.abs().max(w[i].v_right.abs()) * dt;
            idiff += (w[i].v_right - w[i].v_left) * dt;
        }
        prev_t = Some(w[i].t);
        n += 1.0;
    }
    let n = f64::max(n, 1.0);
    f.acc /= n;
    f.acc_signed /= n;
    f.v /= n;
    f.dv /= n;
    f.turn = idiff.signum();
    f.ratio = d / dist.max(1e-3);
    f.err2 = e[0] * e[0] + e[1] * e[1];
    f.nom2 = en[0] * en[0] + en[1] * en[1];
    f.along = along;
    f.cross = (-e[0] * s.reference.dy + e[1] * s.reference.dx) / d;
    f.dur = s.t1 - s.t0;
    f.dref = d;
    f.dpred = s.predicted.dx.hypot(s.predicted.dy);
    f.dtread = dist;
    let poses: Vec<_> = log
        .pose
        .iter()
        .filter(|p| p.t >= s.t0 && p.t <= s.t1)
        .filter_map(|p| Some((p.t, p.east?, p.north?)))
        .collect();
    for q in poses.windows(2) {
        let dt = q[1].0 - q[0].0;
        f.gap = f.gap.max(dt);
        let ps = (q[1].1 - q[0].1).hypot(q[1].2 - q[0].2) / dt.max(1e-6);
        // Faster tread speed over the interval (wheel clock).
        let fast = w
            .iter()
            .filter(|x| x.t >= q[0].0 - off - 0.05 && x.t <= q[1].0 - off + 0.05)
            .map(|x| x.v_left.abs().max(x.v_right.abs()))
            .fold(0.0, f64::max);
        f.jump = f.jump.max(ps / fast.max(0.1));
    }
    f
}
