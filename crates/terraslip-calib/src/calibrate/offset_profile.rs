//! The second stage of the wheel/pose time-offset search: the profile of a
//! quick model fit over candidate offsets.

use terraslip_core::IcrParams;
use terraslip_io::DriveLog;

use crate::lm::{self, LmConfig};
use crate::model;
use crate::offset;
use crate::segment::{SegmentConfig, Segments};

/// Spread (m) that best explains the yaw changes with unit alphas:
/// `dyaw ~ int (v_r - v_l) dt / spread`. A starting point without meta.toml.
pub(super) fn spread_from_yaw(segs: &Segments) -> Option<f64> {
    let (mut num, mut den) = (0.0, 0.0);
    for s in &segs.segments {
        num += s.int_diff * s.int_diff;
        den += s.int_diff * s.reference.dyaw;
    }
    let d = num / den;
    (d.is_finite() && d > 0.0).then_some(d)
}

/// Second stage of the offset search, with the model itself: the profile
/// of the fit over the offset. At each offset within +-0.15 s of the
/// model-free estimate (50 ms steps, the same segments at every one, see
/// [`offset::common_segments`]) a quick per-terrain LM fit is made, and the
/// offset whose fit leaves the smallest trimmed residual (mean squared norm
/// of the best 90 % of segments, so stalled poses do not decide) wins,
/// refined by a parabola. This is the joint least-squares estimate of the
/// offset and the parameters; the model-free first stage only sees
/// symmetric ICRs and pure rotation or translation. Returns `offset`
/// unchanged when no fit is possible.
pub(super) fn refine_offset(
    log: &DriveLog,
    cfg: &SegmentConfig,
    offset: f64,
    max: f64,
    yaw_weight: f64,
) -> f64 {
    const STEP: f64 = 0.05;
    let grid: Vec<f64> = (-3..=3)
        .map(|k| offset + STEP * k as f64)
        .filter(|t| t.abs() <= max + 1e-9)
        .collect();
    let curve = profile(log, cfg, &grid, yaw_weight);
    offset::parabolic_minimum(&curve, STEP).unwrap_or(offset)
}

/// Most segments each quick fit of the profile uses; a longer drive's
/// common segments are thinned to this many, evenly spread
/// ([`Segments::evenly_spread`]), each fit then integrating only their
/// steps. A 600 s drive has about 600.
const PROFILE_SEGMENTS: usize = 2000;

/// `(offset, trimmed residual)` of a quick per-terrain LM fit at each
/// offset of `grid`, all on the same segments. One offset's segments are
/// in memory at a time.
fn profile(log: &DriveLog, cfg: &SegmentConfig, grid: &[f64], yaw_weight: f64) -> Vec<(f64, f64)> {
    let keys = offset::common_keys(log, grid, cfg);
    let quick = LmConfig {
        irls_rounds: 2,
        ..LmConfig::default()
    };
    // Terrain names and the starting width, from the first offset's
    // segments (every offset has the same ones).
    let mut names: Vec<Option<String>> = Vec::new();
    let mut starts: Vec<IcrParams> = Vec::new();
    let mut curve = Vec::new();
    for (k, &t) in grid.iter().enumerate() {
        let mut segs = offset::segments_among(log, t, cfg, &keys);
        if segs.len() > PROFILE_SEGMENTS {
            segs = segs.subset(&Segments::evenly_spread(
                &vec![true; segs.len()],
                PROFILE_SEGMENTS,
            ));
        }
        if k == 0 {
            if segs.is_empty() {
                return Vec::new();
            }
            let width = match log.meta.track_width.or_else(|| spread_from_yaw(&segs)) {
                Some(w) => w,
                None => return Vec::new(),
            };
            for s in &segs.segments {
                if !names.contains(&s.terrain) {
                    names.push(s.terrain.clone());
                }
            }
            // Warm start from the previous offset's fit: neighbouring
            // offsets have neighbouring parameters.
            starts = vec![IcrParams::no_slip(width); names.len()];
        }
        let segs = &segs;
        let mut sq: Vec<f64> = Vec::new();
        for (name, start) in names.iter().zip(starts.iter_mut()) {
            let active: Vec<bool> = segs.segments.iter().map(|s| s.terrain == *name).collect();
            if active.iter().filter(|&&a| a).count() < 10 {
                continue;
            }
            let Some(f) = lm::fit(segs, start, &active, yaw_weight, &quick) else {
                continue;
            };
            *start = f.params;
            sq.extend(
                segs.segments
                    .iter()
                    .zip(&active)
                    .filter(|(_, &a)| a)
                    .map(|(s, _)| {
                        let r = model::residual(&f.params, segs, s, yaw_weight);
                        r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
                    }),
            );
        }
        if sq.len() < 10 {
            continue;
        }
        sq.sort_by(f64::total_cmp);
        let keep = (sq.len() * 9).div_ceil(10);
        curve.push((t, sq[..keep].iter().sum::<f64>() / keep as f64));
    }
    curve
}
