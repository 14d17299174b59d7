//! The course `follow` drives: straights and arcs turning left and right,
//! sampled every [`STEP`] m, over stretches of ground laid end to end.
//! The course heads east where one ground meets the next, so a ground is
//! the strip of the world between two eastings.
//!
//! Frames: world ENU m, headings rad counter-clockwise from east; the
//! course starts at the origin heading east.

use std::f64::consts::FRAC_PI_2;

use terraslip_core::angle::wrap;

/// Spacing of the course's points, m.
pub const STEP: f64 = 0.05;

/// One piece of a course.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Piece {
    /// Straight ahead, m.
    Straight(f64),
    /// An arc of radius `radius` m turning by `angle` rad (> 0 = left).
    Arc { radius: f64, angle: f64 },
}

/// A point of the course.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    pub east: f64,
    pub north: f64,
    /// Heading of the course here, rad.
    pub heading: f64,
    /// Arc length from the start, m.
    pub s: f64,
}

/// Where a turn of the course ends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TurnEnd {
    /// Arc length, m.
    pub s: f64,
    /// The course's heading there, rad.
    pub heading: f64,
    /// Index into [`Course::grounds`].
    pub ground: usize,
}

/// A course over grounds.
#[derive(Debug, Clone)]
pub struct Course {
    pub points: Vec<Point>,
    /// Ground names, in the order driven.
    pub grounds: Vec<String>,
    /// Arc length where each ground starts, m (the first at 0).
    pub ground_s: Vec<f64>,
    /// Easting where each ground starts, m (the first at -inf).
    ground_east: Vec<f64>,
    pub turn_ends: Vec<TurnEnd>,
}

/// The turns of one stretch of ground, driven twice: a straight, a left
/// quarter turn of 2 m radius, a straight, a right quarter turn of 1.5 m
/// radius, a straight. The second lap is the same geometry as the first, so
/// the error the follower settles to on a ground is measured on the turns
/// it first met just after the ground changed.
pub fn lap() -> Vec<Piece> {
    vec![
        Piece::Straight(4.0),
        Piece::Arc {
            radius: 2.0,
            angle: FRAC_PI_2,
        },
        Piece::Straight(4.0),
        Piece::Arc {
            radius: 1.5,
            angle: -FRAC_PI_2,
        },
        Piece::Straight(4.0),
    ]
}

impl Course {
    /// `grounds` in order, each driven over `laps` laps of [`lap`], and a
    /// straight run-out of 3 m at the end.
    pub fn new(grounds: &[&str], laps: usize) -> Self {
        let mut c = Course {
            points: vec![Point {
                east: 0.0,
                north: 0.0,
                heading: 0.0,
                s: 0.0,
            }],
            grounds: grounds.iter().map(|g| g.to_string()).collect(),
            ground_s: Vec::new(),
            ground_east: Vec::new(),
            turn_ends: Vec::new(),
        };
        for (gi, _) in grounds.iter().enumerate() {
            let here = *c.points.last().expect("a course has a start");
            c.ground_s.push(here.s);
            c.ground_east.push(if gi == 0 {
                f64::NEG_INFINITY
            } else {
                here.east
            });
            for _ in 0..laps {
                for piece in lap() {
                    c.add(piece);
                    if matches!(piece, Piece::Arc { .. }) {
                        let end = *c.points.last().expect("an arc adds points");
                        c.turn_ends.push(TurnEnd {
                            s: end.s,
                            heading: end.heading,
                            ground: gi,
                        });
                    }
                }
            }
        }
        c.add(Piece::Straight(3.0));
        c
    }

    fn add(&mut self, piece: Piece) {
        let p0 = *self.points.last().expect("a course has a start");
        let (len, curvature) = match piece {
            Piece::Straight(l) => (l, 0.0),
            Piece::Arc { radius, angle } => (radius * angle.abs(), angle.signum() / radius),
        };
        let n = (len / STEP).round().max(1.0) as usize;
        for i in 1..=n {
            let u = len * i as f64 / n as f64;
            let heading = p0.heading + curvature * u;
            let (de, dn) = if curvature == 0.0 {
                (u * p0.heading.cos(), u * p0.heading.sin())
            } else {
                (
                    (heading.sin() - p0.heading.sin()) / curvature,
                    (p0.heading.cos() - heading.cos()) / curvature,
                )
            };
            self.points.push(Point {
                east: p0.east + de,
                north: p0.north + dn,
                heading: wrap(heading),
                s: p0.s + u,
            });
        }
    }

    /// Length, m.
    pub fn length(&self) -> f64 {
        self.points.last().map_or(0.0, |p| p.s)
    }

    /// The ground under a point: the strip of eastings it lies in.
    pub fn ground_at(&self, east: f64) -> usize {
        self.ground_east
            .partition_point(|&e| e <= east)
            .saturating_sub(1)
    }

    /// The ground of arc length `s`.
    pub fn ground_of(&self, s: f64) -> usize {
        self.ground_s.partition_point(|&g| g <= s).saturating_sub(1)
    }

    /// The course point nearest `(east, north)`, searched from index
    /// `from` onwards over `window` m of course (progress never runs
    /// backwards by more than that window's start), with the signed
    /// cross-track distance (m, > 0 = left of the course).
    pub fn project(&self, east: f64, north: f64, from: usize, window: f64) -> (usize, f64) {
        let n = ((window / STEP) as usize).max(1);
        let lo = from.min(self.points.len() - 1);
        let hi = (lo + n).min(self.points.len() - 1);
        let d2 = |p: &Point| (p.east - east).powi(2) + (p.north - north).powi(2);
        let i = (lo..=hi)
            .min_by(|&a, &b| d2(&self.points[a]).total_cmp(&d2(&self.points[b])))
            .unwrap_or(lo);
        let p = &self.points[i];
        let (s, c) = p.heading.sin_cos();
        (i, -s * (east - p.east) + c * (north - p.north))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_course_is_continuous_and_heads_east_at_every_ground_change() {
        let c = Course::new(&["asphalt", "sand"], 2);
        for w in c.points.windows(2) {
            let d = (w[1].east - w[0].east).hypot(w[1].north - w[0].north);
            assert!((d - (w[1].s - w[0].s)).abs() < 1e-3, "{d}");
        }
        assert_eq!(c.turn_ends.len(), 8);
        assert!(c.turn_ends.iter().any(|t| t.heading > 1.5));
        let lap_len = 12.0 + 2.0 * FRAC_PI_2 + 1.5 * FRAC_PI_2;
        assert!((c.length() - (4.0 * lap_len + 3.0)).abs() < 1e-9);
        let change = c.ground_s[1];
        let i = c.points.partition_point(|p| p.s < change);
        assert!(c.points[i].heading.abs() < 1e-9);
        assert_eq!(c.ground_at(c.points[i].east - 0.1), 0);
        assert_eq!(c.ground_at(c.points[i].east + 0.1), 1);
        assert_eq!(c.ground_of(change + 0.1), 1);
        // Left of a course heading east is north.
        let (j, e) = c.project(1.0, 0.3, 0, 5.0);
        assert_eq!(j, 20);
        assert!((e - 0.3).abs() < 1e-9);
    }
}
