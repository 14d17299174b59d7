//! `terraslip calibrate`: offline identification of the ICR kinematic
//! parameters, and `terraslip calibrate validate`: scoring them on other drives.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use indicatif::{ProgressBar, ProgressStyle};
use terraslip_calib::model::PARAM_NAMES;
use terraslip_calib::{
    calibrate, validate, CalibConfig, Method, ModelChoice, OffsetChoice, Progress, RateModel,
    TimeOffset, ValidateConfig, Validation,
};
use terraslip_io::{DriveLog, ParamsFile};
use terraslip_report::{Figure, LinePlot, Series, SeriesStyle};

const AFTER_HELP: &str = "\
How it works: each drive is cut into segments between pose observations at
least --min-segment s apart; the ICR model is integrated over the wheel
samples of each segment and compared with the reference increment in the
frame of the segment start (Mandow et al. 2007, eq. 13, heading errors
weighted by --yaw-weight m/rad). The wheel/pose time offset is estimated per
log; held, mistimed and jumping poses are dropped; outlier segments are
dropped and listed in the output. With terrain.csv: one set per terrain.

Methods: lm (robust Levenberg-Marquardt from the no-slip model, with 1-sigma
uncertainties), ga (Mandow's genetic algorithm; --seed, --population,
--generations, --gene-bits, --bound), symmetric (eqs. 11-12 from spins in
place and straight runs). Without --method all three run, the best is written.

Past the paper: a turn-rate dependent model (--rate-model, default auto)
whose ICR spread and speed factors change with the tread speed difference
is fitted next to the constant one and kept under `rate_model` when it
lowers the information criterion; on top of it a traction term
(--traction, default auto) lowers both speed factors by k_acc per m/s^2 of
tread acceleration, kept by the same criterion. `estimate --init` reads the constant
`params`, `calibrate validate` scores the rate model where it was selected
(--model constant scores the constant one) and reports both.

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
#[derive(clap::Args)]
#[command(
    args_conflicts_with_subcommands = true,
    subcommand_negates_reqs = true,
    after_help = AFTER_HELP
)]
pub struct Args {
    #[command(subcommand)]
    command: Option<Sub>,
    /// Log directories (wheels.csv + pose.csv, optional terrain.csv, meta.toml).
    #[arg(required = true, value_name = "LOG")]
    logs: Vec<PathBuf>,
    /// Where to write the parameters (JSON, read by `estimate --init`).
    #[arg(long, value_name = "PARAMS", required = true)]
    out: Option<PathBuf>,
    /// Identification method; all three and keep the best if not given.
    #[arg(long, value_enum)]
    method: Option<MethodArg>,
    /// Print the parameters file as one JSON object on stdout.
    #[arg(long)]
    json: bool,
    /// Weight between metres and radians in eq. 13 (m/rad). Mandow et al. use 1.
    #[arg(long, default_value_t = 0.5, value_name = "M_PER_RAD")]
    yaw_weight: f64,
    #[command(flatten)]
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
    /// Fit segments overlap, each lasting --min-segment: one starts at every
    /// pose where an earlier one ended, and at the first pose at least this
    /// many seconds after the previous start (0: at every pose, the
    /// default). `validate` always scores chained segments.
    #[arg(long, default_value_t = 0.0, value_name = "S")]
    stride: f64,
    /// Fit on chained segments only (each starting where the previous one
    /// ended), as `validate` scores and as before the overlapping fit.
    #[arg(long)]
    chained: bool,
    /// Print the configuration used to stderr.
    #[arg(long)]
    print_config: bool,
}

#[derive(clap::ValueEnum, Clone, Copy)]
enum RateArg {
    Off,
    Auto,
    On,
}

#[derive(clap::ValueEnum, Clone, Copy)]
enum ModelArg {
    /// The turn-rate model where calibration selected one, else constant.
    Params,
    /// The constant ICRs (Mandow's five parameters).
    Constant,
}

/// Segment selection shared by calibrate and validate.
#[derive(clap::Args, Clone)]
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

#[derive(clap::ValueEnum, Clone, Copy)]
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
    Validate(ValidateArgs),
}

#[derive(clap::Args)]
struct ValidateArgs {
    #[arg(required = true, value_name = "LOG")]
    logs: Vec<PathBuf>,
    /// Parameters file written by `terraslip calibrate`.
    #[arg(long, required = true, value_name = "PARAMS")]
    params: PathBuf,
    /// Print one JSON object on stdout.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    seg: SegmentArgs,
    /// Wheel/pose time offset: `params` (stored at calibration), `auto`
    /// (estimated on these logs, without any model parameter) or seconds.
    #[arg(long, default_value = "params", value_name = "params|auto|SECONDS")]
    time_offset: String,
    /// Which model to score as `calibrated`: `params` (the turn-rate model
    /// where the file has one selected, else the constant ICRs) or
    /// `constant`. The constant model's scores are reported either way.
    #[arg(long, value_enum, default_value = "params")]
    model: ModelArg,
    /// Draw predicted vs reference segments into this SVG file.
    #[arg(long, value_name = "SVG")]
    plot: Option<PathBuf>,
}

fn read_logs(paths: &[PathBuf]) -> anyhow::Result<Vec<DriveLog>> {
    paths
        .iter()
        .map(|p| DriveLog::read(p).with_context(|| format!("reading log {}", p.display())))
        .collect()
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
        rate_model: match a.rate_model {
            RateArg::Off => RateModel::Off,
            RateArg::Auto => RateModel::Auto,
            RateArg::On => RateModel::On,
        },
        traction: match a.traction {
            RateArg::Off => RateModel::Off,
            RateArg::Auto => RateModel::Auto,
            RateArg::On => RateModel::On,
        },
        traction_signed: a.traction_signed,
        ..Default::default()
    };
    if !(a.stride.is_finite() && a.stride >= 0.0) {
        bail!("--stride must be a non-negative number of seconds");
    }
    c.segment.overlap = (!a.chained).then_some(a.stride);
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

fn fmt_std(s: f64) -> String {
    if s.is_finite() {
        format!("{s:.4}")
    } else {
        "-".into()
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    if let Some(Sub::Validate(v)) = args.command {
        return run_validate(v);
    }
    let out = args.out.clone().context("--out PARAMS is required")?;
    let cfg = config(&args)?;
    if args.print_config {
        eprintln!("{cfg:#?}");
    }
    let logs = read_logs(&args.logs)?;
    let bar = ProgressBar::new_spinner();
    bar.set_style(
        ProgressStyle::with_template("{spinner} {msg} [{bar:30}] {pos}/{len}")
            .unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    let cal = calibrate(&logs, &cfg, &|p| match p {
        Progress::Stage(s) => bar.set_message(s.to_string()),
        Progress::Generation { done, total } => {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
        }
    })
    .context("calibration failed")?;
    bar.finish_and_clear();
    for w in &cal.warnings {
        eprintln!("warning: {w}");
    }
    for s in &cal.sets {
        let name = s.terrain.as_deref().unwrap_or("all terrains");
        eprintln!(
            "[{name}] {} segments used, {} dropped as outliers (sigma {:.3} m), {} stationary, {} implausible references; {} held and {} mistimed poses dropped; time offset {}",
            s.segments_used,
            s.dropped.len(),
            s.sigma,
            s.stats.stationary,
            s.stats.implausible,
            s.stats.stale_poses,
            s.stats.mistimed_poses,
            s.time_offsets
                .iter()
                .map(|(n, o)| format!("{n}: {o:+.3} s"))
                .collect::<Vec<_>>()
                .join(", ")
        );
        eprintln!("  method      cost(eq.13)      y_l      y_r      x_c  alpha_l  alpha_r");
        for f in &s.fits {
            let p = f.params;
            eprintln!(
                "  {:9} {:12.4} {:8.4} {:8.4} {:8.4} {:8.4} {:8.4}{}",
                f.method.name(),
                f.cost,
                p.y_l,
                p.y_r,
                p.x_c,
                p.alpha_l,
                p.alpha_r,
                if f.method == s.best.method {
                    "  <- best"
                } else {
                    ""
                }
            );
        }
        eprintln!(
            "  1-sigma     {:>12} {:>8} {:>8} {:>8} {:>8} {:>8}",
            "",
            fmt_std(s.best.std[0]),
            fmt_std(s.best.std[1]),
            fmt_std(s.best.std[2]),
            fmt_std(s.best.std[3]),
            fmt_std(s.best.std[4])
        );
        if let Some(chi) = s.chi() {
            eprintln!(
                "  steering efficiency chi = {chi:.3}, eccentricity e = {:.3}",
                s.best.params.eccentricity()
            );
        }
        if s.pioneer {
            match s.pioneer_settings() {
                Some((t, r)) => {
                    eprintln!("  Pioneer server settings: Ticksmm = {t}, Revcount = {r}")
                }
                None => eprintln!("  Pioneer settings need wheel_radius in meta.toml"),
            }
        }
        for n in &s.notes {
            eprintln!("  note: {n}");
        }
        if let Some(r) = &s.rate {
            let f = &r.fit;
            eprintln!(
                "  turn-rate model: k_spread {:.4} +- {} s/m, k_alpha {:.4} +- {} s/m, BIC {:.1} vs constant {:.1}: {}",
                f.slopes.k_spread,
                fmt_std(f.std[5]),
                f.slopes.k_alpha,
                fmt_std(f.std[6]),
                r.bic_rate,
                r.bic_constant,
                match &r.reason {
                    None if r.traction_selected => "superseded by the traction model".to_string(),
                    None => "selected".to_string(),
                    Some(why) => format!("not selected, {why}"),
                }
            );
            if let Some((t, bic)) = &r.traction {
                eprintln!(
                    "  traction term: k_acc {:.4} +- {} s^2/m, k_dir {:.4} +- {} s^2/m, BIC {:.1}: {}",
                    t.slopes.k_acc,
                    fmt_std(t.std[7]),
                    t.slopes.k_dir,
                    fmt_std(t.std[8]),
                    bic,
                    match &r.traction_reason {
                        None => "selected".to_string(),
                        Some(why) => format!("not selected, {why}"),
                    }
                );
            }
        }
        if !s.unidentified.is_empty() {
            eprintln!(
                "  warning: not identified by this data: {}",
                s.unidentified.join(", ")
            );
        }
    }
    let pf = cal.params_file();
    pf.write(&out)
        .with_context(|| format!("writing {}", out.display()))?;
    eprintln!("wrote {}", out.display());
    if args.json {
        println!("{}", serde_json::to_string(&pf)?);
    }
    Ok(())
}

fn run_validate(a: ValidateArgs) -> anyhow::Result<()> {
    let params = ParamsFile::read(&a.params)
        .with_context(|| format!("reading parameters {}", a.params.display()))?;
    let cfg = ValidateConfig {
        segment: a.seg.config()?,
        time_offset: parse_offset(&a.time_offset, "`params`, `auto` or seconds")?,
        model: match a.model {
            ModelArg::Params => ModelChoice::FromParams,
            ModelArg::Constant => ModelChoice::Constant,
        },
    };
    let logs = read_logs(&a.logs)?;
    let v = validate(&logs, &params, &cfg).context("validation failed")?;
    let ratio = |n: f64, c: f64| if c > 0.0 { n / c } else { f64::INFINITY };
    eprintln!(
        "{} segments ({} stationary skipped, {} implausible references dropped, {} held and {} mistimed poses dropped, {} without parameters); time offset {}",
        v.segments.len(),
        v.stats.stationary,
        v.stats.implausible,
        v.stats.stale_poses,
        v.stats.mistimed_poses,
        v.no_params,
        v.offsets
            .iter()
            .map(|o| format!("{o:+.3} s"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    eprintln!("                 dx [m^2]   dy [m^2]  dyaw [rad^2]");
    eprintln!(
        "  calibrated   {:10.5} {:10.5} {:10.5}",
        v.mse.dx, v.mse.dy, v.mse.dyaw
    );
    if v.rate_segments > 0 {
        eprintln!(
            "  constant     {:10.5} {:10.5} {:10.5}   (the calibrated row uses the turn-rate model on {} segments)",
            v.constant_mse.dx, v.constant_mse.dy, v.constant_mse.dyaw, v.rate_segments
        );
    }
    eprintln!(
        "  no-slip      {:10.5} {:10.5} {:10.5}",
        v.nominal_mse.dx, v.nominal_mse.dy, v.nominal_mse.dyaw
    );
    eprintln!(
        "  position MSE ratio no-slip / calibrated = {:.2}",
        ratio(v.nominal_mse.position(), v.mse.position())
    );
    if v.rate_segments > 0 {
        eprintln!(
            "  position MSE ratio no-slip / constant   = {:.2}",
            ratio(v.nominal_mse.position(), v.constant_mse.position())
        );
    }
    for (t, (n, m, nm)) in &v.per_terrain {
        eprintln!(
            "  [{t}] {n} segments: position MSE {:.4} vs no-slip {:.4} ({:.2}x)",
            m.position(),
            nm.position(),
            ratio(nm.position(), m.position())
        );
    }
    // The 2 s prediction error, as `estimate` reports it: the parameters of
    // the terrain in effect (or the pooled set) held over each 2 s.
    let prediction = terraslip::validation::prediction(&logs, &params);
    if let Some(p) = &prediction {
        eprintln!(
            "  2 s prediction: {} segments, mean {:.3} m (no-slip {:.3} m), p90 {:.3} m",
            p.segments.len(),
            p.stats.mean_m,
            p.no_slip.mean_m,
            p.stats.p90_m
        );
    }
    if let Some(path) = &a.plot {
        plot_validation(&v, path)?;
        eprintln!("wrote {}", path.display());
    }
    if a.json {
        println!(
            "{}",
            terraslip::validation::to_json(&v, prediction.as_ref())
        );
    }
    Ok(())
}

/// Three panels: segment end points in the start frame (reference,
/// calibrated, no-slip), position error per segment over time, and the
/// predicted against the reference heading change.
fn plot_validation(v: &Validation, path: &Path) -> anyhow::Result<()> {
    let pick = |f: &dyn Fn(&terraslip_calib::validate::SegmentScore) -> (f64, f64)| {
        v.segments.iter().map(f).collect::<Vec<_>>()
    };
    let ends = LinePlot::new(
        "Segment end points in the frame of each segment start",
        "dx forward [m]",
        "dy left [m]",
    )
    .series(Series::points("reference", pick(&|s| (s.reference.dx, s.reference.dy))).color(0))
    .series(Series::points("calibrated", pick(&|s| (s.predicted.dx, s.predicted.dy))).color(5))
    .series(Series::points("no-slip", pick(&|s| (s.nominal.dx, s.nominal.dy))).color(4))
    .equal_aspect(true);
    let err = |p: &terraslip_calib::Increment, r: &terraslip_calib::Increment| {
        ((r.dx - p.dx).powi(2) + (r.dy - p.dy).powi(2)).sqrt()
    };
    let errors = LinePlot::new(
        "Position error per segment",
        "segment start [s]",
        "error [m]",
    )
    .series(
        Series::points(
            "calibrated",
            pick(&|s| (s.t0, err(&s.predicted, &s.reference))),
        )
        .color(5),
    )
    .series(Series::points("no-slip", pick(&|s| (s.t0, err(&s.nominal, &s.reference)))).color(4));
    let (lo, hi) = v.segments.iter().fold((0.0f64, 0.0f64), |(lo, hi), s| {
        (lo.min(s.reference.dyaw), hi.max(s.reference.dyaw))
    });
    let yaw = LinePlot::new(
        "Heading change: predicted against reference",
        "reference dyaw [rad]",
        "predicted dyaw [rad]",
    )
    .series(
        Series::line("ideal", vec![(lo, lo), (hi, hi)])
            .style(SeriesStyle::Dashed)
            .color(0),
    )
    .series(
        Series::points(
            "calibrated",
            pick(&|s| (s.reference.dyaw, s.predicted.dyaw)),
        )
        .color(5),
    )
    .series(Series::points("no-slip", pick(&|s| (s.reference.dyaw, s.nominal.dyaw))).color(4));
    Figure::new(vec![ends, errors, yaw])
        .write_svg(path)
        .with_context(|| format!("writing plot {}", path.display()))?;
    Ok(())
}
