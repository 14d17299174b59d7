//! Training a terrain model: fitted to the labelled logs, then calibrated
//! on grouped inner folds of its training runs when asked.

use terraslip_io::DriveLog;

use crate::calibrate::inner_calibration;
use crate::error::Result;
use crate::features::Features;
use crate::model::TerrainModel;
use crate::train_options::TrainOptions;

impl TerrainModel {
    /// Trains on labelled logs. Classes are the sorted union of their labels.
    pub fn train(logs: &[DriveLog], opts: &TrainOptions) -> Result<Self> {
        let mut classes: Vec<String> = logs.iter().flat_map(|l| l.terrain_names()).collect();
        classes.sort();
        classes.dedup();
        Self::train_classes(logs, &classes, opts)
    }

    /// Trains for the given classes (labels outside them are ignored).
    pub fn train_classes(
        logs: &[DriveLog],
        classes: &[String],
        opts: &TrainOptions,
    ) -> Result<Self> {
        let mut model = Self::fit(logs, classes, opts)?;
        if opts.calibration_folds >= 2 {
            let mut inner = opts.clone();
            inner.calibration_folds = 0;
            if let Features::Vibration { config, .. } = &model.features {
                inner.speed_floor = Some(config.speed_norm_min);
            }
            model.calibration = inner_calibration(logs, classes, &inner, opts.calibration_folds)?;
        }
        Ok(model)
    }
}
