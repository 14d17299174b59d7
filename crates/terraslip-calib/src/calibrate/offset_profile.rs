//! The second stage of the wheel/pose time-offset search: the profile of a
//! quick model fit over candidate offsets.

use terraslip_core::IcrParams;
use terraslip_io::DriveLog;

use crate::lm::{self, LmConfig};
use crate::model;
use crate::offset;
use crate::reduction::Reduction;
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

/// The offset the profile of the fit chose, with how well the data pin it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct ProfiledOffset {
    /// s, the pose read this much later than its stamps.
    pub offset: f64,
    /// 1-sigma (s) from the profile's curvature at its minimum; `None`
    /// when the profile has no interior minimum within the search range
    /// (the data do not bracket the offset) or no fit was possible.
    pub std: Option<f64>,
}

impl ProfiledOffset {
    /// Largest 1-sigma (s) that still counts as pinned: the profile is
    /// sampled 50 ms apart and the held-out score moves by 0.1 m within
    /// about +-0.05 s of the best offset (docs/calibration.md).
    pub const PINNED_STD: f64 = 0.05;

    /// The data locate the offset: an interior minimum with a 1-sigma
    /// under [`Self::PINNED_STD`].
    pub fn pinned(&self) -> bool {
        self.std.is_some_and(|s| s <= Self::PINNED_STD)
    }
}

/// Second stage of the offset search, with the model itself: the profile
/// of the fit over the offset. At each offset within +-0.15 s of the
/// model-free estimate (50 ms steps, the same segments at every one, see
/// [`offset::common_segments`]) a quick per-terrain LM fit is made, and the
/// offset whose fit leaves the smallest trimmed residual (mean squared norm
/// of the best 90 % of segments, so stalled poses do not decide) wins,
/// refined by a parabola. This is the joint least-squares estimate of the
/// offset and the parameters; the model-free first stage only sees
/// symmetric ICRs and pure rotation or translation. Its 1-sigma is read
/// from the same parabola ([`offset_std`]). Returns `offset` unchanged,
/// without a 1-sigma, when no fit is possible.
///
/// `held` names the terrain sets whose fit holds a reduced model
/// ([`Reduction`]); the others fit all five parameters.
pub(super) fn refine_offset(
    log: &DriveLog,
    cfg: &SegmentConfig,
    offset: f64,
    (max, yaw_weight): (f64, f64),
    held: &[(Option<String>, Reduction)],
) -> ProfiledOffset {
    const STEP: f64 = 0.05;
    let grid: Vec<f64> = (-3..=3)
        .map(|k| offset + STEP * k as f64)
        .filter(|t| t.abs() <= max + 1e-9)
        .collect();
    let (curve, n) = profile(log, cfg, &grid, yaw_weight, held);
    ProfiledOffset {
        offset: offset::parabolic_minimum(&curve, STEP).unwrap_or(offset),
        std: offset_std(&curve, STEP, n),
    }
}

/// 1-sigma (s) of the offset from the profile `curve` of `(t, J)`, `J` the
/// mean squared residual norm of `n` segments: with Gaussian residuals of
/// variance `J_min / 3` per component (x, y and the weighted yaw), minus
/// twice the log-likelihood is `3 n J(t) / J_min`, and the offset's 1-sigma
/// is where that rises by 1 on the parabola `J_min + a (t - t0)^2` through
/// the minimum and its neighbours: `sqrt(J_min / (3 n a))`. `None` when the
/// minimum is at an end of the curve (not bracketed) or the parabola does
/// not open upwards.
pub(super) fn offset_std(curve: &[(f64, f64)], step: f64, n: usize) -> Option<f64> {
    let best = (0..curve.len())
        .filter(|&i| curve[i].1.is_finite())
        .min_by(|&a, &b| curve[a].1.total_cmp(&curve[b].1))?;
    if best == 0 || best + 1 >= curve.len() || n == 0 {
        return None;
    }
    let (l, m, r) = (curve[best - 1].1, curve[best].1, curve[best + 1].1);
    let a = (l - 2.0 * m + r) / (2.0 * step * step);
    // The vertex's value, not the grid point's.
    let j_min = m - (r - l).powi(2) / (16.0 * a * step * step);
    let var = j_min / (3.0 * n as f64 * a);
    (a > 0.0 && var.is_finite() && var > 0.0).then(|| var.sqrt())
}

/// Most segments each quick fit of the profile uses; a longer drive's
/// common segments are thinned to this many, evenly spread
/// ([`Segments::evenly_spread`]), each fit then integrating only their
/// steps. A 600 s Warthog drive has 1800-2300 (a segment from every pose).
const PROFILE_SEGMENTS: usize = 2000;

/// `(offset, trimmed residual)` of a quick per-terrain LM fit at each
/// offset of `grid`, all on the same segments, and the number of segments
/// each trimmed residual averages. One offset's segments are in memory at
/// a time.
fn profile(
    log: &DriveLog,
    cfg: &SegmentConfig,
    grid: &[f64],
    yaw_weight: f64,
    held: &[(Option<String>, Reduction)],
) -> (Vec<(f64, f64)>, usize) {
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
    let mut used = 0;
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
                return (Vec::new(), 0);
            }
            let width = match log.meta.track_width.or_else(|| spread_from_yaw(&segs)) {
                Some(w) => w,
                None => return (Vec::new(), 0),
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
            let quick = LmConfig {
                reduction: held
                    .iter()
                    .find(|h| h.0 == *name)
                    .map_or(Reduction::NONE, |h| h.1),
                ..quick.clone()
            };
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
        // Overlapping segments share their poses: the evidence of the
        // equivalent chained segments.
        used = used.max((keep as f64 / segs.coverage()).round() as usize);
        curve.push((t, sq[..keep].iter().sum::<f64>() / keep as f64));
    }
    (curve, used)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::{drive, mandow_table1, SynthConfig};

    #[test]
    fn a_monotone_profile_has_no_std_and_a_parabola_its_curvature() {
        // J = 0.03 + 3 (t - 0.31)^2 from 300 segments: J_min / (3 n a)
        // = 0.03 / 2700.
        let curve: Vec<(f64, f64)> = (0..7)
            .map(|k| {
                let t = 0.15 + 0.05 * k as f64;
                (t, 0.03 + 3.0 * (t - 0.31f64).powi(2))
            })
            .collect();
        let s = offset_std(&curve, 0.05, 300).expect("interior minimum");
        assert!((s - (0.03f64 / 2700.0).sqrt()).abs() < 1e-9, "{s}");
        let falling: Vec<(f64, f64)> = curve.iter().map(|&(t, _)| (t, 1.0 - t)).collect();
        assert_eq!(offset_std(&falling, 0.05, 300), None);
    }

    /// On simulated drives with a known pose latency the profiled offset
    /// lies within its stated 1-sigma as often as a 1-sigma should.
    #[test]
    fn the_offset_and_its_std_match_a_known_latency() {
        let mut z = Vec::new();
        for (seed, latency) in [
            (11, 0.2),
            (4, 0.2),
            (12, 0.33),
            (13, 0.33),
            (14, 0.1),
            (15, 0.1),
            (16, 0.0),
            (17, 0.0),
        ] {
            let mut sc = SynthConfig::p3at(200.0, seed);
            sc.pose_latency = latency;
            // The simulated tread speeds are held between samples, which the
            // segments read as half a sample late (5 ms at 100 Hz): fast
            // samples keep that bias of the simulation below the 1-sigma.
            sc.wheel_rate = 400.0;
            let log = drive(&[("asphalt", mandow_table1())], &sc);
            let cfg = super::super::CalibConfig::default()
                .segment
                .for_logs(std::slice::from_ref(&log));
            let cfg = SegmentConfig {
                overlap: Some(0.0),
                ..cfg
            };
            let (first, _) = offset::estimate_offset(&log, &cfg, 0.5, 0.01).expect("first stage");
            let p = refine_offset(&log, &cfg, first, (0.5, 0.5), &[]);
            let std = p.std.expect("an interior minimum");
            eprintln!("seed {seed} latency {latency}: {:.4} +- {std:.4}", p.offset);
            assert!(p.pinned(), "{p:?}");
            z.push((p.offset - latency) / std);
        }
        let rms = (z.iter().map(|z| z * z).sum::<f64>() / z.len() as f64).sqrt();
        eprintln!("normalised errors {z:?}, rms {rms:.2}");
        assert!(rms < 2.0 && z.iter().all(|z| z.abs() < 4.0), "{z:?}");
    }
}
