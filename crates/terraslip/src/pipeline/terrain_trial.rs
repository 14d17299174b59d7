//! A classifier's change of terrain on trial. A terrain read wrong, and
//! believed, recalls another ground's slip; so a change the classifier
//! declares is tried against the pose fixes before it is kept. From the
//! change on, two estimators are fed the same samples: one with the change,
//! and a copy of the estimator as it was before it (the terrain and slip
//! it held, still learning them). Both are scored by their misfit to the
//! fixes since the change ([`terraslip_core::estimator::Misfit`]: the slip
//! the data show). The rows come from the one that fits better so far
//! (the change until it fits worse by [`SHOW_HELD_NIS`]); the change is undone when it fits worse
//! by [`UNDO_NIS`], or has not fitted better at the end of the trial, and
//! kept when it fits better by [`KEEP_NIS`].
//!
//! Where no fix has come since the change (a log without a pose reference,
//! an outage), the two are scored the same way by the gyro's windows
//! instead ([`Estimator::gyro_misfit`]: the turn the gyro saw against the
//! turn each one's slip makes of the tread speeds).
//!
//! Labels are not tried: they are the ground's truth.

use terraslip_core::estimator::{Estimator, Misfit};
use terraslip_core::ChangeAction;

/// Excess NIS of the change over the terrain held (summed over the fix
/// parts since the change) at which the change is undone.
pub const UNDO_NIS: f64 = 15.0;
/// Advantage in NIS at which the change is kept before the trial ends.
/// Large: a change that fits is kept to the end of the trial, so that a
/// recalled set that wanders off later can still be undone (keeping it at
/// 20 or 40 NIS lost on the simulated worlds).
pub const KEEP_NIS: f64 = 1000.0;
/// Excess NIS at which the rows come from the terrain held while the
/// trial goes on.
pub const SHOW_HELD_NIS: f64 = 3.0;
/// Fix parts a trial lasts at most; at its end a change that has not
/// fitted better than the terrain held is undone.
pub const TRIAL_PARTS: u64 = 100;

/// What a trial found so far.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// Not decided yet.
    Open,
    /// The change fits the fixes: keep it.
    Kept,
    /// The change fits worse than the terrain held: undo it.
    Undone,
}

/// Two estimators on trial: with a declared change, and without it.
pub struct Trial {
    /// The estimator whose rows are not in use.
    pub other: Estimator,
    /// The rows in use are those of the estimator without the change.
    pub held_in_use: bool,
    /// What the change did.
    pub action: ChangeAction,
    /// The misfits to the fixes with the change and without it, at the
    /// change.
    start: (Misfit, Misfit),
    /// The same, to the gyro's windows.
    start_gyro: (Misfit, Misfit),
}

/// The NIS by which `with` has fitted worse than `held` since `start`, and
/// the parts since.
fn excess_since(with: Misfit, held: Misfit, start: (Misfit, Misfit)) -> (f64, u64) {
    let parts = with.parts.saturating_sub(start.0.parts);
    let excess = (with.nis - start.0.nis) - (held.nis - start.1.nis);
    (excess, parts)
}

impl Trial {
    /// A trial of the change (`action`) that turned `before` into `after`;
    /// `after` is in use.
    pub fn new(before: Estimator, after: &Estimator, action: ChangeAction) -> Self {
        let start = (after.misfit(), before.misfit());
        let start_gyro = (after.gyro_misfit(), before.gyro_misfit());
        Self {
            other: before,
            held_in_use: false,
            action,
            start,
            start_gyro,
        }
    }

    /// The NIS by which the change fits worse than the terrain held, and
    /// the parts since the change: of the fixes, or of the gyro's windows
    /// while no fix has come since; `in_use` the estimator in use.
    fn excess(&self, in_use: &Estimator) -> (f64, u64) {
        let (with, held) = if self.held_in_use {
            (&self.other, in_use)
        } else {
            (in_use, &self.other)
        };
        let fixes = excess_since(with.misfit(), held.misfit(), self.start);
        if fixes.1 > 0 {
            return fixes;
        }
        excess_since(with.gyro_misfit(), held.gyro_misfit(), self.start_gyro)
    }

    /// The verdict on the change.
    pub fn verdict(&self, in_use: &Estimator) -> Verdict {
        let (excess, parts) = self.excess(in_use);
        if excess > UNDO_NIS {
            Verdict::Undone
        } else if excess < -KEEP_NIS {
            Verdict::Kept
        } else if parts >= TRIAL_PARTS {
            if excess > 0.0 {
                Verdict::Undone
            } else {
                Verdict::Kept
            }
        } else {
            Verdict::Open
        }
    }

    /// Whether the rows should come from the terrain held, the trial open.
    pub fn shows_held(&self, in_use: &Estimator) -> bool {
        let (excess, _) = self.excess(in_use);
        if self.held_in_use {
            excess > 0.0
        } else {
            excess > SHOW_HELD_NIS
        }
    }
}
