//! The outage yardstick: how far a model dead-reckons off while the pose
//! is withheld for 10, 30 and 60 s (a GNSS or localisation outage), and
//! whether the model's own uncertainty says so.
//!
//! Starts lie every `stride` seconds after a `warmup` on the wheels'
//! clock (`t0 + warmup + k * stride`, `t0` the first wheels row). Every
//! model dead-reckons from the same [`Start`]: the online filter's pose and
//! heading at the start, what a robot losing its fixes would go on from
//! (the reference pose there would hand the other models a pose the robot
//! never had: a GNSS fix is metres from the filter's). At each horizon its
//! end position is compared with the reference position (linear
//! interpolation of the pose stream, read with the start's clock offset):
//! the error (m), the distance the reference travelled (m), the
//! error's along-track and cross-track parts (along the reference's
//! heading at the end, or its direction of travel when it has none), and,
//! for a model with a propagated covariance, the normalised estimation
//! error squared per degree of freedom (`e^T P^-1 e / 2`: 1 when the
//! covariance is right).

use terraslip_core::Twist;
use terraslip_io::{PoseObs, WheelSample};

use crate::prediction::{heading_at, lerp, predict_with};

/// The withheld spans, s.
pub const HORIZONS: [f64; 3] = [10.0, 30.0, 60.0];

/// Settings of the yardstick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OutageSpec {
    /// Time from the first wheels row before the first start, s.
    pub warmup: f64,
    /// Time between starts, s.
    pub stride: f64,
    /// Longest gap in the pose stream around a start or an end, s.
    pub max_gap: f64,
}

impl Default for OutageSpec {
    fn default() -> Self {
        Self {
            warmup: 60.0,
            stride: 10.0,
            max_gap: 1.5,
        }
    }
}

impl OutageSpec {
    /// The start times from `t0` (the first wheels row, s) up to `t_end`.
    pub fn starts(&self, t0: f64, t_end: f64) -> impl Iterator<Item = f64> + '_ {
        let first = t0 + self.warmup;
        (0..)
            .map(move |k| first + k as f64 * self.stride)
            .take_while(move |t| *t <= t_end)
    }
}

/// Where every model dead-reckons from at a start: the online filter's
/// pose there (east, north m; yaw rad) and its clock offset (s: the
/// reference is read that much later than the wheels' clock).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Start {
    /// Start, s (wheels' clock).
    pub t: f64,
    pub east: f64,
    pub north: f64,
    pub yaw: f64,
    pub clock: f64,
}

impl Start {
    /// The point `(x, y)` m of a start's frame (x along its heading, y to
    /// its left), in east and north.
    pub fn place(&self, x: f64, y: f64) -> (f64, f64) {
        let (s, c) = self.yaw.sin_cos();
        (self.east + x * c - y * s, self.north + x * s + y * c)
    }
}

/// A filter's end of an outage, unscored, with the start it went from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FilterEnd {
    pub start: Start,
    pub horizon: f64,
    pub end: End,
}

impl FilterEnd {
    /// The end as if the filter had set out from `to` (same time) rather
    /// than from its own start: its motion (and covariance) carried into
    /// `to`'s frame. Dead reckoning without fixes moves rigidly with its
    /// start pose.
    pub fn from_start(&self, to: &Start) -> End {
        let (de, dn) = (
            self.end.east - self.start.east,
            self.end.north - self.start.north,
        );
        let (s, c) = (-self.start.yaw).sin_cos();
        let (x, y) = (de * c - dn * s, de * s + dn * c);
        let (east, north) = to.place(x, y);
        let cov = self.end.cov.map(|[a, b, d]| {
            let (s, c) = (to.yaw - self.start.yaw).sin_cos();
            // R P R^T, R the rotation by the change of heading.
            [
                c * c * a - 2.0 * c * s * b + s * s * d,
                c * s * (a - d) + (c * c - s * s) * b,
                s * s * a + 2.0 * c * s * b + c * c * d,
            ]
        });
        End { east, north, cov }
    }
}

/// A model's position at the end of an outage, and its covariance when
/// the model propagates one (east, north; m and m^2).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct End {
    pub east: f64,
    pub north: f64,
    /// `[var_e, cov_en, var_n]`.
    pub cov: Option<[f64; 3]>,
}

/// One scored end of an outage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OutageEnd {
    /// Start, s (wheels' clock), and the outage's length, s.
    pub t: f64,
    pub horizon: f64,
    /// End position error, m.
    pub error: f64,
    /// Distance the reference travelled during the outage, m.
    pub distance: f64,
    /// Signed along-track and cross-track parts of the error, m.
    pub along: f64,
    pub cross: f64,
    /// NEES of the end position per degree of freedom (`None` without a
    /// covariance).
    pub nees: Option<f64>,
}

/// The pose reference an outage is scored against: positions with the
/// path length travelled to them, and headings (unwrapped).
#[derive(Debug, Clone, Default)]
pub struct Track {
    /// Time, east, north, path length from the first position (s, m).
    positions: Vec<[f64; 4]>,
    headings: Vec<(f64, f64)>,
}

impl Track {
    /// The reference of a whole pose stream.
    pub fn of(pose: &[PoseObs]) -> Self {
        let mut t = Self::default();
        for p in pose {
            t.push(p);
        }
        t
    }

    /// The next pose row (in time order).
    pub fn push(&mut self, p: &PoseObs) {
        if let (Some(e), Some(n)) = (p.east, p.north) {
            if e.is_finite() && n.is_finite() {
                let s = self
                    .positions
                    .last()
                    .map_or(0.0, |q| q[3] + (e - q[1]).hypot(n - q[2]));
                self.positions.push([p.t, e, n, s]);
            }
        }
        if let Some(y) = p.yaw.filter(|y| y.is_finite()) {
            let y = match self.headings.last() {
                Some(&(_, prev)) => prev + terraslip_core::angle::wrap(y - prev),
                None => y,
            };
            self.headings.push((p.t, y));
        }
    }

    /// Position and path length at `t`, between positions no further
    /// apart than `max_gap` s.
    pub fn position(&self, t: f64, max_gap: f64) -> Option<[f64; 3]> {
        let r = &self.positions;
        let i = r.partition_point(|p| p[0] < t);
        let near = |k: usize| r.get(k).map(|p| p[0]);
        if near(i) != Some(t) && near(i)? - near(i.checked_sub(1)?)? > max_gap {
            return None;
        }
        lerp(r, t, |p| p[0], |p| [p[1], p[2], p[3]])
    }

    /// Heading at `t` (rad, unwrapped), between headings no further
    /// apart than `max_gap` s.
    pub fn heading(&self, t: f64, max_gap: f64) -> Option<f64> {
        heading_at(&self.headings, t, max_gap)
    }

    /// Scores `end`, a model's position after the outage from `t`
    /// (wheels' clock) of `horizon` s, against the reference read
    /// `clock_offset` s later.
    pub fn score(
        &self,
        t: f64,
        horizon: f64,
        clock_offset: f64,
        end: End,
        max_gap: f64,
    ) -> Option<OutageEnd> {
        let (r0, r1) = (t + clock_offset, t + horizon + clock_offset);
        let [_, _, s0] = self.position(r0, max_gap)?;
        let [e1, n1, s1] = self.position(r1, max_gap)?;
        let (de, dn) = (end.east - e1, end.north - n1);
        if !(de.is_finite() && dn.is_finite()) {
            return None;
        }
        // The direction of travel at the end: the reference's heading, or
        // the way it moved over the last second.
        let dir = self.heading(r1, max_gap).or_else(|| {
            let [ea, na, _] = self.position(r1 - 1.0, max_gap)?;
            ((e1 - ea).hypot(n1 - na) > 0.05).then(|| (n1 - na).atan2(e1 - ea))
        });
        let (along, cross) = match dir {
            Some(y) => (de * y.cos() + dn * y.sin(), -de * y.sin() + dn * y.cos()),
            None => (de.hypot(dn), 0.0),
        };
        let nees = end.cov.and_then(|[a, b, c]| {
            let det = a * c - b * b;
            (det > 0.0 && a > 0.0)
                .then(|| 0.5 * (c * de * de - 2.0 * b * de * dn + a * dn * dn) / det)
        });
        Some(OutageEnd {
            t,
            horizon,
            error: de.hypot(dn),
            distance: s1 - s0,
            along,
            cross,
            nees,
        })
    }

    /// The outage ends of a fixed model `twist` (a wheels row's body
    /// twist for a start `t`), dead-reckoned from each start's pose.
    pub fn fixed_model(
        &self,
        wheels: &[WheelSample],
        twist: &dyn Fn(f64, &WheelSample) -> Twist,
        starts: &[Start],
        max_gap: f64,
    ) -> Vec<OutageEnd> {
        let mut out = Vec::new();
        for s in starts {
            let a = (s.east, s.north, s.yaw);
            for h in HORIZONS {
                let (east, north) = predict_with(wheels, &|w| twist(s.t, w), s.t, s.t + h, a);
                let end = End {
                    east,
                    north,
                    cov: None,
                };
                out.extend(self.score(s.t, h, s.clock, end, max_gap));
            }
        }
        out
    }

    /// A filter's ends, each carried to the start of `starts` at its time
    /// ([`FilterEnd::from_start`]) and scored; ends with no such start are
    /// left out.
    pub fn filter_from(
        &self,
        ends: &[FilterEnd],
        starts: &[Start],
        max_gap: f64,
    ) -> Vec<OutageEnd> {
        ends.iter()
            .filter_map(|e| {
                let to = starts.iter().find(|s| s.t == e.start.t)?;
                self.score(to.t, e.horizon, to.clock, e.from_start(to), max_gap)
            })
            .collect()
    }
}

/// Figures of one model at one horizon.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct OutageStats {
    pub horizon_s: f64,
    pub segments: usize,
    pub mean_m: f64,
    pub median_m: f64,
    /// Total error over total distance travelled, m per km.
    pub m_per_km: f64,
    /// Root-mean-square along-track and cross-track errors, m.
    pub along_rms_m: f64,
    pub cross_rms_m: f64,
    /// Median NEES per degree of freedom (`None` without a covariance).
    pub nees_median: Option<f64>,
}

impl OutageStats {
    /// The figures of `ends` at `horizon` (`None` when none is there).
    pub fn of(ends: &[OutageEnd], horizon: f64) -> Option<Self> {
        let at: Vec<&OutageEnd> = ends.iter().filter(|e| e.horizon == horizon).collect();
        if at.is_empty() {
            return None;
        }
        let n = at.len() as f64;
        let median = |mut v: Vec<f64>| {
            v.sort_by(|a, b| a.total_cmp(b));
            let k = v.len();
            if k % 2 == 1 {
                v[k / 2]
            } else {
                0.5 * (v[k / 2 - 1] + v[k / 2])
            }
        };
        let nees: Vec<f64> = at.iter().filter_map(|e| e.nees).collect();
        let sum = |f: &dyn Fn(&OutageEnd) -> f64| at.iter().map(|e| f(e)).sum::<f64>();
        let distance = sum(&|e| e.distance);
        Some(Self {
            horizon_s: horizon,
            segments: at.len(),
            mean_m: sum(&|e| e.error) / n,
            median_m: median(at.iter().map(|e| e.error).collect()),
            m_per_km: if distance > 0.0 {
                1000.0 * sum(&|e| e.error) / distance
            } else {
                f64::NAN
            },
            along_rms_m: (sum(&|e| e.along * e.along) / n).sqrt(),
            cross_rms_m: (sum(&|e| e.cross * e.cross) / n).sqrt(),
            nees_median: (nees.len() == at.len()).then(|| median(nees)),
        })
    }

    /// The figures of `ends` at every horizon that has some.
    pub fn all(ends: &[OutageEnd]) -> Vec<Self> {
        HORIZONS.iter().filter_map(|h| Self::of(ends, *h)).collect()
    }
}

/// The outage figures of a run: each model's ends.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct OutageScore {
    pub spec: Option<OutageSpec>,
    /// Model name and its scored ends.
    pub models: Vec<(String, Vec<OutageEnd>)>,
    /// Where every model set out from at each start.
    pub starts: Vec<Start>,
    /// The online filter's own ends, unscored (to carry into another
    /// run's starts: [`Track::filter_from`]).
    pub filter_ends: Vec<FilterEnd>,
}

impl OutageScore {
    /// The ends of the model `name`.
    pub fn ends(&self, name: &str) -> Option<&[OutageEnd]> {
        self.models
            .iter()
            .find(|m| m.0 == name)
            .map(|m| m.1.as_slice())
    }

    /// The `outage` object of `summary.json`: per model, its figures at
    /// each horizon.
    pub fn to_json(&self) -> serde_json::Value {
        let spec = self.spec.unwrap_or_default();
        let mut models = serde_json::Map::new();
        for (name, ends) in &self.models {
            models.insert(name.clone(), serde_json::json!(OutageStats::all(ends)));
        }
        serde_json::json!({
            "horizons_s": HORIZONS,
            "stride_s": spec.stride,
            "warmup_s": spec.warmup,
            "models": models,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(t: f64, e: f64, n: f64, yaw: Option<f64>) -> PoseObs {
        PoseObs {
            t,
            east: Some(e),
            north: Some(n),
            yaw,
            std_xy: None,
            std_yaw: None,
        }
    }

    #[test]
    fn an_end_splits_into_along_and_cross_track_with_its_nees() {
        // Driving east at 1 m/s for 100 s.
        let p: Vec<PoseObs> = (0..=1000)
            .map(|k| pose(k as f64 * 0.1, k as f64 * 0.1, 0.0, Some(0.0)))
            .collect();
        let track = Track::of(&p);
        // 0.3 m short and 0.4 m to the left after 30 s from t = 10.
        let end = End {
            east: 40.0 - 0.3,
            north: 0.4,
            cov: Some([0.09, 0.0, 0.16]),
        };
        let s = track.score(10.0, 30.0, 0.0, end, 1.0).unwrap();
        assert!((s.error - 0.5).abs() < 1e-9);
        assert!((s.distance - 30.0).abs() < 1e-9);
        assert!((s.along + 0.3).abs() < 1e-9 && (s.cross - 0.4).abs() < 1e-9);
        // One sigma on each axis: NEES 2 over 2 degrees of freedom.
        assert!((s.nees.unwrap() - 1.0).abs() < 1e-9);
        // Past the reference's end: nothing to score.
        assert!(track.score(80.0, 30.0, 0.0, end, 1.0).is_none());
    }

    #[test]
    fn a_fixed_model_dead_reckons_from_each_start_s_pose() {
        let p: Vec<PoseObs> = (0..=1500)
            .map(|k| pose(k as f64 * 0.1, k as f64 * 0.1, 0.0, Some(0.0)))
            .collect();
        let wheels: Vec<WheelSample> = (0..=7500)
            .map(|k| WheelSample {
                t: k as f64 * 0.02,
                v_left: 1.0,
                v_right: 1.0,
            })
            .collect();
        let track = Track::of(&p);
        let spec = OutageSpec::default();
        let starts: Vec<f64> = spec.starts(0.0, 150.0).collect();
        assert_eq!(
            starts,
            [60.0, 70.0, 80.0, 90.0, 100.0, 110.0, 120.0, 130.0, 140.0, 150.0]
        );
        // A model 10 % slow: 10 % of the distance short.
        let slow = |_: f64, w: &WheelSample| Twist {
            v_x: 0.45 * (w.v_left + w.v_right),
            v_y: 0.0,
            omega: 0.0,
        };
        let on_track = |t: f64| Start {
            t,
            east: t,
            north: 0.0,
            yaw: 0.0,
            clock: 0.0,
        };
        let at: Vec<Start> = starts.iter().map(|&t| on_track(t)).collect();
        let ends = track.fixed_model(&wheels, &slow, &at, 1.0);
        let s = OutageStats::of(&ends, 30.0).unwrap();
        // Starts up to 120 s end inside the 150 s reference.
        assert_eq!(s.segments, 7);
        assert!((s.m_per_km - 100.0).abs() < 0.5, "{s:?}");
        assert!(s.cross_rms_m < 1e-9 && (s.along_rms_m - 3.0).abs() < 0.02);
        assert!(s.nees_median.is_none());
        // Set out 2 m to the left of the track, heading along it: 2 m
        // cross-track at every horizon (the reference's start is not used).
        let left: Vec<Start> = at.iter().map(|s| Start { north: 2.0, ..*s }).collect();
        let ends = track.fixed_model(&wheels, &slow, &left, 1.0);
        let s = OutageStats::of(&ends, 10.0).unwrap();
        assert!((s.cross_rms_m - 2.0).abs() < 1e-9, "{s:?}");
    }

    #[test]
    fn a_filter_s_end_is_carried_into_another_start() {
        // A filter set out from (10, 0) heading north and ended 3 m ahead,
        // 1 m to its left, with 1 m^2 along and 4 m^2 across its heading.
        let own = Start {
            t: 60.0,
            east: 10.0,
            north: 0.0,
            yaw: std::f64::consts::FRAC_PI_2,
            clock: 0.1,
        };
        let e = FilterEnd {
            start: own,
            horizon: 10.0,
            end: End {
                east: 9.0,
                north: 3.0,
                cov: Some([4.0, 0.0, 1.0]),
            },
        };
        // From the origin heading east: 3 m east, 1 m north.
        let to = Start {
            east: 0.0,
            yaw: 0.0,
            ..own
        };
        let end = e.from_start(&to);
        assert!((end.east - 3.0).abs() < 1e-12 && (end.north - 1.0).abs() < 1e-12);
        let [a, b, d] = end.cov.unwrap();
        assert!((a - 1.0).abs() < 1e-12 && b.abs() < 1e-12 && (d - 4.0).abs() < 1e-12);
        // Into its own start: unchanged.
        let back = e.from_start(&own);
        assert!((back.east - 9.0).abs() < 1e-12 && (back.north - 3.0).abs() < 1e-12);
    }
}
