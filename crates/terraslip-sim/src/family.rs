//! A seeded family of simulated worlds unlike the built-in scenarios: the
//! estimator is judged on the distribution over many of them, never on
//! one drive it was tuned on.
//!
//! Each seed draws a robot (track width, top speed, encoders), 2-4 terrain
//! stretches with their own tread speed factors (in [0.6, 1]; exactly 1 on
//! every terrain in about a quarter of the worlds) and ICR spreads (1-2.2
//! track widths, eccentricity, x_c), a law for how the spread moves with
//! the turn (none, or growing or shrinking by up to 30 % in fast turns), a
//! GNSS receiver (0.02-3 m per axis at 0.5-10 Hz, white or with a slow
//! error correlated over up to 60 s, the odd multipath jump, one 30 s
//! outage inside a terrain stretch after the first minute), a compass in about two thirds of the
//! worlds, and [`World::clock_offset`] and [`World::stated_std`] for the
//! log: a pose stream stamped up to 0.1 s late or early, and `std_xy` /
//! `std_yaw` columns in about half of the worlds.

use std::collections::BTreeMap;

use crate::scenario::{
    Camera, Compass, Drive, Gnss, Imu, Robot, Scenario, Segment, Slip, Wheels, Window,
};
use crate::terrain::{TerrainSpec, CATALOGUE};

/// One world of the family.
#[derive(Debug, Clone, PartialEq)]
pub struct World {
    /// The scenario to simulate.
    pub scenario: Scenario,
    /// How late the pose stream is stamped against the wheels, s (apply to
    /// `pose.csv`'s `t` after simulating).
    pub clock_offset: f64,
    /// Whether `pose.csv` keeps its `std_xy` / `std_yaw` columns.
    pub stated_std: bool,
    /// GNSS std per axis, m (white and correlated parts together).
    pub gnss_std: f64,
    /// The outage window, s.
    pub outage: (f64, f64),
}

impl World {
    /// The world with a yaw-rate gyro on the robot (`imu.csv`): 50-200 Hz,
    /// white noise 0.002-0.01 rad/s per sample, a bias within +-0.02 rad/s,
    /// drawn from `seed` apart from the world's other draws (which stay as
    /// they are).
    pub fn with_gyro(mut self, seed: u64) -> Self {
        let mut r = Draw(seed ^ 0x6779_726F);
        self.scenario.imu = Imu {
            rate: r.uniform(50.0, 200.0),
            gyro_noise: r.uniform(0.002, 0.01),
            gyro_bias: r.uniform(-0.02, 0.02),
            ..Default::default()
        };
        self
    }

    /// The world's gyro reading `1 + e` times the true yaw rate, `e` drawn
    /// uniformly in `+-max` from `seed` apart from every other draw (call
    /// after [`World::with_gyro`]).
    pub fn with_gyro_scale(mut self, seed: u64, max: f64) -> Self {
        let mut r = Draw(seed ^ 0x7363_616C);
        self.scenario.imu.gyro_scale = 1.0 + r.uniform(-max, max);
        self
    }
}

/// Which worlds to draw.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Subset {
    /// The whole family.
    All,
    /// GNSS of 2 m per axis (0.8 m white + 1.8 m correlated over 30 s) at
    /// 1 Hz with a 1 degree compass; everything else drawn as usual.
    Gnss2m,
    /// [`Subset::Gnss2m`]'s worlds with a speed factor difference
    /// `alpha_l - alpha_r` of its own on every ground (within +-0.04, the
    /// Warthog's calibrations span -0.03 to +0.04) and a mild turn law (the
    /// spread moves 1.5 % with the turn rate, or not at all). Everything
    /// else is drawn as in world `seed` of [`Subset::Gnss2m`].
    Ground,
    /// The papers' world under [`Subset::Gnss2m`]'s sensors: constant ICRs
    /// per terrain (no turn law, no speed dependence, no lag), tread speed
    /// factors of exactly 1, spreads of 1.5-2.2 track widths. The class in
    /// which the papers' EKF (speed factors fixed at 1) is right by
    /// construction.
    Papers,
}

/// A small deterministic generator (SplitMix64).
struct Draw(u64);

impl Draw {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * ((self.next() >> 11) as f64 / (1u64 << 53) as f64)
    }
    fn log_uniform(&mut self, lo: f64, hi: f64) -> f64 {
        (self.uniform(lo.ln(), hi.ln())).exp()
    }
    fn chance(&mut self, p: f64) -> bool {
        self.uniform(0.0, 1.0) < p
    }
    fn pick(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

/// World number `seed` of the family (or of a subset).
pub fn world(seed: u64, subset: Subset) -> World {
    let mut r = Draw(seed.wrapping_mul(0xD1B5_4A32_D192_ED03) ^ 0x5DEE_CE66_D1CE);
    let track = r.uniform(0.25, 1.2);
    let top = r.uniform(0.8, 3.0);
    let robot = Robot {
        name: format!("family-{seed}"),
        track_width: track,
        wheel_radius: 0.12 * track.max(0.4),
        length: 1.3 * track,
        max_tread_speed: top,
    };

    // Terrains: 2-4 stretches, a name may come back.
    let alpha_one = r.chance(0.25);
    let n_terrains = 2 + r.pick(3);
    let mut names: Vec<String> = Vec::new();
    let mut terrains = BTreeMap::new();
    let lr_diff = r.uniform(-0.01, 0.01);
    // Per-ground differences come from a generator of their own, so that
    // every other draw is the same as in the other subsets.
    let mut ground = Draw(seed ^ 0x6772_6F75_6E64);
    for k in 0..n_terrains {
        let name = CATALOGUE[(seed as usize + 3 * k) % CATALOGUE.len()].to_string();
        let alpha = if alpha_one { 1.0 } else { r.uniform(0.6, 1.0) };
        let lr_diff = if subset == Subset::Ground {
            ground.uniform(-0.04, 0.04)
        } else {
            lr_diff
        };
        let spread = track * r.uniform(1.0, 2.2);
        let ecc = r.uniform(-0.1, 0.1);
        terrains.insert(
            name.clone(),
            TerrainSpec {
                y_l: Some(0.5 * spread * (1.0 - ecc)),
                y_r: Some(-0.5 * spread * (1.0 + ecc)),
                x_c: Some(r.uniform(-0.15, 0.15) * track),
                alpha_l: Some(alpha * (1.0 + 0.5 * lr_diff)),
                alpha_r: Some(alpha * (1.0 - 0.5 * lr_diff)),
                ..Default::default()
            },
        );
        names.push(name);
    }
    let n_segments = 2 + r.pick(3);
    let mut segments = Vec::new();
    let mut last: Option<usize> = None;
    for _ in 0..n_segments {
        let mut k = r.pick(names.len());
        if Some(k) == last {
            k = (k + 1) % names.len();
        }
        last = Some(k);
        segments.push(Segment {
            terrain: names[k].clone(),
            duration: r.uniform(60.0, 150.0),
        });
    }
    let duration: f64 = segments.iter().map(|s| s.duration).sum();
    // The outage: 30 s inside the longest stretch after the first minute,
    // at least 20 s from the stretch's ends (what the estimator has had
    // time to learn is what dead reckoning is judged on).
    let (mut start, mut longest) = (0.0, 0.0);
    let mut t = 0.0f64;
    for s in &segments {
        let from = t.max(60.0 - 20.0);
        let usable = t + s.duration - from;
        if usable > longest {
            (start, longest) = (from, usable);
        }
        t += s.duration;
    }
    let o0 = start + 20.0 + r.uniform(0.0, (longest - 70.0).max(0.0));
    let outage = (o0, o0 + 30.0);

    let (gnss_std, gnss_rate, tau) = match subset {
        Subset::All => (
            r.log_uniform(0.02, 3.0),
            r.log_uniform(0.5, 10.0),
            if r.chance(0.25) {
                0.0
            } else {
                r.uniform(5.0, 60.0)
            },
        ),
        Subset::Gnss2m | Subset::Ground | Subset::Papers => (2.0, 1.0, 30.0),
    };
    let (white, markov) = if tau > 0.0 {
        (0.4 * gnss_std, 0.9165 * gnss_std)
    } else {
        (gnss_std, 0.0)
    };
    let gnss = Gnss {
        rate: gnss_rate,
        white_std: white,
        markov_std: markov,
        markov_tau: tau.max(1.0),
        reported_std: gnss_std,
        multipath_rate: if gnss_std > 0.3 { 0.002 } else { 0.0 },
        multipath_jump: r.uniform(3.0, 30.0),
        multipath_duration: [1.0, 3.0],
        jumps: Vec::new(),
        outages: vec![Window {
            start: outage.0,
            duration: 30.0,
        }],
        lever_arm: [0.0; 2],
    };
    let compass = match subset {
        Subset::Gnss2m | Subset::Ground | Subset::Papers => Compass {
            rate: 1.0,
            std_deg: 1.0,
            bias_deg: r.uniform(-1.0, 1.0),
            reported_std_deg: 1.0,
        },
        Subset::All if r.chance(2.0 / 3.0) => {
            let sd = r.uniform(0.5, 3.0);
            Compass {
                rate: gnss_rate.max(1.0),
                std_deg: sd,
                bias_deg: r.uniform(-2.0, 2.0),
                reported_std_deg: sd,
            }
        }
        Subset::All => Compass {
            rate: 0.0,
            ..Default::default()
        },
    };
    let turn_law = if r.chance(0.25) {
        0.0
    } else {
        r.uniform(-0.3, 0.3)
    };
    let mut slip = Slip {
        turn_sensitivity: turn_law,
        turn_rate_ref: r.uniform(0.3, 1.0),
        speed_sensitivity: r.uniform(-0.02, 0.02),
        lag: r.uniform(0.1, 0.5),
        transition: 1.0,
    };
    if subset == Subset::Ground {
        slip.turn_sensitivity = 0.015 * turn_law.signum();
    }
    if subset == Subset::Papers {
        slip.turn_sensitivity = 0.0;
        slip.speed_sensitivity = 0.0;
        for t in terrains.values_mut() {
            // The drawn spread of 1-2.2 track widths mapped onto 1.5-2.2,
            // eccentricity kept.
            let (y_l, y_r) = (t.y_l.unwrap_or(0.0), t.y_r.unwrap_or(0.0));
            let q = (y_l - y_r) / track;
            let k = (1.5 + (q - 1.0) * 0.7 / 1.2) / q;
            t.y_l = Some(y_l * k);
            t.y_r = Some(y_r * k);
            t.alpha_l = Some(1.0);
            t.alpha_r = Some(1.0);
        }
    }
    let drive = Drive {
        speed: [0.25 * top, 0.65 * top],
        radii: [1.0, 2.0, 4.0, 8.0]
            .iter()
            .map(|x| x * 2.0 * track)
            .collect(),
        area_radius: 40.0 * track.max(0.5),
        ..Default::default()
    };
    let scenario = Scenario {
        name: format!("family-{seed}"),
        description: format!("world {seed} of the estimator's family of worlds"),
        robot,
        segments,
        terrains,
        slip,
        drive,
        integration: Default::default(),
        wheels: Wheels {
            rate: r.uniform(10.0, 100.0),
            ticks_per_rev: [360.0, 540.0, 1024.0, 2048.0][r.pick(4)],
        },
        gnss,
        compass,
        imu: Imu {
            rate: 0.0,
            ..Default::default()
        },
        camera: Camera {
            rate: 0.0,
            ..Default::default()
        },
    };
    World {
        scenario,
        clock_offset: r.uniform(-0.1, 0.1),
        stated_std: r.chance(0.5),
        gnss_std,
        outage: (outage.0, outage.1.min(duration)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ground_worlds_differ_from_gnss2m_only_in_the_differences_and_the_law() {
        for seed in 1..=20 {
            let (g, m) = (world(seed, Subset::Ground), world(seed, Subset::Gnss2m));
            g.scenario.validate().unwrap();
            assert_eq!(g.outage, m.outage);
            assert_eq!(g.scenario.segments, m.scenario.segments);
            assert_eq!(g.scenario.gnss, m.scenario.gnss);
            assert!(g.scenario.slip.turn_sensitivity.abs() <= 0.015);
            let diffs: Vec<f64> = g
                .scenario
                .terrains
                .values()
                .map(|t| {
                    let (l, r) = (t.alpha_l.unwrap(), t.alpha_r.unwrap());
                    2.0 * (l - r) / (l + r)
                })
                .collect();
            assert!(diffs.iter().all(|d| d.abs() <= 0.04 + 1e-12), "{diffs:?}");
            if diffs.len() > 1 {
                assert!(diffs.windows(2).any(|w| w[0] != w[1]), "{diffs:?}");
            }
        }
    }

    #[test]
    fn worlds_are_valid_deterministic_and_span_the_ranges() {
        let worlds: Vec<World> = (1..=60).map(|s| world(s, Subset::All)).collect();
        assert_eq!(worlds[3], world(4, Subset::All));
        for w in &worlds {
            w.scenario
                .validate()
                .unwrap_or_else(|e| panic!("{}: {e}", w.scenario.name));
        }
        let alpha_one = worlds
            .iter()
            .filter(|w| {
                w.scenario
                    .terrains
                    .values()
                    .all(|t| (t.alpha_l.unwrap() + t.alpha_r.unwrap() - 2.0).abs() < 0.011)
            })
            .count();
        assert!((5..=30).contains(&alpha_one), "{alpha_one}");
        let no_compass = worlds
            .iter()
            .filter(|w| w.scenario.compass.rate == 0.0)
            .count();
        assert!((8..=35).contains(&no_compass), "{no_compass}");
        let stated = worlds.iter().filter(|w| w.stated_std).count();
        assert!((15..=45).contains(&stated), "{stated}");
        let spreads: Vec<f64> = worlds
            .iter()
            .flat_map(|w| {
                let tw = w.scenario.robot.track_width;
                w.scenario
                    .terrains
                    .values()
                    .map(move |t| (t.y_l.unwrap() - t.y_r.unwrap()) / tw)
                    .collect::<Vec<_>>()
            })
            .collect();
        assert!(spreads.iter().all(|s| (0.99..=2.21).contains(s)));
        assert!(spreads.iter().any(|s| *s < 1.2) && spreads.iter().any(|s| *s > 2.0));
        assert!(worlds.iter().all(|w| w.clock_offset.abs() <= 0.1));
        let g = world(7, Subset::Gnss2m);
        assert_eq!((g.gnss_std, g.scenario.gnss.rate), (2.0, 1.0));
        assert_eq!(g.scenario.compass.rate, 1.0);
    }

    #[test]
    fn the_papers_class_has_constant_icrs_unit_speed_factors_and_wide_spreads() {
        for seed in 1..=30 {
            let w = world(seed, Subset::Papers);
            w.scenario.validate().unwrap();
            assert_eq!((w.gnss_std, w.scenario.gnss.rate), (2.0, 1.0));
            let slip = &w.scenario.slip;
            assert_eq!((slip.turn_sensitivity, slip.speed_sensitivity), (0.0, 0.0));
            let tw = w.scenario.robot.track_width;
            for t in w.scenario.terrains.values() {
                assert_eq!((t.alpha_l, t.alpha_r), (Some(1.0), Some(1.0)));
                let q = (t.y_l.unwrap() - t.y_r.unwrap()) / tw;
                assert!(
                    (1.499..=2.201).contains(&q),
                    "world {seed}: spread {q} track widths"
                );
            }
            // The same robot and drive as the other subsets draw.
            assert_eq!(w.scenario.robot, world(seed, Subset::Gnss2m).scenario.robot);
        }
    }
}
