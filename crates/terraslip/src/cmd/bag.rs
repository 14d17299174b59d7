//! A ROS 2 bag wherever a command takes a LOG: the bag is imported into a
//! temporary log directory (the same code as `terraslip import`) and read
//! from there, so a bag and its imported log give identical results.

use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

use anyhow::Context;
use terraslip_io::{DriveLog, LogError};

/// `--topics FILE.toml`, given once for the whole command line.
static TOPICS: OnceLock<Option<PathBuf>> = OnceLock::new();
/// Temporary logs made from bags, removed by [`cleanup`].
static TEMP: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
/// Bags read: path, time origin (ns since the epoch) and the topics used.
#[cfg(feature = "ros2")]
type Imported = (PathBuf, u64, Vec<String>);
#[cfg(feature = "ros2")]
static IMPORTED: Mutex<Vec<Imported>> = Mutex::new(Vec::new());

/// The time origin (ns) of the log made from bag `path`, and the topics it used.
#[cfg(feature = "ros2")]
pub fn imported(path: &Path) -> Option<(u64, Vec<String>)> {
    let v = IMPORTED.lock().ok()?;
    v.iter()
        .find(|(p, _, _)| p == path)
        .map(|(_, o, t)| (*o, t.clone()))
}

pub fn set_topics(p: Option<PathBuf>) {
    let _ = TOPICS.set(p);
}

pub fn topics_file() -> Option<&'static Path> {
    TOPICS.get().and_then(|p| p.as_deref())
}

/// Whether `path` is a bag rather than a log directory.
pub fn is_bag(path: &Path) -> bool {
    #[cfg(feature = "ros2")]
    {
        terraslip_ros2::is_bag(path)
    }
    #[cfg(not(feature = "ros2"))]
    {
        path.join("metadata.yaml").is_file()
            || path.extension().is_some_and(|e| e == "mcap" || e == "db3")
    }
}

/// Reads `path` with `read` (a log directory reader), importing it first
/// when it is a bag.
pub fn read_with(
    path: &Path,
    read: impl Fn(&Path) -> Result<DriveLog, LogError>,
) -> anyhow::Result<DriveLog> {
    if !is_bag(path) {
        if topics_file().is_some() && !path.is_dir() {
            anyhow::bail!("{}: --topics is for ROS 2 bags", path.display());
        }
        return read(path).with_context(|| format!("reading log {}", path.display()));
    }
    let dir = import_to_temp(path)?;
    let mut log =
        read(&dir).with_context(|| format!("reading the log imported from {}", path.display()))?;
    if log.images.is_empty() {
        let _ = std::fs::remove_dir_all(dir.parent().unwrap_or(&dir));
        TEMP.lock()
            .map(|mut t| t.retain(|p| !dir.starts_with(p)))
            .ok();
        log.dir = path.to_path_buf();
    }
    Ok(log)
}

/// Reads a log directory or a bag with everything in it.
pub fn read_full(path: &Path) -> anyhow::Result<DriveLog> {
    read_with(path, |p| DriveLog::read(p))
}

#[cfg(feature = "ros2")]
fn import_to_temp(bag: &Path) -> anyhow::Result<PathBuf> {
    let cfg = match topics_file() {
        Some(p) => terraslip_ros2::TopicsConfig::read(p).map_err(anyhow::Error::msg)?,
        None => Default::default(),
    };
    let root = tempfile::Builder::new()
        .prefix("terraslip-bag-")
        .tempdir()
        .context("creating a temporary directory")?
        .keep();
    TEMP.lock().map(|mut t| t.push(root.clone())).ok();
    let name = bag
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "bag".into());
    let dir = root.join(name);
    let (log, report) = terraslip_ros2::import(bag, &cfg, Some(&dir))?;
    log.write(&dir)?;
    let mut topics: Vec<String> = report.streams.iter().map(|s| s.topic.clone()).collect();
    topics.dedup();
    IMPORTED
        .lock()
        .map(|mut v| v.push((bag.to_path_buf(), report.time_origin_ns, topics)))
        .ok();
    Ok(dir)
}

#[cfg(not(feature = "ros2"))]
fn import_to_temp(bag: &Path) -> anyhow::Result<PathBuf> {
    anyhow::bail!(
        "{}: a ROS 2 bag; this terraslip was built without the `ros2` feature",
        bag.display()
    )
}

/// Removes the temporary logs made from bags.
pub fn cleanup() {
    if let Ok(mut t) = TEMP.lock() {
        for p in t.drain(..) {
            let _ = std::fs::remove_dir_all(p);
        }
    }
}
