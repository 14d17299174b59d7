//! What a gated fix says about the published pose.
//!
//! A fix part the chi-square gate rejects is left out of the estimate: one
//! outlier must not drag it. But when the estimate is the one that is off
//! (a slip held for seconds on ice, a heading the filter lost), every fix
//! of that part is gated and the filter goes on stating a covariance the
//! fixes plainly contradict. So the stated pose covariance takes in what
//! the last gated part's innovation `ν` left unexplained by its covariance
//! `S`, `max(0, ν² − S)` (per position axis, and for the heading), until a
//! fix of that part is fused again. The estimate, and the filter's own
//! covariance, are left as they are: a lone outlier costs only a wider
//! stated pose until the next fix.

use nalgebra::{Matrix2, Matrix3};

use crate::filter::{Fate, UpdateReport};

/// The variance the fixes' last gated parts left unexplained.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct GatedDisagreement {
    /// Per position axis (m²), and the heading's (rad²).
    var: [f64; 2],
}

impl GatedDisagreement {
    /// Takes in one update: a gated part sets its variance, a fused or
    /// anchored one clears it, an absent one leaves it.
    pub fn record(&mut self, rep: &UpdateReport) {
        for (k, fate) in [rep.position, rep.yaw].into_iter().enumerate() {
            match fate {
                Fate::Gated => self.var[k] = rep.unexplained[k],
                Fate::Fused | Fate::Anchored => self.var[k] = 0.0,
                Fate::Absent => {}
            }
        }
    }

    /// A position covariance (east, north; m²), such as the position's
    /// as the fixes see it, with the position's unexplained variance added.
    pub fn widen_position(&self, cov: &Matrix2<f64>) -> Matrix2<f64> {
        cov + Matrix2::identity() * self.var[0]
    }

    /// `cov` (east, north, yaw) with the unexplained variances added.
    pub fn widen(&self, cov: &Matrix3<f64>) -> Matrix3<f64> {
        let mut c = *cov;
        let position = self.widen_position(&c.fixed_view::<2, 2>(0, 0).into_owned());
        c.fixed_view_mut::<2, 2>(0, 0).copy_from(&position);
        c[(2, 2)] += self.var[1];
        c
    }
}

#[cfg(test)]
mod tests {
    use crate::angle;
    use crate::rng::SplitMix64;

    /// The slipping skid-steer of `twist_noise`'s tests, fixes (0.02 m,
    /// 0.005 rad, stated) at 10 Hz: 300 s of turning and driving, then
    /// straight ahead at 1 m/s with a yaw slip of 0.15 rad/s held for 2 s.
    /// Returns the largest heading error squared over the stated heading
    /// variance, and over the filter's own, at the steps where a heading
    /// fix was gated in the 3 s from the slip's start, and how many.
    fn held_yaw_slip() -> (f64, f64, usize) {
        let (truth, mut est) = crate::twist_noise::tests::slipping_world();
        let mut rng = SplitMix64::new(9);
        let dt = 0.05;
        let (mut e, mut n, mut yaw) = (0.0f64, 0.0f64, 0.3f64);
        let (mut vl, mut vr, mut slip) = (0.0, 0.0, 0.0);
        let warm = 6000;
        let (mut stated, mut own, mut gated) = (0.0f64, 0.0f64, 0);
        for step in 0..warm + 60 {
            let t = step as f64 * dt;
            if step < warm {
                if step % 120 == 0 {
                    vl = 2.0 * rng.uniform() - 1.0;
                    vr = if rng.uniform() < 0.5 {
                        vl
                    } else {
                        2.0 * rng.uniform() - 1.0
                    };
                }
                if rng.uniform() < dt {
                    slip = 0.03 * rng.normal();
                }
            } else {
                (vl, vr) = (1.0, 1.0);
                slip = if step - warm < 40 { 0.15 } else { 0.0 };
            }
            let before = est.counts().yaw_gated;
            if step % 2 == 0 {
                let fix = crate::twist_noise::tests::stated_fix(&mut rng, (e, n, yaw));
                est.on_pose(t, fix).unwrap();
            }
            est.on_wheels(t, vl, vr).unwrap();
            if step >= warm && est.counts().yaw_gated > before {
                gated += 1;
                let err = angle::wrap(yaw - est.filter().pose().2);
                stated = stated.max(err * err / est.pose_covariance()[(2, 2)]);
                own = own.max(err * err / est.filter().pose_covariance()[(2, 2)]);
            }
            let tw = truth.twist(vl, vr);
            (e, n, yaw) = crate::twist_noise::tests::advance((e, n, yaw), &tw, slip, dt);
        }
        (stated, own, gated)
    }

    #[test]
    fn a_slip_the_gate_rejects_widens_the_stated_heading() {
        let (stated, own, gated) = held_yaw_slip();
        // The slip's heading fixes are gated, and meanwhile the filter's
        // own heading variance claims a heading it has lost (about 1 000).
        assert!(gated >= 5, "{gated} heading fixes gated");
        assert!(own > 100.0, "the filter's own: largest e²/P {own:.1}");
        // The stated one covers the error the gated fixes show (about 1).
        assert!(
            stated < 4.0,
            "stated: largest e²/P {stated:.1} ({gated} gated)"
        );
    }
}
