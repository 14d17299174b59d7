//! The whole offline calibration: the time offset searched (and profiled
//! again with a reduced model), then one parameter set per terrain.

use terraslip_io::DriveLog;

use super::offset_profile::refine_offset;
use super::offset_warnings::{offset_at_edge, offset_not_pinned};
use super::per_terrain::calibrate_sets;
use super::{CalibConfig, Calibration, Progress, TimeOffset};
use crate::offset::estimate_offset;
use crate::reduction::Reduction;
use crate::segment::SegmentConfig;
use crate::CalibError;

/// Calibrates from `logs` (each must have `pose.csv`).
pub fn calibrate(
    logs: &[DriveLog],
    cfg: &CalibConfig,
    progress: &dyn Fn(Progress),
) -> Result<Calibration, CalibError> {
    if logs.is_empty() {
        return Err(CalibError::NoLogs);
    }
    let mut warnings = Vec::new();
    for log in logs {
        if log.pose.is_empty() {
            return Err(CalibError::NoPose {
                log: log.dir.clone(),
            });
        }
        warnings.extend(log.warnings.iter().cloned());
    }
    if logs.iter().all(crate::track::position_only) {
        return super::position_only::calibrate(logs, cfg, progress, warnings);
    }
    let scfg = cfg.segment.for_logs(logs);
    // The offset search compares candidates on the segments usable at
    // every one ([`crate::offset::common_keys`]): a segment from every
    // pose, so that a pose dropped at one candidate (mistimed, gated)
    // removes only the segments that touch it. Chained segments shift
    // their phase at such a pose and lose every later segment to the
    // comparison (44 of 190 kept on the first half of the ice drive).
    let ocfg = SegmentConfig {
        overlap: Some(0.0),
        ..scfg.clone()
    };
    // The offset is the joint least-squares estimate with the model; a set
    // that holds a reduced model ([`crate::reduction`]) has it profiled
    // again with that model, until the selection stands.
    let mut held: Vec<(Option<String>, Reduction)> = Vec::new();
    let mut pass = 1;
    loop {
        let mut w = warnings.clone();
        let offsets = search_offsets(logs, cfg, &ocfg, &held, &mut w, progress);
        let cal = calibrate_sets(logs, cfg, &scfg, &offsets, progress, w)?;
        let selected: Vec<(Option<String>, Reduction)> = cal
            .sets
            .iter()
            .filter_map(|s| Some((s.terrain.clone(), s.reduction.as_ref()?.selected)))
            .filter(|h| !h.1.is_none())
            .collect();
        if selected == held
            || pass >= OFFSET_PASSES
            || !matches!(cfg.time_offset, TimeOffset::Auto { .. })
        {
            return Ok(cal);
        }
        held = selected;
        pass += 1;
    }
}

/// Most rounds of the offset search and the calibration when a reduced
/// model is selected: the second profiles the offset with it, a third
/// settles a selection that the offset changed.
const OFFSET_PASSES: usize = 3;

/// Each log's time offset (s) and its 1-sigma, searched (or given) as
/// `cfg.time_offset` says, the profile's fits holding `held`'s reduced
/// models; warnings about offsets the data do not pin go to `warnings`.
pub(super) fn search_offsets(
    logs: &[DriveLog],
    cfg: &CalibConfig,
    ocfg: &SegmentConfig,
    held: &[(Option<String>, Reduction)],
    warnings: &mut Vec<String>,
    progress: &dyn Fn(Progress),
) -> Vec<(f64, Option<f64>)> {
    progress(Progress::Stage("aligning wheel and pose streams"));
    let mut offsets = Vec::with_capacity(logs.len());
    for full in logs {
        // A long drive's offset is searched on evenly spread windows of it.
        let log = &*crate::offset::thinned(full, crate::offset::OFFSET_POSES);
        let o = match cfg.time_offset {
            TimeOffset::Fixed(o) => o,
            TimeOffset::Auto { max, step } => match estimate_offset(log, ocfg, max, step) {
                Some((o, _)) => o,
                None => {
                    warnings.push(format!(
                        "{}: too few moving segments to estimate the time offset; using 0 s",
                        log.dir.display()
                    ));
                    0.0
                }
            },
        };
        let (o, std) = match cfg.time_offset {
            TimeOffset::Auto { max, step } => {
                let p = refine_offset(log, ocfg, o, (max, cfg.yaw_weight), held);
                if p.offset.abs() >= max - 0.5 * step {
                    warnings.push(offset_at_edge(log, p.offset, max));
                } else if !p.pinned() {
                    warnings.push(offset_not_pinned(log, &p));
                }
                (p.offset, p.std)
            }
            TimeOffset::Fixed(_) => (o, None),
        };
        offsets.push((o, std));
    }
    offsets
}
