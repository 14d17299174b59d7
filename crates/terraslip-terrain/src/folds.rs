//! Which runs a cross-validation holds out: whole runs dealt round-robin
//! to folds by terrain ([`run_folds`]), or the runs driven outside the
//! speeds and turn rates that the training runs of their terrain cover
//! ([`manoeuvre_split`]).

use serde::Serialize;
use terraslip_io::DriveLog;

/// Folds of runs: the runs of each terrain (by first label) are dealt
/// round-robin to `k` folds so that every fold tests every terrain it can.
pub fn run_folds(logs: &[DriveLog], k: usize) -> Vec<Vec<usize>> {
    let k = k.max(2);
    let all: Vec<usize> = (0..logs.len()).collect();
    let by_class = group_by_terrain(logs, &all);
    let mut folds = vec![Vec::new(); k];
    let mut next = 0;
    for (_, runs) in &by_class {
        for &r in runs {
            folds[next % k].push(r);
            next += 1;
        }
    }
    folds.retain(|f| !f.is_empty());
    folds
}

/// How a run was driven, from its own `wheels.csv` (tread speeds, m/s).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Manoeuvre {
    /// Mean of (|v_left| + |v_right|) / 2, m/s.
    pub speed: f64,
    /// Mean of |v_right − v_left|, m/s (how hard it turned).
    pub tread_diff: f64,
    /// Mean of |v_r − v_l| / (|v_l| + |v_r|): 0 straight, 1 spinning in place.
    pub spin_share: f64,
}

/// A run whose spin share is at least this is a spin, otherwise a drive.
pub const SPIN_SHARE_OF_A_SPIN: f64 = 0.5;

/// Runs within this relative distance of a terrain's extreme are held out
/// with it (ties: several runs driven alike).
const EXTREME_TIE: f64 = 0.05;

impl Manoeuvre {
    /// The means over the log's wheel samples (zeros without any).
    pub fn of(log: &DriveLog) -> Self {
        let n = log.wheels.len().max(1) as f64;
        let mut m = Self {
            speed: 0.0,
            tread_diff: 0.0,
            spin_share: 0.0,
        };
        for w in &log.wheels {
            let sum = w.v_left.abs() + w.v_right.abs();
            let diff = (w.v_right - w.v_left).abs();
            m.speed += 0.5 * sum;
            m.tread_diff += diff;
            if sum > 1e-6 {
                m.spin_share += diff / sum;
            }
        }
        m.speed /= n;
        m.tread_diff /= n;
        m.spin_share /= n;
        m
    }

    /// Whether the run spins (turns in place) rather than drives.
    pub fn is_spin(&self) -> bool {
        self.spin_share >= SPIN_SHARE_OF_A_SPIN
    }
}

/// A run held out by [`manoeuvre_split`], and why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HeldOut {
    /// Index in the logs.
    pub run: usize,
    pub manoeuvre: Manoeuvre,
    /// E.g. `fastest drive of snow: 0.39 m/s, training drives 0.19-0.28 m/s`.
    pub why: String,
}

/// The manoeuvre split: for every terrain (a run's first label), its
/// fastest drive (highest mean tread speed) and its slowest spin (lowest
/// mean tread difference) are held out, each with the runs of its kind
/// within 5 % of it, when the terrain keeps at least one run of that kind
/// to train on. Drives and spins are told apart by the spin share
/// ([`SPIN_SHARE_OF_A_SPIN`]). Every held-out run is then driven outside
/// the speed (drives) or turn rate (spins) of the training runs of its
/// terrain, which a robot in the field does; leave-run-out mostly tests
/// runs driven like a training run. Defined from the runs' own statistics,
/// not from their names.
pub fn manoeuvre_split(logs: &[DriveLog]) -> Vec<HeldOut> {
    let all: Vec<usize> = (0..logs.len()).collect();
    let m: Vec<Manoeuvre> = logs.iter().map(Manoeuvre::of).collect();
    let mut out = Vec::new();
    for (terrain, runs) in group_by_terrain(logs, &all) {
        for spin in [false, true] {
            let kind: Vec<usize> = runs
                .iter()
                .copied()
                .filter(|&r| m[r].is_spin() == spin)
                .collect();
            // Drives: the fastest; spins: the gentlest turn.
            let key = |r: usize| if spin { -m[r].tread_diff } else { m[r].speed };
            let Some(extreme) = kind.iter().map(|&r| key(r)).max_by(|a, b| a.total_cmp(b)) else {
                continue;
            };
            let tie = EXTREME_TIE * extreme.abs();
            let (held, kept): (Vec<usize>, Vec<usize>) =
                kind.iter().partition(|&&r| key(r) >= extreme - tie);
            if kept.is_empty() {
                continue;
            }
            let range = |v: &mut dyn Iterator<Item = f64>| {
                v.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
                    (lo.min(x), hi.max(x))
                })
            };
            for r in held {
                let why = if spin {
                    let (lo, hi) = range(&mut kept.iter().map(|&k| m[k].tread_diff));
                    format!(
                        "slowest spin of {terrain}: tread difference {:.2} m/s, training spins {lo:.2}-{hi:.2} m/s",
                        m[r].tread_diff
                    )
                } else {
                    let (lo, hi) = range(&mut kept.iter().map(|&k| m[k].speed));
                    format!(
                        "fastest drive of {terrain}: {:.2} m/s, training drives {lo:.2}-{hi:.2} m/s",
                        m[r].speed
                    )
                };
                out.push(HeldOut {
                    run: r,
                    manoeuvre: m[r],
                    why,
                });
            }
        }
    }
    out.sort_by_key(|h| h.run);
    out
}

/// The runs `runs` grouped by their first terrain label, groups in order of
/// first appearance.
pub(crate) fn group_by_terrain(logs: &[DriveLog], runs: &[usize]) -> Vec<(String, Vec<usize>)> {
    let mut groups: Vec<(String, Vec<usize>)> = Vec::new();
    for &i in runs {
        let c = logs[i]
            .terrain
            .first()
            .map(|x| x.terrain.clone())
            .unwrap_or_default();
        match groups.iter_mut().find(|(n, _)| *n == c) {
            Some((_, v)) => v.push(i),
            None => groups.push((c, vec![i])),
        }
    }
    groups
}

/// Orders runs so that consecutive ones have different terrains as far as possible.
pub(crate) fn interleave_by_terrain(logs: &[DriveLog], runs: &[usize]) -> Vec<usize> {
    let groups = group_by_terrain(logs, runs);
    let mut out = Vec::with_capacity(runs.len());
    let mut round = 0;
    while out.len() < runs.len() {
        for (_, g) in &groups {
            if let Some(&i) = g.get(round) {
                out.push(i);
            }
        }
        round += 1;
    }
    out
}
