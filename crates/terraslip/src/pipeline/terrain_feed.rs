//! Terrain evidence (labels, or classifier frames through the terrain
//! belief) declared to the estimator as the log's clock advances. A
//! classifier's change of terrain is declared at its onset: the first frame
//! of the run of frames that made the belief change
//! ([`super::terrain_onset`]).

use terraslip_core::estimator::Estimator;
use terraslip_core::terrain_belief::TerrainBelief;

use super::terrain_onset::Lookahead;
use super::{TerrainChange, TerrainEvidence};
use crate::config::EstimatorConfig;

/// Feeds labels or classifier frames into the estimator up to a time.
pub(super) struct TerrainFeed<'a> {
    evidence: &'a TerrainEvidence,
    belief: Option<TerrainBelief>,
    next: usize,
    next_detection: usize,
    /// Frames before this index were looked ahead over without the belief
    /// changing its terrain.
    looked_to: usize,
    /// The slip-change detector fired since the last classifier frame.
    pub jump: bool,
    pub current: Option<usize>,
    names: Vec<String>,
    /// The estimator as it was before the first change a classifier
    /// declared in the last [`Self::advance`] (the change goes on trial).
    before: Option<Estimator>,
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
            looked_to: 0,
            jump: false,
            current: None,
            names: super::setup::terrain_names(evidence),
            before: None,
        }
    }

    /// The estimator as it was before the classifier's change the last
    /// [`Self::advance`] declared (none for labels, or for the first
    /// terrain of a drive, which has nothing to try it against).
    pub fn take_before(&mut self) -> Option<Estimator> {
        self.before.take()
    }

    /// Declares to `est` the terrain in effect at `t`; returns the change
    /// the schedule acted on, if any.
    pub fn advance(
        &mut self,
        est: &mut Estimator,
        t: f64,
    ) -> Result<Option<TerrainChange>, terraslip_core::FilterError> {
        let mut out = None;
        self.before = None;
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
                    if self.next >= self.looked_to {
                        let ahead = Lookahead {
                            frames,
                            changes,
                            from: self.next,
                            next_detection: self.next_detection,
                            jump: self.jump,
                        };
                        match ahead.switch(b) {
                            Ok(s) => {
                                *b = s.belief;
                                self.next = s.next;
                                self.next_detection = s.next_detection;
                                self.looked_to = s.next;
                                self.jump = false;
                                let action = declare(&mut self.before, est, s.terrain)?;
                                out = Some(TerrainChange {
                                    t: *tf,
                                    terrain: s.terrain,
                                    action,
                                });
                                continue;
                            }
                            Err(end) => self.looked_to = end,
                        }
                    }
                    while self.next_detection < changes.len() && changes[self.next_detection] <= *tf
                    {
                        self.jump = true;
                        self.next_detection += 1;
                    }
                    if let Some(k) = b.update(p, self.jump) {
                        let action = declare(&mut self.before, est, k)?;
                        out = Some(TerrainChange {
                            t: *tf,
                            terrain: k,
                            action,
                        });
                    }
                    self.jump = false;
                    self.next += 1;
                }
                self.current = est.schedule().current();
            }
        }
        Ok(out)
    }
}

/// Declares a classifier's terrain `k` to `est`, keeping in `before` the
/// estimator as it was before the first change (to try the change).
fn declare(
    before: &mut Option<Estimator>,
    est: &mut Estimator,
    k: usize,
) -> Result<terraslip_core::ChangeAction, terraslip_core::FilterError> {
    let held = est.schedule().current();
    if before.is_none() && held.is_some_and(|h| h != k) {
        *before = Some(est.clone());
    }
    est.on_terrain(k)
}
