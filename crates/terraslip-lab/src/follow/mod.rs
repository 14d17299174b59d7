//! `terraslip-lab follow`: a regulated pure pursuit follower drives a
//! course of left and right turns over grounds of different slip, steering
//! on the online estimator's pose, in the closed-loop simulator; once with
//! its twist sent as it is, once through a static wheel separation
//! multiplier tuned on the first ground, once through live compensation
//! under the estimator's current model. Figures per ground against the
//! true pose, over a family of seeds: median and worst.

mod course;
mod driver;
mod pursuit;
mod score;
mod steering;
mod table;
mod world;

use anyhow::Context;
use terraslip::config::EstimatorConfig;
use terraslip_sim::closed_loop::simulate_closed_loop;

pub use course::Course;
use driver::{Follower, Outage};
use pursuit::Pursuit;
pub use score::RunScore;
use steering::Steering;

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
    /// Print the table as JSON.
    #[arg(long)]
    json: bool,
}

/// Control period of the follower, s (Nav2's controller at 20 Hz).
pub const PERIOD: f64 = 0.05;
/// Length of the GNSS outage, s.
pub const OUTAGE_S: f64 = 30.0;

/// How the follower's twist reaches the drive.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variant {
    /// As it is.
    None,
    /// Through a static multiplier from a turn test on the first ground.
    Static,
    /// Through live compensation under the estimator's model.
    Live,
}

impl Variant {
    pub const ALL: [Variant; 3] = [Variant::None, Variant::Static, Variant::Live];

    pub fn name(self) -> &'static str {
        match self {
            Variant::None => "none",
            Variant::Static => "static",
            Variant::Live => "live",
        }
    }
}

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

/// One seed: the turn-test multiplier and the score of each variant.
pub fn run_seed(
    grounds: &[String],
    laps: usize,
    cfg: &EstimatorConfig,
    variants: &[Variant],
    seed: u64,
) -> anyhow::Result<(f64, Vec<RunScore>)> {
    let sc = world::scenario(grounds, seed)?;
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
            Variant::Live => Steering::live(track_width)?,
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
    anyhow::ensure!(!a.grounds.is_empty(), "--grounds: at least one");
    let (_, cfg) = crate::estimators::resolve(std::slice::from_ref(&a.estimator))?
        .into_iter()
        .next()
        .context("one estimator")?;
    let mut runs = Vec::new();
    for seed in a.first_seed..a.first_seed + a.seeds {
        let (m, scores) = run_seed(&a.grounds, a.laps, &cfg, &Variant::ALL, seed)?;
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
