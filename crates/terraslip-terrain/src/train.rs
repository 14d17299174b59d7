//! Training a terrain model on labelled logs.

use terraslip_io::DriveLog;

use crate::error::Result;
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
        Self::fit(logs, classes, opts)
    }
}
