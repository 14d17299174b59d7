//! The `follow` table: per ground and variant, the median and worst over
//! the seeds, and the done-lines judged on them.

use std::fmt::Write as _;

use serde_json::json;

use super::driver::OUTAGE_S;
use super::score::{RunScore, RECOVERY_FACTOR};
use super::steering::Variant;
use super::world;
use crate::stats::quantile;

/// Slippery: a nominal yaw gain (steering efficiency x speed factor)
/// below this.
pub const SLIPPERY_GAIN: f64 = 0.6;

/// One seed's runs, in [`Variant::ALL`] order.
#[derive(Debug, Clone)]
pub struct SeedRuns {
    pub seed: u64,
    pub multiplier: f64,
    pub scores: Vec<RunScore>,
}

/// Median and worst (largest; NaN counts as infinite) of one figure.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Stat {
    pub median: f64,
    pub worst: f64,
}

fn stat(v: &[f64]) -> Stat {
    let v: Vec<f64> = v
        .iter()
        .map(|x| if x.is_nan() { f64::INFINITY } else { *x })
        .collect();
    Stat {
        median: quantile(&v, 0.5),
        worst: v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    }
}

/// One row: a ground (or the whole course) and a variant.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Row {
    pub ground: String,
    pub variant: &'static str,
    pub cross_track_rms_cm: Stat,
    pub turn_heading_deg: Stat,
    pub time_s: Stat,
    pub recovery_s: Option<Stat>,
}

/// The table and its done-lines.
pub struct Table {
    seeds: Vec<u64>,
    grounds: Vec<String>,
    multiplier: Stat,
    multiplier_min: f64,
    rows: Vec<Row>,
    /// Per slippery ground: median and worst per-seed cut of cross-track
    /// RMS, live against none (1 - live / none).
    cuts: Vec<(String, f64, f64)>,
    /// Live and static cross-track RMS on the first ground, median, cm.
    tuned: (f64, f64),
    /// The mid-course change: the ground entered and the recovery of live.
    mid: Option<(usize, Stat)>,
}

impl Table {
    pub fn new(grounds: &[String], runs: &[SeedRuns]) -> Self {
        let col = |v: Variant| Variant::ALL.iter().position(|x| *x == v).unwrap_or(0);
        let per = |v: Variant, f: &dyn Fn(&RunScore) -> f64| -> Vec<f64> {
            runs.iter().map(|r| f(&r.scores[col(v)])).collect()
        };
        let mut rows = Vec::new();
        for (g, name) in grounds.iter().enumerate() {
            for v in Variant::ALL {
                rows.push(Row {
                    ground: name.clone(),
                    variant: v.name(),
                    cross_track_rms_cm: stat(&per(v, &|s| 100.0 * s.grounds[g].cross_track_rms_m)),
                    turn_heading_deg: stat(&per(v, &|s| s.grounds[g].turn_heading_deg)),
                    time_s: stat(&per(v, &|s| s.grounds[g].time_s)),
                    recovery_s: (g > 0).then(|| stat(&per(v, &|s| s.grounds[g].recovery_s))),
                });
            }
        }
        for v in Variant::ALL {
            rows.push(Row {
                ground: "course".into(),
                variant: v.name(),
                cross_track_rms_cm: stat(&per(v, &|s| 100.0 * s.cross_track_rms_m)),
                turn_heading_deg: stat(&per(v, &|s| {
                    let t: Vec<f64> = s.grounds.iter().map(|g| g.turn_heading_deg).collect();
                    (t.iter().map(|x| x * x).sum::<f64>() / t.len() as f64).sqrt()
                })),
                time_s: stat(&per(v, &|s| s.time_s)),
                recovery_s: None,
            });
        }
        let cuts = grounds
            .iter()
            .enumerate()
            .filter(|(_, n)| world::yaw_gain(n).is_some_and(|k| k < SLIPPERY_GAIN))
            .map(|(g, n)| {
                let c: Vec<f64> = runs
                    .iter()
                    .map(|r| {
                        let none = r.scores[col(Variant::None)].grounds[g].cross_track_rms_m;
                        let live = r.scores[col(Variant::Live)].grounds[g].cross_track_rms_m;
                        1.0 - live / none
                    })
                    .collect();
                let worst = c.iter().copied().fold(f64::INFINITY, f64::min);
                (n.clone(), quantile(&c, 0.5), worst)
            })
            .collect();
        let med = |v: Variant| quantile(&per(v, &|s| 100.0 * s.grounds[0].cross_track_rms_m), 0.5);
        let mid = (grounds.len() >= 2).then(|| {
            let g = grounds.len() / 2;
            (g, stat(&per(Variant::Live, &|s| s.grounds[g].recovery_s)))
        });
        let m: Vec<f64> = runs.iter().map(|r| r.multiplier).collect();
        Self {
            seeds: runs.iter().map(|r| r.seed).collect(),
            grounds: grounds.to_vec(),
            multiplier: stat(&m),
            multiplier_min: m.iter().copied().fold(f64::INFINITY, f64::min),
            rows,
            cuts,
            tuned: (med(Variant::Live), med(Variant::Static)),
            mid,
        }
    }

    fn done_lines(&self) -> Vec<(String, bool)> {
        let mut out = Vec::new();
        for (n, median, worst) in &self.cuts {
            out.push((
                format!(
                    "{n}: live cuts cross-track RMS against none by {:.0} % (median seed; worst seed {:.0} %), >= 50 %",
                    100.0 * median,
                    100.0 * worst
                ),
                *median >= 0.5,
            ));
        }
        out.push((
            format!(
                "{} (static tuned here): live {:.1} cm against static {:.1} cm (median), no worse",
                self.grounds[0], self.tuned.0, self.tuned.1
            ),
            // Judged at the table's resolution (0.1 cm).
            (10.0 * self.tuned.0).round() <= (10.0 * self.tuned.1).round(),
        ));
        if let Some((g, r)) = &self.mid {
            out.push((
                format!(
                    "{} -> {} (mid-course): live back within {RECOVERY_FACTOR} x settled in {:.1} s (median; worst {:.1} s), <= 10 s",
                    self.grounds[g - 1], self.grounds[*g], r.median, r.worst
                ),
                r.worst <= 10.0,
            ));
        }
        out
    }

    pub fn text(&self) -> String {
        let mut s = String::new();
        let seeds = self.seeds.len();
        let (a, b) = (self.seeds[0], self.seeds[seeds - 1]);
        let _ = writeln!(
            s,
            "follow: {seeds} seeds ({a}..{b}), grounds {}; GNSS out {OUTAGE_S} s from the start of {}'s last lap",
            self.grounds.join(" -> "),
            self.grounds[self.grounds.len() - 1]
        );
        let _ = writeln!(
            s,
            "static multiplier (turn test on {}): median {:.3}, range {:.3}..{:.3}",
            self.grounds[0], self.multiplier.median, self.multiplier_min, self.multiplier.worst
        );
        let _ = writeln!(s, "median / worst over the seeds");
        let _ = writeln!(
            s,
            "{:9} {:7} {:>17} {:>17} {:>15} {:>17}",
            "ground", "variant", "cross-track cm", "turn heading deg", "time s", "back in 1.5x s"
        );
        let f = |x: &Stat, w: usize| format!("{:>w$.1} {:>w$.1}", x.median, x.worst);
        for r in &self.rows {
            let rec = r
                .recovery_s
                .as_ref()
                .map_or(format!("{:>17}", "-"), |x| f(x, 8));
            let _ = writeln!(
                s,
                "{:9} {:7} {} {} {} {}",
                r.ground,
                r.variant,
                f(&r.cross_track_rms_cm, 8),
                f(&r.turn_heading_deg, 8),
                f(&r.time_s, 7),
                rec
            );
        }
        let _ = writeln!(s, "done-lines");
        for (line, met) in self.done_lines() {
            let _ = writeln!(s, "  [{}] {line}", if met { "met" } else { "NOT met" });
        }
        s
    }

    pub fn to_json(&self) -> serde_json::Value {
        json!({
            "seeds": self.seeds,
            "grounds": self.grounds,
            "outage_s": OUTAGE_S,
            "static_multiplier": {
                "median": self.multiplier.median,
                "min": self.multiplier_min,
                "max": self.multiplier.worst,
            },
            "rows": self.rows,
            "done_lines": self.done_lines().into_iter()
                .map(|(l, met)| json!({"line": l, "met": met}))
                .collect::<Vec<_>>(),
        })
    }
}
