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

/// For a bag read as a log: the decisions its import made again where
/// later windows contradicted them (`decided:` lines).
pub fn revisited(path: &Path) -> Vec<String> {
    let Ok(v) = IMPORTED.lock() else {
        return Vec::new();
    };
    v.iter()
        .find(|(p, _)| p == path)
        .map_or_else(Vec::new, |(_, i)| i.revisited.clone())
}

/// `--strict`: bags with a message that cannot be physical are refused.
static STRICT: OnceLock<bool> = OnceLock::new();

/// For a bag read as a log: its topics, "name (type)", comma-separated.
pub fn bag_topics(path: &Path) -> Option<String> {
    let v = IMPORTED.lock().ok()?;
    let (_, i) = v.iter().find(|(p, _)| p == path)?;
    Some(
        i.bag_topics
            .iter()
            .map(|(n, t)| format!("{n} ({t})"))
            .collect::<Vec<_>>()
            .join(", "),
    )
}

pub fn set_topics(p: Option<PathBuf>, strict: bool) {
    let _ = TOPICS.set(p.map_or(Topics::ByType, Topics::File));
    let _ = STRICT.set(strict);
}

/// `--strict` given.
pub fn strict() -> bool {
    STRICT.get().copied().unwrap_or(false)
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
    read_using(path, topics(), read)
}

/// [`read_with`] with `topics` in place of `--topics`.
pub fn read_using(
    path: &Path,
    topics: &Topics,
    read: impl Fn(&Path) -> Result<DriveLog, LogError>,
) -> anyhow::Result<DriveLog> {
    let input = terraslip::bag::read_checked(path, topics, strict(), read)?;
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

/// What `summary.json` records of a bag input so that `report` can read it
/// again as the estimate did: the topics file given (path and content), or
/// `null` for topics chosen by type.
pub fn topics_record() -> anyhow::Result<serde_json::Value> {
    Ok(match topics() {
        Topics::ByType => serde_json::Value::Null,
        Topics::File(p) => serde_json::json!({
            "file": p.display().to_string(),
            "toml": std::fs::read_to_string(p)
                .map_err(|e| anyhow::anyhow!("{}: {e}", p.display()))?,
        }),
        Topics::Toml { text, name } => serde_json::json!({"file": name, "toml": text}),
    })
}

/// The topics recorded by [`topics_record`] in a summary.
pub fn topics_from_record(record: &serde_json::Value) -> Topics {
    match (record["toml"].as_str(), record["file"].as_str()) {
        (Some(text), name) => Topics::Toml {
            text: text.to_string(),
            name: name.unwrap_or("the recorded topics").to_string(),
        },
        _ => Topics::ByType,
    }
}
