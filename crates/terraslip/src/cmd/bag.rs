//! A ROS 2 bag wherever a command takes a LOG ([`terraslip::bag`]), with
//! the global `--topics` and the bags' temporary logs kept until the
//! command ends.

use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

use terraslip::bag::{Imported, Topics};
use terraslip_io::{DriveLog, LogError};

/// `--topics FILE.toml`, given once for the whole command line.
static TOPICS: OnceLock<Topics> = OnceLock::new();
/// Bags read, by the path given, with what their import used; dropping
/// one removes its temporary log.
static IMPORTED: Mutex<Vec<(PathBuf, Imported)>> = Mutex::new(Vec::new());

/// The time origin (ns) of the log made from bag `path`, and the topics it used.
#[cfg(feature = "ros2")]
pub fn imported(path: &Path) -> Option<(u64, Vec<String>)> {
    let v = IMPORTED.lock().ok()?;
    v.iter()
        .find(|(p, _)| p == path)
        .map(|(_, i)| (i.time_origin_ns, i.topics.clone()))
}

pub fn set_topics(p: Option<PathBuf>) {
    let _ = TOPICS.set(p.map_or(Topics::ByType, Topics::File));
}

/// `--topics`, or topics chosen by type.
pub fn topics() -> &'static Topics {
    TOPICS.get_or_init(Topics::default)
}

/// Reads `path` with `read` (a log directory reader), importing it first
/// when it is a bag.
pub fn read_with(
    path: &Path,
    read: impl Fn(&Path) -> Result<DriveLog, LogError>,
) -> anyhow::Result<DriveLog> {
    let input = terraslip::bag::read(path, topics(), read)?;
    if let Some(bag) = input.bag {
        for d in &bag.decisions {
            eprintln!("{}: decided: {d}", path.display());
        }
        if let Ok(mut v) = IMPORTED.lock() {
            v.push((path.to_path_buf(), bag));
        }
    }
    Ok(input.log)
}

/// Reads a log directory or a bag with everything in it.
pub fn read_full(path: &Path) -> anyhow::Result<DriveLog> {
    read_with(path, |p| DriveLog::read(p))
}

/// Removes the temporary logs made from bags.
pub fn cleanup() {
    if let Ok(mut v) = IMPORTED.lock() {
        v.clear();
    }
}
