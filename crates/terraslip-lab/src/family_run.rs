//! One estimator run in one simulated world of the family: what it is
//! told (an oracle the terrain labels and each terrain's true parameters,
//! `oracle-prior` trusting them no more than the prior) and the window
//! over which the pose is withheld.

use terraslip::config::EstimatorConfig;
use terraslip::pipeline::{self, EstimateRun, RunOptions, TerrainEvidence};
use terraslip_sim::family::World;
use terraslip_sim::SimRun;

use crate::family_target;

/// What the oracle is told: the terrain labels and each terrain's nominal
/// parameters.
fn oracle(w: &World, sim: &SimRun) -> (TerrainEvidence, Option<terraslip_io::ParamsFile>) {
    let mut pf = terraslip_io::ParamsFile::default();
    for l in &sim.log.terrain {
        if let Ok(p) = w.scenario.terrain_icr(&l.terrain) {
            pf.terrains
                .insert(l.terrain.clone(), terraslip_io::ParamEntry::new(p));
        }
    }
    (TerrainEvidence::Labels(sim.log.terrain.clone()), Some(pf))
}

/// Estimator `name` (configuration `cfg`) over world `w` (its log
/// `sim`), the pose withheld over `outage` (s, the wheels' clock): an `oracle` name is
/// told the terrain labels and each terrain's true parameters
/// (`oracle-prior` trusting them no more than the prior); the others get
/// the labels only with `labels`.
pub(crate) fn run_in_world(
    w: &World,
    sim: &SimRun,
    name: &str,
    cfg: &EstimatorConfig,
    labels: bool,
    outage: (f64, f64),
) -> anyhow::Result<EstimateRun> {
    // The outage on the pose stream's clock.
    let outage = (outage.0 + w.clock_offset, outage.1 + w.clock_offset);
    let opts = RunOptions {
        outage: Some(outage),
    };
    let (evidence, init) = if name.starts_with("oracle") {
        oracle(w, sim)
    } else if labels {
        (TerrainEvidence::Labels(sim.log.terrain.clone()), None)
    } else {
        (TerrainEvidence::None, None)
    };
    let prior_cfg;
    let cfg = if name == family_target::NAME {
        let track = sim
            .log
            .meta
            .track_width
            .unwrap_or(w.scenario.robot.track_width);
        prior_cfg = family_target::prior_uncertainty(cfg, track);
        &prior_cfg
    } else {
        cfg
    };
    Ok(pipeline::run_with(
        &sim.log,
        cfg,
        &evidence,
        init.as_ref(),
        opts,
        &mut |_, _| {},
    )?)
}
