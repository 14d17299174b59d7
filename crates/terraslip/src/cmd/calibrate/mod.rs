//! `terraslip calibrate`: offline identification of the ICR kinematic
//! parameters, and `terraslip calibrate validate`: scoring them on other drives.

use std::path::PathBuf;

use anyhow::{bail, Context};
use serde::Serialize;
use terraslip_calib::model::PARAM_NAMES;
use terraslip_calib::{
    calibrate, CalibConfig, Method, OffsetChoice, Progress, RateModel, TimeOffset,
};
use terraslip_io::DriveLog;

use crate::progress;

mod print_config;
mod summary;
mod validate;

const AFTER_HELP: &str = "\
How it works: each drive is cut into segments between pose observations at
least --min-segment s apart; the ICR model is integrated over the wheel
samples of each segment and compared with the reference increment in the
frame of the segment start (Mandow et al. 2007, eq. 13, heading errors
weighted by --yaw-weight m/rad). The wheel/pose time offset is estimated per
log; held, mistimed and jumping poses are dropped; outlier segments are
dropped and listed in the output. With terrain.csv: one set per terrain.

Position-only references (GNSS fixes and no heading, as in most ROS 2 bags):
the model's path over --window s of fixes is placed on them by the rotation
and translation that fit best (the start heading and position of each window
are left free), and the ICRs are fitted to what remains: the path's length
(speed factors) and bend (spread). Only lm applies; x_c and the ICRs' centre
are held at 0 when the fixes do not pin them down.

Methods: lm (robust Levenberg-Marquardt from the no-slip model, with 1-sigma
uncertainties), ga (Mandow's genetic algorithm; --seed, --population,
--generations, --gene-bits, --bound), symmetric (eqs. 11-12 from spins in
place and straight runs). Without --method all three run, the best is written.

Past the paper: a turn-rate dependent model (--rate-model, default auto)
whose ICR spread and speed factors change with the tread speed difference
is fitted next to the constant one and kept under `rate_model` when it
lowers the information criterion; on top of it a traction term
(--traction, default auto) lowers both speed factors by k_acc per m/s^2 of
tread acceleration, kept by the same criterion; on top of the selected
model the centripetal terms (--centripetal, default auto) move x_c by
k_x_speed per m/s of speed (a lateral slip on v*omega, as DRIVE's learned
model has) and scale the spread by 1 + k_spread_speed |v| (a yaw slip on
v*omega), kept by the same criterion. Where none is kept, reduced
constant sets (--reduced-models, default auto: symmetric ICRs, x_c at 0,
equal speed factors) hold what a short drive does not resolve, kept by
the same criterion and written as a full set under `reduction`.
`calibrate validate` scores the
variable model where it was selected (--model constant scores the constant
one) and reports both.

The output (JSON) is what `terraslip estimate --init` reads; it also holds
chi, e, uncertainties, the time offset, dropped segments and, for a Pioneer,
Ticksmm/Revcount. A drive that never turns cannot identify y_l, y_r, x_c:
that is an error unless --allow-partial.

Examples:
  terraslip calibrate drive1/ drive2/ --out params.json
  terraslip calibrate drive/ --t-max 300 --out first-half.json --method ga --seed 7
  terraslip calibrate validate drive/ --t-min 300 --params first-half.json --plot v.svg";

/// `terraslip calibrate LOG... --out PARAMS` and its `validate` subcommand;
/// the user-facing text is in [`AFTER_HELP`] and the variant's doc in main.rs.
// Serialize: `--print-config` prints the settings, keyed by their flags.
#[derive(clap::Args, Serialize)]
#[serde(rename_all = "kebab-case")]
#[command(
    args_conflicts_with_subcommands = true,
    subcommand_negates_reqs = true,
    after_help = AFTER_HELP
)]
pub struct Args {
    #[command(subcommand)]
    #[serde(skip)]
    command: Option<Sub>,
    #[arg(
        required_unless_present = "print_config",
        value_name = "LOG",
        help = concat!("One or more drives, each with a pose reference (terrain.csv labels give one parameter set per terrain). ", log_help!())
    )]
    #[serde(skip)]
    logs: Vec<PathBuf>,
    /// Where to write the parameters (JSON, read by `estimate --init`).
    #[arg(long, value_name = "PARAMS", required_unless_present = "print_config")]
    #[serde(skip)]
    out: Option<PathBuf>,
    /// Identification method; all three and keep the best if not given.
    #[arg(long, value_enum)]
    method: Option<MethodArg>,
    /// Print the parameters file as one JSON object on stdout.
    #[arg(long)]
    #[serde(skip)]
    json: bool,
    /// Also write a diff_drive_controller parameter file (ROS 2 YAML, one
    /// block per terrain) from the calibrated ICRs.
    #[cfg(feature = "ros2")]
    #[arg(long, value_name = "FILE.yaml")]
    #[serde(skip)]
    ros2_params: Option<PathBuf>,
    /// Weight between metres and radians in eq. 13 (m/rad). Mandow et al. use 1.
    #[arg(long, default_value_t = 0.5, value_name = "M_PER_RAD")]
    yaw_weight: f64,
    #[command(flatten)]
    #[serde(flatten)]
    seg: SegmentArgs,
    /// Wheel/pose time offset: `auto` (searched per log within +-0.5 s, then
    /// +-0.15 s around that with the model) or seconds.
    #[arg(long, default_value = "auto", value_name = "auto|SECONDS")]
    time_offset: String,
    /// GA random seed (same seed, same result).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// GA population size.
    #[arg(long, default_value_t = 48)]
    population: usize,
    /// GA generations.
    #[arg(long, default_value_t = 100)]
    generations: usize,
    /// GA bits per gene (the paper: 8); real-coded if not given.
    #[arg(long)]
    gene_bits: Option<u32>,
    /// GA gene bound, repeatable: NAME=LOW:HIGH with NAME one of y_l, y_r,
    /// x_c, alpha_l, alpha_r (default: scaled by the track width).
    #[arg(long = "bound", value_name = "NAME=LOW:HIGH")]
    #[serde(rename = "bound")]
    bounds: Vec<String>,
    /// Worker threads for the GA (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Segments beyond this many robust sigmas are dropped as outliers.
    #[arg(long, default_value_t = 5.0)]
    outlier_sigmas: f64,
    /// Cauchy loss scale in robust sigmas (e.g. 2.385); trimmed least squares if not given.
    #[arg(long)]
    cauchy: Option<f64>,
    /// Fewest usable moving segments per set.
    #[arg(long, default_value_t = 10)]
    min_segments: usize,
    /// Position-only references (GNSS fixes without a heading): length of
    /// the windows of fixes the model's path is fitted on, s (a new window
    /// every half of it).
    #[arg(long, default_value_t = 20.0, value_name = "S")]
    window: f64,
    /// When the data cannot identify some parameters (e.g. the robot never
    /// turns), keep those at their no-slip values and list them under
    /// `unidentified` instead of failing.
    #[arg(long)]
    allow_partial: bool,
    /// Turn-rate dependent ICR model next to the constant one: `auto`
    /// (kept when it lowers the information criterion), `on` (kept when
    /// its slopes are identified) or `off`.
    #[arg(long, value_enum, default_value = "auto")]
    rate_model: RateArg,
    /// Traction term on top of the turn-rate model (both speed factors
    /// scale by `1 - k_acc |a|`, `a` the tread acceleration): `auto` (kept
    /// when it lowers the information criterion further), `on` (kept when
    /// identified) or `off`.
    #[arg(long, value_enum, default_value = "auto")]
    traction: RateArg,
    /// Let the traction term differ between accelerating and braking
    /// (adds `k_dir`: the factors scale by `1 - k_acc |a| - k_dir a`).
    #[arg(long)]
    traction_signed: bool,
    /// Centripetal terms on top of the selected model (x_c moves by
    /// `k_x_speed` s per m/s of mean tread speed `v`, the spread scales by
    /// `1 + k_spread_speed |v|`): `auto` (kept when they lower the
    /// information criterion further), `on` (kept when identified) or `off`.
    #[arg(long, value_enum, default_value = "auto")]
    centripetal: RateArg,
    /// Reduced constant models where no variable model is selected:
    /// symmetric ICRs (`y_r = -y_l`), `x_c` at 0, equal speed factors, and
    /// their combinations, each tried when the full fit leaves a parameter
    /// it removes unresolved (1-sigma over 0.05 m, 0.01 for a speed
    /// factor). `auto` keeps the one of lowest information criterion and
    /// profiles the time offset again with it (a short drive holds the
    /// relations it cannot resolve); `off` fits all five.
    #[arg(long, value_enum, default_value = "auto")]
    reduced_models: ReducedArg,
    /// Fit segments overlap, each lasting --min-segment: one starts at every
    /// pose where an earlier one ended, and at the first pose at least this
    /// many seconds after the previous start (0: at every pose, the
    /// default). `validate` always scores chained segments.
    #[arg(long, default_value_t = 0.0, value_name = "S")]
    stride: f64,
    /// Fit on chained segments only (each starting where the previous one
    /// ended), as `validate` scores.
    #[arg(long)]
    chained: bool,
    /// Print the settings in effect (the defaults and the flags given) as
    /// TOML on stdout, each key named after its flag and preceded by the
    /// flag's documentation, and exit.
    #[arg(long)]
    #[serde(skip)]
    print_config: bool,
}

#[derive(clap::ValueEnum, Clone, Copy, Serialize)]
#[serde(rename_all = "kebab-case")]
enum RateArg {
    Off,
    Auto,
    On,
}

impl From<RateArg> for RateModel {
    fn from(a: RateArg) -> Self {
        match a {
            RateArg::Off => RateModel::Off,
            RateArg::Auto => RateModel::Auto,
            RateArg::On => RateModel::On,
        }
    }
}

#[derive(clap::ValueEnum, Clone, Copy, Serialize)]
#[serde(rename_all = "kebab-case")]
enum ReducedArg {
    Off,
    Auto,
}

/// Segment selection shared by calibrate and validate.
#[derive(clap::Args, Clone, Serialize)]
#[serde(rename_all = "kebab-case")]
struct SegmentArgs {
    /// Shortest segment between pose observations, s.
    #[arg(long, default_value_t = 1.0, value_name = "S")]
    min_segment: f64,
    /// Only use poses at or after this time (log clock, s): for time splits.
    #[arg(long, value_name = "S")]
    t_min: Option<f64>,
    /// Only use poses at or before this time (log clock, s).
    #[arg(long, value_name = "S")]
    t_max: Option<f64>,
    /// Keep segments whose reference the treads cannot have produced
    /// (stalled or jumping poses) and poses stamped at the wrong time; both
    /// are dropped by default, alike for every model scored.
    #[arg(long)]
    no_gate: bool,
}

impl SegmentArgs {
    fn config(&self) -> anyhow::Result<terraslip_calib::SegmentConfig> {
        if !(self.min_segment.is_finite() && self.min_segment > 0.0) {
            bail!("--min-segment must be a positive number of seconds");
        }
        let mut c = terraslip_calib::SegmentConfig {
            min_duration: self.min_segment,
            max_duration: (3.0f64).max(3.0 * self.min_segment),
            reference_gate: !self.no_gate,
            drop_mistimed: !self.no_gate,
            ..Default::default()
        };
        if let Some(t) = self.t_min {
            c.t_min = t;
        }
        if let Some(t) = self.t_max {
            c.t_max = t;
        }
        Ok(c)
    }
}

#[derive(clap::ValueEnum, Clone, Copy, Serialize)]
#[serde(rename_all = "kebab-case")]
enum MethodArg {
    Lm,
    Ga,
    Symmetric,
}

#[derive(clap::Subcommand)]
enum Sub {
    /// Score parameters on other drives against the no-slip model (meta.toml
    /// track_width), per segment: mean squared dx, dy (m^2) and dyaw (rad^2)
    /// in the frame of each segment start, like Mandow et al.'s Table III.
    ///
    ///   terraslip calibrate validate drive/ --params p.json --json
    Validate(validate::ValidateArgs),
}

/// Reads the logs; a bag without a pose reference is refused naming its
/// topics (a log directory's is told by the calibration).
fn read_logs(paths: &[PathBuf]) -> anyhow::Result<Vec<DriveLog>> {
    let read = |p: &PathBuf| {
        let log = super::bag::read_full(p)?;
        if log.pose.is_empty() {
            if let Some(topics) = super::bag::bag_topics(p) {
                bail!(
                    "{}: no pose reference among its topics ({topics}); calibration needs \
                     positions: sensor_msgs/NavSatFix or a pose (Odometry, PoseStamped, \
                     PoseWithCovarianceStamped); an IMU heading helps only beside them",
                    p.display()
                );
            }
        }
        Ok(log)
    };
    paths.iter().map(read).collect()
}

fn parse_bound(s: &str) -> anyhow::Result<(usize, (f64, f64))> {
    let err = || format!("--bound `{s}`: expected NAME=LOW:HIGH, e.g. y_l=0.1:1.5");
    let (name, range) = s.split_once('=').with_context(err)?;
    let k = PARAM_NAMES
        .iter()
        .position(|n| *n == name.trim())
        .with_context(|| {
            format!(
                "--bound `{s}`: unknown parameter `{name}` (one of {})",
                PARAM_NAMES.join(", ")
            )
        })?;
    let (lo, hi) = range.split_once(':').with_context(err)?;
    let (lo, hi): (f64, f64) = (
        lo.trim().parse().ok().with_context(err)?,
        hi.trim().parse().ok().with_context(err)?,
    );
    if !(lo.is_finite() && hi.is_finite() && lo < hi) {
        bail!("--bound `{s}`: need finite LOW < HIGH");
    }
    Ok((k, (lo, hi)))
}

/// `--time-offset`: `auto` (searched within +-0.5 s), seconds, or `params`
/// where `accepted` (the wording of the error) offers it.
fn parse_offset(s: &str, accepted: &str) -> anyhow::Result<OffsetChoice> {
    match s {
        "params" if accepted.contains("params") => Ok(OffsetChoice::FromParams),
        "auto" => Ok(OffsetChoice::Auto {
            max: 0.5,
            step: 0.01,
        }),
        s => s
            .parse::<f64>()
            .ok()
            .filter(|x| x.is_finite())
            .map(OffsetChoice::Fixed)
            .with_context(|| format!("--time-offset `{s}`: expected {accepted}")),
    }
}

fn config(a: &Args) -> anyhow::Result<CalibConfig> {
    let mut c = CalibConfig {
        segment: a.seg.config()?,
        method: a.method.map(|m| match m {
            MethodArg::Lm => Method::Lm,
            MethodArg::Ga => Method::Ga,
            MethodArg::Symmetric => Method::Symmetric,
        }),
        min_segments: a.min_segments.max(3),
        allow_partial: a.allow_partial,
        rate_model: a.rate_model.into(),
        traction: a.traction.into(),
        traction_signed: a.traction_signed,
        centripetal: a.centripetal.into(),
        reduced_models: matches!(a.reduced_models, ReducedArg::Auto),
        ..Default::default()
    };
    if !(a.stride.is_finite() && a.stride >= 0.0) {
        bail!("--stride must be a non-negative number of seconds");
    }
    c.segment.overlap = (!a.chained).then_some(a.stride);
    if !(a.window.is_finite() && a.window > 0.0) {
        bail!("--window must be a positive number of seconds");
    }
    c.track.window = a.window;
    c.track.stride = 0.5 * a.window;
    if !(a.yaw_weight.is_finite() && a.yaw_weight > 0.0) {
        bail!("--yaw-weight must be a positive number (m/rad)");
    }
    c.yaw_weight = a.yaw_weight;
    c.time_offset = match parse_offset(&a.time_offset, "`auto` or seconds")? {
        OffsetChoice::Auto { max, step } => TimeOffset::Auto { max, step },
        OffsetChoice::Fixed(o) => TimeOffset::Fixed(o),
        OffsetChoice::FromParams => bail!("--time-offset params: only `validate` has parameters"),
    };
    c.lm.outlier_sigmas = a.outlier_sigmas;
    c.lm.cauchy_c = a.cauchy.unwrap_or(f64::INFINITY);
    c.ga.seed = a.seed;
    c.ga.population = a.population.max(4);
    c.ga.generations = a.generations;
    c.ga.gene_bits = a.gene_bits;
    c.ga.threads = a.threads;
    if !a.bounds.is_empty() {
        let mut b = [(0.0, 0.0); 5];
        let mut given = [false; 5];
        for s in &a.bounds {
            let (k, r) = parse_bound(s)?;
            b[k] = r;
            given[k] = true;
        }
        if given.iter().any(|g| !g) {
            bail!(
                "--bound: give all five bounds ({}) or none",
                PARAM_NAMES.join(", ")
            );
        }
        c.ga.bounds = Some(b);
    }
    Ok(c)
}

pub fn run(args: Args) -> anyhow::Result<()> {
    if let Some(Sub::Validate(v)) = args.command {
        return validate::run(v);
    }
    let cfg = config(&args)?;
    if args.print_config {
        print!("{}", print_config::documented_toml(&args)?);
        return Ok(());
    }
    let out = args.out.clone().context("--out PARAMS is required")?;
    let inputs = super::inputs_with(&args.logs, &[]);
    inputs.check("--out", &out)?;
    #[cfg(feature = "ros2")]
    if let Some(p) = &args.ros2_params {
        inputs.check("--ros2-params", p)?;
        terraslip_io::Outputs::new()
            .file("--out", &out)?
            .file("--ros2-params", p)?;
    }
    let mut logs = read_logs(&args.logs)?;
    // Fixes of a reference off the axle, moved onto it: x_c is slip only.
    for log in &mut logs {
        if let Some(w) = terraslip_calib::lever_arm::move_fixes_to_axle(log) {
            eprintln!("warning: {w}");
        }
    }
    let bar = progress::Progress::new(0, "generations");
    let cal = calibrate(&logs, &cfg, &|p| match p {
        Progress::Stage(s) => bar.set_message(format!("calibrate: {s}")),
        Progress::Generation { done, total } => {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
        }
    })
    .context("calibration failed")?;
    bar.finish();
    for w in &cal.warnings {
        eprintln!("warning: {w}");
    }
    for s in &cal.sets {
        summary::print_set(s);
    }
    let mut pf = cal.params_file();
    if let Some(scale) = logs.first().and_then(|l| l.meta.separation_note()) {
        pf.extra.insert("separation".into(), scale);
    }
    if let Some(m) = logs.first().and_then(|l| l.meta.pose) {
        pf.extra.insert(
            "pose_lever_arm_m".into(),
            serde_json::json!({"x": m.lever_arm_x, "y": m.lever_arm_y, "source": "stated"}),
        );
    }
    pf.write(&out)
        .with_context(|| format!("writing {}", out.display()))?;
    eprintln!("wrote {}", out.display());
    #[cfg(feature = "ros2")]
    if let Some(p) = &args.ros2_params {
        super::ros2out::write_params(p, &pf, &logs, |l, f| {
            terraslip::validation::prediction(l, f).map(|s| s.stats.rmse_m)
        })?;
    }
    if args.json {
        println!("{}", serde_json::to_string(&pf)?);
    }
    Ok(())
}
