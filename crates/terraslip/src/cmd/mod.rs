use std::path::{Path, PathBuf};

pub mod bag;
pub mod calibrate;
pub mod demo;
pub mod estimate;
#[cfg(feature = "ros2")]
pub mod import;
#[cfg(any(feature = "node", feature = "node-humble"))]
pub mod node;
pub mod report;
#[cfg(feature = "ros2")]
pub mod ros2out;
pub mod simulate;
pub mod terrain;

pub use terraslip::estimate::read_log;

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
