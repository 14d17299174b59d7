//! Calibration of a model on grouped inner folds of its training runs:
//! models trained without each fold's runs classify them, and the
//! temperature and unknown threshold ([`Calibration`]) are fitted on those
//! held-out windows only.

use terraslip_io::DriveLog;

use crate::confidence::Calibration;
use crate::error::Result;
use crate::folds::run_folds;
use crate::model::TerrainModel;
use crate::train_options::TrainOptions;

/// Held-out class probabilities and true classes of `logs` over `folds`
/// grouped folds (whole runs out, dealt by terrain), each fold's runs
/// classified by a model fitted on the others with `opts` (not calibrated
/// itself: `opts.calibration_folds` is not read). A fold whose training
/// runs lack a class is skipped.
pub fn held_out_windows(
    logs: &[DriveLog],
    classes: &[String],
    opts: &TrainOptions,
    folds: usize,
) -> Result<(Vec<Vec<f64>>, Vec<usize>, usize)> {
    let mut probs = Vec::new();
    let mut truth = Vec::new();
    let mut used = 0;
    let folds = run_folds(logs, folds.min(logs.len()));
    if folds.len() < 2 {
        return Ok((probs, truth, 0));
    }
    for fold in &folds {
        let train: Vec<DriveLog> = (0..logs.len())
            .filter(|i| !fold.contains(i))
            .map(|i| logs[i].clone())
            .collect();
        let model = match TerrainModel::fit(&train, classes, opts) {
            Ok(m) => m,
            Err(crate::TerrainError::Training(_)) => continue,
            Err(e) => return Err(e),
        };
        drop(train);
        used += 1;
        for &i in fold {
            let tl = model.classify_log(&logs[i])?;
            for (t, p) in tl.frames {
                if let Some(c) = logs[i]
                    .terrain_at(t)
                    .and_then(|n| classes.iter().position(|c| c == n))
                {
                    probs.push(p);
                    truth.push(c);
                }
            }
        }
    }
    Ok((probs, truth, used))
}

/// [`Calibration::fit`] on [`held_out_windows`]; `None` when no inner fold
/// could be trained or no window was held out.
pub fn inner_calibration(
    logs: &[DriveLog],
    classes: &[String],
    opts: &TrainOptions,
    folds: usize,
) -> Result<Option<Calibration>> {
    let (probs, truth, used) = held_out_windows(logs, classes, opts, folds)?;
    Ok((!probs.is_empty()).then(|| Calibration::fit(&probs, &truth, used)))
}
