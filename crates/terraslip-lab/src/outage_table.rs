//! `terraslip-lab heldout`'s outage table: each model dead-reckoned through
//! 10, 30 and 60 s without the pose ([`terraslip_calib::outage`]) on the
//! scored span, and at 30 s the online default against half the no-slip
//! odometry's error and against DRIVE's model by a paired block bootstrap.

use terraslip_calib::outage::{OutageEnd, OutageScore, OutageStats, Start, Track, HORIZONS};
use terraslip_core::rng::SplitMix64;
use terraslip_io::DriveLog;

/// One model's outage ends on a drive.
pub struct Column {
    pub name: String,
    pub ends: Vec<OutageEnd>,
}

/// The starts every model sets out from: the online default's (`score`,
/// its run's yardstick) in `[from, to)`.
pub fn starts(score: Option<&OutageScore>, from: f64, to: f64) -> Vec<Start> {
    score.map_or_else(Vec::new, |s| {
        s.starts
            .iter()
            .filter(|s| s.t >= from && s.t < to)
            .copied()
            .collect()
    })
}

/// A fixed model's ends: dead-reckoned from each of `starts`.
pub fn fixed(
    log: &DriveLog,
    name: &str,
    twist: &dyn Fn(f64, &terraslip_io::WheelSample) -> terraslip_core::Twist,
    starts: &[Start],
) -> Column {
    let gap = terraslip_calib::outage::OutageSpec::default().max_gap;
    Column {
        name: name.into(),
        ends: Track::of(&log.pose).fixed_model(&log.wheels, twist, starts, gap),
    }
}

/// A run's ends of `model` from starts in `[from, to)`.
pub fn from_run(name: &str, score: Option<&OutageScore>, model: &str, from: f64) -> Column {
    let ends = score
        .and_then(|s| s.ends(model))
        .map(|e| e.iter().filter(|e| e.t >= from).copied().collect())
        .unwrap_or_default();
    Column {
        name: name.into(),
        ends,
    }
}

/// Another online run's own dead reckoning, carried from its starts into
/// `starts` (the default's).
pub fn carried(
    log: &DriveLog,
    name: &str,
    score: Option<&OutageScore>,
    starts: &[Start],
) -> Column {
    let gap = terraslip_calib::outage::OutageSpec::default().max_gap;
    let ends = score.map_or_else(Vec::new, |s| {
        Track::of(&log.pose).filter_from(&s.filter_ends, starts, gap)
    });
    Column {
        name: name.into(),
        ends,
    }
}

/// Prints a drive's outage table: one row per model, per horizon its mean
/// error (m), m per km and NEES median per dof; then the along/cross split
/// and the paired comparisons at 30 s.
pub fn print(drive: &str, cols: &[Column]) {
    println!();
    println!("outage dead reckoning on {drive}: mean m (m/km, NEES median per dof; n)");
    println!("| model | 10 s | 30 s | 60 s | 30 s along / cross rms m |");
    println!("|---|---|---|---|---|");
    for c in cols {
        let mut cells = Vec::new();
        for h in HORIZONS {
            cells.push(match OutageStats::of(&c.ends, h) {
                Some(s) => format!(
                    "{:.2} ({:.0}, {}; {})",
                    s.mean_m,
                    s.m_per_km,
                    s.nees_median.map_or("-".into(), |v| format!("{v:.2}")),
                    s.segments
                ),
                None => "-".into(),
            });
        }
        let split = OutageStats::of(&c.ends, 30.0).map_or("-".into(), |s| {
            format!("{:.2} / {:.2}", s.along_rms_m, s.cross_rms_m)
        });
        println!("| {} | {} | {split} |", c.name, cells.join(" | "));
    }
    // A name, else a name with its settings in brackets after it.
    let find = |n: &str| {
        cols.iter()
            .find(|c| c.name == n)
            .or_else(|| cols.iter().find(|c| c.name.starts_with(&format!("{n} ("))))
    };
    let pairs = [
        ("online default", "no-slip", 0.5),
        ("online default", "DRIVE's model", 1.0),
        ("online default", "DRIVE's model (DRIVE's protocol)", 1.0),
        ("hindsight selected", "no-slip", 0.5),
        ("hindsight best", "no-slip", 0.5),
    ];
    for (lead, other, k) in pairs {
        let (Some(a), Some(b)) = (find(lead), find(other)) else {
            continue;
        };
        if let Some((m, lo, hi)) = paired(&a.ends, &b.ends, k, 30.0) {
            let verdict = if hi < 0.0 {
                "ahead"
            } else if lo > 0.0 {
                "behind"
            } else {
                "tie"
            };
            println!(
                "30 s: {} - {k} x {other}: mean {m:+.2} m, 95 % [{lo:+.2}, {hi:+.2}] ({verdict})",
                a.name
            );
        }
    }
}

/// Length of the bootstrap's blocks of starts, s.
const BLOCK_S: f64 = 20.0;

/// The mean of `a - k b` over the starts both scored at `horizon`, and
/// its 95 % interval by a block bootstrap (blocks of [`BLOCK_S`] s of
/// starts, 2000 resamples).
pub fn paired(a: &[OutageEnd], b: &[OutageEnd], k: f64, horizon: f64) -> Option<(f64, f64, f64)> {
    let diffs: Vec<(f64, f64)> = a
        .iter()
        .filter(|x| x.horizon == horizon)
        .filter_map(|x| {
            b.iter()
                .find(|y| y.horizon == horizon && (y.t - x.t).abs() < 1e-6)
                .map(|y| (x.t, x.error - k * y.error))
        })
        .collect();
    let t0 = diffs.first()?.0;
    let mut blocks: Vec<Vec<f64>> = Vec::new();
    for (t, d) in &diffs {
        let j = ((t - t0) / BLOCK_S).floor() as usize;
        if blocks.len() <= j {
            blocks.resize(j + 1, Vec::new());
        }
        blocks[j].push(*d);
    }
    blocks.retain(|b| !b.is_empty());
    let mean = diffs.iter().map(|d| d.1).sum::<f64>() / diffs.len() as f64;
    let mut rng = SplitMix64::new(37);
    let mut means: Vec<f64> = (0..2000)
        .map(|_| {
            let (mut s, mut n) = (0.0, 0usize);
            for _ in 0..blocks.len() {
                let b = &blocks[rng.below(blocks.len())];
                s += b.iter().sum::<f64>();
                n += b.len();
            }
            s / n.max(1) as f64
        })
        .collect();
    means.sort_by(|x, y| x.total_cmp(y));
    let q = |p: f64| means[((means.len() - 1) as f64 * p).round() as usize];
    Some((mean, q(0.025), q(0.975)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn end(t: f64, error: f64) -> OutageEnd {
        OutageEnd {
            t,
            horizon: 30.0,
            error,
            distance: 30.0,
            along: error,
            cross: 0.0,
            nees: None,
        }
    }

    #[test]
    fn a_paired_difference_is_a_tie_only_when_its_interval_holds_zero() {
        let a: Vec<OutageEnd> = (0..60).map(|k| end(k as f64 * 10.0, 1.0)).collect();
        let b: Vec<OutageEnd> = (0..60)
            .map(|k| end(k as f64 * 10.0, 3.0 + (k % 3) as f64))
            .collect();
        let (m, lo, hi) = paired(&a, &b, 0.5, 30.0).unwrap();
        assert!(
            (m + 1.0).abs() < 1e-9 && hi < 0.0 && lo < m && m < hi,
            "{m} {lo} {hi}"
        );
        // Noise around zero: a tie.
        let c: Vec<OutageEnd> = (0..60)
            .map(|k| end(k as f64 * 10.0, 1.0 + 0.3 * ((k * 7 % 5) as f64 - 2.0)))
            .collect();
        let (_, lo, hi) = paired(&a, &c, 1.0, 30.0).unwrap();
        assert!(lo < 0.0 && hi > 0.0, "{lo} {hi}");
        assert!(paired(&a, &[], 1.0, 30.0).is_none());
    }
}
