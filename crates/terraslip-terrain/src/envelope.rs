//! The manoeuvres a model was trained on, per terrain: which tread speeds
//! and tread speed differences its training windows of each terrain
//! cover. A window driven unlike every training window of the terrain it
//! is read as is an extrapolation (the vibration and the motor currents
//! change with speed and turning), so its class probabilities are mixed
//! with a uniform distribution before they reach the terrain belief, and
//! `terrain eval` / `estimate` report the share of such windows: the sign
//! that more driving should be recorded.

use serde::{Deserialize, Serialize};

/// Width of a cell of the grid, in tread speed and in tread speed
/// difference, m/s.
pub const CELL_M_S: f64 = 0.05;

/// Training windows a cell needs to count as covered (one stray window
/// does not make a manoeuvre known).
pub const MIN_WINDOWS_PER_CELL: u32 = 3;

/// Share of a uniform distribution mixed into the class probabilities of
/// a window outside the envelope of the terrain it is read as.
pub const OUTSIDE_MIX: f64 = 0.5;

/// Covered cells of the (tread speed, tread speed difference) grid per
/// class, as `[speed cell, difference cell]`, sorted; cell `i` spans
/// `[i, i + 1) · CELL_M_S`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Envelope {
    /// Cell width, m/s.
    pub cell_m_s: f64,
    /// Per class (order of the model's classes), the covered cells.
    pub cells: Vec<Vec<[u32; 2]>>,
}

/// The grid cell of a window's mean tread speed and mean |v_r − v_l|, m/s
/// (`None` when either is not finite).
fn cell(speed: f64, diff: f64, width: f64) -> Option<[u32; 2]> {
    let c = |v: f64| (v.is_finite()).then(|| (v.max(0.0) / width).floor().min(1e6) as u32);
    Some([c(speed)?, c(diff)?])
}

impl Envelope {
    /// The envelope of training windows `(class, speed, diff)`.
    pub fn fit(windows: impl IntoIterator<Item = (usize, f64, f64)>, n_classes: usize) -> Self {
        let mut counts: Vec<std::collections::BTreeMap<[u32; 2], u32>> =
            vec![Default::default(); n_classes];
        for (c, v, d) in windows {
            if let (Some(m), Some(k)) = (counts.get_mut(c), cell(v, d, CELL_M_S)) {
                *m.entry(k).or_default() += 1;
            }
        }
        Self {
            cell_m_s: CELL_M_S,
            cells: counts
                .into_iter()
                .map(|m| {
                    m.into_iter()
                        .filter(|&(_, n)| n >= MIN_WINDOWS_PER_CELL)
                        .map(|(k, _)| k)
                        .collect()
                })
                .collect(),
        }
    }

    /// Whether class `c` has training windows in the cell of (`speed`,
    /// `diff`) or a cell next to it (one cell of slack each way: within
    /// about 0.05-0.1 m/s of a training window). False for a speed that
    /// is not finite.
    pub fn covers(&self, c: usize, speed: f64, diff: f64) -> bool {
        let (Some(cells), Some([i, j])) = (self.cells.get(c), cell(speed, diff, self.cell_m_s))
        else {
            return false;
        };
        (i.saturating_sub(1)..=i + 1)
            .any(|a| (j.saturating_sub(1)..=j + 1).any(|b| cells.binary_search(&[a, b]).is_ok()))
    }

    /// Consistency with a model of `n_classes` classes (for loading).
    pub fn check(&self, n_classes: usize) -> std::result::Result<(), String> {
        if !(self.cell_m_s.is_finite() && self.cell_m_s > 0.0) {
            return Err("envelope: the cell width must be positive".into());
        }
        if self.cells.len() != n_classes {
            return Err("envelope: one list of cells per class expected".into());
        }
        if self
            .cells
            .iter()
            .any(|c| c.windows(2).any(|w| w[0] >= w[1]))
        {
            return Err("envelope: cells must be sorted and distinct".into());
        }
        Ok(())
    }
}

/// `p` mixed with [`OUTSIDE_MIX`] of a uniform distribution, in place.
pub fn lower_confidence(p: &mut [f64]) {
    let k = p.len().max(1) as f64;
    for v in p.iter_mut() {
        *v = (1.0 - OUTSIDE_MIX) * *v + OUTSIDE_MIX / k;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_terrain_covers_only_the_manoeuvres_it_was_trained_on() {
        // Class 0 driven straight at 0.2 m/s; class 1 spun with a tread
        // difference of 0.4 m/s; one stray class-1 window at 1 m/s.
        let mut w = Vec::new();
        for i in 0..20 {
            w.push((0, 0.2 + 0.001 * i as f64, 0.0));
            w.push((1, 0.2, 0.4 + 0.001 * i as f64));
        }
        w.push((1, 1.0, 0.0));
        w.push((7, 0.2, 0.0)); // a class the model does not have: ignored
        let e = Envelope::fit(w, 2);
        assert!(e.check(2).is_ok());
        assert!(e.covers(0, 0.21, 0.0) && e.covers(0, 0.26, 0.03));
        // Twice the speed, or turning: outside.
        assert!(!e.covers(0, 0.4, 0.0) && !e.covers(0, 0.2, 0.3));
        assert!(e.covers(1, 0.2, 0.4) && !e.covers(1, 0.2, 0.0));
        assert!(!e.covers(1, 1.0, 0.0), "a single window covers nothing");
        assert!(!e.covers(0, f64::NAN, 0.0) && !e.covers(2, 0.2, 0.0));
        let mut p = [0.9, 0.1];
        lower_confidence(&mut p);
        assert!((p[0] - 0.7).abs() < 1e-12 && (p[1] - 0.3).abs() < 1e-12);
        // A file with unsorted cells or the wrong number of classes is refused.
        let mut bad = e.clone();
        bad.cells[0].reverse();
        bad.cells[0].push([0, 0]);
        assert!(bad.check(2).is_err() && e.check(3).is_err());
    }
}
