//! One parameter set per terrain label (or one pooled): the sets the
//! labels make, each calibrated on its segments with the robot's facts
//! and the logs' offsets.

use terraslip_io::DriveLog;

use super::offset_warnings::offset_note;
use super::robot::RobotFacts;
use super::set::calibrate_set;
use super::{CalibConfig, Calibration, Progress, TimeOffset};
use crate::segment::{SegmentConfig, Segments};
use crate::CalibError;

/// Most fit segments one parameter set is calibrated on; a set with more
/// (a long drive) is thinned to this many, evenly spread
/// ([`Segments::evenly_spread`]), and every method fits on those. A 600 s
/// drive has about 2500.
pub const FIT_SEGMENTS: usize = 20_000;

/// One parameter set per terrain (or one pooled), the logs read with
/// `offsets` (s, with their 1-sigma).
pub(super) fn calibrate_sets(
    logs: &[DriveLog],
    cfg: &CalibConfig,
    scfg: &SegmentConfig,
    offset_found: &[(f64, Option<f64>)],
    progress: &dyn Fn(Progress),
    mut warnings: Vec<String>,
) -> Result<Calibration, CalibError> {
    let offsets: Vec<f64> = offset_found.iter().map(|o| o.0).collect();
    let offset_stds: Vec<Option<f64>> = offset_found.iter().map(|o| o.1).collect();
    let refs: Vec<&DriveLog> = logs.iter().collect();
    let all = Segments::build(&refs, &offsets, scfg);
    let names = terrain_sets(all.segments.iter().map(|s| &s.terrain));
    let RobotFacts {
        track_width,
        wheel_radius,
        pioneer,
    } = RobotFacts::of(logs);
    let mut sets = Vec::new();
    let n_sets = names.len();
    let mut first_err: Option<CalibError> = None;
    for name in names {
        let mut segs = all.clone();
        segs.retain(|s| s.terrain == name);
        let found = segs.len();
        let thinned = found > FIT_SEGMENTS;
        if thinned {
            segs = segs.subset(&Segments::evenly_spread(&vec![true; found], FIT_SEGMENTS));
        }
        let label = name.clone().unwrap_or_else(|| "all".into());
        progress(Progress::Stage(&label));
        let mut set = match calibrate_set(&segs, &label, track_width, cfg, progress, &mut warnings)
        {
            Ok(s) => s,
            // One terrain patch too short to calibrate must not sink the others.
            Err(e) if n_sets > 1 => {
                warnings.push(format!("terrain `{label}` not calibrated: {e}"));
                first_err.get_or_insert(e);
                continue;
            }
            Err(e) => return Err(e),
        };
        set.terrain = name;
        if thinned {
            set.notes.push(format!(
                "fitted on {FIT_SEGMENTS} of its {found} segments, evenly spread over the \
                 drive (the bound that keeps long drives fast)"
            ));
        }
        // Counts and offsets of the logs that drove on this terrain.
        let mut used_logs: Vec<usize> = segs.segments.iter().map(|s| s.log).collect();
        used_logs.dedup();
        used_logs.sort_unstable();
        used_logs.dedup();
        for &i in &used_logs {
            if let Some(st) = all.per_log.get(i) {
                set.stats.add(st);
            }
        }
        set.time_offsets = used_logs
            .iter()
            .map(|&i| (logs[i].name(), offsets[i]))
            .collect();
        if matches!(cfg.time_offset, TimeOffset::Auto { .. }) {
            set.notes.extend(
                used_logs
                    .iter()
                    .map(|&i| offset_note(&logs[i], offset_stds[i])),
            );
        }
        set.track_width = track_width;
        set.wheel_radius = wheel_radius;
        set.pioneer = pioneer;
        for d in &mut set.dropped {
            if let Ok(i) = d.log.parse::<usize>() {
                d.log = logs.get(i).map(|l| l.name()).unwrap_or_default();
            }
        }
        sets.push(set);
    }
    if sets.is_empty() {
        if let Some(e) = first_err {
            return Err(e);
        }
    }
    Ok(Calibration { sets, warnings })
}

/// The parameter sets, one per terrain label in order of appearance
/// (`None`, the pooled set, for unlabelled data; just that when there is
/// nothing).
pub(super) fn terrain_sets<'a>(
    labels: impl Iterator<Item = &'a Option<String>>,
) -> Vec<Option<String>> {
    let mut names: Vec<Option<String>> = Vec::new();
    for l in labels {
        if !names.contains(l) {
            names.push(l.clone());
        }
    }
    if names.is_empty() {
        names.push(None);
    }
    names
}
