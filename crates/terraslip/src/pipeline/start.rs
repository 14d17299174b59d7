//! The estimator as a run starts it: its pose fixes, its starting slip
//! parameters and each terrain's seeded memory.

use terraslip_core::estimator::Estimator;
use terraslip_core::filter::PoseFix;
use terraslip_io::{DriveLog, ParamsFile, PoseObs};

use super::setup;
use super::{PipelineError, TerrainEvidence};
use crate::config::EstimatorConfig;

/// The fix a pose row gives: the configured noise where the row states
/// none.
pub fn pose_fix(cfg: &EstimatorConfig, p: &PoseObs) -> PoseFix {
    PoseFix {
        position: p.east.zip(p.north),
        yaw: p.yaw,
        std_xy: p.std_xy.unwrap_or(cfg.measurement.std_xy),
        std_yaw: p.std_yaw.unwrap_or(cfg.measurement.std_yaw),
        stated: p.std_xy.is_some() || p.std_yaw.is_some(),
    }
}

/// A streaming estimator as [`run`] builds it for a robot of track width
/// `track_width` (m) without terrain evidence, and the source of its
/// starting slip parameters (`prior`, `init:<set>`). Per-terrain sets of
/// `init` are for [`seed_terrain`] once their terrain is declared.
pub fn estimator(
    cfg: &EstimatorConfig,
    track_width: f64,
    init: Option<&ParamsFile>,
) -> Result<(Estimator, String, Vec<String>), PipelineError> {
    cfg.validate().map_err(|e| PipelineError::Config(e.0))?;
    let mut log = DriveLog::default();
    log.meta.track_width = Some(track_width);
    let s = setup::setup(&log, cfg, &TerrainEvidence::None, init)?;
    Ok((s.estimator, s.init_source, s.warnings))
}

/// Seeds terrain `k`'s memory with `init`'s set named `name`, as [`run`]
/// does for each terrain of its evidence.
pub fn seed_terrain(
    est: &mut Estimator,
    cfg: &EstimatorConfig,
    init: &ParamsFile,
    k: usize,
    name: &str,
) {
    if let Some(entry) = init.terrains.get(name) {
        est.schedule_mut().seed(
            k,
            &entry.params,
            setup::set_std(cfg, entry.extra.get("std")),
        );
    }
}
