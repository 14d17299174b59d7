//! Predicted increments and the fitness of a parameter set (Mandow eq. 13).

use terraslip_core::kinematics::{CentripetalSlopes, TurnRateSlopes, RATE_GAIN_MAX, RATE_GAIN_MIN};
use terraslip_core::{angle, IcrParams, Twist};

use crate::segment::{Increment, Segment, Segments, Step};

/// Turn-rate dependence of the ICR model, past Mandow's constant ICRs.
///
/// On the Warthog drives a robot spinning fast turns relatively more, and
/// drives relatively slower, than one turning gently: the lateral friction
/// of the treads saturates, so the ICRs move with the turn. With
/// `dv = |v_r - v_l|` the measured tread speed difference (m/s), the spread
/// `y_l - y_r` scales by `1 + k_spread dv` and both speed factors by
/// `1 + k_alpha dv` (slopes in s/m; `x_c` stays): the core's
/// [`TurnRateSlopes`], which the online filter uses. Each factor is kept
/// within [0.2, 5] so a slope fitted on gentle turns cannot make the model
/// singular on a faster one. Zero slopes are the constant model.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RateSlopes {
    /// Relative change of the spread per m/s of tread speed difference, s/m.
    pub k_spread: f64,
    /// Relative change of both speed factors per m/s of difference, s/m.
    pub k_alpha: f64,
    /// Traction term: relative loss of both speed factors per m/s^2 of
    /// tread acceleration `a` ([`Step::acc`], > 0 when speeding up), s^2/m:
    /// the factors scale by `1 - k_acc |a| - k_dir a` (`k_dir` makes
    /// accelerating and braking differ). Zero in Mandow's and the
    /// turn-rate model.
    pub k_acc: f64,
    pub k_dir: f64,
    /// Centripetal terms ([`CentripetalSlopes`]): `x_c` moves by
    /// `k_x_speed` (s) per m/s of mean tread speed `v` (a lateral slip
    /// `-k_x_speed v omega`) and the spread scales by
    /// `1 + k_spread_speed |v|` (s/m). Zero in the other models.
    pub k_x_speed: f64,
    pub k_spread_speed: f64,
}

impl RateSlopes {
    /// The constant-ICR model.
    pub const NONE: RateSlopes = RateSlopes {
        k_spread: 0.0,
        k_alpha: 0.0,
        k_acc: 0.0,
        k_dir: 0.0,
        k_x_speed: 0.0,
        k_spread_speed: 0.0,
    };

    pub fn is_constant(&self) -> bool {
        *self == Self::NONE
    }

    /// Whether the traction term is on.
    pub fn has_traction(&self) -> bool {
        self.k_acc != 0.0 || self.k_dir != 0.0
    }

    /// Whether the centripetal terms are on.
    pub fn has_centripetal(&self) -> bool {
        !self.centripetal().is_constant()
    }

    /// The centripetal part alone.
    pub fn centripetal(&self) -> CentripetalSlopes {
        CentripetalSlopes {
            k_x_speed: self.k_x_speed,
            k_spread_speed: self.k_spread_speed,
        }
    }

    /// The turn-rate part alone: the law the online filter uses too.
    pub fn turn_rate(&self) -> TurnRateSlopes {
        TurnRateSlopes {
            k_spread: self.k_spread,
            k_alpha: self.k_alpha,
        }
    }

    /// `(yaw and lateral gain, forward gain)` relative to the constant model
    /// at measured tread speeds (m/s) and tread acceleration `acc` (m/s^2,
    /// [`Step::acc`]): `omega` and `v_y` scale by the first, `v_x` by the
    /// second.
    #[inline(always)]
    fn gains(&self, v_left: f64, v_right: f64, acc: f64) -> (f64, f64) {
        let (d, a) = self.turn_rate().gains(v_left, v_right);
        let traction =
            (1.0 - self.k_acc * acc.abs() - self.k_dir * acc).clamp(RATE_GAIN_MIN, RATE_GAIN_MAX);
        let a = a * traction;
        (a / d, a)
    }

    /// Body twist (body frame, m/s and rad/s) of parameters `p` with these
    /// slopes from measured tread speeds (m/s) and the tread acceleration
    /// `acc` (m/s^2, [`Step::acc`]).
    pub fn twist(&self, p: &IcrParams, v_left: f64, v_right: f64, acc: f64) -> Twist {
        self.applied(p.twist(v_left, v_right), v_left, v_right, acc)
    }

    /// The constant model's twist `t` at measured tread speeds (m/s) and
    /// tread acceleration (m/s^2) turned into this model's.
    #[inline(always)]
    fn applied(&self, t: Twist, v_left: f64, v_right: f64, acc: f64) -> Twist {
        let (turn, fwd) = self.gains(v_left, v_right, acc);
        let (gs, dx) = self.centripetal().terms(v_left, v_right);
        let omega = turn / gs * t.omega;
        Twist {
            v_x: fwd * t.v_x,
            v_y: turn / gs * t.v_y - dx * omega,
            omega,
        }
    }
}

/// Integrates the ICR model (lv2019 eq. 3 / Mandow eqs. 6-7) over wheel
/// steps, starting at the origin with zero heading: the predicted increment
/// in the frame of the segment start. Each step has a constant twist, so the
/// arc is integrated exactly (displacement = R(theta + w dt/2) v dt sinc(w dt/2)).
///
/// This is the inner loop of every method (the GA calls it millions of
/// times), so the heading is carried as a unit complex number and rotated by
/// each step's half angle; for the small angles of one wheel step the sine
/// and cosine come from their Taylor series (error below 1e-15 for
/// half angles under 0.05 rad), larger ones from `sin_cos`.
pub fn integrate(p: &IcrParams, steps: &[Step]) -> Increment {
    integrate_rate(p, &RateSlopes::NONE, steps)
}

/// [`integrate`] with the turn-rate dependent model ([`RateSlopes`]).
pub fn integrate_rate(p: &IcrParams, k: &RateSlopes, steps: &[Step]) -> Increment {
    let mut end = Pose::ORIGIN;
    walk(p, k, steps, |q| end = q);
    Increment {
        dx: end.x,
        dy: end.y,
        dyaw: end.th,
    }
}

/// A pose of an integrated trajectory: position (m) and heading, the
/// heading both accumulated (`th`, rad, unwrapped) and as its unit complex
/// number (`c`, `s`), in the frame the integration started in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    pub x: f64,
    pub y: f64,
    pub th: f64,
    pub c: f64,
    pub s: f64,
}

impl Pose {
    pub const ORIGIN: Pose = Pose {
        x: 0.0,
        y: 0.0,
        th: 0.0,
        c: 1.0,
        s: 0.0,
    };

    /// The motion from `self` to `b` in the frame of `self`: what
    /// [`integrate`] gives over the steps between them.
    pub fn to(&self, b: &Pose) -> Increment {
        let (de, dn) = (b.x - self.x, b.y - self.y);
        Increment {
            dx: self.c * de + self.s * dn,
            dy: -self.s * de + self.c * dn,
            dyaw: b.th - self.th,
        }
    }
}

/// The trajectory of the model over all of `steps`, from the origin: the
/// pose before each step and after the last (`steps.len() + 1` poses).
/// The increment of any run of steps `a..b` is `traj[a].to(&traj[b])`, equal
/// to integrating that run alone up to rounding (below 1e-9 m on a 600 s drive).
pub fn trajectory_rate(p: &IcrParams, k: &RateSlopes, steps: &[Step]) -> Vec<Pose> {
    let mut out = Vec::with_capacity(steps.len() + 1);
    out.push(Pose::ORIGIN);
    walk(p, k, steps, |q| out.push(q));
    out
}

/// Integrates the model over `steps`, handing each pose after a step to `visit`.
#[inline(always)]
fn walk(p: &IcrParams, k: &RateSlopes, steps: &[Step], visit: impl FnMut(Pose)) {
    // IcrParams::twist is linear in the tread speeds: take its coefficients
    // once instead of dividing by the spread at every step.
    let (l, r) = (p.twist(1.0, 0.0), p.twist(0.0, 1.0));
    let linear = |st: &Step| Twist {
        v_x: l.v_x * st.v_left + r.v_x * st.v_right,
        v_y: l.v_y * st.v_left + r.v_y * st.v_right,
        omega: l.omega * st.v_left + r.omega * st.v_right,
    };
    if k.is_constant() {
        return integrate_twists(steps, linear, visit);
    }
    integrate_twists(
        steps,
        |st| k.applied(linear(st), st.v_left, st.v_right, st.acc),
        visit,
    )
}

#[inline(always)]
fn integrate_twists(steps: &[Step], twist: impl Fn(&Step) -> Twist, mut visit: impl FnMut(Pose)) {
    let (mut x, mut y, mut th) = (0.0f64, 0.0f64, 0.0f64);
    let (mut c, mut s) = (1.0f64, 0.0f64);
    for st in steps {
        let tw = twist(st);
        let half = 0.5 * tw.omega * st.dt;
        let h2 = half * half;
        let (sh, ch, sinc) = if half.abs() < 0.05 {
            let sinc = 1.0 - h2 / 6.0 * (1.0 - h2 / 20.0 * (1.0 - h2 / 42.0));
            (
                half * sinc,
                1.0 - h2 / 2.0 * (1.0 - h2 / 12.0 * (1.0 - h2 / 30.0)),
                sinc,
            )
        } else {
            let (sh, ch) = half.sin_cos();
            (sh, ch, sh / half)
        };
        // Heading at mid-step.
        let (cm, sm) = (c * ch - s * sh, s * ch + c * sh);
        let k = st.dt * sinc;
        x += (cm * tw.v_x - sm * tw.v_y) * k;
        y += (sm * tw.v_x + cm * tw.v_y) * k;
        (c, s) = (cm * ch - sm * sh, sm * ch + cm * sh);
        th += tw.omega * st.dt;
        visit(Pose { x, y, th, c, s });
    }
}

/// Residual `reference - predicted` of one segment: `[dx, dy, yaw_weight * dyaw]`
/// (m, m, m). The heading error is wrapped, so a segment that turns more than
/// half a revolution still compares correctly.
pub fn residual(p: &IcrParams, segs: &Segments, seg: &Segment, yaw_weight: f64) -> [f64; 3] {
    residual_rate(p, &RateSlopes::NONE, segs, seg, yaw_weight)
}

/// [`residual`] of the turn-rate dependent model.
pub fn residual_rate(
    p: &IcrParams,
    k: &RateSlopes,
    segs: &Segments,
    seg: &Segment,
    yaw_weight: f64,
) -> [f64; 3] {
    let pred = integrate_rate(p, k, segs.steps_of(seg));
    let r = seg.reference;
    [
        r.dx - pred.dx,
        r.dy - pred.dy,
        yaw_weight * angle::wrap(r.dyaw - pred.dyaw),
    ]
}

/// [`residual_rate`] of every segment of `segs`, in order, from one
/// integration of all the steps: overlapping segments share their steps, so
/// this costs one pass over the drive whatever the overlap.
pub fn residuals_rate(
    p: &IcrParams,
    k: &RateSlopes,
    segs: &Segments,
    yaw_weight: f64,
) -> Vec<[f64; 3]> {
    // Only the poses at segment boundaries are kept: a pose per step would
    // be megabytes per evaluation on a long drive.
    let mut need: Vec<usize> = segs
        .segments
        .iter()
        .flat_map(|s| [s.steps.start, s.steps.end])
        .collect();
    need.sort_unstable();
    need.dedup();
    let mut at = Vec::with_capacity(need.len());
    let mut next = 0usize;
    if need.first() == Some(&0) {
        at.push(Pose::ORIGIN);
        next = 1;
    }
    let last = need.last().copied().unwrap_or(0);
    let mut i = 0usize;
    walk(p, k, &segs.steps[..last.min(segs.steps.len())], |q| {
        i += 1;
        if need.get(next) == Some(&i) {
            at.push(q);
            next += 1;
        }
    });
    let pose = |i: usize| need.binary_search(&i).ok().and_then(|j| at.get(j));
    segs.segments
        .iter()
        .map(|seg| {
            let (Some(a), Some(b)) = (pose(seg.steps.start), pose(seg.steps.end)) else {
                return [f64::NAN; 3];
            };
            let pred = a.to(b);
            let r = seg.reference;
            [
                r.dx - pred.dx,
                r.dy - pred.dy,
                yaw_weight * angle::wrap(r.dyaw - pred.dyaw),
            ]
        })
        .collect()
}

/// Mandow et al. eq. 13: the sum over segments of squared increment errors,
/// `sum (dx_i - dx^_i)^2 + (dy_i - dy^_i)^2 + (w (dphi_i - dphi^_i))^2`, where
/// `w = yaw_weight` (m/rad) converts heading errors into metres (the paper
/// uses w = 1). Only segments with `weights[i] > 0` count, scaled by their weight.
pub fn cost(p: &IcrParams, segs: &Segments, weights: &[f64], yaw_weight: f64) -> f64 {
    segs.segments
        .iter()
        .zip(weights)
        .filter(|(_, &w)| w > 0.0)
        .map(|(s, &w)| {
            let r = residual(p, segs, s, yaw_weight);
            w * (r[0] * r[0] + r[1] * r[1] + r[2] * r[2])
        })
        .sum()
}

/// Cauchy loss of a squared residual norm `s2` with scale `c` (m):
/// `c^2 ln(1 + s2/c^2)`. Grows like `s2` near zero and only logarithmically
/// for outliers, so a relocalisation jump cannot dominate the fit.
/// An infinite `c` gives plain least squares, `s2`.
pub fn cauchy(s2: f64, c: f64) -> f64 {
    if !c.is_finite() {
        return s2;
    }
    let c2 = c * c;
    c2 * (s2 / c2).ln_1p()
}

/// Robust (Cauchy) version of eq. 13 over the segments with `mask[i]`.
pub fn robust_cost(p: &IcrParams, segs: &Segments, mask: &[bool], yaw_weight: f64, c: f64) -> f64 {
    segs.segments
        .iter()
        .zip(mask)
        .filter(|(_, &m)| m)
        .map(|(s, _)| {
            let r = residual(p, segs, s, yaw_weight);
            cauchy(r[0] * r[0] + r[1] * r[1] + r[2] * r[2], c)
        })
        .sum()
}

/// Parameter vector order used by the optimisers.
pub const PARAM_NAMES: [&str; 5] = ["y_l", "y_r", "x_c", "alpha_l", "alpha_r"];

pub fn to_vec(p: &IcrParams) -> [f64; 5] {
    [p.y_l, p.y_r, p.x_c, p.alpha_l, p.alpha_r]
}

pub fn from_vec(v: &[f64; 5]) -> IcrParams {
    IcrParams {
        y_l: v[0],
        y_r: v[1],
        x_c: v[2],
        alpha_l: v[3],
        alpha_r: v[4],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_twist_integrates_to_the_exact_arc() {
        // v = 1 m/s, omega = 0.5 rad/s for 2 s: a circle of radius 2 m.
        let p = IcrParams::no_slip(0.5);
        let (vl, vr) = p.tread_speeds(1.0, 0.5);
        let steps: Vec<Step> = (0..7)
            .map(|k| Step {
                dt: if k == 6 { 0.2 } else { 0.3 },
                v_left: vl,
                v_right: vr,
                acc: 0.0,
            })
            .collect();
        let inc = integrate(&p, &steps);
        let (r, th) = (2.0f64, 1.0f64);
        assert!((inc.dx - r * th.sin()).abs() < 1e-12);
        assert!((inc.dy - r * (1.0 - th.cos())).abs() < 1e-12);
        assert!((inc.dyaw - th).abs() < 1e-12);
    }

    #[test]
    fn fast_rotation_matches_sin_cos_on_irregular_steps() {
        let p = IcrParams {
            y_l: 0.3,
            y_r: -0.25,
            x_c: 0.04,
            alpha_l: 0.93,
            alpha_r: 0.95,
        };
        let steps: Vec<Step> = (0..500)
            .map(|k| Step {
                dt: 0.005 + 0.03 * ((k * 7 % 11) as f64 / 11.0),
                v_left: (k as f64 * 0.05).sin(),
                v_right: 1.2 * (k as f64 * 0.031).cos(),
                acc: 0.0,
            })
            .collect();
        let fast = integrate(&p, &steps);
        let (mut x, mut y, mut th) = (0.0f64, 0.0f64, 0.0f64);
        for st in &steps {
            let tw = p.twist(st.v_left, st.v_right);
            let half = 0.5 * tw.omega * st.dt;
            let sinc = if half == 0.0 { 1.0 } else { half.sin() / half };
            let (sn, cs) = (th + half).sin_cos();
            x += (cs * tw.v_x - sn * tw.v_y) * st.dt * sinc;
            y += (sn * tw.v_x + cs * tw.v_y) * st.dt * sinc;
            th += tw.omega * st.dt;
        }
        assert!((fast.dx - x).abs() < 1e-10 && (fast.dy - y).abs() < 1e-10);
        assert!((fast.dyaw - th).abs() < 1e-12);
    }

    #[test]
    fn rate_slopes_scale_the_turn_and_the_speed_and_stay_bounded() {
        let p = IcrParams::no_slip(1.0);
        let k = RateSlopes {
            k_spread: -0.1,
            k_alpha: -0.05,
            ..Default::default()
        };
        // Straight: no difference, no change.
        assert_eq!(k.twist(&p, 1.0, 1.0, 0.0), p.twist(1.0, 1.0));
        // A spin with dv = 2 m/s: spread x0.8, speeds x0.9, turn x1.125.
        let (c, t) = (p.twist(-1.0, 1.0), k.twist(&p, -1.0, 1.0, 0.0));
        assert!((t.omega - c.omega * 0.9 / 0.8).abs() < 1e-12);
        // A slope that would make the spread negative is held at 0.2x.
        let wild = RateSlopes {
            k_spread: -10.0,
            ..Default::default()
        };
        let t = wild.twist(&p, -1.0, 1.0, 0.0);
        assert!(t.omega.is_finite() && (t.omega - c.omega * 5.0).abs() < 1e-9);
        // Traction: both speed factors lose k_acc |a| + k_dir a, whatever
        // the turn; accelerating (a > 0) and braking differ through k_dir.
        let tr = RateSlopes {
            k_acc: 0.1,
            k_dir: 0.02,
            ..Default::default()
        };
        let s = p.twist(0.5, 1.5);
        for (acc, f) in [(2.0, 0.76), (-2.0, 0.84), (0.0, 1.0)] {
            let t = tr.twist(&p, 0.5, 1.5, acc);
            assert!((t.v_x - f * s.v_x).abs() < 1e-12, "{acc}");
            assert!((t.omega - f * s.omega).abs() < 1e-12, "{acc}");
        }
        assert!(tr.has_traction() && !k.has_traction() && !tr.is_constant());
        // A slope that would reverse the motion is held at 0.2x.
        let slip = RateSlopes {
            k_acc: 10.0,
            ..Default::default()
        };
        assert!((slip.twist(&p, 1.0, 1.0, 3.0).v_x - 0.2).abs() < 1e-12);
        // The integrator agrees with the twist, and with the constant model
        // for zero slopes.
        let steps = vec![
            Step {
                dt: 0.1,
                v_left: -1.0,
                v_right: 1.0,
                acc: 0.0,
            };
            10
        ];
        let a = integrate_rate(&p, &k, &steps);
        assert!((a.dyaw - k.twist(&p, -1.0, 1.0, 0.0).omega).abs() < 1e-12);
        assert_eq!(
            integrate_rate(&p, &RateSlopes::NONE, &steps),
            integrate(&p, &steps)
        );
    }

    #[test]
    fn centripetal_terms_are_the_core_law_on_top_of_the_turn_rate_law() {
        let p = IcrParams {
            y_l: 0.3,
            y_r: -0.25,
            x_c: 0.04,
            alpha_l: 0.93,
            alpha_r: 0.95,
        };
        let k = RateSlopes {
            k_spread: -0.1,
            k_alpha: -0.05,
            k_x_speed: 0.2,
            k_spread_speed: 0.1,
            ..Default::default()
        };
        for (vl, vr) in [(0.4, 1.2), (-1.0, -0.3), (-0.5, 0.5), (0.8, 0.8)] {
            let t = k.twist(&p, vl, vr, 0.0);
            let want = k
                .centripetal()
                .at(&k.turn_rate().at(&p, vl, vr), vl, vr)
                .twist(vl, vr);
            for (a, b) in [(t.v_x, want.v_x), (t.v_y, want.v_y), (t.omega, want.omega)] {
                assert!((a - b).abs() < 1e-12, "{vl} {vr}: {t:?} vs {want:?}");
            }
        }
        assert!(k.has_centripetal() && !RateSlopes::NONE.has_centripetal());
        // The integrator agrees with the twist.
        let steps = vec![
            Step {
                dt: 0.1,
                v_left: 0.4,
                v_right: 1.2,
                acc: 0.0,
            };
            10
        ];
        let a = integrate_rate(&p, &k, &steps);
        assert!((a.dyaw - k.twist(&p, 0.4, 1.2, 0.0).omega).abs() < 1e-12);
    }

    #[test]
    fn trajectory_increments_equal_per_segment_integration() {
        use crate::segment::SegmentConfig;
        use crate::synthetic::{drive, mandow_table1, SynthConfig};
        // A 600 s drive (the bench's): rounding grows along the trajectory.
        let log = drive(
            &[("asphalt", mandow_table1())],
            &SynthConfig::p3at(600.0, 3),
        );
        let cfg = SegmentConfig {
            overlap: Some(0.0),
            ..Default::default()
        };
        let segs = Segments::build(&[&log], &[0.03], &cfg);
        assert!(segs.len() > 2000, "{}", segs.len());
        let p = IcrParams {
            y_l: 0.3,
            y_r: -0.25,
            x_c: 0.04,
            alpha_l: 0.93,
            alpha_r: 0.95,
        };
        for k in [
            RateSlopes::NONE,
            RateSlopes {
                k_spread: -0.1,
                k_alpha: -0.05,
                k_acc: 0.1,
                k_dir: 0.02,
                k_x_speed: 0.1,
                k_spread_speed: 0.05,
            },
        ] {
            let all = residuals_rate(&p, &k, &segs, 0.5);
            let mut worst = 0.0f64;
            for (seg, r) in segs.segments.iter().zip(&all) {
                let one = residual_rate(&p, &k, &segs, seg, 0.5);
                for c in 0..3 {
                    worst = worst.max((one[c] - r[c]).abs());
                }
            }
            assert!(worst < 1e-9, "{worst}");
        }
        // A segment that does not start at the beginning of the drive
        // really is read relative to its start: a wrong pose index would
        // be off by metres.
        let traj = trajectory_rate(&p, &RateSlopes::NONE, &segs.steps);
        let s = &segs.segments[segs.len() / 2];
        let wrong = traj[0].to(&traj[s.steps.end]);
        let right = integrate(&p, segs.steps_of(s));
        assert!((wrong.dx - right.dx).abs() + (wrong.dy - right.dy).abs() > 0.1);
    }

    #[test]
    fn cauchy_grows_slower_than_squares_and_infinite_scale_is_plain() {
        assert!((cauchy(1e-6, 1.0) - 1e-6).abs() < 1e-11);
        assert!(cauchy(100.0, 1.0) < 5.0);
        assert_eq!(cauchy(3.0, f64::INFINITY), 3.0);
    }
}
