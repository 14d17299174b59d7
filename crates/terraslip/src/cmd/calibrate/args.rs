//! The calibrate command's options.

use std::path::PathBuf;

use serde::Serialize;
use terraslip_calib::RateModel;

use super::segment_args::SegmentArgs;
use super::validate;

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
    pub(super) command: Option<Sub>,
    #[arg(
        required_unless_present = "print_config",
        value_name = "LOG",
        help = concat!("One or more drives, each with a pose reference (terrain.csv labels give one parameter set per terrain). ", log_help!())
    )]
    #[serde(skip)]
    pub(super) logs: Vec<PathBuf>,
    /// Where to write the parameters (JSON, read by `estimate --init`).
    #[arg(long, value_name = "PARAMS", required_unless_present = "print_config")]
    #[serde(skip)]
    pub(super) out: Option<PathBuf>,
    /// Identification method; all three and keep the best if not given.
    #[arg(long, value_enum)]
    pub(super) method: Option<MethodArg>,
    /// Print the parameters file as one JSON object on stdout.
    #[arg(long)]
    #[serde(skip)]
    pub(super) json: bool,
    /// Also write a diff_drive_controller parameter file (ROS 2 YAML, one
    /// block per terrain) from the calibrated ICRs.
    #[cfg(feature = "ros2")]
    #[arg(long, value_name = "FILE.yaml")]
    #[serde(skip)]
    pub(super) ros2_params: Option<PathBuf>,
    /// Weight between metres and radians in eq. 13 (m/rad). Mandow et al. use 1.
    #[arg(long, default_value_t = 0.5, value_name = "M_PER_RAD")]
    pub(super) yaw_weight: f64,
    #[command(flatten)]
    #[serde(flatten)]
    pub(super) seg: SegmentArgs,
    /// Wheel/pose time offset: `auto` (searched per log within +-0.5 s, then
    /// +-0.15 s around that with the model) or seconds.
    #[arg(long, default_value = "auto", value_name = "auto|SECONDS")]
    pub(super) time_offset: String,
    /// GA random seed (same seed, same result).
    #[arg(long, default_value_t = 1)]
    pub(super) seed: u64,
    /// GA population size.
    #[arg(long, default_value_t = 48)]
    pub(super) population: usize,
    /// GA generations.
    #[arg(long, default_value_t = 100)]
    pub(super) generations: usize,
    /// GA bits per gene (the paper: 8); real-coded if not given.
    #[arg(long)]
    pub(super) gene_bits: Option<u32>,
    /// GA gene bound, repeatable: NAME=LOW:HIGH with NAME one of y_l, y_r,
    /// x_c, alpha_l, alpha_r (default: scaled by the track width).
    #[arg(long = "bound", value_name = "NAME=LOW:HIGH")]
    #[serde(rename = "bound")]
    pub(super) bounds: Vec<String>,
    /// Worker threads for the GA (default: all cores).
    #[arg(long)]
    pub(super) threads: Option<usize>,
    /// Segments beyond this many robust sigmas are dropped as outliers.
    #[arg(long, default_value_t = 5.0)]
    pub(super) outlier_sigmas: f64,
    /// Cauchy loss scale in robust sigmas (e.g. 2.385); trimmed least squares if not given.
    #[arg(long)]
    pub(super) cauchy: Option<f64>,
    /// Fewest usable moving segments per set.
    #[arg(long, default_value_t = 10)]
    pub(super) min_segments: usize,
    /// Position-only references (GNSS fixes without a heading): length of
    /// the windows of fixes the model's path is fitted on, s (a new window
    /// every half of it).
    #[arg(long, default_value_t = 20.0, value_name = "S")]
    pub(super) window: f64,
    /// When the data cannot identify some parameters (e.g. the robot never
    /// turns), keep those at their no-slip values and list them under
    /// `unidentified` instead of failing.
    #[arg(long)]
    pub(super) allow_partial: bool,
    /// Turn-rate dependent ICR model next to the constant one: `auto`
    /// (kept when it lowers the information criterion), `on` (kept when
    /// its slopes are identified) or `off`.
    #[arg(long, value_enum, default_value = "auto")]
    pub(super) rate_model: RateArg,
    /// Traction term on top of the turn-rate model (both speed factors
    /// scale by `1 - k_acc |a|`, `a` the tread acceleration): `auto` (kept
    /// when it lowers the information criterion further), `on` (kept when
    /// identified) or `off`.
    #[arg(long, value_enum, default_value = "auto")]
    pub(super) traction: RateArg,
    /// Let the traction term differ between accelerating and braking
    /// (adds `k_dir`: the factors scale by `1 - k_acc |a| - k_dir a`).
    #[arg(long)]
    pub(super) traction_signed: bool,
    /// Centripetal terms on top of the selected model (x_c moves by
    /// `k_x_speed` s per m/s of mean tread speed `v`, the spread scales by
    /// `1 + k_spread_speed |v|`): `auto` (kept when they lower the
    /// information criterion further), `on` (kept when identified) or `off`.
    #[arg(long, value_enum, default_value = "auto")]
    pub(super) centripetal: RateArg,
    /// Reduced constant models where no variable model is selected:
    /// symmetric ICRs (`y_r = -y_l`), `x_c` at 0, equal speed factors, and
    /// their combinations, each tried when the full fit leaves a parameter
    /// it removes unresolved (1-sigma over 0.05 m, 0.01 for a speed
    /// factor). `auto` keeps the one of lowest information criterion and
    /// profiles the time offset again with it (a short drive holds the
    /// relations it cannot resolve); `off` fits all five.
    #[arg(long, value_enum, default_value = "auto")]
    pub(super) reduced_models: ReducedArg,
    /// Fit segments overlap, each lasting --min-segment: one starts at every
    /// pose where an earlier one ended, and at the first pose at least this
    /// many seconds after the previous start (0: at every pose, the
    /// default). `validate` always scores chained segments.
    #[arg(long, default_value_t = 0.0, value_name = "S")]
    pub(super) stride: f64,
    /// Fit on chained segments only (each starting where the previous one
    /// ended), as `validate` scores.
    #[arg(long)]
    pub(super) chained: bool,
    /// Print the settings in effect (the defaults and the flags given) as
    /// TOML on stdout, each key named after its flag and preceded by the
    /// flag's documentation, and exit.
    #[arg(long)]
    #[serde(skip)]
    pub(super) print_config: bool,
}

#[derive(clap::ValueEnum, Clone, Copy, Serialize)]
#[serde(rename_all = "kebab-case")]
pub(super) enum RateArg {
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
pub(super) enum ReducedArg {
    Off,
    Auto,
}

#[derive(clap::ValueEnum, Clone, Copy, Serialize)]
#[serde(rename_all = "kebab-case")]
pub(super) enum MethodArg {
    Lm,
    Ga,
    Symmetric,
}

#[derive(clap::Subcommand)]
pub(super) enum Sub {
    /// Score parameters on other drives against the no-slip model (meta.toml
    /// track_width), per segment: mean squared dx, dy (m^2) and dyaw (rad^2)
    /// in the frame of each segment start, like Mandow et al.'s Table III.
    ///
    ///   terraslip calibrate validate drive/ --params p.json --json
    Validate(validate::ValidateArgs),
}
