//! A ROS 2 bag wherever a LOG is taken. The bag is imported into a
//! temporary log directory (what `terraslip import` writes) and read back by
//! the log reader, so a bag and its imported log give identical results.
//! The command line and the Python package read their LOG arguments through
//! [`read`].

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use terraslip_io::{DriveLog, LogError};

/// `--topics`: which topic of a bag feeds which stream of the log, and the
/// numbers a bag cannot tell (docs/user-guide.md, ROS 2 bags).
#[derive(Debug, Clone, Default, PartialEq)]
pub enum Topics {
    /// Streams chosen by message type.
    #[default]
    ByType,
    /// A topics file (TOML).
    File(PathBuf),
    /// A topics file's content; `name` stands for the file in messages.
    Toml { text: String, name: String },
}

impl Topics {
    /// Whether topics were given at all.
    pub fn is_given(&self) -> bool {
        !matches!(self, Topics::ByType)
    }

    /// The topics file read and checked (unknown keys are errors, with the
    /// line they are on).
    #[cfg(feature = "ros2")]
    pub fn config(&self) -> anyhow::Result<terraslip_ros2::TopicsConfig> {
        let (text, name) = match self {
            Topics::ByType => return Ok(Default::default()),
            Topics::File(p) => (
                std::fs::read_to_string(p).with_context(|| p.display().to_string())?,
                p.display().to_string(),
            ),
            Topics::Toml { text, name } => (text.clone(), name.clone()),
        };
        toml::from_str(&text)
            .map_err(|e| anyhow::Error::msg(crate::config::toml_message(&text, &e)))
            .context(name)
    }
}

/// A LOG argument read: a log directory's content, or a bag's.
#[derive(Debug)]
pub struct Input {
    pub log: DriveLog,
    /// For a bag: what the import used.
    pub bag: Option<Imported>,
}

/// What a bag's log was made from.
#[derive(Debug)]
pub struct Imported {
    /// `t` = 0 of the log, ns since the epoch.
    pub time_origin_ns: u64,
    /// The topics the log's streams were read from.
    pub topics: Vec<String>,
    /// What the import decided that the bag does not state, and how sure
    /// it is, one line each (`terraslip_ros2::ImportReport::decisions`).
    pub decisions: Vec<String>,
    /// Decisions made from the data and made again where later windows of
    /// the recording contradicted them, one line each (among `decisions`).
    pub revisited: Vec<String>,
    /// Every topic of the bag: name and type.
    pub bag_topics: Vec<(String, String)>,
    /// The temporary log directory, kept (and removed on drop) while the
    /// log's camera frames are read from it; the log's `dir` is then that
    /// directory, otherwise the bag.
    #[cfg(feature = "ros2")]
    _frames: Option<tempfile::TempDir>,
}

/// Whether `path` is a bag (a directory with `metadata.yaml`, or an
/// `.mcap` / `.db3` file) rather than a log directory.
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

/// Reads the log at `path` with `read` (a log directory reader such as
/// [`DriveLog::read`] or [`crate::estimate::read_log`]), importing it
/// first, with `topics`, when it is a bag. Errors say which log.
pub fn read(
    path: &Path,
    topics: &Topics,
    read: impl Fn(&Path) -> Result<DriveLog, LogError>,
) -> anyhow::Result<Input> {
    read_checked(path, topics, false, read)
}

/// [`read`]; with `strict`, a bag with a message that cannot be physical is
/// refused rather than imported without it (as the topics file's
/// `strict = true`; `--strict` on the command line).
pub fn read_checked(
    path: &Path,
    topics: &Topics,
    strict: bool,
    read: impl Fn(&Path) -> Result<DriveLog, LogError>,
) -> anyhow::Result<Input> {
    if is_bag(path) {
        return import(path, topics, strict, read);
    }
    if topics.is_given() && !path.is_dir() {
        anyhow::bail!("{}: --topics is for ROS 2 bags", path.display());
    }
    let log = read(path).with_context(|| format!("reading log {}", path.display()))?;
    Ok(Input { log, bag: None })
}

#[cfg(feature = "ros2")]
fn import(
    bag: &Path,
    topics: &Topics,
    strict: bool,
    read: impl Fn(&Path) -> Result<DriveLog, LogError>,
) -> anyhow::Result<Input> {
    let mut cfg = topics.config()?;
    cfg.strict |= strict;
    let temp = tempfile::Builder::new()
        .prefix("terraslip-bag-")
        .tempdir()
        .context("creating a temporary directory")?;
    let name = bag
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "bag".into());
    let dir = temp.path().join(name);
    let (log, report) = import_deciding(bag, topics, &cfg, &dir)?;
    log.write(&dir)?;
    let mut log = read(&dir).map_err(|e| in_bag_terms(&e.to_string(), bag, &dir, &report))?;
    // What the import warned about (skipped messages, mountings) is the
    // log's to tell, on every path that reads a bag.
    log.warnings.splice(0..0, report.warnings.iter().cloned());
    let mut used: Vec<String> = report.streams.iter().map(|s| s.topic.clone()).collect();
    used.dedup();
    let frames = if log.images.is_empty() {
        log.dir = bag.to_path_buf();
        None
    } else {
        Some(temp)
    };
    Ok(Input {
        log,
        bag: Some(Imported {
            time_origin_ns: report.time_origin_ns,
            topics: used,
            decisions: report.decisions,
            revisited: report.revisited,
            bag_topics: report
                .topics
                .iter()
                .map(|(name, ty, _)| (name.clone(), ty.clone()))
                .collect(),
            _frames: frames,
        }),
    })
}

/// An error about the temporary log made from `bag` (in `dir`), told in
/// the bag's terms: each file named by the topic it was made from.
#[cfg(feature = "ros2")]
fn in_bag_terms(
    message: &str,
    bag: &Path,
    dir: &Path,
    report: &terraslip_ros2::ImportReport,
) -> anyhow::Error {
    let mut msg = message.to_string();
    for s in &report.streams {
        let file = s.file.split(' ').next().unwrap_or(&s.file);
        msg = msg.replace(
            &dir.join(file).display().to_string(),
            &format!("{} topic {} (as {file})", bag.display(), s.topic),
        );
    }
    let msg = msg.replace(
        &dir.display().to_string(),
        &format!("the log imported from {}", bag.display()),
    );
    anyhow::anyhow!(msg)
}

#[cfg(not(feature = "ros2"))]
fn import(
    bag: &Path,
    _: &Topics,
    _: bool,
    _: impl Fn(&Path) -> Result<DriveLog, LogError>,
) -> anyhow::Result<Input> {
    anyhow::bail!(
        "{}: a ROS 2 bag; this terraslip was built without the `ros2` feature",
        bag.display()
    )
}

/// `bag` imported into `dir` with `cfg`: with no topics file, deciding from
/// the first window of the recording, as `terraslip node` decides from its
/// warm-up ([`crate::pipeline::warmup::WarmUp::default_window`]).
#[cfg(feature = "ros2")]
pub fn import_deciding(
    bag: &Path,
    topics: &Topics,
    cfg: &terraslip_ros2::TopicsConfig,
    dir: &Path,
) -> Result<(DriveLog, terraslip_ros2::ImportReport), terraslip_ros2::Ros2Error> {
    if topics.is_given() {
        terraslip_ros2::import(bag, cfg, Some(dir))
    } else {
        let window = crate::pipeline::warmup::WarmUp::default_window();
        terraslip_ros2::import_within(bag, cfg, Some(dir), window)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn topics_are_for_bags() {
        let d = tempfile::tempdir().unwrap();
        let file = d.path().join("wheels.csv");
        let topics = Topics::File(d.path().join("t.toml"));
        let e = read(&file, &topics, |p| DriveLog::read(p)).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!("{}: --topics is for ROS 2 bags", file.display())
        );
        // Without topics the log reader says what is wrong.
        let e = read(&file, &Topics::ByType, |p| DriveLog::read(p)).unwrap_err();
        assert!(crate::one_line(&e).starts_with("reading log "), "{e:#}");
    }

    #[cfg(feature = "ros2")]
    #[test]
    fn topics_errors_name_the_file_and_line() {
        let d = tempfile::tempdir().unwrap();
        let missing = d.path().join("missing.toml");
        let e = Topics::File(missing.clone()).config().unwrap_err();
        assert!(e
            .chain()
            .any(|c| c.downcast_ref::<std::io::Error>().is_some()));
        assert!(crate::one_line(&e).starts_with(&missing.display().to_string()));
        let text = "[wheels]\nseparation = 1.0\nseperation = 1.0\n";
        let bad = Topics::Toml {
            text: text.into(),
            name: "topics".into(),
        };
        let msg = crate::one_line(&bad.config().unwrap_err());
        assert!(
            msg.starts_with("topics: line 3: unknown field `seperation`"),
            "{msg}"
        );
        let good = Topics::Toml {
            text: text.replace("seperation = 1.0\n", ""),
            name: "topics".into(),
        };
        assert_eq!(good.config().unwrap().wheels.separation, Some(1.0));
    }
}
