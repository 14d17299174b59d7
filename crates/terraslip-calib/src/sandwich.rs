//! Where the residual noise comes from, and the parameter covariance that
//! follows from it (a sandwich estimate).
//!
//! A segment's reference increment is its end pose minus its start pose in
//! the start frame, so a pose's noise enters every segment it ends with one
//! sign and every segment it starts with the other (rotated). Residuals of
//! segments that share a pose are therefore correlated, and with chains or
//! overlapping chains most of a pose's noise cancels in the fit (a
//! telescoping sum). The plain least-squares covariance `s² (JᵀWJ)⁻¹`
//! treats residuals as independent and overstates the uncertainty 4-7x on
//! overlapping fit segments (see `docs/research-log.md`).
//!
//! Noise model, per log:
//! - every pose carries independent noise: `σ_xy` on each position axis
//!   (isotropic, so its frame does not matter) and `σ_yaw` on the heading;
//! - on top, each segment carries an excess that grows with its duration
//!   like a random walk (wheel noise, what the kinematic model cannot
//!   explain): `q_xy` m²/s per position axis and `q_yaw` (m of the weighted
//!   yaw residual)²/s; two overlapping segments share the excess of their
//!   common time (frame rotation between their start frames neglected).
//!
//! Both are estimated from the residuals at the fit: the pose noise from
//! the lag-one cross moments of touching segments (one ending at the pose
//! another starts at: `E[r_a r_bᵀ]` is minus the pose noise, rotated, and
//! independent of the excess), the excess from what the pose noise leaves
//! of the residual variance. Then, with `g = Σ w_i J_iᵀ r_i` the score,
//! `cov(θ) = A⁻¹ Var(g) A⁻¹`, `A = Σ w_i J_iᵀ J_i`,
//! `Var(g) = Σ_p G_p S G_pᵀ + Σ_{i,j} w_i w_j overlap_ij J_iᵀ Q J_j` with
//! `G_p = Σ_{i touching p} w_i J_iᵀ D_ip` (`D_ip` the derivative of segment
//! `i`'s residual w.r.t. the noise of pose `p` in that pose's frame).
//! Without any touching segments the pose noise cannot be told from the
//! excess, everything is excess and the estimate is the usual
//! independent-residual one (up to its `n - k` correction).

#![allow(non_snake_case)]

use std::collections::BTreeMap;

use nalgebra::SMatrix;

use crate::segment::Segments;

/// The residual noise the sandwich estimate assumes, estimated from the
/// residuals of one fit.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ResidualNoise {
    /// Pose reference noise per position axis, m (1-sigma).
    pub pose_xy: f64,
    /// Pose reference heading noise, rad (1-sigma).
    pub pose_yaw: f64,
    /// Excess per position axis per segment, m/√s (1-sigma of a 1 s segment).
    pub excess_xy: f64,
    /// Excess heading noise per segment, rad/√s.
    pub excess_yaw: f64,
    /// Touching segment pairs the pose noise was estimated from.
    pub pairs: usize,
}

/// The segments at each pose, keyed by (log, pose time bits): (segment,
/// whether it ends there).
type PoseUse = BTreeMap<(usize, u64), Vec<(usize, bool)>>;

/// Pairs of segments (by index) that share a pose, `a` ending where `b`
/// starts, and the segments at each pose.
fn touching(segs: &Segments, w: &[f64]) -> (Vec<(usize, usize)>, PoseUse) {
    // Poses are shared bit for bit: a segment's t0/t1 are the pose times.
    let mut at = PoseUse::new();
    for (i, s) in segs.segments.iter().enumerate() {
        if w[i] > 0.0 {
            at.entry((s.log, s.t0.to_bits()))
                .or_default()
                .push((i, false));
            at.entry((s.log, s.t1.to_bits()))
                .or_default()
                .push((i, true));
        }
    }
    let mut pairs = Vec::new();
    for list in at.values() {
        for &(a, a_ends) in list {
            for &(b, b_ends) in list {
                if a_ends && !b_ends {
                    pairs.push((a, b));
                }
            }
        }
    }
    pairs.sort_unstable();
    (pairs, at)
}

/// Rotation by `phi` applied to `(x, y)`.
fn rot(phi: f64, x: f64, y: f64) -> (f64, f64) {
    let (s, c) = phi.sin_cos();
    (c * x - s * y, s * x + c * y)
}

/// Estimates [`ResidualNoise`] from the residuals `r` (`[dx, dy, yaw_weight
/// dyaw]`) of the segments with `w > 0`.
pub fn estimate_noise(
    segs: &Segments,
    r: &[[f64; 3]],
    w: &[f64],
    yaw_weight: f64,
) -> ResidualNoise {
    let (pairs, _) = touching(segs, w);
    let yw2 = (yaw_weight * yaw_weight).max(1e-300);
    let (mut sxy2, mut syaw2) = (0.0, 0.0);
    if !pairs.is_empty() {
        let (mut cp, mut cy) = (0.0, 0.0);
        for &(a, b) in &pairs {
            // E[r_a,pos · R(φ_a) r_b,pos] = -2 σ_xy², E[r_a,yaw r_b,yaw] = -w² σ_yaw².
            let (x, y) = rot(segs.segments[a].reference.dyaw, r[b][0], r[b][1]);
            cp += r[a][0] * x + r[a][1] * y;
            cy += r[a][2] * r[b][2];
        }
        let n = pairs.len() as f64;
        sxy2 = (-cp / (2.0 * n)).max(0.0);
        syaw2 = (-cy / (n * yw2)).max(0.0);
    }
    // What the pose noise leaves of the residual variance is the excess.
    let (mut ep, mut ey, mut t) = (0.0, 0.0, 0.0);
    for (i, s) in segs.segments.iter().enumerate() {
        if w[i] > 0.0 {
            let d2 = s.reference.dx.powi(2) + s.reference.dy.powi(2);
            ep += r[i][0].powi(2) + r[i][1].powi(2) - 4.0 * sxy2 - syaw2 * d2;
            ey += r[i][2].powi(2) - 2.0 * yw2 * syaw2;
            t += s.t1 - s.t0;
        }
    }
    let t = t.max(1e-300);
    ResidualNoise {
        pose_xy: sxy2.sqrt(),
        pose_yaw: syaw2.sqrt(),
        excess_xy: (ep / (2.0 * t)).max(0.0).sqrt(),
        excess_yaw: ((ey / t).max(0.0) / yw2).sqrt(),
        pairs: pairs.len(),
    }
}

/// `Var(Σ w_i J_iᵀ r_i)` under `noise` (module doc); `J[i][k][c]` is the
/// derivative of segment `i`'s residual component `c` w.r.t. parameter `k`
/// (either sign), zero for fixed parameters.
pub fn meat<const N: usize>(
    segs: &Segments,
    J: &[[[f64; 3]; N]],
    w: &[f64],
    yaw_weight: f64,
    noise: &ResidualNoise,
) -> SMatrix<f64, N, N> {
    let mut M = SMatrix::<f64, N, N>::zeros();
    let (sxy2, syaw2) = (noise.pose_xy.powi(2), noise.pose_yaw.powi(2));
    let (_, at) = touching(segs, w);
    if sxy2 > 0.0 || syaw2 > 0.0 {
        for list in at.values() {
            // G_p: N x 3 (noise x, y, yaw in the pose's frame).
            let mut G = [[0.0f64; 3]; N];
            for &(i, ends) in list {
                let s = &segs.segments[i];
                for k in 0..N {
                    let j = J[i][k];
                    let g = if ends {
                        // Residual of a segment ending at p: R(dyaw) n_xy, w n_yaw.
                        let (sn, cs) = s.reference.dyaw.sin_cos();
                        [
                            j[0] * cs + j[1] * sn,
                            -j[0] * sn + j[1] * cs,
                            j[2] * yaw_weight,
                        ]
                    } else {
                        // Starting at p: -n_xy, the increment turned by n_yaw, -w n_yaw.
                        [
                            -j[0],
                            -j[1],
                            j[0] * s.reference.dy - j[1] * s.reference.dx - j[2] * yaw_weight,
                        ]
                    };
                    for c in 0..3 {
                        G[k][c] += w[i] * g[c];
                    }
                }
            }
            for a in 0..N {
                for b in 0..N {
                    M[(a, b)] +=
                        sxy2 * (G[a][0] * G[b][0] + G[a][1] * G[b][1]) + syaw2 * G[a][2] * G[b][2];
                }
            }
        }
    }
    let q = [
        noise.excess_xy.powi(2),
        noise.excess_xy.powi(2),
        (noise.excess_yaw * yaw_weight).powi(2),
    ];
    if q.iter().any(|&x| x > 0.0) {
        let mut order: Vec<usize> = (0..segs.segments.len()).filter(|&i| w[i] > 0.0).collect();
        order.sort_by(|&a, &b| {
            let (x, y) = (&segs.segments[a], &segs.segments[b]);
            x.log.cmp(&y.log).then(x.t0.total_cmp(&y.t0))
        });
        for (n, &i) in order.iter().enumerate() {
            let si = &segs.segments[i];
            for &j in &order[n..] {
                let sj = &segs.segments[j];
                if sj.log != si.log || sj.t0 >= si.t1 {
                    break;
                }
                let ov = si.t1.min(sj.t1) - sj.t0;
                let f = w[i] * w[j] * ov * if i == j { 1.0 } else { 2.0 };
                for a in 0..N {
                    for b in 0..N {
                        let v: f64 = (0..3)
                            .map(|c| {
                                0.5 * q[c] * (J[i][a][c] * J[j][b][c] + J[j][a][c] * J[i][b][c])
                            })
                            .sum();
                        M[(a, b)] += f * v;
                    }
                }
            }
        }
    }
    M
}
