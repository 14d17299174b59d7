//! Coordinates in which a filter carries the five slip parameters of
//! [`IcrParams`] (its "chart"), and the body twist with its partial
//! derivatives in those coordinates.
//!
//! * [`Chart::Tread`]: `(y_l, y_r, x_c, alpha_l, alpha_r)` as they are: the
//!   papers' filters (lv2019, wang2018, chen2023) estimate the ICRs in these
//!   coordinates.
//! * [`Chart::Gain`]: `(g, h, a, y_c, x_c)` with
//!   `g = a / d` (1/m), `h = (alpha_l - alpha_r) / d` (1/m),
//!   `a = (alpha_l + alpha_r) / 2`, `y_c = (y_l + y_r) / 2` (m) and `x_c`
//!   (m), where `d = y_l - y_r`. In them the yaw rate is linear,
//!   `omega = g (V_r - V_l) - h (V_l + V_r) / 2`, and the body velocity is
//!   that of the point `(x_c, y_c)` moving straight ahead at the mean tread
//!   speed: `v_x = vbar + y_c omega`, `v_y = -x_c omega`. A heading sensor
//!   sees `g` and `h` only, position sees `a` (and the lever arms `y_c`,
//!   `x_c` in turns), so no linearisation point makes one sensor "observe"
//!   what only the other can: the spread `d = a / g` is as well known as
//!   the speed factor is.
//!
//! Both give the same twist for the same [`IcrParams`] (unit-tested), so
//! the choice only changes how an estimator's uncertainty and linearisation
//! are shaped.

use nalgebra::{SMatrix, SVector};

use crate::kinematics::{CentripetalSlopes, IcrParams, Twist, MIN_SPREAD};

/// Five slip parameters in a chart's coordinates.
pub type Slip = SVector<f64, 5>;
/// A 5x5 matrix over slip parameters (covariances, Jacobians).
pub type SlipMat = SMatrix<f64, 5, 5>;
/// Partial derivatives of the body twist `(v_x, v_y, omega)` by the five
/// slip parameters of a chart.
pub type TwistJac = SMatrix<f64, 3, 5>;

/// Smallest turning gain `g` (1/m) the [`Chart::Gain`] conversions divide
/// by: a spread of a kilometre.
const MIN_GAIN: f64 = 1e-3;

/// Measured tread speeds of one step, m/s (encoder speeds, before the
/// speed factors `alpha`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TreadInput {
    /// Left tread speed, m/s.
    pub v_left: f64,
    /// Right tread speed, m/s.
    pub v_right: f64,
}

/// Coordinates of the slip parameters. See the module documentation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "kebab-case"))]
pub enum Chart {
    /// `(y_l, y_r, x_c, alpha_l, alpha_r)`: the papers' coordinates.
    Tread,
    /// `(g, h, a, y_c, x_c)`: turning gain, heading drift per metre, common
    /// speed factor, ICR centre offsets.
    Gain,
}

impl Chart {
    /// Indices (in the chart's five) of the parameters that hold the tread
    /// speed factors (what `learn_alpha = false` keeps fixed).
    pub fn factor_slots(self) -> [usize; 2] {
        match self {
            Chart::Tread => [3, 4],
            Chart::Gain => [1, 2],
        }
    }

    /// Indices (in the chart's five) of the parameters only a position
    /// reference teaches: the speed factor and the ICR centre offsets
    /// (`a`, `y_c`, `x_c` in [`Chart::Gain`]; `x_c`, `alpha_l`, `alpha_r` in
    /// [`Chart::Tread`], whose axes cannot hold the common speed factor
    /// without its difference). Heading and yaw rate see the others.
    pub fn position_slots(self) -> [usize; 3] {
        [2, 3, 4]
    }

    /// The chart coordinates of `p`.
    pub fn from_icr(self, p: &IcrParams) -> Slip {
        match self {
            Chart::Tread => Slip::new(p.y_l, p.y_r, p.x_c, p.alpha_l, p.alpha_r),
            Chart::Gain => {
                let d = p.guarded_spread();
                let a = 0.5 * (p.alpha_l + p.alpha_r);
                Slip::new(
                    a / d,
                    (p.alpha_l - p.alpha_r) / d,
                    a,
                    0.5 * (p.y_l + p.y_r),
                    p.x_c,
                )
            }
        }
    }

    /// The ICR parameters of chart coordinates `s`.
    pub fn to_icr(self, s: &Slip) -> IcrParams {
        match self {
            Chart::Tread => IcrParams {
                y_l: s[0],
                y_r: s[1],
                x_c: s[2],
                alpha_l: s[3],
                alpha_r: s[4],
            },
            Chart::Gain => {
                let (g, h, a, y_c) = (s[0].max(MIN_GAIN), s[1], s[2], s[3]);
                let d = a / g;
                let e = 0.5 * h * d;
                IcrParams {
                    y_l: y_c + 0.5 * d,
                    y_r: y_c - 0.5 * d,
                    x_c: s[4],
                    alpha_l: a + e,
                    alpha_r: a - e,
                }
            }
        }
    }

    /// `d(y_l, y_r, x_c, alpha_l, alpha_r) / d(chart)` at `s`: carries a
    /// covariance from the chart to the ICR parameters (`J P J'`).
    pub fn icr_jacobian(self, s: &Slip) -> SlipMat {
        match self {
            Chart::Tread => SlipMat::identity(),
            Chart::Gain => {
                let (g, h, a) = (s[0].max(MIN_GAIN), s[1], s[2]);
                let g2 = g * g;
                let mut j = SlipMat::zeros();
                // d = a/g; e = h a / (2 g)
                let (dd_dg, dd_da) = (-a / g2, 1.0 / g);
                let (de_dg, de_dh, de_da) = (-h * a / (2.0 * g2), a / (2.0 * g), h / (2.0 * g));
                // y_l = y_c + d/2, y_r = y_c - d/2
                j[(0, 0)] = 0.5 * dd_dg;
                j[(0, 2)] = 0.5 * dd_da;
                j[(0, 3)] = 1.0;
                j[(1, 0)] = -0.5 * dd_dg;
                j[(1, 2)] = -0.5 * dd_da;
                j[(1, 3)] = 1.0;
                j[(2, 4)] = 1.0;
                // alpha_l = a + e, alpha_r = a - e
                j[(3, 0)] = de_dg;
                j[(3, 1)] = de_dh;
                j[(3, 2)] = 1.0 + de_da;
                j[(4, 0)] = -de_dg;
                j[(4, 1)] = -de_dh;
                j[(4, 2)] = 1.0 - de_da;
                j
            }
        }
    }

    /// A covariance over the ICR parameters `(y_l, y_r, x_c, alpha_l,
    /// alpha_r)` carried into the chart at `s` (first order). `None` when
    /// the chart is singular there.
    pub fn cov_from_icr(self, s: &Slip, icr_cov: &SlipMat) -> Option<SlipMat> {
        match self {
            Chart::Tread => Some(*icr_cov),
            Chart::Gain => {
                let inv = self.icr_jacobian(s).try_inverse()?;
                let c = inv * icr_cov * inv.transpose();
                Some(0.5 * (c + c.transpose()))
            }
        }
    }

    /// A chart covariance carried to the ICR parameters at `s`.
    pub fn cov_to_icr(self, s: &Slip, cov: &SlipMat) -> SlipMat {
        let j = self.icr_jacobian(s);
        let c = j * cov * j.transpose();
        0.5 * (c + c.transpose())
    }

    /// Body twist (REP-103 body frame) from measured tread speeds, and its
    /// partial derivatives by the chart's parameters at `s`.
    #[inline]
    pub fn twist(self, s: &Slip, u: TreadInput) -> (Twist, TwistJac) {
        let mut jac = TwistJac::zeros();
        match self {
            Chart::Tread => {
                let (y_l, y_r, x_c) = (s[0], s[1], s[2]);
                let d = (y_l - y_r).max(MIN_SPREAD);
                let inv_d = 1.0 / d;
                let (v_l, v_r) = (s[3] * u.v_left, s[4] * u.v_right);
                let omega = (v_r - v_l) * inv_d;
                let t = Twist {
                    v_x: (v_r * y_l - v_l * y_r) * inv_d,
                    v_y: -x_c * omega,
                    omega,
                };
                let dlr = (v_l - v_r) * inv_d * inv_d;
                // columns y_l, y_r, x_c, alpha_l, alpha_r; rows v_x, v_y, omega
                let cols = [
                    (y_r * dlr, dlr),
                    (-y_l * dlr, -dlr),
                    (0.0, 0.0),
                    (-u.v_left * y_r * inv_d, -u.v_left * inv_d),
                    (u.v_right * y_l * inv_d, u.v_right * inv_d),
                ];
                for (k, (dvx, dw)) in cols.into_iter().enumerate() {
                    jac[(0, k)] = dvx;
                    jac[(1, k)] = -x_c * dw;
                    jac[(2, k)] = dw;
                }
                jac[(1, 2)] = -omega;
                (t, jac)
            }
            Chart::Gain => {
                let (g, h, a, y_c, x_c) = (s[0].max(MIN_GAIN), s[1], s[2], s[3], s[4]);
                let dv = u.v_right - u.v_left;
                let vm = 0.5 * (u.v_left + u.v_right);
                let omega = g * dv - h * vm;
                let q = dv / (4.0 * g);
                let vbar = a * vm - h * a * q;
                let t = Twist {
                    v_x: vbar + y_c * omega,
                    v_y: -x_c * omega,
                    omega,
                };
                let dw = [dv, -vm, 0.0, 0.0, 0.0];
                let dvbar = [h * a * q / g, -a * q, vm - h * q, 0.0, 0.0];
                for k in 0..5 {
                    jac[(0, k)] = dvbar[k] + y_c * dw[k];
                    jac[(1, k)] = -x_c * dw[k];
                    jac[(2, k)] = dw[k];
                }
                jac[(0, 3)] += omega;
                jac[(1, 4)] -= omega;
                (t, jac)
            }
        }
    }
}

/// Largest factor the turn law may apply to the spread (and its inverse
/// the smallest), so a slope learned on gentle turns cannot make the model
/// singular on a faster one.
pub const MAX_LAW_FACTOR: f64 = 2.0;

/// The spread factor of the turn law `1 + k dv` (clamped to
/// `[1 / MAX_LAW_FACTOR, MAX_LAW_FACTOR]`) and its derivative by `k`
/// (0 where clamped); `dv` is the law's input, the tread speed difference
/// `|V_r - V_l|` (m/s) as the ground has taken it up.
#[inline]
pub fn law_factor(k: f64, dv: f64) -> (f64, f64) {
    let f = 1.0 + k * dv;
    if f < 1.0 / MAX_LAW_FACTOR {
        (1.0 / MAX_LAW_FACTOR, 0.0)
    } else if f > MAX_LAW_FACTOR {
        (MAX_LAW_FACTOR, 0.0)
    } else {
        (f, dv)
    }
}

impl Chart {
    /// The parameters with the spread `y_l - y_r` scaled by `f` about the
    /// ICR centre `(y_l + y_r) / 2` (speed factors, centre and `x_c`
    /// unchanged), and the derivatives of the result by the parameters
    /// (a matrix) and by `f` (a vector).
    #[inline]
    pub fn scale_spread(self, s: &Slip, f: f64) -> (Slip, SlipMat, Slip) {
        let mut d = SlipMat::identity();
        let mut df = Slip::zeros();
        let mut out = *s;
        match self {
            Chart::Tread => {
                // y_l' = c + f (y_l - c), y_r' = c + f (y_r - c), c = (y_l + y_r) / 2
                let (hp, hm) = (0.5 * (1.0 + f), 0.5 * (1.0 - f));
                out[0] = hp * s[0] + hm * s[1];
                out[1] = hm * s[0] + hp * s[1];
                d[(0, 0)] = hp;
                d[(0, 1)] = hm;
                d[(1, 0)] = hm;
                d[(1, 1)] = hp;
                df[0] = 0.5 * (s[0] - s[1]);
                df[1] = -0.5 * (s[0] - s[1]);
            }
            Chart::Gain => {
                // d' = f d: g' = g / f, h' = h / f
                out[0] = s[0] / f;
                out[1] = s[1] / f;
                d[(0, 0)] = 1.0 / f;
                d[(1, 1)] = 1.0 / f;
                df[0] = -s[0] / (f * f);
                df[1] = -s[1] / (f * f);
            }
        }
        (out, d, df)
    }

    /// The ICRs in effect under the turn law of slope `k` at input `dv`.
    pub fn to_icr_at(self, s: &Slip, k: f64, dv: f64) -> IcrParams {
        let (f, _) = law_factor(k, dv);
        self.to_icr(&self.scale_spread(s, f).0)
    }

    /// Index (in the chart's five) of `x_c`.
    pub fn x_c_slot(self) -> usize {
        match self {
            Chart::Tread => 2,
            Chart::Gain => 4,
        }
    }

    /// The body twist under the turn law (slope `k`, s/m, input `dv`, m/s)
    /// and the centripetal terms `c` ([`CentripetalSlopes`]) at tread speeds
    /// `u`: the spread in effect is `(1 + k dv) (1 + c.k_spread_speed |v|)`
    /// times the one of `s` (each factor clamped as [`law_factor`]), `x_c`
    /// is moved by `c.k_x_speed v`, `v = (V_l + V_r) / 2`. Returns the
    /// twist and its derivatives by the parameters, by `k` and by
    /// `(c.k_x_speed, c.k_spread_speed)` (columns).
    #[inline]
    pub fn twist_with_terms(
        self,
        s: &Slip,
        k: f64,
        dv: f64,
        c: &CentripetalSlopes,
        u: TreadInput,
    ) -> (Twist, TwistJac, [f64; 3], SMatrix<f64, 3, 2>) {
        let a = self.with_terms(s, k, dv, c, u);
        let (t, j) = self.twist(&a.slip, u);
        let jf = j * a.d_factor;
        let dk = jf * (a.d_law * a.centripetal);
        let mut dc = SMatrix::<f64, 3, 2>::zeros();
        for r in 0..3 {
            dc[(r, 0)] = j[(r, self.x_c_slot())] * a.speed;
            dc[(r, 1)] = jf[r] * a.law * a.d_centripetal;
        }
        (t, j * a.d_slip, [dk[0], dk[1], dk[2]], dc)
    }

    /// `s` with the turn law's and the centripetal terms' spread factors
    /// and `x_c` shift applied, and what their derivatives need.
    #[inline]
    pub(crate) fn with_terms(
        self,
        s: &Slip,
        k: f64,
        dv: f64,
        c: &CentripetalSlopes,
        u: TreadInput,
    ) -> WithTerms {
        let speed = 0.5 * (u.v_left + u.v_right);
        let (law, d_law) = law_factor(k, dv);
        let (centripetal, d_centripetal) = law_factor(c.k_spread_speed, libm::fabs(speed));
        let (mut slip, d_slip, d_factor) = self.scale_spread(s, law * centripetal);
        slip[self.x_c_slot()] += c.k_x_speed * speed;
        WithTerms {
            slip,
            d_slip,
            d_factor,
            speed,
            law,
            d_law,
            centripetal,
            d_centripetal,
        }
    }
}

/// [`Chart::with_terms`]: the parameters in effect, their derivatives by
/// the straight-line ones and by the spread factor, the mean tread speed
/// (m/s), and each spread factor with its derivative by its slope.
pub(crate) struct WithTerms {
    pub(crate) slip: Slip,
    pub(crate) d_slip: SlipMat,
    pub(crate) d_factor: Slip,
    pub(crate) speed: f64,
    pub(crate) law: f64,
    pub(crate) d_law: f64,
    pub(crate) centripetal: f64,
    pub(crate) d_centripetal: f64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn params() -> impl Strategy<Value = IcrParams> {
        (
            0.1f64..1.5,
            -1.5f64..-0.1,
            -0.3f64..0.3,
            0.5f64..1.3,
            0.5f64..1.3,
        )
            .prop_map(|(y_l, y_r, x_c, alpha_l, alpha_r)| IcrParams {
                y_l,
                y_r,
                x_c,
                alpha_l,
                alpha_r,
            })
    }

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
    }

    proptest! {
        #[test]
        fn charts_round_trip_and_agree_on_the_twist(
            p in params(), vl in -3.0f64..3.0, vr in -3.0f64..3.0,
        ) {
            let u = TreadInput { v_left: vl, v_right: vr };
            let want = p.twist(vl, vr);
            for chart in [Chart::Tread, Chart::Gain] {
                let s = chart.from_icr(&p);
                let back = chart.to_icr(&s);
                for (a, b) in [(back.y_l, p.y_l), (back.y_r, p.y_r), (back.x_c, p.x_c),
                               (back.alpha_l, p.alpha_l), (back.alpha_r, p.alpha_r)] {
                    prop_assert!(close(a, b, 1e-12));
                }
                let (t, _) = chart.twist(&s, u);
                prop_assert!(close(t.v_x, want.v_x, 1e-12));
                prop_assert!(close(t.v_y, want.v_y, 1e-12));
                prop_assert!(close(t.omega, want.omega, 1e-12));
            }
        }

        #[test]
        fn jacobians_match_central_differences(
            p in params(), vl in -3.0f64..3.0, vr in -3.0f64..3.0,
        ) {
            let u = TreadInput { v_left: vl, v_right: vr };
            for chart in [Chart::Tread, Chart::Gain] {
                let s = chart.from_icr(&p);
                let (_, jt) = chart.twist(&s, u);
                let ji = chart.icr_jacobian(&s);
                for k in 0..5 {
                    let h = 1e-6 * (1.0 + s[k].abs());
                    let (mut sp, mut sm) = (s, s);
                    sp[k] += h;
                    sm[k] -= h;
                    let (tp, _) = chart.twist(&sp, u);
                    let (tm, _) = chart.twist(&sm, u);
                    let num = [(tp.v_x - tm.v_x), (tp.v_y - tm.v_y), (tp.omega - tm.omega)];
                    for r in 0..3 {
                        prop_assert!((num[r] / (2.0 * h) - jt[(r, k)]).abs() < 1e-5,
                            "{chart:?} twist d{r}/d{k}: {} vs {}", num[r] / (2.0 * h), jt[(r, k)]);
                    }
                    let (ip, im) = (chart.to_icr(&sp), chart.to_icr(&sm));
                    let num = [ip.y_l - im.y_l, ip.y_r - im.y_r, ip.x_c - im.x_c,
                               ip.alpha_l - im.alpha_l, ip.alpha_r - im.alpha_r];
                    for r in 0..5 {
                        prop_assert!((num[r] / (2.0 * h) - ji[(r, k)]).abs() < 1e-5 * (1.0 + ji[(r, k)].abs()),
                            "{chart:?} icr d{r}/d{k}");
                    }
                }
            }
        }
    }

    proptest! {
        #[test]
        fn the_turn_law_scales_the_spread_alike_in_both_charts_and_its_jacobian_holds(
            p in params(), vl in -3.0f64..3.0, vr in -3.0f64..3.0, k in -0.3f64..0.3,
        ) {
            let u = TreadInput { v_left: vl, v_right: vr };
            let dv = (vr - vl).abs();
            let none = CentripetalSlopes::NONE;
            let (f, _) = law_factor(k, dv);
            let a = Chart::Tread.to_icr_at(&Chart::Tread.from_icr(&p), k, dv);
            let b = Chart::Gain.to_icr_at(&Chart::Gain.from_icr(&p), k, dv);
            prop_assert!(close(a.spread(), f * p.spread(), 1e-12));
            prop_assert!(close(b.spread(), f * p.spread(), 1e-12));
            prop_assert!(close(a.y_l + a.y_r, p.y_l + p.y_r, 1e-12));
            prop_assert!(close(b.alpha_l, p.alpha_l, 1e-12));
            for chart in [Chart::Tread, Chart::Gain] {
                let s = chart.from_icr(&p);
                let (t, j, dk, _) = chart.twist_with_terms(&s, k, dv, &none, u);
                let want = chart.to_icr_at(&s, k, dv).twist(vl, vr);
                prop_assert!(close(t.omega, want.omega, 1e-9) && close(t.v_x, want.v_x, 1e-9));
                let h = 1e-6;
                let (tp, ..) = chart.twist_with_terms(&s, k + h, dv, &none, u);
                let (tm, ..) = chart.twist_with_terms(&s, k - h, dv, &none, u);
                let num = [tp.v_x - tm.v_x, tp.v_y - tm.v_y, tp.omega - tm.omega];
                for r in 0..3 {
                    prop_assert!((num[r] / (2.0 * h) - dk[r]).abs() < 1e-5, "{chart:?} dk {r}");
                }
                for c in 0..5 {
                    let hc = 1e-6 * (1.0 + s[c].abs());
                    let (mut sp, mut sm) = (s, s);
                    sp[c] += hc;
                    sm[c] -= hc;
                    let (tp, ..) = chart.twist_with_terms(&sp, k, dv, &none, u);
                    let (tm, ..) = chart.twist_with_terms(&sm, k, dv, &none, u);
                    let num = [tp.v_x - tm.v_x, tp.v_y - tm.v_y, tp.omega - tm.omega];
                    for r in 0..3 {
                        prop_assert!((num[r] / (2.0 * hc) - j[(r, c)]).abs() < 1e-5, "{chart:?} d{r}/d{c}");
                    }
                }
            }
        }
    }

    #[test]
    fn gain_chart_separates_what_heading_and_position_see() {
        // Scaling the speed factors and the spread together leaves the yaw
        // rate alone: in the gain chart that is a change of `a` alone, and
        // the heading's row of the Jacobian has no `a` column.
        let p = IcrParams {
            y_l: 0.4,
            y_r: -0.38,
            x_c: 0.02,
            alpha_l: 0.9,
            alpha_r: 0.91,
        };
        let s = Chart::Gain.from_icr(&p);
        let (_, j) = Chart::Gain.twist(
            &s,
            TreadInput {
                v_left: 0.2,
                v_right: 0.9,
            },
        );
        assert_eq!(j[(2, 2)], 0.0);
        let mut q = p;
        for v in [&mut q.y_l, &mut q.y_r, &mut q.alpha_l, &mut q.alpha_r] {
            *v *= 0.8;
        }
        let s2 = Chart::Gain.from_icr(&q);
        assert!((s2[0] - s[0]).abs() < 1e-12 && (s2[1] - s[1]).abs() < 1e-12);
        assert!((s2[2] - 0.8 * s[2]).abs() < 1e-12);
    }

    #[test]
    fn covariances_carry_both_ways() {
        let p = IcrParams::no_slip(0.5);
        let s = Chart::Gain.from_icr(&p);
        let c = SlipMat::from_diagonal(&Slip::new(0.01, 0.01, 1e-4, 1e-4, 1e-4));
        let icr = Chart::Gain.cov_to_icr(&s, &c);
        let back = Chart::Gain.cov_from_icr(&s, &icr).unwrap();
        assert!((back - c).abs().max() < 1e-12);
    }
}
