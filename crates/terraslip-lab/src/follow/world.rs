//! The world `follow` drives in: the simulator's small four-wheeled robot
//! (lv2019's, 0.26 m between the treads) with 50 Hz encoders, a 200 Hz
//! gyro and an RTK-grade receiver (5 Hz, 1.5 cm, with a 0.2° dual-antenna
//! heading), over the course's grounds; and the turn test a user tunes a
//! static `wheel_separation_multiplier` with.
//!
//! Each seed draws its own grounds around the catalogue's (steering
//! efficiency within +-10 %, eccentricity within +-0.03, speed factor
//! within +-0.02), its gyro's bias (+-0.01 rad/s) and its sensors' noise.

use std::collections::BTreeMap;

use terraslip_core::kinematics::Twist;
use terraslip_core::rng::SplitMix64;
use terraslip_sim::closed_loop::{simulate_closed_loop, Controller, Sensed};
use terraslip_sim::scenario::{Compass, Gnss, Segment};
use terraslip_sim::terrain::TerrainSpec;
use terraslip_sim::Scenario;

/// The low-friction ground: soil that turns worse and rolls short (wet
/// clay): steering efficiency 0.45, speed factors 0.90.
pub const MUD: &str = "mud";
const MUD_CHI: f64 = 0.45;
const MUD_ALPHA: f64 = 0.90;

/// The world of `seed` over `grounds` (catalogue names or [`MUD`]), in
/// the order driven. With `uncorrelated_gnss` the receiver's whole error
/// is white (its 1-sigma per axis unchanged): no part of it wanders
/// together over tens of seconds for the estimate to inherit.
pub fn scenario(
    grounds: &[String],
    seed: u64,
    uncorrelated_gnss: bool,
) -> anyhow::Result<Scenario> {
    let mut sc = Scenario::builtin("papers")?;
    sc.name = format!("follow-{seed}");
    sc.description = "terraslip-lab follow: a path follower over grounds of different slip".into();
    sc.segments = grounds
        .iter()
        .map(|g| Segment {
            terrain: g.clone(),
            duration: 1.0,
        })
        .collect();
    let mut rng = SplitMix64::new(seed ^ 0x666F_6C6C_6F77);
    let mut within = |lo: f64, hi: f64| lo + (hi - lo) * rng.uniform();
    sc.terrains = BTreeMap::new();
    for g in grounds {
        let (like, chi, ecc, alpha) = if g == MUD {
            ("soil", MUD_CHI, 0.03, MUD_ALPHA)
        } else {
            let t = terraslip_sim::terrain::catalogue(g)
                .ok_or_else(|| anyhow::anyhow!("unknown ground `{g}`"))?;
            (g.as_str(), t.chi, t.eccentricity, t.alpha_l)
        };
        let alpha = alpha + within(-0.02, 0.02);
        sc.terrains.insert(
            g.clone(),
            TerrainSpec {
                like: Some(like.into()),
                chi: Some(chi * within(0.9, 1.1)),
                eccentricity: Some(ecc + within(-0.03, 0.03)),
                alpha_l: Some(alpha),
                alpha_r: Some(alpha),
                ..Default::default()
            },
        );
    }
    sc.gnss = Gnss::rtk(5.0);
    if uncorrelated_gnss {
        sc.gnss.white_std = sc.gnss.total_std();
        sc.gnss.markov_std = 0.0;
    }
    sc.compass = Compass {
        rate: 5.0,
        std_deg: 0.2,
        bias_deg: 0.0,
        reported_std_deg: 0.2,
    };
    sc.imu.gyro_bias = within(-0.01, 0.01);
    sc.camera.rate = 0.0;
    sc.validate().map_err(anyhow::Error::msg)?;
    Ok(sc)
}

/// Drives a fixed twist for a fixed time, then stands for [`STAND`] s.
struct Fixed {
    twist: Twist,
    until: f64,
}

/// s
const STAND: f64 = 3.0;

impl Controller for Fixed {
    fn command(&mut self, s: &Sensed<'_>) -> Option<Twist> {
        if s.t < self.until {
            Some(self.twist)
        } else {
            (s.t < self.until + STAND).then(Twist::default)
        }
    }
}

/// The multiplier a user finds with a turn test on the first ground of
/// `sc`: an arc commanded at `speed` m/s and radius `radius` m for two full
/// turns, then the commanded angle over the angle the robot turned (a
/// perfect protractor: the truth).
pub fn turn_test_multiplier(sc: &Scenario, speed: f64, radius: f64) -> anyhow::Result<f64> {
    let omega = speed / radius;
    let angle = 2.0 * std::f64::consts::TAU;
    let mut c = Fixed {
        twist: Twist {
            v_x: speed,
            v_y: 0.0,
            omega,
        },
        until: angle / omega,
    };
    let until = c.until;
    let run = simulate_closed_loop(sc, &|_, _| 0, 0.0, 0.05, until + 2.0 * STAND, &mut c, 1)?;
    // The yaw unwrapped over the whole test, the robot at rest again.
    let turned: f64 = run
        .truth
        .windows(2)
        .map(|w| terraslip_core::angle::wrap(w[1].yaw - w[0].yaw))
        .sum();
    let commanded = omega * until;
    anyhow::ensure!(
        turned.abs() > 0.1,
        "the turn test did not turn ({turned} rad)"
    );
    Ok(commanded / turned)
}

/// The nominal yaw gain of ground `name` (steering efficiency times speed
/// factor: the fraction of a commanded turn a nominal drive gets).
pub fn yaw_gain(name: &str) -> Option<f64> {
    if name == MUD {
        return Some(MUD_CHI * MUD_ALPHA);
    }
    terraslip_sim::terrain::catalogue(name).map(|t| t.chi * t.alpha_l)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_turn_test_finds_the_turn_the_ground_loses() {
        let grounds = vec!["sand".to_string(), MUD.to_string()];
        let sc = scenario(&grounds, 3, false).unwrap();
        let p = sc.terrain_icr("sand").unwrap();
        // A nominal drive's yaw rate is alpha W / (y_l - y_r) of the command;
        // the slip model moves the spread a few percent with the turn.
        let lost = p.alpha_l * sc.robot.track_width / p.spread();
        let m = turn_test_multiplier(&sc, 0.5, 2.0).unwrap();
        assert!(
            (m * lost - 1.0).abs() < 0.03,
            "multiplier {m}, 1 / gain {}",
            1.0 / lost
        );
        // Seeds draw their own grounds, within the stated ranges.
        let other = scenario(&grounds, 4, false).unwrap();
        assert_ne!(other.terrains, sc.terrains);
        // Uncorrelated: the same error per axis, all of it white.
        let white = scenario(&grounds, 3, true).unwrap();
        assert_eq!(white.gnss.markov_std, 0.0);
        assert!((white.gnss.total_std() - sc.gnss.total_std()).abs() < 1e-12);
        assert_eq!(white.terrains, sc.terrains);
        let mud = sc.terrain(MUD).unwrap();
        assert!((mud.chi / MUD_CHI - 1.0).abs() <= 0.1 + 1e-12);
        assert!((mud.alpha_l - MUD_ALPHA).abs() <= 0.02 + 1e-12);
    }
}
