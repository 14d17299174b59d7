//! The model's twist error learned at the horizon the twist is published
//! for: how far the ICR model's body twist, averaged over about a second,
//! is from the motion the pose fixes show.
//!
//! The filter's own model noise is learned from innovations a fix apart
//! (0.15 s on a lidar reference) as a random walk, while the model's error
//! is a slip that holds for seconds; over the published second that
//! understates it. Here, between two fixes [`TWIST_WINDOW_S`] or more
//! apart, the model's twist integrated in the body frame at the first fix
//! is compared with the fixes' displacement (and turn, when both carry a
//! heading). Each body component `k` (`v_x`, `v_y`, `ω`) of the mean
//! twist's error has a variance that is a quadratic form of the motion,
//!
//! `var_k = c_k0 + c_k1 v² + c_k2 ω²` (v the mean tread speed, ω the yaw
//! rate, both mean squares over the window),
//!
//! fitted by covariance matching, as the filter learns its fix noise
//! ([`crate::filter`]'s `noise.rs`): exponentially forgetting weighted least
//! squares of `e_k² / T² - known_k` on `(1, v², ω²)`, weights the inverse
//! of the variance stated for the window (so that the fit's constant term
//! makes the mean of `e_k² / stated` one, what a consistent covariance
//! keeps, even where the quadratic form is only near the truth),
//! coefficients non-negative, the prior (the filter's
//! model noise over the window) worth a few windows. `known_k` is what the
//! rest explains: the parameters' uncertainty through the kinematics and
//! the fixes' own noise at both ends. Nothing here changes the estimate.
//!
//! Frames: body REP-103 at the window's start; SI units.

use nalgebra::{Matrix2, Matrix3, SMatrix, Vector3};

use crate::kinematics::IcrParams;
use crate::odometry::{twist_jacobian, ModelNoise, TwistNoise, TWIST_WINDOW_S};
use crate::slip::SlipMat;

/// Memory of the learning, s of windows: old windows fade with this time
/// constant.
pub const TWIST_NOISE_MEMORY_S: f64 = 300.0;
/// Weight of the prior, windows.
const PRIOR_WEIGHT: f64 = 2.0;
/// Weight (windows) below which forgetting stops.
const MIN_WEIGHT: f64 = 10.0;
/// A sample weighs at most this many times the running mean weight.
const WEIGHT_CAP: f64 = 100.0;
/// Rate of the running mean of the weights, per sample.
const MEAN_RATE: f64 = 0.02;
/// Windows longer than this many [`TWIST_WINDOW_S`] (a gap in the fixes)
/// are not used.
const MAX_WINDOW_FACTOR: f64 = 2.0;

/// One component's regression `var = c · (1, v², ω²)`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct ComponentFit {
    m: Matrix3<f64>,
    v: Vector3<f64>,
    start: Vector3<f64>,
    placed: [bool; 3],
    coef: Vector3<f64>,
    mean_weight: f64,
    count: f64,
}

impl ComponentFit {
    fn new(start: [f64; 3]) -> Self {
        let s = Vector3::from(start);
        Self {
            m: Matrix3::zeros(),
            v: Vector3::zeros(),
            start: s,
            placed: [false; 3],
            coef: s,
            mean_weight: 0.0,
            count: 0.0,
        }
    }

    fn predict(&self, x: &Vector3<f64>) -> f64 {
        self.coef.dot(x)
    }

    fn forget(&mut self, keep: f64) {
        if self.count > MIN_WEIGHT {
            let k = keep.clamp(0.0, 1.0).max(MIN_WEIGHT / self.count);
            self.m *= k;
            self.v *= k;
            self.count *= k;
        }
    }

    /// One window: `y` the squared error of the mean twist less what the
    /// rest explains, `known` that part (for the sample's weight), `x` the
    /// regressors.
    fn add(&mut self, y: f64, known: f64, x: Vector3<f64>) {
        if !(y.is_finite() && known.is_finite() && x.iter().all(|v| v.is_finite())) {
            return;
        }
        let s = (known + self.predict(&x)).max(1e-12);
        let mut w = 1.0 / s;
        if self.mean_weight > 0.0 {
            w = w.min(WEIGHT_CAP * self.mean_weight);
        }
        self.mean_weight = if self.mean_weight > 0.0 {
            (1.0 - MEAN_RATE) * self.mean_weight + MEAN_RATE * w
        } else {
            w
        };
        for k in 0..3 {
            if !self.placed[k] && x[k] > 0.0 {
                self.placed[k] = true;
                let wk = PRIOR_WEIGHT * w * x[k] * x[k];
                self.m[(k, k)] += wk;
                self.v[k] += wk * self.start[k];
                self.count += PRIOR_WEIGHT;
            }
        }
        self.m += w * x * x.transpose();
        self.v += w * x * y;
        self.count += 1.0;
        self.solve();
    }

    /// Non-negative least squares over the placed parts: the best of the
    /// subsets whose solution is non-negative.
    fn solve(&mut self) {
        let mut best: Option<(f64, Vector3<f64>)> = None;
        for mask in 0u8..8 {
            let on: [bool; 3] = core::array::from_fn(|k| mask & (1 << k) != 0 && self.placed[k]);
            if (0..3).any(|k| mask & (1 << k) != 0 && !on[k]) {
                continue;
            }
            let mut m = self.m;
            let mut v = self.v;
            for k in 0..3 {
                if !on[k] {
                    for j in 0..3 {
                        m[(k, j)] = 0.0;
                        m[(j, k)] = 0.0;
                    }
                    m[(k, k)] = 1.0;
                    v[k] = 0.0;
                }
            }
            let Some(inv) = m.try_inverse() else {
                continue;
            };
            let c = inv * v;
            if c.iter().any(|c| !(c.is_finite() && *c >= 0.0)) {
                continue;
            }
            // Weighted sum of squares up to a constant.
            let cost = (c.transpose() * self.m * c)[0] - 2.0 * c.dot(&self.v);
            if best.is_none_or(|(b, _)| cost < b) {
                best = Some((cost, c));
            }
        }
        if let Some((_, c)) = best {
            // Parts not seen yet stay at their prior.
            self.coef = Vector3::from_fn(|k, _| if self.placed[k] { c[k] } else { self.start[k] });
        }
    }
}

/// What the model claims between the window's first fix and now.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Window {
    /// Time since the first fix, s.
    span: f64,
    /// The model's displacement (m) and turn (rad) in the body frame at the
    /// first fix.
    d: [f64; 2],
    turn: f64,
    /// Derivative of `(d, turn)` with respect to the ICR parameters.
    jac: SMatrix<f64, 3, 5>,
    /// `∫ v² dt`, `∫ ω² dt`.
    v2: f64,
    w2: f64,
    /// The first fix: position (m), heading (rad), the heading the body
    /// frame is taken at (the fix's, else the filter's), and the ICR
    /// parameters' covariance then.
    start_pos: Option<(f64, f64)>,
    start_yaw: Option<f64>,
    frame_yaw: f64,
    icr_cov: SlipMat,
}

/// The twist noise learner: the running window and the three fits.
#[derive(Debug, Clone, PartialEq)]
pub struct TwistNoiseLearner {
    fits: Option<[ComponentFit; 3]>,
    window: Option<Window>,
    windows: u64,
}

impl Default for TwistNoiseLearner {
    fn default() -> Self {
        Self::new()
    }
}

/// A pose fix as the learner takes it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FixSeen {
    /// Position of the reference point, m (ENU).
    pub position: Option<(f64, f64)>,
    /// Heading, rad.
    pub yaw: Option<f64>,
    /// The fixes' noise as the filter learned it: the white position std
    /// per axis (m), the heading std (rad), the std of the slow position
    /// error (m) and its correlation time (s).
    pub std_xy: f64,
    pub std_yaw: f64,
    pub bias_std: f64,
    pub bias_time: f64,
    /// The filter's heading after the fix, rad, and whether it is known.
    pub filter_yaw: f64,
    pub heading_known: bool,
    /// Where the reference sits on the body, m.
    pub lever_arm: (f64, f64),
}

impl TwistNoiseLearner {
    pub fn new() -> Self {
        Self {
            fits: None,
            window: None,
            windows: 0,
        }
    }

    /// Windows learned from.
    pub fn windows(&self) -> u64 {
        self.windows
    }

    /// The learned noise; `prior` (the filter's model noise) where nothing
    /// is learned yet.
    pub fn noise(&self, prior: &ModelNoise) -> TwistNoise {
        match &self.fits {
            Some(f) => TwistNoise {
                coef: core::array::from_fn(|k| f[k].coef.into()),
            },
            None => TwistNoise::from_model_noise(prior),
        }
    }

    /// A model step: twist `(v_x, v_y, ω)` of parameters `p` at tread
    /// speeds `v_left`, `v_right` (m/s) held over `dt` s.
    pub fn step(&mut self, p: &IcrParams, v_left: f64, v_right: f64, dt: f64) {
        let Some(w) = self.window.as_mut() else {
            return;
        };
        let tw = p.twist(v_left, v_right);
        if !(tw.v_x.is_finite() && tw.v_y.is_finite() && tw.omega.is_finite() && dt >= 0.0) {
            self.window = None;
            return;
        }
        let (s, c) = libm::sincos(w.turn);
        w.d[0] += (c * tw.v_x - s * tw.v_y) * dt;
        w.d[1] += (s * tw.v_x + c * tw.v_y) * dt;
        w.turn += tw.omega * dt;
        let j = twist_jacobian(p, v_left, v_right);
        let rot = Matrix2::new(c, -s, s, c);
        let xy = rot * j.fixed_rows::<2>(0) * dt;
        for k in 0..5 {
            w.jac[(0, k)] += xy[(0, k)];
            w.jac[(1, k)] += xy[(1, k)];
            w.jac[(2, k)] += j[(2, k)] * dt;
        }
        let v = 0.5 * (v_left + v_right);
        w.v2 += v * v * dt;
        w.w2 += tw.omega * tw.omega * dt;
        w.span += dt;
    }

    /// A window is running: [`Self::step`] adds to it.
    pub fn is_open(&self) -> bool {
        self.window.is_some()
    }

    /// Drops the running window (a gap in the tread speeds).
    pub fn break_window(&mut self) {
        self.window = None;
    }

    /// A fix taken now (after the filter's update): closes the running
    /// window when it is long enough and opens the next. `icr_cov` is the
    /// covariance of the ICR parameters in effect, `prior` the filter's
    /// model noise (the learning's start).
    pub fn on_fix(&mut self, fix: &FixSeen, icr_cov: &SlipMat, prior: &ModelNoise) {
        if fix.position.is_none() && fix.yaw.is_none() {
            return;
        }
        if let Some(w) = self.window {
            if w.span < TWIST_WINDOW_S - 1e-6 {
                return;
            }
            if w.span <= MAX_WINDOW_FACTOR * TWIST_WINDOW_S {
                self.learn(&w, fix, prior);
            }
        }
        self.window = Some(Window {
            span: 0.0,
            d: [0.0; 2],
            turn: 0.0,
            jac: SMatrix::zeros(),
            v2: 0.0,
            w2: 0.0,
            start_pos: fix.position,
            start_yaw: fix.yaw,
            frame_yaw: fix.yaw.unwrap_or(fix.filter_yaw),
            icr_cov: *icr_cov,
        });
        if fix.position.is_some() && fix.yaw.is_none() && !fix.heading_known {
            // No body frame to compare a displacement in.
            if let Some(w) = self.window.as_mut() {
                w.start_pos = None;
            }
        }
    }

    fn learn(&mut self, w: &Window, fix: &FixSeen, prior: &ModelNoise) {
        let t = w.span;
        let x = Vector3::new(1.0, w.v2 / t, w.w2 / t);
        let sym = 0.5 * (w.icr_cov + w.icr_cov.transpose());
        let param = w.jac * sym * w.jac.transpose();
        let fits = self.fits.get_or_insert_with(|| {
            let n = TwistNoise::from_model_noise(prior);
            core::array::from_fn(|k| ComponentFit::new(n.coef[k]))
        });
        for f in fits.iter_mut() {
            f.forget(libm::exp(-t / TWIST_NOISE_MEMORY_S));
        }
        let mut used = false;
        if let (Some(a), Some(b)) = (w.start_pos, fix.position) {
            // The reference point's displacement in the body frame at the
            // start, against the model's (the lever arm turned with it).
            let (s, c) = libm::sincos(w.frame_yaw);
            let (de, dn) = (b.0 - a.0, b.1 - a.1);
            let seen = [c * de + s * dn, -s * de + c * dn];
            let (ls, lc) = libm::sincos(w.turn);
            let (lx, ly) = fix.lever_arm;
            let model = [
                w.d[0] + lc * lx - ls * ly - lx,
                w.d[1] + ls * lx + lc * ly - ly,
            ];
            // Both ends' white noise, and how far the slow error moved.
            let moved = if fix.bias_time > 0.0 {
                1.0 - libm::exp(-t / fix.bias_time)
            } else {
                1.0
            };
            let r2 = 2.0 * fix.std_xy * fix.std_xy + 2.0 * fix.bias_std * fix.bias_std * moved;
            for k in 0..2 {
                let e = model[k] - seen[k];
                let known = param[(k, k)] + r2;
                fits[k].add((e * e - known) / (t * t), known / (t * t), x);
            }
            used = true;
        }
        if let (Some(a), Some(b)) = (w.start_yaw, fix.yaw) {
            let e = crate::angle::wrap(w.turn - crate::angle::wrap(b - a));
            let known = param[(2, 2)] + 2.0 * fix.std_yaw * fix.std_yaw;
            fits[2].add((e * e - known) / (t * t), known / (t * t), x);
            used = true;
        }
        self.windows += u64::from(used);
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::rng::SplitMix64;

    #[test]
    fn learns_a_slip_noise_that_grows_with_speed() {
        // Windows of 1 s at random speeds; the mean twist's error has
        // variance 0.01 v² along, 0.004 v² across, 0.002 + 0.05 ω² in yaw.
        let mut rng = SplitMix64::new(11);
        let mut fit = [
            ComponentFit::new([1e-4, 1e-3, 0.0]),
            ComponentFit::new([1e-4, 1e-3, 0.0]),
            ComponentFit::new([1e-6, 0.0, 1e-3]),
        ];
        let truth = [[0.0, 0.01, 0.0], [0.0, 0.004, 0.0], [0.002, 0.0, 0.05]];
        for _ in 0..4000 {
            let v = 2.0 * rng.uniform();
            let w = rng.uniform() - 0.5;
            let x = Vector3::new(1.0, v * v, w * w);
            for k in 0..3 {
                let var = Vector3::from(truth[k]).dot(&x);
                let e = var.sqrt() * rng.normal();
                fit[k].add(e * e, 0.0, x);
                fit[k].forget(libm::exp(-1.0 / TWIST_NOISE_MEMORY_S));
            }
        }
        for k in 0..3 {
            for (j, want) in truth[k].iter().copied().enumerate() {
                let got = fit[k].coef[j];
                assert!(
                    (got - want).abs() < 0.2 * want.max(2e-3),
                    "component {k} term {j}: {got} vs {want}"
                );
            }
        }
    }

    /// A fix of the pose `(east, north, yaw)` with 0.02 m and 0.005 rad of
    /// noise, stated.
    pub(crate) fn stated_fix(
        rng: &mut crate::rng::SplitMix64,
        (e, n, yaw): (f64, f64, f64),
    ) -> crate::filter::PoseFix {
        crate::filter::PoseFix {
            position: Some((e + 0.02 * rng.normal(), n + 0.02 * rng.normal())),
            yaw: Some(crate::angle::wrap(yaw + 0.005 * rng.normal())),
            std_xy: 0.02,
            std_yaw: 0.005,
            stated: true,
        }
    }

    /// The true pose `(east, north, yaw)` (m, rad) moved over `dt` s by the
    /// body twist `tw` with `slip` (rad/s) added to its yaw rate.
    pub(crate) fn advance(
        (e, n, yaw): (f64, f64, f64),
        tw: &crate::kinematics::Twist,
        slip: f64,
        dt: f64,
    ) -> (f64, f64, f64) {
        let (s, c) = libm::sincos(yaw);
        (
            e + (c * tw.v_x - s * tw.v_y) * dt,
            n + (s * tw.v_x + c * tw.v_y) * dt,
            crate::angle::wrap(yaw + (tw.omega + slip) * dt),
        )
    }

    /// The slipping skid-steer's true ICRs (0.62 m spread on a 0.5 m
    /// track) and an estimator for it: the default filter from a no-slip
    /// prior, no terrain evidence.
    pub(crate) fn slipping_world() -> (IcrParams, crate::Estimator) {
        use crate::filter::{Filter, FilterConfig, IcrBand, MeasurementConfig, Prior, SlipStd};
        use crate::kinematics::CentripetalSlopes;
        use crate::schedule::{NoiseSchedule, ScheduleConfig};
        let truth = IcrParams {
            y_l: 0.32,
            y_r: -0.30,
            x_c: 0.03,
            alpha_l: 0.93,
            alpha_r: 0.96,
        };
        let prior = Prior {
            icr: IcrParams::no_slip(0.5),
            std: SlipStd {
                spread: 0.25,
                centre: 0.05,
                x_c: 0.1,
                alpha: 0.15,
                alpha_diff: 0.01,
            },
            turn_law: 0.0,
            turn_law_std: 0.0,
            centripetal: CentripetalSlopes::NONE,
            centripetal_std: CentripetalSlopes::NONE,
            speed_law: 0.0,
            speed_law_std: 0.0,
        };
        let band = IcrBand {
            min_spread: 0.25,
            max_spread: 2.0,
            max_centre: 0.125,
            max_x_c: 0.25,
            alpha_range: (0.3, 1.5),
        };
        let f = Filter::new(
            &prior,
            FilterConfig::default(),
            MeasurementConfig::default(),
            band,
        )
        .unwrap();
        let est = crate::Estimator::new(f, NoiseSchedule::new(ScheduleConfig::default()), 0.0);
        (truth, est)
    }

    /// A world with known slip noise: the true twist is the ICR model's
    /// plus an error held for a random time, a second on average (variances along `4e-4 + 6.4e-3
    /// v²` (m/s)², across 9e-4 (m/s)², yaw `9e-4 + 0.01 ω²` (rad/s)²), pose
    /// fixes at
    /// 10 Hz. Returns the mean NEES of the published one-second twist
    /// against the truth over `n` windows after a warm-up, with the learned
    /// noise and with the filter's model noise (`q / window`).
    fn world_nees() -> (f64, f64, usize) {
        use crate::filter::PoseFix;
        use crate::odometry::twist_covariance;
        let (truth, mut est) = slipping_world();
        let mut rng = SplitMix64::new(21);
        let dt = 0.05;
        let (mut e, mut n, mut yaw) = (0.0f64, 0.0f64, 0.3f64);
        let (mut vl, mut vr) = (0.0, 0.0);
        let mut slip = [0.0; 3];
        let (mut sum_learned, mut sum_model, mut count) = (0.0, 0.0, 0);
        for sec in 0..1500 {
            if sec % 6 == 0 {
                vl = 2.0 * rng.uniform() - 1.0;
                vr = if rng.uniform() < 0.5 {
                    vl
                } else {
                    2.0 * rng.uniform() - 1.0
                };
            }
            let tw = truth.twist(vl, vr);
            let v = 0.5 * (vl + vr);
            let sd = [
                libm::sqrt(4e-4 + 6.4e-3 * v * v),
                0.03,
                libm::sqrt(9e-4 + 0.01 * tw.omega * tw.omega),
            ];
            // Over the second: the true mean twist, the published one and
            // its covariance at the second's middle.
            let mut published = Vector3::zeros();
            let mut truth_mean = Vector3::<f64>::zeros();
            let mut stated = (Matrix3::zeros(), Matrix3::zeros());
            for step in 0..20 {
                let t = sec as f64 + step as f64 * dt;
                // The slip changes at random, once a second on average.
                if rng.uniform() < dt || (sec % 6 == 0 && step == 0) {
                    for k in 0..3 {
                        slip[k] = sd[k] * rng.normal();
                    }
                }
                truth_mean +=
                    Vector3::new(tw.v_x + slip[0], tw.v_y + slip[1], tw.omega + slip[2]) / 20.0;
                let (s, c) = libm::sincos(yaw);
                let (vx, vy, w) = (tw.v_x + slip[0], tw.v_y + slip[1], tw.omega + slip[2]);
                if step % 2 == 0 {
                    let fix = PoseFix {
                        position: Some((e + 0.02 * rng.normal(), n + 0.02 * rng.normal())),
                        yaw: Some(yaw + 0.005 * rng.normal()),
                        std_xy: 0.02,
                        std_yaw: 0.005,
                        stated: true,
                    };
                    est.on_pose(t, fix).unwrap();
                }
                est.on_wheels(t, vl, vr).unwrap();
                e += (c * vx - s * vy) * dt;
                n += (s * vx + c * vy) * dt;
                yaw += w * dt;
                let f = est.filter();
                let p = f.icr_now();
                let pt = p.twist(vl, vr);
                published += Vector3::new(pt.v_x, pt.v_y, pt.omega) / 20.0;
                if step == 10 {
                    let cov = f.icr_now_covariance();
                    let prior = ModelNoise::of(f);
                    stated = (
                        twist_covariance(&p, &cov, &est.twist_noise(), vl, vr),
                        twist_covariance(&p, &cov, &TwistNoise::from_model_noise(&prior), vl, vr),
                    );
                }
            }
            if sec >= 300 {
                let err = published - truth_mean;
                let nees = |c: Matrix3<f64>| (err.transpose() * c.try_inverse().unwrap() * err)[0];
                sum_learned += nees(stated.0);
                sum_model += nees(stated.1);
                count += 1;
            }
        }
        (sum_learned / count as f64, sum_model / count as f64, count)
    }

    #[test]
    fn the_published_twist_is_consistent_in_a_world_with_known_slip_noise() {
        // A consistent covariance keeps the mean NEES at 3 (3 dof). The
        // windows share slips that straddle them, so the band of n
        // independent χ²(3) (±0.14 here) is too narrow a yardstick: 10 %.
        let (learned, model, n) = world_nees();
        assert!(
            (learned - 3.0).abs() < 0.3,
            "learned noise: mean NEES {learned:.2} over {n} windows"
        );
        // The filter's model noise as a random walk states far too little.
        assert!(model > 6.0, "model noise: mean NEES {model:.2}");
    }
}
