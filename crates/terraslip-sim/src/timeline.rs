//! The terrain schedule of a drive: which terrain is under the robot when,
//! and the ICRs it gives before the slip model (blended over
//! `slip.transition` s after each border).

use std::path::PathBuf;

use terraslip_core::kinematics::IcrParams;
use terraslip_io::TerrainLabel;

use crate::{Scenario, SimError, Terrain};

pub(crate) struct Timeline {
    /// The terrains, in order of first appearance.
    pub terrains: Vec<Terrain>,
    /// `(start s, index into terrains)` of each scenario segment.
    schedule: Vec<(f64, usize)>,
    /// The terrain labels of the log (one per segment).
    pub labels: Vec<TerrainLabel>,
    /// Length of the drive, s.
    pub duration: f64,
    /// Each terrain's ICRs for the scenario's robot.
    nominal: Vec<IcrParams>,
    /// Blend time after a border, s.
    transition: f64,
}

impl Timeline {
    pub fn new(sc: &Scenario) -> Result<Self, SimError> {
        let mut terrains: Vec<Terrain> = Vec::new();
        let mut schedule = Vec::new();
        let mut labels = Vec::new();
        let mut t0 = 0.0;
        for seg in &sc.segments {
            let ter = sc
                .terrain(&seg.terrain)
                .map_err(|reason| SimError::Scenario {
                    path: PathBuf::from(format!("<scenario {}>", sc.name)),
                    line: 0,
                    reason,
                })?;
            let idx = match terrains.iter().position(|t| t.name == ter.name) {
                Some(i) => i,
                None => {
                    terrains.push(ter);
                    terrains.len() - 1
                }
            };
            schedule.push((t0, idx));
            labels.push(TerrainLabel {
                t: t0,
                terrain: seg.terrain.clone(),
            });
            t0 += seg.duration;
        }
        let nominal = terrains.iter().map(|t| t.icr(&sc.robot)).collect();
        Ok(Self {
            terrains,
            schedule,
            labels,
            duration: t0,
            nominal,
            transition: sc.slip.transition,
        })
    }

    /// Start times of the terrain changes (the first segment excluded), s.
    pub fn changes(&self) -> Vec<f64> {
        self.schedule
            .windows(2)
            .filter(|w| w[0].1 != w[1].1)
            .map(|w| w[1].0)
            .collect()
    }

    /// The terrain index of scenario segment `i`.
    pub fn segment_terrain(&self, i: usize) -> Option<usize> {
        self.schedule.get(i).map(|s| s.1)
    }

    /// The nominal ICRs of terrain `i` (before the slip model).
    pub fn nominal(&self, i: usize) -> IcrParams {
        self.nominal[i]
    }

    /// The nominal ICRs (terrain blend, before the slip model) and the
    /// terrain index at `t`.
    pub fn nominal_at(&self, t: f64) -> (IcrParams, usize) {
        let i = self
            .schedule
            .partition_point(|s| s.0 <= t)
            .saturating_sub(1);
        let (start, ti) = self.schedule[i];
        let here = self.nominal[ti];
        if i == 0 || self.transition <= 0.0 || t - start >= self.transition {
            return (here, ti);
        }
        let prev = self.nominal[self.schedule[i - 1].1];
        (blend(&prev, &here, (t - start) / self.transition), ti)
    }
}

pub(crate) fn blend(a: &IcrParams, b: &IcrParams, w: f64) -> IcrParams {
    let m = |x: f64, y: f64| x + (y - x) * w;
    IcrParams {
        y_l: m(a.y_l, b.y_l),
        y_r: m(a.y_r, b.y_r),
        x_c: m(a.x_c, b.x_c),
        alpha_l: m(a.alpha_l, b.alpha_l),
        alpha_r: m(a.alpha_r, b.alpha_r),
    }
}
