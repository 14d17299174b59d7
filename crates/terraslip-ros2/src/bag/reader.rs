//! A bag opened for reading: its files, its topics and their definitions.

use std::path::{Path, PathBuf};

use super::files::{kind_of, storage_files, Storage, Whole};
use super::tables::{mcap_summary, open_sqlite, sqlite_topics};
use crate::Ros2Error;

/// One topic of a bag.
#[derive(Debug, Clone, PartialEq)]
pub struct Topic {
    pub name: String,
    /// As recorded, e.g. `nav_msgs/msg/Odometry`.
    pub ty: String,
    /// `ros2msg` definition stored with the topic (empty when the bag has none).
    pub definition: String,
    /// Messages seen so far (filled while reading).
    pub count: u64,
}

/// One raw message.
#[derive(Debug, Clone, Copy)]
pub struct RawMessage<'a> {
    /// Index into [`Bag::topics`].
    pub topic: usize,
    /// Receive (recording) time, ns since the epoch.
    pub recv_ns: u64,
    /// CDR bytes.
    pub data: &'a [u8],
    /// 0-based index of the message in the bag, in reading order.
    pub index: u64,
}

/// A message held in memory: a live graph's warm-up, read as a bag.
#[derive(Debug, Clone)]
pub struct HeldMessage {
    /// Index into [`Bag::topics`].
    pub topic: usize,
    /// Receive time, ns since the epoch.
    pub recv_ns: u64,
    /// CDR bytes.
    pub data: Vec<u8>,
}

/// A rosbag2 recording opened for reading.
#[derive(Debug, Clone)]
pub struct Bag {
    /// The path the user gave.
    pub path: PathBuf,
    /// Topics, filled by [`Bag::open`] from the metadata and the storage files.
    pub topics: Vec<Topic>,
    pub(super) files: Vec<(PathBuf, Storage, Whole)>,
    /// Each message's data is zstd-compressed (metadata `compression_mode: MESSAGE`).
    pub(super) message_zstd: bool,
    /// What reading found that costs data (an MCAP file cut short), one
    /// line each, naming the file; filled while streaming.
    pub warnings: Vec<String>,
    /// Messages held in memory, in arrival order, read instead of files.
    pub(super) held: Option<std::sync::Arc<[HeldMessage]>>,
}

impl Bag {
    /// Opens a bag directory or a single storage file and lists its topics.
    pub fn open(path: impl AsRef<Path>) -> Result<Self, Ros2Error> {
        let path = path.as_ref().to_path_buf();
        let err = |reason: String| Ros2Error::Bag {
            bag: path.clone(),
            reason,
        };
        let mut bag = Bag {
            path: path.clone(),
            topics: Vec::new(),
            files: Vec::new(),
            message_zstd: false,
            warnings: Vec::new(),
            held: None,
        };
        if path.is_dir() && !path.join("metadata.yaml").exists() {
            // No metadata: the storage files themselves name their topics.
            bag.files = storage_files(&path);
            if bag.files.is_empty() {
                return Err(err(
                    "not a bag: no metadata.yaml and no .mcap or .db3 file in the directory".into(),
                ));
            }
        } else if path.is_dir() {
            let meta_path = path.join("metadata.yaml");
            let text = std::fs::read_to_string(&meta_path)
                .map_err(|e| err(format!("metadata.yaml: {e}")))?;
            let meta = crate::metadata::Metadata::parse(&text)
                .map_err(|e| err(format!("metadata.yaml: {e}")))?;
            bag.message_zstd = meta.compression_mode.eq_ignore_ascii_case("message");
            if bag.message_zstd && !meta.compression_format.eq_ignore_ascii_case("zstd") {
                return Err(err(format!(
                    "message compression `{}` is not supported (zstd is)",
                    meta.compression_format
                )));
            }
            for f in &meta.files {
                let p = path.join(f);
                let (mut storage, whole) = kind_of(&p).unwrap_or(match meta.storage.as_str() {
                    "mcap" => (Storage::Mcap, Whole::None),
                    _ => (Storage::Sqlite, Whole::None),
                });
                if meta.storage == "mcap" {
                    storage = Storage::Mcap;
                }
                bag.files.push((p, storage, whole));
            }
            for (name, ty) in meta.topics {
                bag.topics.push(Topic {
                    name,
                    ty,
                    definition: String::new(),
                    count: 0,
                });
            }
            if bag.files.is_empty() {
                return Err(err("metadata.yaml lists no storage files".into()));
            }
        } else {
            let (s, w) = kind_of(&path).ok_or_else(|| {
                err(
                    "not a bag: expected a directory with metadata.yaml, or a .mcap or .db3 file"
                        .into(),
                )
            })?;
            bag.files.push((path.clone(), s, w));
        }
        bag.scan_definitions()?;
        Ok(bag)
    }

    /// Index of a topic by name.
    /// The topics of a live ROS 2 graph as a bag with no storage files, so
    /// that topic choice, decoding and error messages are those of a
    /// recording; `label` names the graph in errors (e.g. `ROS 2 graph,
    /// domain 0`). Reading messages from it yields none.
    pub fn live(label: impl Into<PathBuf>, topics: Vec<Topic>) -> Self {
        Bag {
            path: label.into(),
            topics,
            files: Vec::new(),
            message_zstd: false,
            warnings: Vec::new(),
            held: None,
        }
    }

    /// Messages received from a live graph, held in memory, as a bag
    /// (`label` names the graph in errors): reading it streams `messages`
    /// in their order, so that `import` decides from them as from a file.
    pub fn held(label: impl Into<PathBuf>, topics: Vec<Topic>, messages: Vec<HeldMessage>) -> Self {
        Bag {
            held: Some(messages.into()),
            ..Self::live(label, topics)
        }
    }

    pub fn topic(&self, name: &str) -> Option<usize> {
        self.topics.iter().position(|t| t.name == name)
    }

    pub(super) fn topic_index(&mut self, name: &str, ty: &str) -> usize {
        match self.topic(name) {
            Some(i) => i,
            None => {
                self.topics.push(Topic {
                    name: name.to_string(),
                    ty: ty.to_string(),
                    definition: String::new(),
                    count: 0,
                });
                self.topics.len() - 1
            }
        }
    }

    /// Reads topic types and definitions from the storage files' own tables
    /// (sqlite3) or from the MCAP summary when it has one.
    pub(super) fn scan_definitions(&mut self) -> Result<(), Ros2Error> {
        let mut needs_pass = false;
        for k in 0..self.files.len() {
            let (p, s, w) = self.files[k].clone();
            match (s, w) {
                (Storage::Sqlite, Whole::None) => {
                    let conn = open_sqlite(&p).map_err(|e| self.file_err(&p, e))?;
                    let topics = sqlite_topics(&conn).map_err(|e| self.file_err(&p, e))?;
                    for (_, name, ty, def) in topics {
                        let i = self.topic_index(&name, &ty);
                        if self.topics[i].definition.is_empty() {
                            self.topics[i].definition = def;
                        }
                    }
                }
                // Definitions come with the channels while streaming; the
                // summary, when present, lists them up front.
                (Storage::Mcap, Whole::None) => match mcap_summary(&p) {
                    Ok(summary) => {
                        for (name, ty, def) in summary {
                            let i = self.topic_index(&name, &ty);
                            if self.topics[i].definition.is_empty() {
                                self.topics[i].definition = def;
                            }
                        }
                    }
                    Err(_) => needs_pass = true,
                },
                // Compressed whole: channels are known only by reading.
                (Storage::Mcap, _) => needs_pass = true,
                _ => {}
            }
        }
        if needs_pass {
            self.for_each(&|_| false, &mut |_, _| Ok(()))?;
        }
        Ok(())
    }

    /// An error in one of the bag's files; the file is named only when it
    /// is not the bag itself (a single `.mcap` / `.db3`).
    pub(super) fn file_err(&self, file: &Path, reason: impl std::fmt::Display) -> Ros2Error {
        let reason = if file == self.path {
            reason.to_string()
        } else {
            format!("{}: {reason}", file.display())
        };
        Ros2Error::Bag {
            bag: self.path.clone(),
            reason,
        }
    }

    /// An error about message `index` of topic `topic`.
    pub fn msg_err(&self, topic: usize, index: u64, reason: impl std::fmt::Display) -> Ros2Error {
        let t = &self.topics[topic];
        Ros2Error::Message {
            bag: self.path.clone(),
            topic: t.name.clone(),
            ty: t.ty.clone(),
            index,
            reason: reason.to_string(),
        }
    }
}
