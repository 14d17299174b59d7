//! `terraslip-lab follow`: a regulated pure pursuit follower drives a
//! course of left and right turns over grounds of different slip, steering
//! on the online estimator's pose, in the closed-loop simulator; once with
//! its twist sent as it is, once through a static wheel separation
//! multiplier tuned on the first ground, once through live compensation
//! under the estimator's current model to the controller of that
//! multiplier. Figures per ground against the
//! true pose, over a family of seeds: median and worst.

mod course;
mod driver;
mod pursuit;
mod score;
mod steering;
mod table;
mod world;

use anyhow::Context;
use terraslip::belief::{Belief, CONFIDENT_SPREAD_STD};
use terraslip::config::EstimatorConfig;
use terraslip_core::compensate::CompensateConfig;
use terraslip_sim::closed_loop::simulate_closed_loop;

pub use course::Course;
use driver::{Follower, Outage, OUTAGE_S};
use pursuit::Pursuit;
pub use score::RunScore;
pub use steering::{Steering, Variant};

/// Follow a course over grounds of different slip, with and without slip
/// compensation.
#[derive(clap::Args)]
pub struct Args {
    /// Number of seeds (each draws its own grounds, gyro bias and noise).
    #[arg(long, default_value_t = 20)]
    seeds: u64,
    /// Seed of the first run.
    #[arg(long, default_value_t = 1)]
    first_seed: u64,
    /// The grounds, in the order driven (catalogue names, or `mud`: a
    /// low-friction soil).
    #[arg(long, value_delimiter = ',', default_value = "asphalt,grass,sand,mud")]
    grounds: Vec<String>,
    /// Laps of the turn pattern on each ground (the error settles on the
    /// last; at least 2).
    #[arg(long, default_value_t = 2)]
    laps: usize,
    /// The estimator the follower steers on (a preset or `config:FILE.toml`).
    #[arg(long, default_value = "terraslip")]
    estimator: String,
    /// Live compensation: fastest the correction may change, per s (the
    /// compensator's `max_correction_rate`).
    #[arg(long, default_value_t = CompensateConfig::new(1.0).max_correction_rate)]
    correction_rate: f64,
    /// Live compensation: seconds the estimate must have been confident
    /// before it is applied (the compensator's `engage_after`).
    #[arg(long, default_value_t = CompensateConfig::new(1.0).engage_after)]
    engage_after: f64,
    /// Live compensation: seconds after a detected slip change during which
    /// the estimate is not believed (`terraslip node --compensate
    /// --hold-after-change`).
    #[arg(long, default_value_t = terraslip::belief::HOLD_AFTER_CHANGE)]
    hold_after_change: f64,
    /// Live compensation on a drive controller of wheel separation
    /// multiplier 1 (else on the controller of the static variant, whose
    /// multiplier the turn test tuned).
    #[arg(long)]
    live_on_untuned: bool,
    /// The receiver's error all white, its 1-sigma per axis unchanged
    /// (a diagnosis: the RTK receiver's error otherwise has a part that
    /// wanders over tens of seconds, which the estimate inherits).
    #[arg(long)]
    uncorrelated_gnss: bool,
    /// Print one line per seed and variant (to stderr): cross-track RMS
    /// per ground, cm, and the recovery after each change, s.
    #[arg(long)]
    verbose: bool,
    /// Print the table as JSON.
    #[arg(long)]
    json: bool,
}

/// Control period of the follower, s (Nav2's controller at 20 Hz).
pub const PERIOD: f64 = 0.05;

/// The course of `grounds`, `laps` laps each.
pub fn course(grounds: &[String], laps: usize) -> Course {
    let names: Vec<&str> = grounds.iter().map(String::as_str).collect();
    Course::new(&names, laps)
}

/// Where the outage begins: the start of the last ground's last lap, m.
pub fn outage(course: &Course, laps: usize) -> Outage {
    let g = course.ground_s.len() - 1;
    let lap = (course.length() - 3.0 - course.ground_s[g]) / laps as f64;
    Outage {
        from_s: course.ground_s[g] + lap * (laps - 1) as f64,
        duration: OUTAGE_S,
    }
}

/// The settings of a run besides the seed.
pub struct Setup<'a> {
    pub grounds: &'a [String],
    /// Laps of the turn pattern per ground.
    pub laps: usize,
    pub estimator: &'a EstimatorConfig,
    /// The compensator's correction rate (per s) and engage delay (s).
    pub correction_rate: f64,
    pub engage_after: f64,
    /// Seconds after a detected slip change the estimate is not believed.
    pub hold_after_change: f64,
    /// Live compensation on a controller of multiplier 1 (else on the
    /// static variant's).
    pub live_on_untuned: bool,
    /// The receiver's error all white (no correlated part).
    pub uncorrelated_gnss: bool,
}

/// One seed: the turn-test multiplier and the score of each variant.
pub fn run_seed(
    setup: &Setup<'_>,
    variants: &[Variant],
    seed: u64,
) -> anyhow::Result<(f64, Vec<RunScore>)> {
    let (grounds, laps, cfg) = (setup.grounds, setup.laps, setup.estimator);
    let sc = world::scenario(grounds, seed, setup.uncorrelated_gnss)?;
    let course = course(grounds, laps);
    let pursuit = Pursuit::default();
    let multiplier = world::turn_test_multiplier(&sc, pursuit.desired_linear_vel, 2.0)?;
    let ground_map = |east: f64, _north: f64| course.ground_at(east);
    let max_duration = 4.0 * course.length() / pursuit.desired_linear_vel;
    let track_width = sc.robot.track_width;
    let mut scores = Vec::new();
    for &v in variants {
        let steering = match v {
            Variant::None => Steering::None,
            Variant::Static => Steering::Multiplier(multiplier),
            Variant::Live => {
                let m = if setup.live_on_untuned {
                    1.0
                } else {
                    multiplier
                };
                let mut c = CompensateConfig::new(track_width * m);
                c.max_correction_rate = setup.correction_rate;
                c.engage_after = setup.engage_after;
                let belief = Belief::new(CONFIDENT_SPREAD_STD, setup.hold_after_change);
                Steering::live(c, belief, m)?
            }
        };
        let mut f = Follower::new(
            &course,
            cfg,
            track_width,
            pursuit,
            steering,
            outage(&course, laps),
        )?;
        let run = simulate_closed_loop(&sc, &ground_map, 0.0, PERIOD, max_duration, &mut f, seed)?;
        if let Some(e) = f.error.take() {
            return Err(e).with_context(|| format!("seed {seed}, {}", v.name()));
        }
        scores.push(score::score(&course, &run.truth, f.finished));
    }
    Ok((multiplier, scores))
}

pub fn run(a: Args) -> anyhow::Result<()> {
    anyhow::ensure!(
        a.laps >= 2,
        "--laps {}: at least 2 (the error settles on the last)",
        a.laps
    );
    anyhow::ensure!(a.seeds >= 1, "--seeds: at least 1");
    anyhow::ensure!(
        a.hold_after_change.is_finite() && a.hold_after_change >= 0.0,
        "--hold-after-change {}: finite seconds >= 0",
        a.hold_after_change
    );
    anyhow::ensure!(!a.grounds.is_empty(), "--grounds: at least one");
    let (_, cfg) = crate::estimators::resolve(std::slice::from_ref(&a.estimator))?
        .into_iter()
        .next()
        .context("one estimator")?;
    let setup = Setup {
        grounds: &a.grounds,
        laps: a.laps,
        estimator: &cfg,
        correction_rate: a.correction_rate,
        engage_after: a.engage_after,
        hold_after_change: a.hold_after_change,
        live_on_untuned: a.live_on_untuned,
        uncorrelated_gnss: a.uncorrelated_gnss,
    };
    let mut runs = Vec::new();
    for seed in a.first_seed..a.first_seed + a.seeds {
        let (m, scores) = run_seed(&setup, &Variant::ALL, seed)?;
        if a.verbose {
            for (v, sc) in Variant::ALL.iter().zip(&scores) {
                let g: Vec<String> = sc
                    .grounds
                    .iter()
                    .map(|g| {
                        format!(
                            "{:5.1} ({:4.1} s)",
                            100.0 * g.cross_track_rms_m,
                            g.recovery_s
                        )
                    })
                    .collect();
                eprintln!("seed {seed:3} x{m:.3} {:6} {}", v.name(), g.join(" "));
            }
        }
        runs.push(table::SeedRuns {
            seed,
            multiplier: m,
            scores,
        });
    }
    let t = table::Table::new(&a.grounds, &runs);
    if a.json {
        println!("{}", serde_json::to_string_pretty(&t.to_json())?);
    } else {
        print!("{}", t.text());
    }
    Ok(())
}

#[cfg(test)]
mod tests;
