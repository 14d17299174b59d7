//! `terraslip calibrate validate`: scores calibrated parameters on other
//! drives, per segment (Mandow et al. 2007, Table III) and by the 2 s
//! prediction error.

use std::path::{Path, PathBuf};

use anyhow::Context;
use terraslip::validation::Scores;
use terraslip_calib::{ModelChoice, ValidateConfig, Validation};
use terraslip_io::ParamsFile;
use terraslip_report::{Figure, LinePlot, Series, SeriesStyle};

use super::logs::read_logs;
use super::segment_args::{parse_offset, SegmentArgs};

#[derive(clap::ValueEnum, Clone, Copy)]
enum ModelArg {
    /// The turn-rate model where calibration selected one, else constant.
    Params,
    /// The constant ICRs (Mandow's five parameters).
    Constant,
}

#[derive(clap::Args)]
pub(super) struct ValidateArgs {
    #[arg(
        required = true,
        value_name = "LOG",
        help = concat!("One or more drives to score, each with a pose reference. ", log_help!())
    )]
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

pub(super) fn run(a: ValidateArgs) -> anyhow::Result<()> {
    if let Some(path) = &a.plot {
        super::super::inputs_with(&a.logs, &[("--params", Some(&a.params))])
            .check("--plot", path)?;
    }
    let params = ParamsFile::read(&a.params)
        .with_context(|| format!("reading parameters {}", a.params.display()))?;
    // The limits the fit hit hold for these scores too.
    for w in params.warnings() {
        eprintln!(
            "warning: {w} (from the calibration, {})",
            a.params.display()
        );
    }
    let cfg = ValidateConfig {
        segment: a.seg.config()?,
        time_offset: parse_offset(&a.time_offset, "`params`, `auto` or seconds")?,
        model: match a.model {
            ModelArg::Params => ModelChoice::FromParams,
            ModelArg::Constant => ModelChoice::Constant,
        },
    };
    let logs = read_logs(&a.logs)?;
    if a.plot.is_some() && logs.iter().all(terraslip_calib::track::position_only) {
        anyhow::bail!(
            "--plot draws segment scores, which a position-only reference (no heading) does not give"
        );
    }
    let (v, prediction) = match terraslip::validation::score(&logs, &params, &cfg)? {
        Scores::PositionOnly(s) => return position_only(&a, &s),
        Scores::Segments {
            validation,
            prediction,
        } => (*validation, prediction),
    };
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
    // The 2 s prediction error, as `estimate` reports it: the model of the
    // terrain in effect (or the pooled set) over each 2 s, with the time
    // offsets the scores above used.
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

/// Position-only references: the 2 s prediction with the start heading
/// and position profiled out, nothing per segment.
fn position_only(
    a: &ValidateArgs,
    s: &terraslip::validation::PositionOnlyScore,
) -> anyhow::Result<()> {
    let offset = s.offsets.first().copied().unwrap_or(0.0);
    let p = &s.prediction;
    eprintln!(
        "position-only reference (no heading): no segment scores (they need headings); time offset {offset:+.3} s"
    );
    eprintln!(
        "  2 s prediction, each model's start heading and position profiled out over the {} s of fixes before each start: {} segments, mean {:.3} m (no-slip {:.3} m at {} m), p90 {:.3} m (no-slip {:.3} m)",
        p.profiled_window_s.unwrap_or(f64::NAN),
        p.segments.len(),
        p.stats.mean_m,
        p.no_slip.mean_m,
        s.no_slip_widths
            .iter()
            .map(|w| format!("{w}"))
            .collect::<Vec<_>>()
            .join(", "),
        p.stats.p90_m,
        p.no_slip.p90_m
    );
    if a.json {
        println!("{}", s.to_json());
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
