//! A world's outage drift as an average, and the same world with the
//! sensors' noise drawn afresh.
//!
//! One 30 s outage per world scores one stretch of driving with one draw
//! of the sensors' noise: the oracle itself, run on a second draw of the
//! same world, lands over 1.5 x its first figure in about two worlds of
//! five. `family --outages K` withholds the pose over `K` separate 30 s
//! windows (the world's own and `K - 1` more, one run each) and takes the
//! mean drift; `NAME@drawN` runs estimator `NAME` on draw `N` of the
//! sensors' noise (`terraslip_sim::simulate_draw`), so that
//! `oracle-prior@draw1` judged against `oracle-prior` tells how often the
//! target's own reference misses it.

use terraslip::pipeline::EstimateRun;
use terraslip_io::TerrainLabel;

/// Shortest time after the start before a window opens, s (the warm-up of
/// the world's own outage).
const WARMUP_S: f64 = 60.0;
/// Fixes between two windows, s: time for the filter to take the pose
/// back before the next one.
const BETWEEN_S: f64 = 30.0;

/// `k` windows of the world's own outage's length on the wheels' clock:
/// `own` first, then up to `k - 1` more spread evenly over the drive
/// (`duration` s) after [`WARMUP_S`], none within [`BETWEEN_S`] of
/// another or past the end. Fewer when the drive has no room.
pub fn windows(own: (f64, f64), duration: f64, k: usize) -> Vec<(f64, f64)> {
    let len = own.1 - own.0;
    let mut out = vec![own];
    if k <= 1 || !(len > 0.0 && duration.is_finite()) {
        return out;
    }
    let clear = |s: f64| s + len <= own.0 - BETWEEN_S || s >= own.1 + BETWEEN_S;
    let last = duration - len;
    let candidates: Vec<f64> = (0..)
        .map(|j| WARMUP_S + f64::from(j) * (len + BETWEEN_S))
        .take_while(|s| *s <= last)
        .filter(|s| clear(*s))
        .collect();
    let want = (k - 1).min(candidates.len());
    for j in 0..want {
        // Evenly over the candidates, first and last included.
        let i = if want == 1 {
            candidates.len() / 2
        } else {
            j * (candidates.len() - 1) / (want - 1)
        };
        out.push((candidates[i], candidates[i] + len));
    }
    out
}

/// One withheld window's drift, and where it lies against the changes of
/// ground.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct WindowDrift {
    /// Start, s on the wheels' clock.
    pub start_s: f64,
    /// Time since the ground last changed (the drive's start counts as a
    /// change), s.
    pub since_change_s: f64,
    /// Whether the ground changes inside the window.
    pub change_inside: bool,
    /// Drift, % of the distance (NaN: not scored).
    pub drift_pct: f64,
    /// Fixes the run fused inside the window (0: withheld as asked).
    pub fused: usize,
}

impl WindowDrift {
    /// Window `o` (s) of a drive whose ground follows `labels`.
    /// `fused`: the fixes the run fused inside it.
    pub fn new(labels: &[TerrainLabel], o: (f64, f64), drift_pct: f64, fused: usize) -> Self {
        let last = labels
            .iter()
            .filter(|l| l.t <= o.0)
            .map(|l| l.t)
            .fold(0.0f64, f64::max);
        Self {
            start_s: o.0,
            since_change_s: o.0 - last,
            change_inside: labels.iter().any(|l| l.t > o.0 && l.t < o.1),
            drift_pct,
            fused,
        }
    }
}

impl WindowDrift {
    /// Window `o` (s, the wheels' clock) of `run`, a drive whose ground
    /// follows `labels`, with its fixes fused counted half a second in
    /// from the window's ends.
    pub fn of(run: &EstimateRun, labels: &[TerrainLabel], o: (f64, f64), drift_pct: f64) -> Self {
        let fused = run
            .rows
            .iter()
            .filter(|r| r.fused && r.t > o.0 + 0.5 && r.t < o.1 - 0.5)
            .count();
        Self::new(labels, o, drift_pct, fused)
    }
}

/// `NAME@drawN` as `(NAME, N)`; a name without a draw is draw 0.
pub fn split_draw(name: &str) -> anyhow::Result<(&str, u64)> {
    match name.rsplit_once("@draw") {
        None => Ok((name, 0)),
        Some((base, n)) => n.parse().map(|n| (base, n)).map_err(|_| {
            anyhow::anyhow!("--estimator {name}: expected NAME@drawN with N a whole number (the sensors' noise draw)")
        }),
    }
}

/// Mean of the finite values of `v` (NaN when there is none).
pub fn mean_finite(v: &[f64]) -> f64 {
    let f: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    if f.is_empty() {
        f64::NAN
    } else {
        f.iter().sum::<f64>() / f.len() as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_windows_keep_clear_of_the_worlds_own_and_of_the_end() {
        let own = (120.0, 150.0);
        let w = windows(own, 400.0, 5);
        assert_eq!(w[0], own);
        assert_eq!(w.len(), 5);
        for (i, a) in w.iter().enumerate() {
            assert!(a.0 >= WARMUP_S && a.1 <= 400.0, "{a:?}");
            for b in &w[i + 1..] {
                assert!(
                    a.1 + BETWEEN_S <= b.0 || b.1 + BETWEEN_S <= a.0,
                    "{a:?} {b:?}"
                );
            }
        }
        // A short drive has room for fewer.
        assert_eq!(windows(own, 200.0, 5).len(), 2);
        assert_eq!(windows((60.0, 90.0), 130.0, 5).len(), 1);
        assert_eq!(windows(own, 400.0, 1), vec![own]);
    }

    #[test]
    fn a_window_knows_the_changes_of_ground_around_it() {
        let l = |t: f64, g: &str| TerrainLabel {
            t,
            terrain: g.into(),
        };
        let labels = [l(0.0, "sand"), l(90.0, "grass"), l(200.0, "ice")];
        let w = WindowDrift::new(&labels, (120.0, 150.0), 2.0, 0);
        assert_eq!((w.since_change_s, w.change_inside), (30.0, false));
        let w = WindowDrift::new(&labels, (180.0, 210.0), 2.0, 0);
        assert_eq!((w.since_change_s, w.change_inside), (90.0, true));
    }

    #[test]
    fn a_draw_is_named_after_the_estimator() {
        assert_eq!(
            split_draw("oracle-prior@draw2").unwrap(),
            ("oracle-prior", 2)
        );
        assert_eq!(split_draw("terraslip").unwrap(), ("terraslip", 0));
        assert!(split_draw("terraslip@drawx").is_err());
    }
}
