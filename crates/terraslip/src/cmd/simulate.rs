//! `terraslip simulate SCENARIO --out LOG [--seed N]`, `terraslip simulate --list`.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use terraslip_sim::{builtin_names, simulate, Scenario};

use crate::progress::Progress;

const DETAILS: &str = "\
The truth follows the ICR kinematic model with per-terrain ICRs that vary a
few percent with speed and turn rate, and tread speed factors alpha != 1,
integrated in 1 ms steps. Sensors (quantised encoders, GNSS with white and
Gauss-Markov error, outages and multipath jumps, a biased compass, a 200 Hz
accelerometer whose vibration depends on terrain and speed, a ground camera)
each sample at their own rate. The log directory holds the files of
log-format.md plus truth.csv (with alphas and body twist), terrain.csv,
meta.toml, images/ and the scenario.toml it came from.

Examples:
  terraslip simulate --list
  terraslip simulate papers --out logs/papers --seed 7
  terraslip simulate papers-rtk --out logs/papers-rtk --no-camera
  terraslip simulate papers --print-scenario > my-field.toml   # edit, then:
  terraslip simulate my-field.toml --out logs/field

Scenario files are TOML; docs/simulator.md documents every key.";

#[derive(clap::Args, Debug)]
#[command(after_long_help = DETAILS)]
pub struct Args {
    /// Built-in scenario name (see --list) or path of a scenario TOML file.
    #[arg(required_unless_present = "list")]
    pub scenario: Option<String>,
    /// Log directory to write. Must not exist, be empty, or be a log
    /// directory (which is replaced as a whole).
    #[arg(long, required_unless_present_any = ["list", "print_scenario"])]
    pub out: Option<PathBuf>,
    /// Random seed: the same scenario and seed give the same log, bit for bit.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// List the built-in scenarios with a one-line description each.
    #[arg(long)]
    pub list: bool,
    /// Print the scenario as TOML (a template for your own) and exit.
    #[arg(long)]
    pub print_scenario: bool,
    /// Leave out the ground camera (much faster, far less disk).
    #[arg(long)]
    pub no_camera: bool,
    /// Camera frame rate in Hz, overriding the scenario's.
    #[arg(long, value_name = "HZ", conflicts_with = "no_camera")]
    pub camera_rate: Option<f64>,
}

pub fn run(args: Args) -> anyhow::Result<()> {
    if args.list {
        for (name, desc) in builtin_names() {
            println!("{name:<18} {desc}");
        }
        return Ok(());
    }
    let Some(name) = args.scenario.as_deref() else {
        bail!("no scenario given (try `terraslip simulate --list`)");
    };
    if let Some(out) = &args.out {
        let mut inputs = super::inputs();
        // A scenario file (a built-in name is no path).
        if Path::new(name).is_file() {
            inputs.add(Path::new(name), "the scenario file");
        }
        inputs.check_replaced("--out", out)?;
    }
    let mut scenario = Scenario::resolve(name)?;
    if args.no_camera {
        scenario.camera.rate = 0.0;
    }
    if let Some(r) = args.camera_rate {
        if !(r.is_finite() && r >= 0.0) {
            bail!("--camera-rate {r}: must be zero or a positive number of frames per second");
        }
        scenario.camera.rate = r;
    }
    if args.print_scenario {
        print!("{}", toml::to_string(&scenario)?);
        return Ok(());
    }
    let Some(out) = args.out.as_deref() else {
        bail!("--out LOG is required");
    };
    check_target(out, "wheels.csv", "a drive log")?;
    let run = simulate(&scenario, args.seed)?;

    let bar = if run.frames.is_empty() {
        Progress::hidden()
    } else {
        Progress::new(run.frames.len() as u64, "frames")
    };
    bar.set_message("simulate: rendering camera");
    let staging = staging_dir(out)?;
    let written = run.write_with_progress(&staging, |done, _| bar.set_position(done as u64));
    bar.finish();
    if let Err(e) = written {
        let _ = std::fs::remove_dir_all(&staging);
        return Err(e.into());
    }
    replace_dir(&staging, out)?;

    let dist: f64 = run
        .truth
        .windows(2)
        .map(|w| (w[1].east - w[0].east).hypot(w[1].north - w[0].north))
        .sum();
    eprintln!(
        "{}: scenario `{}` seed {}: {:.0} s, {:.0} m driven, terrains {}, {} wheel / {} pose / {} imu rows, {} frames",
        out.display(),
        scenario.name,
        args.seed,
        scenario.duration(),
        dist,
        run.terrains
            .iter()
            .map(|t| t.name.as_str())
            .collect::<Vec<_>>()
            .join(" "),
        run.log.wheels.len(),
        run.log.pose.len(),
        run.log.imu.len(),
        run.frames.len()
    );
    Ok(())
}

/// Refuses to clobber anything but an earlier output of the same kind: a
/// directory that is empty or holds `marker` (`what` names it in the error).
pub(crate) fn check_target(out: &Path, marker: &str, what: &str) -> anyhow::Result<()> {
    if !out.exists() {
        return Ok(());
    }
    if !out.is_dir() {
        bail!(
            "{}: exists and is not a directory; refusing to overwrite it",
            out.display()
        );
    }
    let mut entries = std::fs::read_dir(out).with_context(|| format!("{}", out.display()))?;
    let empty = entries.next().is_none();
    if !empty && !out.join(marker).is_file() {
        bail!(
            "{}: directory is not empty and is not {what} (no {marker}); refusing to overwrite it",
            out.display()
        );
    }
    Ok(())
}

/// A fresh directory beside `out`, so the final rename stays on one file system.
pub(crate) fn staging_dir(out: &Path) -> anyhow::Result<PathBuf> {
    let parent = match out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    std::fs::create_dir_all(&parent).with_context(|| format!("{}", parent.display()))?;
    let name = out
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let staging = parent.join(format!(".{name}.partial-{}", std::process::id()));
    if staging.exists() {
        std::fs::remove_dir_all(&staging).with_context(|| format!("{}", staging.display()))?;
    }
    std::fs::create_dir(&staging).with_context(|| format!("{}", staging.display()))?;
    Ok(staging)
}

/// Moves the finished `staging` directory to `out`, replacing an old log
/// there only once the new one is complete.
pub(crate) fn replace_dir(staging: &Path, out: &Path) -> anyhow::Result<()> {
    if out.exists() {
        let old = staging.with_extension("old");
        std::fs::rename(out, &old)
            .with_context(|| format!("{}: cannot move aside", out.display()))?;
        if let Err(e) = std::fs::rename(staging, out) {
            let _ = std::fs::rename(&old, out);
            return Err(e).with_context(|| format!("{}", out.display()));
        }
        let _ = std::fs::remove_dir_all(&old);
    } else {
        std::fs::rename(staging, out).with_context(|| format!("{}", out.display()))?;
    }
    Ok(())
}
