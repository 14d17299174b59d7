//! Where a classifier's change of terrain began. The terrain belief
//! changes its terrain only after a run of frames has read the new one (its
//! filter and λ-vote need several); the ground changed at the run's first
//! frame. Offline, where every frame is known, the estimator declares the
//! new terrain there: the belief is run ahead over the run, on a copy, and
//! the terrain it changes to is declared at the run's first frame. This is
//! what rewinding the estimator to the onset and replaying the rows since
//! with the new terrain's set would give, without holding rows.

use terraslip_core::terrain_belief::{TerrainBelief, MAX_VOTE_LAMBDA};
use terraslip_terrain::classify::argmax;

/// Frames a run is looked ahead over at most: twice the longest vote, so
/// any belief that changes on a steady run changes within it.
const MAX_RUN_FRAMES: usize = 2 * MAX_VOTE_LAMBDA as usize;

/// A look ahead from frame `from` of a classifier's frames.
pub(super) struct Lookahead<'a> {
    /// `(t, p)`: time, s, and class probabilities.
    pub frames: &'a [(f64, Vec<f64>)],
    /// Camera change detections, s, in time order.
    pub changes: &'a [f64],
    pub from: usize,
    /// The first detection not yet fused.
    pub next_detection: usize,
    /// The estimator's change detector fired since the last frame fused.
    pub jump: bool,
}

/// The belief after the run that changed its terrain.
pub(super) struct Switch {
    pub belief: TerrainBelief,
    /// The terrain declared, and the first frame and detection after the run.
    pub terrain: usize,
    pub next: usize,
    pub next_detection: usize,
}

impl Lookahead<'_> {
    /// Runs a copy of `belief` over the frames from `from` that read the
    /// same terrain as it (the run), as the belief itself would fuse them.
    /// `Ok` when the belief changes to that terrain within the run; else
    /// `Err(i)`: frames `from..i` leave its terrain as it is.
    pub fn switch(&self, belief: &TerrainBelief) -> Result<Switch, usize> {
        let Some((_, first)) = self.frames.get(self.from) else {
            return Err(self.from);
        };
        let class = argmax(first);
        if belief.current() == Some(class) {
            return Err(self.from + 1);
        }
        let mut b = belief.clone();
        let (mut det, mut jump) = (self.next_detection, self.jump);
        let end = self.frames.len().min(self.from + MAX_RUN_FRAMES);
        for (i, (t, p)) in self.frames.iter().enumerate().take(end).skip(self.from) {
            if argmax(p) != class {
                return Err(i);
            }
            while det < self.changes.len() && self.changes[det] <= *t {
                jump = true;
                det += 1;
            }
            if let Some(k) = b.update(p, jump) {
                if k != class {
                    return Err(i);
                }
                return Ok(Switch {
                    belief: b,
                    terrain: k,
                    next: i + 1,
                    next_detection: det,
                });
            }
            jump = false;
        }
        Err(end)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use terraslip_core::terrain_belief::BeliefConfig;

    fn frames() -> Vec<(f64, Vec<f64>)> {
        (0..40)
            .map(|i| {
                let t = 0.5 * i as f64;
                (
                    t,
                    if t < 10.0 {
                        vec![0.9, 0.1]
                    } else {
                        vec![0.1, 0.9]
                    },
                )
            })
            .collect()
    }

    #[test]
    fn a_run_that_changes_the_belief_is_declared_at_its_first_frame() {
        let f = frames();
        let mut b = TerrainBelief::new(2, BeliefConfig::default());
        for (_, p) in &f[..20] {
            b.update(p, false);
        }
        assert_eq!(b.current(), Some(0));
        let ahead = Lookahead {
            frames: &f,
            changes: &[],
            from: 20,
            next_detection: 0,
            jump: false,
        };
        let s = ahead.switch(&b).ok().unwrap();
        assert_eq!(s.terrain, 1);
        // The belief needed more than one frame: the run's first decides.
        assert!(s.next > 21, "{}", s.next);
        assert_eq!(s.belief.current(), Some(1));
        // A frame of the terrain already held looks no further.
        let held = Lookahead { from: 5, ..ahead };
        assert_eq!(held.switch(&b).err(), Some(6));
    }

    #[test]
    fn a_run_too_short_to_change_the_belief_changes_nothing() {
        let mut f = frames();
        // One stray frame of terrain 1 among terrain 0.
        f[30].1 = vec![0.1, 0.9];
        for x in &mut f[31..] {
            x.1 = vec![0.9, 0.1];
        }
        let mut b = TerrainBelief::new(2, BeliefConfig::default());
        for (_, p) in &f[..30] {
            b.update(p, false);
        }
        let ahead = Lookahead {
            frames: &f[..],
            changes: &[],
            from: 30,
            next_detection: 0,
            jump: false,
        };
        assert_eq!(ahead.switch(&b).err(), Some(31));
    }
}
