//! Changes of ground the classifier says nothing sure of, and what the
//! estimator's own slip-change detector made of them: caught (it fired
//! soon after), and a set recalled or a fresh unnamed set started.

use terraslip::pipeline::{EstimateRun, TerrainEvidence};
use terraslip_core::ChangeAction;
use terraslip_io::TerrainLabel;

/// Seconds after a change of ground in which the classifier's silence,
/// the detector's firing and the schedule's action are looked for.
pub const WITHIN_S: f64 = 15.0;

/// Counts over the changes of ground of one or more runs.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SilentChanges {
    /// Changes of ground with no sure classifier frame within [`WITHIN_S`].
    pub silent: usize,
    /// Of those, the detector fired within [`WITHIN_S`].
    pub caught: usize,
    /// Of those, a remembered set was recalled within [`WITHIN_S`].
    pub recalled: usize,
    /// Of those, a fresh set was started instead.
    pub fresh: usize,
}

impl SilentChanges {
    pub fn add(&mut self, o: &SilentChanges) {
        self.silent += o.silent;
        self.caught += o.caught;
        self.recalled += o.recalled;
        self.fresh += o.fresh;
    }

    /// The counts of one run given `evidence` on a world labelled `labels`.
    pub fn of_run(labels: &[TerrainLabel], evidence: &TerrainEvidence, run: &EstimateRun) -> Self {
        let mut c = SilentChanges::default();
        let TerrainEvidence::Likelihoods { frames, .. } = evidence else {
            return c;
        };
        for t in labels
            .windows(2)
            .filter(|w| w[0].terrain != w[1].terrain)
            .map(|w| w[1].t)
        {
            let within = |x: f64| x >= t && x <= t + WITHIN_S;
            if frames.iter().any(|f| within(f.0)) {
                continue;
            }
            c.silent += 1;
            if run.rows.iter().any(|r| r.change && within(r.t)) {
                c.caught += 1;
                let acted =
                    |a: ChangeAction| run.changes.iter().any(|x| x.action == a && within(x.t));
                c.recalled += usize::from(acted(ChangeAction::Recalled));
                c.fresh += usize::from(acted(ChangeAction::Learning));
            }
        }
        c
    }
}
