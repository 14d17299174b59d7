//! How far dead reckoning drifts in `s` seconds, learned from the fixes.
//!
//! While fixes come, probes dead-reckon beside the filter: each sets out
//! from the filter's state at a fix and carries its model on the tread
//! speeds with every parameter held (as the estimator given no fixes
//! would; [`DeadReckoning`]), and is read against the first fix [`HORIZONS_S`]`[i]`
//! or more later. The end error's square per position axis, `|e|²/2`, is
//! kept per horizon as a histogram of its logarithm; the curve states its
//! median, less the fixes' own noise, as the variance per axis: the
//! median end then reads a NEES of 1 per degree of freedom, the middle of
//! the band a stated uncertainty is judged by. (The drift's tails are
//! heavy and a run's stops and drives mix, so the median, not the mean;
//! a Gaussian error would read 0.69 at the median, and the curve states
//! 1/0.69 times less than the Gaussian reading of the same median. On
//! the DRIVE sand drives that reading is too wide: 0.3-0.9.)
//! [`DriftCurve::variance`] interpolates the horizons in log-log: a slip
//! that holds for seconds grows the variance like `s²`, independent
//! seconds like `s`, and the curve follows whichever the drive shows,
//! with the start's own error in it. Nothing here changes the estimate.
//!
//! Frames: ENU position, yaw from east; SI units.

use nalgebra::{Matrix2, Matrix3};

use crate::filter::DeadReckoning;

/// Horizons the drift is learned at, s.
pub const HORIZONS_S: [f64; 5] = [4.0, 8.0, 16.0, 32.0, 64.0];
/// Probes running per horizon, set out a `1 / PROBES` of it apart.
const PROBES: usize = 8;
/// A probe not read within this share of its horizon past it is dropped.
const LATE: f64 = 0.25;
/// Ends (their weight) a horizon needs before the curve uses it.
pub const MIN_ENDS: f64 = 8.0;
/// Memory of the ends, s of fixes: old ends fade with this time constant
/// (ends come a `1 / PROBES` of their horizon apart), so that the errors
/// of a filter still learning its slip fade too.
pub const DRIFT_MEMORY_S: f64 = 300.0;
/// Horizons with enough ends the curve needs.
const MIN_HORIZONS: usize = 3;
/// Least per-axis variance an end counts, m²: the histogram's first bin.
const MIN_VAR: f64 = 1e-8;
/// Bins of the ends' `ln` variance, each [`BIN`] wide from `ln MIN_VAR`
/// (the last takes everything above, 1e4 m² and more).
const BINS: usize = 110;
const BIN: f64 = 0.25;
/// Beyond the longest horizon the variance grows at least like `s` and at
/// most like `s²`.
const SLOPE_RANGE: (f64, f64) = (1.0, 2.0);

/// Dead reckonings under way at most: one per probe.
const RECKONINGS: usize = HORIZONS_S.len() * PROBES;

/// A dead reckoning under way, shared by the probes of every horizon set
/// out at the same fix (they would carry the same model on the same tread
/// speeds, to the last bit).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Reckoning {
    model: DeadReckoning,
    /// Time since it set out, s.
    span: f64,
    /// Probes reading it.
    probes: u8,
}

/// One horizon's ends, each weighing less as newer ones come: a
/// histogram of `ln` of the per-axis variance, and the weighted sums of
/// `ln` of the spans read (ln s) and of the fixes' noise variance per
/// axis (m²).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Ends {
    n: f64,
    bins: [f64; BINS],
    ln_span: f64,
    var_fix: f64,
}

impl Ends {
    const EMPTY: Self = Self {
        n: 0.0,
        bins: [0.0; BINS],
        ln_span: 0.0,
        var_fix: 0.0,
    };

    /// An end of per-axis variance `var` (m²) read `span` s out against a
    /// fix of noise `var_fix` per axis (m²); the earlier ones fade by
    /// `keep`.
    fn add(&mut self, var: f64, span: f64, var_fix: f64, keep: f64) {
        self.bins.iter_mut().for_each(|b| *b *= keep);
        self.n *= keep;
        self.ln_span *= keep;
        self.var_fix = self.var_fix * keep + var_fix;
        let x = (libm::log(var / MIN_VAR) / BIN).max(0.0);
        let k = if x < BINS as f64 {
            x as usize
        } else {
            BINS - 1
        };
        self.bins[k] += 1.0;
        self.n += 1.0;
        self.ln_span += libm::log(span);
    }

    /// `ln` of the median per-axis variance (linear within its bin).
    fn ln_median(&self) -> f64 {
        let half = 0.5 * self.n;
        let mut below = 0.0;
        for (k, &c) in self.bins.iter().enumerate() {
            if c > 0.0 && below + c >= half {
                let frac = ((half - below) / c).clamp(0.0, 1.0);
                return libm::log(MIN_VAR) + (k as f64 + frac) * BIN;
            }
            below += c;
        }
        libm::log(MIN_VAR)
    }
}

/// The probes and what they have measured; allocation-free.
#[derive(Debug, Clone, PartialEq)]
pub struct DriftCurve {
    reckonings: [Option<Reckoning>; RECKONINGS],
    /// Each probe: the index of the reckoning it reads.
    probes: [[Option<u8>; PROBES]; HORIZONS_S.len()],
    ends: [Ends; HORIZONS_S.len()],
    /// Time since each horizon last set a probe out, s.
    since_start: [f64; HORIZONS_S.len()],
}

impl Default for DriftCurve {
    fn default() -> Self {
        Self::new()
    }
}

impl DriftCurve {
    pub fn new() -> Self {
        Self {
            reckonings: [None; RECKONINGS],
            probes: [[None; PROBES]; HORIZONS_S.len()],
            ends: [Ends::EMPTY; HORIZONS_S.len()],
            since_start: [f64::INFINITY; HORIZONS_S.len()],
        }
    }

    /// Ends read at each horizon, by their weight now.
    pub fn ends(&self) -> [f64; HORIZONS_S.len()] {
        self.ends.map(|e| e.n)
    }

    /// Tread speeds `v_left`, `v_right` (m/s) held over `dt` s: every probe
    /// moves on its own parameters' twist.
    pub fn step(&mut self, v_left: f64, v_right: f64, dt: f64) {
        if !(dt >= 0.0 && dt.is_finite()) {
            return;
        }
        // The probes share the filter's turn-law lag: its gain over `dt`
        // is computed once (again only for a probe with another lag).
        let mut gain: Option<(f64, f64)> = None;
        for r in self.reckonings.iter_mut().flatten() {
            let a = match gain {
                Some((lag, a)) if lag == r.model.lag() => a,
                _ => {
                    let a = r.model.lag_gain(dt);
                    gain = Some((r.model.lag(), a));
                    a
                }
            };
            r.model.step_with_gain(v_left, v_right, dt, a);
            r.span += dt;
        }
        for (i, row) in self.probes.iter_mut().enumerate() {
            self.since_start[i] += dt;
            let late = HORIZONS_S[i] * (1.0 + LATE);
            for slot in row.iter_mut() {
                let Some(r) = slot.and_then(|k| self.reckonings[k as usize]) else {
                    continue;
                };
                let (e, n, y) = r.model.pose();
                if r.span > late || !(e.is_finite() && n.is_finite() && y.is_finite()) {
                    release(&mut self.reckonings, slot);
                }
            }
        }
    }

    /// Drops every probe (a gap in the tread speeds, an outage).
    pub fn break_probes(&mut self) {
        if self.probes.iter().flatten().any(Option::is_some) {
            self.probes = [[None; PROBES]; HORIZONS_S.len()];
            self.reckonings = [None; RECKONINGS];
        }
    }

    /// A position fix `at` (m, ENU) of the reference point `lever_arm` (m,
    /// body) with white noise `var_fix` per axis (m²), taken when the
    /// filter (after the fix) would dead-reckon as `start`: reads the
    /// probes due and sets the next ones out.
    pub fn on_fix(
        &mut self,
        at: (f64, f64),
        var_fix: f64,
        lever_arm: (f64, f64),
        start: &DeadReckoning,
    ) {
        let var_fix = if var_fix.is_finite() {
            var_fix.max(0.0)
        } else {
            0.0
        };
        // The reckoning set out at this fix, once a horizon sets one out.
        let mut set_out: Option<u8> = None;
        for (i, row) in self.probes.iter_mut().enumerate() {
            for slot in row.iter_mut() {
                let Some(p) = slot.and_then(|k| self.reckonings[k as usize]) else {
                    continue;
                };
                if p.span < HORIZONS_S[i] {
                    continue;
                }
                release(&mut self.reckonings, slot);
                let (e, n, y) = p.model.pose();
                let (s, c) = libm::sincos(y);
                let (lx, ly) = lever_arm;
                let de = at.0 - (e + c * lx - s * ly);
                let dn = at.1 - (n + s * lx + c * ly);
                let var = (0.5 * (de * de + dn * dn)).max(MIN_VAR);
                if var.is_finite() {
                    let keep = libm::exp(-HORIZONS_S[i] / (PROBES as f64 * DRIFT_MEMORY_S));
                    self.ends[i].add(var, p.span, var_fix, keep);
                }
            }
            if self.since_start[i] >= HORIZONS_S[i] / PROBES as f64 {
                let slot = row.iter_mut().find(|s| s.is_none());
                let free = || self.reckonings.iter().position(Option::is_none);
                if let Some((slot, k)) = slot.zip(set_out.map(usize::from).or_else(free)) {
                    let r = self.reckonings[k].get_or_insert(Reckoning {
                        model: *start,
                        span: 0.0,
                        probes: 0,
                    });
                    r.probes += 1;
                    *slot = u8::try_from(k).ok();
                    set_out = *slot;
                    self.since_start[i] = 0.0;
                }
            }
        }
    }

    /// The variance per position axis (m²) of a dead reckoning `s` s after
    /// the last fix, or `None` while fewer than [`MIN_HORIZONS`] horizons
    /// have [`MIN_ENDS`] ends whose drift is at least the fixes' own noise
    /// (below it the fixes cannot tell how far the reckoning drifted).
    pub fn variance(&self, s: f64) -> Option<f64> {
        let mut pts = [(0.0, 0.0); HORIZONS_S.len()];
        let mut k = 0;
        for e in self.ends.iter().filter(|e| e.n >= MIN_ENDS) {
            let n = e.n;
            let var_fix = e.var_fix / n;
            let drift = libm::exp(e.ln_median()) - var_fix;
            if !(drift >= var_fix && drift > 0.0) {
                continue;
            }
            // ln of the span and of the variance; the variance never falls
            // with the span.
            let ln_var = libm::log(drift);
            let ln_var = if k > 0 {
                ln_var.max(pts[k - 1].1)
            } else {
                ln_var
            };
            pts[k] = (e.ln_span / n, ln_var);
            k += 1;
        }
        if k < MIN_HORIZONS || !(s > 0.0 && s.is_finite()) {
            return None;
        }
        let ls = libm::log(s);
        let (a, b) = if ls <= pts[0].0 {
            ((pts[0].0, pts[0].1), None)
        } else if let Some(w) = pts[..k].windows(2).find(|w| ls <= w[1].0) {
            (w[0], Some(w[1]))
        } else {
            ((pts[k - 1].0, pts[k - 1].1), None)
        };
        let ln_v = match b {
            Some(b) if b.0 > a.0 => a.1 + (b.1 - a.1) * (ls - a.0) / (b.0 - a.0),
            Some(_) => a.1,
            None if ls <= a.0 => a.1 + SLOPE_RANGE.0 * (ls - a.0),
            None => {
                let (p, q) = (pts[k - 2], pts[k - 1]);
                let slope = if q.0 > p.0 {
                    ((q.1 - p.1) / (q.0 - p.0)).clamp(SLOPE_RANGE.0, SLOPE_RANGE.1)
                } else {
                    SLOPE_RANGE.0
                };
                q.1 + slope * (ls - q.0)
            }
        };
        let v = libm::exp(ln_v);
        (v.is_finite() && v > 0.0).then_some(v)
    }
}

/// Ends a probe (`slot`): the reckoning it read goes when no other probe
/// reads it.
fn release(reckonings: &mut [Option<Reckoning>; RECKONINGS], slot: &mut Option<u8>) {
    let Some(k) = slot.take() else { return };
    let r = &mut reckonings[k as usize];
    if let Some(shared) = r.as_mut() {
        shared.probes = shared.probes.saturating_sub(1);
        if shared.probes == 0 {
            *r = None;
        }
    }
}

/// `cov` (east, north, yaw; m², rad²) with the position's variance set to
/// `var_xy` (m²) on each axis by a congruence on the position's rows and
/// columns: positive definite as `cov` is, the heading's variance kept and
/// its correlation with the position carried along. `cov` unchanged where
/// `var_xy` or the position's block is not positive definite.
pub fn with_position_variance(cov: &Matrix3<f64>, var_xy: f64) -> Matrix3<f64> {
    let now: Matrix2<f64> = cov.fixed_view::<2, 2>(0, 0).into_owned();
    let Some(a) = spd_sqrt(&now)
        .and_then(|c| c.try_inverse())
        .map(|c_inv| c_inv * libm::sqrt(var_xy))
        .filter(|a| var_xy > 0.0 && a.iter().all(|v| v.is_finite()))
    else {
        return *cov;
    };
    let mut t = Matrix3::identity();
    t.fixed_view_mut::<2, 2>(0, 0).copy_from(&a);
    t * cov * t.transpose()
}

/// The symmetric square root of a 2x2 symmetric positive definite `m`:
/// `(m + sqrt(det) I) / sqrt(tr + 2 sqrt(det))`.
fn spd_sqrt(m: &Matrix2<f64>) -> Option<Matrix2<f64>> {
    let det = m[(0, 0)] * m[(1, 1)] - m[(0, 1)] * m[(1, 0)];
    let tr = m[(0, 0)] + m[(1, 1)];
    if !(det > 0.0 && tr > 0.0 && det.is_finite() && tr.is_finite()) {
        return None;
    }
    let sd = libm::sqrt(det);
    Some((m + Matrix2::identity() * sd) / libm::sqrt(tr + 2.0 * sd))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::SplitMix64;
    use std::vec::Vec;

    /// The slipping skid-steer of `twist_noise.rs` with a yaw slip of
    /// 0.02 rad/s std held for 20 s on average (a ground that pulls one
    /// way for a while), tread speeds stepped every 6 s, fixes (0.02 m,
    /// 0.005 rad, stated) at 5 Hz for 400 s; then every 20 s for 800 s a
    /// copy of the estimator dead-reckons 60 s with no fix. Returns each
    /// copy's end-position NEES per dof at 10 s and at 60 s. Each copy
    /// runs beside an [`crate::Estimator::for_outage`] copy, which must
    /// state the same pose and covariance to the last bit.
    fn outage_nees() -> (Vec<f64>, Vec<f64>) {
        let (truth, mut est) = crate::twist_noise::tests::slipping_world();
        let mut rng = SplitMix64::new(11);
        let dt = 0.1;
        let (mut e, mut n, mut yaw) = (0.0f64, 0.0f64, 0.3f64);
        let (mut vl, mut vr, mut slip) = (0.6, 0.6, 0.0);
        let (warm, starts, every) = (4000usize, 40usize, 200usize);
        let mut copies: Vec<(usize, crate::Estimator, crate::Estimator)> = Vec::new();
        let (mut at10, mut at60) = (Vec::new(), Vec::new());
        for step in 0..warm + starts * every + 600 {
            let t = step as f64 * dt;
            if step % 60 == 0 {
                vl = 0.3 + 0.9 * rng.uniform();
                vr = 0.3 + 0.9 * rng.uniform();
            }
            if rng.uniform() < dt / 20.0 {
                slip = 0.02 * rng.normal();
            }
            if step >= warm && (step - warm) % every == 0 && step < warm + starts * every {
                copies.push((step, est.clone(), est.for_outage()));
            }
            if step % 2 == 0 {
                let fix = crate::twist_noise::tests::stated_fix(&mut rng, (e, n, yaw));
                est.on_pose(t, fix).unwrap();
            }
            est.on_wheels(t, vl, vr).unwrap();
            for (from, c, lite) in copies.iter_mut() {
                c.on_wheels(t, vl, vr).unwrap();
                lite.on_wheels(t, vl, vr).unwrap();
                let k = step - *from;
                if k == 100 || k == 600 {
                    let (ce, cn, _) = c.filter().pose();
                    let p = c.pose_covariance();
                    assert_eq!(lite.filter().pose(), (ce, cn, c.filter().pose().2));
                    let bits = |m: nalgebra::Matrix3<f64>| m.map(f64::to_bits);
                    assert_eq!(bits(lite.pose_covariance()), bits(p));
                    let (de, dn) = (e - ce, n - cn);
                    let det = p[(0, 0)] * p[(1, 1)] - p[(0, 1)] * p[(0, 1)];
                    let q = p[(1, 1)] * de * de - 2.0 * p[(0, 1)] * de * dn + p[(0, 0)] * dn * dn;
                    let out = if k == 100 { &mut at10 } else { &mut at60 };
                    out.push(0.5 * q / det);
                }
            }
            copies.retain(|(from, _, _)| step - from < 600);
            let tw = truth.twist(vl, vr);
            (e, n, yaw) = crate::twist_noise::tests::advance((e, n, yaw), &tw, slip, dt);
        }
        (at10, at60)
    }

    fn median(mut v: Vec<f64>) -> f64 {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    }

    #[test]
    fn through_an_outage_the_stated_position_follows_the_drift_the_fixes_showed() {
        // The curve aims the median at 1 per dof (a Gaussian error's reads
        // 0.69). The filter's own noise and the one-second slip noise
        // carried on as a random walk state too little for a slip held for
        // 20 s: 2.1 at 10 s and 6.8 at 60 s.
        let (at10, at60) = outage_nees();
        let (m10, m60) = (median(at10), median(at60));
        assert!(
            (0.5..2.0).contains(&m10),
            "10 s: median NEES per dof {m10:.2}"
        );
        assert!(
            (0.5..2.0).contains(&m60),
            "60 s: median NEES per dof {m60:.2}"
        );
    }

    #[test]
    fn the_curve_waits_for_enough_horizons_and_grows_with_the_span() {
        let mut d = DriftCurve::new();
        assert_eq!(d.variance(10.0), None);
        // A drift whose per-axis variance is 0.01 s² m²/s² (a held slip):
        // ends fed straight in at each horizon.
        for (i, h) in HORIZONS_S.iter().enumerate() {
            for _ in 0..20 {
                d.ends[i].add(0.01 * h * h, *h, 0.0, 1.0);
            }
            let got = d.variance(*h);
            assert_eq!(got.is_some(), i + 1 >= MIN_HORIZONS, "{i}");
        }
        // Within a histogram bin (a factor e^0.25), also past the longest
        // horizon (the slope is at most 2 there).
        for s in [4.0, 10.0, 30.0, 60.0, 100.0] {
            let v = d.variance(s).unwrap();
            let want = 0.01 * s * s;
            assert!(v <= want * 1.3 && v >= want / 1.3, "{s}: {v} vs {want}");
        }
        // Below the shortest horizon it falls like the span, no faster.
        let v2 = d.variance(2.0).unwrap();
        assert!((v2 / d.variance(4.0).unwrap() - 0.5).abs() < 1e-9, "{v2}");
        assert_eq!(d.variance(f64::NAN), None);
    }

    #[test]
    fn the_position_s_variance_is_set_and_the_rest_kept_positive_definite() {
        let cov = Matrix3::new(4.0, 1.5, 0.2, 1.5, 1.0, 0.05, 0.2, 0.05, 0.05);
        assert!(cov.cholesky().is_some());
        let out = with_position_variance(&cov, 9.0);
        let pos = out.fixed_view::<2, 2>(0, 0);
        assert!((pos - Matrix2::identity() * 9.0).norm() < 1e-9, "{out}");
        assert!((out[(2, 2)] - 0.05).abs() < 1e-12);
        assert!(out.cholesky().is_some() && (out - out.transpose()).norm() < 1e-12);
        // The heading's correlation with the position is kept.
        let corr = |m: &Matrix3<f64>| {
            m[(0, 2)] * m[(0, 2)] / (m[(0, 0)] * m[(2, 2)])
                + m[(1, 2)] * m[(1, 2)] / (m[(1, 1)] * m[(2, 2)])
        };
        assert!(corr(&out) > 0.0 && corr(&out) < 1.0);
        assert_eq!(with_position_variance(&cov, f64::NAN), cov);
        assert_eq!(with_position_variance(&cov, -1.0), cov);
        assert_eq!(
            with_position_variance(&Matrix3::zeros(), 1.0),
            Matrix3::zeros()
        );
    }
}
