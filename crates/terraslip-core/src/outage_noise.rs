//! The pose's uncertainty once the fixes stop.
//!
//! Between fixes a tenth of a second apart, the filter's model noise is
//! learned as a random walk over one fix interval; the model's error is a
//! slip that holds for seconds, so over an outage that noise states too
//! little (on the DRIVE ice drive the end-position NEES of a 30 s outage
//! reads 4.6 per dof). The twist noise learned at the one-second horizon
//! (`twist_noise.rs`) is the model's error where it holds: carried on as a
//! random walk of one-second slips, it grows the pose's variance at
//! `sigma^2 T` per second (`T` = [`TWIST_WINDOW_S`]). Once no fix has
//! arrived for [`OUTAGE_AFTER_S`], the estimator adds what that rate exceeds
//! the filter's own model noise by.

use crate::odometry::{ModelNoise, TwistNoise, TWIST_WINDOW_S};

/// Time without a fix (s of wheel time; a gated fix counts as one) after
/// which the pose's variance grows at the one-second twist noise's rate.
pub const OUTAGE_AFTER_S: f64 = 2.0 * TWIST_WINDOW_S;

/// Diffusion beyond the filter's model noise `model`, at mean tread speed
/// `v` (m/s) and yaw rate `omega` (rad/s), of the one-second twist noise
/// `learned` carried as a random walk: `(per position axis, m^2/s;
/// heading, rad^2/s)`, each at least 0. The position's is the mean of the
/// along- and cross-track parts (the filter's is the same on both axes).
pub fn excess_diffusion(
    learned: &TwistNoise,
    model: &ModelNoise,
    v: f64,
    omega: f64,
) -> (f64, f64) {
    let q = learned.variance(v, omega);
    let (q_xy, q_yaw) = model.diffusion(v, omega);
    let xy = 0.5 * (q[0] + q[1]) * TWIST_WINDOW_S - q_xy;
    let yaw = q[2] * TWIST_WINDOW_S - q_yaw;
    let pos = |x: f64| if x.is_finite() { x.max(0.0) } else { 0.0 };
    (pos(xy), pos(yaw))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::angle;
    use crate::rng::SplitMix64;
    use std::vec::Vec;

    /// A skid-steer whose yaw rate is the model's plus a slip of 0.03 rad/s
    /// held for about a second at a time, with fixes (0.02 m, 0.005 rad,
    /// stated) at 10 Hz: 300 s of turning and driving straight, then
    /// `cycles` times 30 s straight ahead at 0.8 m/s with no fix and 30 s
    /// of fixes again. Returns each outage's end heading error squared over
    /// the stated heading variance.
    fn outage_ends(cycles: usize) -> Vec<f64> {
        let (truth, mut est) = crate::twist_noise::tests::slipping_world();
        let mut rng = SplitMix64::new(5);
        let dt = 0.05;
        let (mut e, mut n, mut yaw) = (0.0f64, 0.0f64, 0.3f64);
        let (mut vl, mut vr, mut slip) = (0.0, 0.0, 0.0);
        let warm = 6000;
        let mut ends = Vec::new();
        for step in 0..warm + cycles * 1200 {
            let t = step as f64 * dt;
            // Within a cycle: an outage over its first 600 steps.
            let cycle = step.checked_sub(warm).map(|k| k % 1200);
            let out = cycle.is_some_and(|k| k < 600);
            if cycle == Some(600) {
                let err = angle::wrap(yaw - est.filter().pose().2);
                ends.push(err * err / est.filter().pose_covariance()[(2, 2)]);
            }
            if out {
                (vl, vr) = (0.8, 0.8);
            } else if step % 120 == 0 {
                vl = 0.5 + 0.5 * rng.uniform();
                vr = 0.5 + 0.5 * rng.uniform();
            }
            if rng.uniform() < dt {
                slip = 0.03 * rng.normal();
            }
            if !out && step % 2 == 0 {
                let fix = crate::twist_noise::tests::stated_fix(&mut rng, (e, n, yaw));
                est.on_pose(t, fix).unwrap();
            }
            est.on_wheels(t, vl, vr).unwrap();
            let tw = truth.twist(vl, vr);
            (e, n, yaw) = crate::twist_noise::tests::advance((e, n, yaw), &tw, slip, dt);
        }
        ends
    }

    #[test]
    fn through_an_outage_the_stated_heading_covers_the_held_slips() {
        // The median of a consistent 1-dof NEES is 0.45. With the filter's
        // own model noise it reads 17 here; with the one-second noise
        // carried on, 2.1: a slip held longer than a second is still
        // counted as independent seconds.
        let mut ends = outage_ends(40);
        ends.sort_by(f64::total_cmp);
        let median = ends[ends.len() / 2];
        assert!(
            (0.2..4.0).contains(&median),
            "median heading NEES {median:.2}"
        );
    }

    #[test]
    fn the_filter_s_own_noise_adds_nothing_and_a_wider_one_adds_its_excess() {
        // The default filter's model noise, before it learns.
        let model = ModelNoise::of(crate::twist_noise::tests::slipping_world().1.filter());
        let own = TwistNoise::from_model_noise(&model);
        let (xy, yaw) = excess_diffusion(&own, &model, 1.5, 0.4);
        assert!(xy.abs() < 1e-15 && yaw.abs() < 1e-15, "{xy} {yaw}");
        let mut wider = own;
        wider.coef[0][1] += 0.01;
        wider.coef[2][0] += 4e-4;
        let (xy, yaw) = excess_diffusion(&wider, &model, 2.0, 0.0);
        assert!((xy - 0.5 * 0.01 * 4.0).abs() < 1e-12, "{xy}");
        assert!((yaw - 4e-4).abs() < 1e-12, "{yaw}");
        let narrower = TwistNoise::default();
        assert_eq!(excess_diffusion(&narrower, &model, 1.0, 0.5), (0.0, 0.0));
    }
}
