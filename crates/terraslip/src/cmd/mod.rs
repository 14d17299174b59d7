use std::path::{Path, PathBuf};

pub mod bag;
pub mod calibrate;
pub mod demo;
pub mod estimate;
#[cfg(feature = "ros2")]
pub mod import;
pub mod report;
#[cfg(feature = "ros2")]
pub mod ros2out;
pub mod simulate;
pub mod terrain;

/// Reads only what the estimator uses: wheels, pose, meta and terrain.
/// The imu stream alone can be four times the size of everything else;
/// truth is for scoring, not estimating.
pub fn read_log(dir: &Path) -> Result<terraslip_io::DriveLog, terraslip_io::LogError> {
    if !dir.is_dir() {
        return Err(terraslip_io::LogError::Invalid {
            path: dir.to_path_buf(),
            reason: "not a log directory; give the directory that holds wheels.csv".into(),
        });
    }
    let mut log = terraslip_io::DriveLog {
        dir: dir.to_path_buf(),
        ..Default::default()
    };
    log.wheels = terraslip_io::read_wheels(&dir.join("wheels.csv"), &mut log.warnings)?;
    let pose = dir.join("pose.csv");
    if pose.exists() {
        log.pose = terraslip_io::read_pose(&pose, &mut log.warnings)?;
    }
    let terrain = dir.join("terrain.csv");
    if terrain.exists() {
        log.terrain = terraslip_io::read_terrain(&terrain)?;
    }
    let meta = dir.join("meta.toml");
    if meta.exists() {
        log.meta = terraslip_io::read_meta(&meta)?;
    }
    Ok(log)
}

/// Refuses to write `output` over a file the command reads: one of `files`,
/// or a file of one of the log directories `logs`.
pub fn refuse_overwrite(output: &Path, files: &[&Path], logs: &[&Path]) -> anyhow::Result<()> {
    let Some(out) = resolved(output) else {
        return Ok(());
    };
    let inputs = files.iter().map(|f| f.to_path_buf()).chain(
        logs.iter()
            .flat_map(|d| terraslip_io::DriveLog::FILES.iter().map(move |f| d.join(f))),
    );
    for input in inputs {
        if resolved(&input).is_some_and(|i| i == out) {
            anyhow::bail!(
                "{}: this is {}, which the command reads; write the output somewhere else",
                output.display(),
                input.display()
            );
        }
    }
    Ok(())
}

/// `path` made absolute with symbolic links resolved, for a file that may
/// not exist yet (its directory must); `None` when its directory does not.
fn resolved(path: &Path) -> Option<PathBuf> {
    if let Ok(p) = path.canonicalize() {
        return Some(p);
    }
    let name = path.file_name()?;
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    Some(parent.canonicalize().ok()?.join(name))
}
