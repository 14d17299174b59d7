//! Terrain evidence (labels, or classifier frames through the terrain
//! belief) declared to the estimator as the log's clock advances.

use terraslip_core::estimator::Estimator;
use terraslip_core::terrain_belief::TerrainBelief;

use super::{TerrainChange, TerrainEvidence};
use crate::config::EstimatorConfig;

/// Feeds labels or classifier frames into the estimator up to a time.
pub(super) struct TerrainFeed<'a> {
    evidence: &'a TerrainEvidence,
    belief: Option<TerrainBelief>,
    next: usize,
    next_detection: usize,
    /// The slip-change detector fired since the last classifier frame.
    pub jump: bool,
    pub current: Option<usize>,
    names: Vec<String>,
}

impl<'a> TerrainFeed<'a> {
    pub fn new(evidence: &'a TerrainEvidence, cfg: &EstimatorConfig) -> Self {
        let belief = match evidence {
            TerrainEvidence::Likelihoods { classes, .. } => {
                Some(TerrainBelief::new(classes.len(), cfg.belief))
            }
            _ => None,
        };
        Self {
            evidence,
            belief,
            next: 0,
            next_detection: 0,
            jump: false,
            current: None,
            names: super::setup::terrain_names(evidence),
        }
    }

    /// Declares to `est` the terrain in effect at `t`; returns the change
    /// the schedule acted on, if any.
    pub fn advance(
        &mut self,
        est: &mut Estimator,
        t: f64,
    ) -> Result<Option<TerrainChange>, terraslip_core::FilterError> {
        let mut out = None;
        match self.evidence {
            TerrainEvidence::None => {}
            TerrainEvidence::Labels(labels) => {
                while self.next < labels.len() && labels[self.next].t <= t {
                    self.next += 1;
                }
                let k = self
                    .next
                    .checked_sub(1)
                    .and_then(|i| self.names.iter().position(|n| *n == labels[i].terrain));
                if let Some(k) = k.filter(|k| self.current != Some(*k)) {
                    let action = est.on_terrain(k)?;
                    out = Some(TerrainChange {
                        t,
                        terrain: k,
                        action,
                    });
                    self.current = Some(k);
                }
            }
            TerrainEvidence::Likelihoods {
                frames, changes, ..
            } => {
                let Some(b) = self.belief.as_mut() else {
                    return Ok(None);
                };
                while self.next < frames.len() && frames[self.next].0 <= t {
                    let (tf, p) = &frames[self.next];
                    while self.next_detection < changes.len() && changes[self.next_detection] <= *tf
                    {
                        self.jump = true;
                        self.next_detection += 1;
                    }
                    if let Some(k) = b.update(p, self.jump) {
                        let action = est.on_terrain(k)?;
                        out = Some(TerrainChange {
                            t: *tf,
                            terrain: k,
                            action,
                        });
                    }
                    self.jump = false;
                    self.next += 1;
                }
                self.current = b.current();
            }
        }
        Ok(out)
    }
}
