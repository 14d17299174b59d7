//! `terraslip calibrate`: offline identification of the ICR kinematic
//! parameters, and `terraslip calibrate validate`: scoring them on other drives.

use anyhow::{bail, Context};
use terraslip_calib::model::PARAM_NAMES;
use terraslip_calib::{calibrate, CalibConfig, Method, OffsetChoice, Progress, TimeOffset};

use crate::progress;

mod args;
mod logs;
mod print_config;
mod segment_args;
mod summary;
mod validate;

pub use args::Args;
use args::{MethodArg, ReducedArg, Sub};
use logs::read_logs;
use segment_args::parse_offset;

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
