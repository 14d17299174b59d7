//! What the run is told of the terrain: labels, a classifier's timeline
//! or nothing.

use terraslip_io::TerrainLabel;

/// Where the estimator learns which terrain the robot is on.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum TerrainEvidence {
    /// No terrain evidence: no schedule, no memory.
    #[default]
    None,
    /// Labels (the log's `terrain.csv`): a perfect classifier.
    Labels(Vec<TerrainLabel>),
    /// Classifier outputs: `frames[i] = (t, p)` with `p[k]` the
    /// probability (or likelihood) of `classes[k]` for the ground at `t`
    /// (a window's verdict stamped at its middle: the ground it reads).
    Likelihoods {
        classes: Vec<String>,
        frames: Vec<(f64, Vec<f64>)>,
        /// Times (s) at which a camera change detector fired (lv2019). The
        /// next frame after one is fused as after an innovation jump (lower
        /// stay probability), so the belief follows the change sooner.
        changes: Vec<f64>,
    },
}

impl From<terraslip_terrain::TerrainTimeline> for TerrainEvidence {
    fn from(t: terraslip_terrain::TerrainTimeline) -> Self {
        TerrainEvidence::Likelihoods {
            classes: t.classes,
            frames: t.frames,
            changes: t.changes,
        }
    }
}
