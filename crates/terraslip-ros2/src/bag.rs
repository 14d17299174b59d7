//! Opening a rosbag2 recording and streaming its raw messages.
//!
//! A bag is a directory with `metadata.yaml` (versions 4 to 9) naming its
//! storage files, a directory of storage files without it (a recording that
//! was not closed, or copied without it), or one `.mcap` / `.db3` file
//! (optionally `.zstd`/`.lz4` compressed whole). Messages are streamed file by file; memory holds one
//! MCAP chunk or one sqlite row at a time.

use std::fs::File;
use std::io::{BufReader, Read};
use std::path::{Path, PathBuf};

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

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Storage {
    Mcap,
    Sqlite,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Whole {
    None,
    Zstd,
    Lz4,
}

/// A rosbag2 recording opened for reading.
#[derive(Debug, Clone)]
pub struct Bag {
    /// The path the user gave.
    pub path: PathBuf,
    /// Topics, filled by [`Bag::open`] from the metadata and the storage files.
    pub topics: Vec<Topic>,
    files: Vec<(PathBuf, Storage, Whole)>,
    /// Each message's data is zstd-compressed (metadata `compression_mode: MESSAGE`).
    message_zstd: bool,
    /// What reading found that costs data (an MCAP file cut short), one
    /// line each, naming the file; filled while streaming.
    pub warnings: Vec<String>,
}

/// Whether `path` looks like a bag (a directory with `metadata.yaml`, a
/// directory of `.mcap`/`.db3` files and no `wheels.csv`, or an
/// `.mcap`/`.db3` file) rather than a terraslip log directory.
pub fn is_bag(path: &Path) -> bool {
    if path.is_dir() {
        return path.join("metadata.yaml").is_file()
            || (!path.join("wheels.csv").exists() && !storage_files(path).is_empty());
    }
    kind_of(path).is_some()
}

/// The storage files (`.mcap`, `.db3`, whole-compressed or not) directly in
/// directory `dir`, in recording order: rosbag2 numbers the files of a
/// split bag `<name>_0`, `<name>_1`, ..., so names compare by their
/// trailing number after the text before it.
fn storage_files(dir: &Path) -> Vec<(PathBuf, Storage, Whole)> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut files: Vec<(PathBuf, Storage, Whole)> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file())
        .filter_map(|p| kind_of(&p).map(|(s, w)| (p, s, w)))
        .collect();
    let key = |(p, _, _): &(PathBuf, Storage, Whole)| {
        let name = p.file_name().unwrap_or_default().to_string_lossy();
        let stem = name.split('.').next().unwrap_or_default().to_string();
        let digits = stem.len() - stem.trim_end_matches(|c: char| c.is_ascii_digit()).len();
        let number: u64 = stem[stem.len() - digits..].parse().unwrap_or(0);
        (
            stem[..stem.len() - digits].to_string(),
            number,
            name.to_string(),
        )
    };
    files.sort_by_cached_key(key);
    files
}

fn kind_of(p: &Path) -> Option<(Storage, Whole)> {
    let name = p.to_string_lossy();
    let (stem, whole) = if let Some(s) = name.strip_suffix(".zstd") {
        (s, Whole::Zstd)
    } else if let Some(s) = name.strip_suffix(".lz4") {
        (s, Whole::Lz4)
    } else {
        (&name[..], Whole::None)
    };
    if stem.ends_with(".mcap") {
        Some((Storage::Mcap, whole))
    } else if stem.ends_with(".db3") {
        Some((Storage::Sqlite, whole))
    } else {
        None
    }
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
        }
    }

    pub fn topic(&self, name: &str) -> Option<usize> {
        self.topics.iter().position(|t| t.name == name)
    }

    fn topic_index(&mut self, name: &str, ty: &str) -> usize {
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
    fn scan_definitions(&mut self) -> Result<(), Ros2Error> {
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
    fn file_err(&self, file: &Path, reason: impl std::fmt::Display) -> Ros2Error {
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

    /// Streams every message in storage order (files in metadata order).
    /// `want(topic)` says which topics to hand to `f`; others are skipped
    /// without a copy. `f` returning an error stops the stream.
    pub fn for_each(
        &mut self,
        want: &dyn Fn(usize) -> bool,
        f: &mut dyn FnMut(&Bag, RawMessage) -> Result<(), Ros2Error>,
    ) -> Result<(), Ros2Error> {
        for t in &mut self.topics {
            t.count = 0;
        }
        let mut index = 0u64;
        for k in 0..self.files.len() {
            let (p, s, w) = self.files[k].clone();
            match s {
                Storage::Mcap => {
                    let file = File::open(&p).map_err(|e| self.file_err(&p, e))?;
                    let size = file.metadata().map(|m| m.len()).unwrap_or(0);
                    let reader: Box<dyn Read> = match w {
                        Whole::None => Box::new(BufReader::with_capacity(1 << 16, file)),
                        Whole::Zstd => Box::new(
                            zstd::stream::read::Decoder::new(file)
                                .map_err(|e| self.file_err(&p, e))?,
                        ),
                        Whole::Lz4 => {
                            Box::new(lz4::Decoder::new(file).map_err(|e| self.file_err(&p, e))?)
                        }
                    };
                    let read =
                        self.stream_mcap(&p, reader, record_limit(size), &mut index, want, f)?;
                    if let Some(n) = read.cut_short {
                        self.warn(cut_short(&p, size, n));
                    }
                }
                Storage::Sqlite => {
                    let (db, _tmp) = match w {
                        Whole::None => (p.clone(), None),
                        _ => {
                            // SQLite needs a file: decompress beside nothing of the user's.
                            let tmp =
                                tempfile::NamedTempFile::new().map_err(|e| self.file_err(&p, e))?;
                            let file = File::open(&p).map_err(|e| self.file_err(&p, e))?;
                            let mut out = tmp.reopen().map_err(|e| self.file_err(&p, e))?;
                            let r = match w {
                                Whole::Zstd => std::io::copy(
                                    &mut zstd::stream::read::Decoder::new(file)
                                        .map_err(|e| self.file_err(&p, e))?,
                                    &mut out,
                                ),
                                _ => std::io::copy(
                                    &mut lz4::Decoder::new(file)
                                        .map_err(|e| self.file_err(&p, e))?,
                                    &mut out,
                                ),
                            };
                            r.map_err(|e| self.file_err(&p, format!("decompressing: {e}")))?;
                            (tmp.path().to_path_buf(), Some(tmp))
                        }
                    };
                    self.stream_sqlite(&p, &db, &mut index, want, f)?;
                }
            }
        }
        Ok(())
    }

    fn stream_mcap(
        &mut self,
        p: &Path,
        reader: Box<dyn Read>,
        limit: usize,
        index: &mut u64,
        want: &dyn Fn(usize) -> bool,
        f: &mut dyn FnMut(&Bag, RawMessage) -> Result<(), Ros2Error>,
    ) -> Result<McapRead, Ros2Error> {
        let mut map: Vec<Option<usize>> = Vec::new();
        let mut buf = Vec::new();
        let first = *index;
        let options = mcap::sans_io::LinearReaderOptions::default().with_record_length_limit(limit);
        for m in mcap::io::MessageReader::new_with_options(reader, options) {
            let m = match m {
                Ok(m) => m,
                // A recording killed before it closed the file: every whole
                // message before the cut is read, the rest is lost.
                Err(mcap::McapError::UnexpectedEof) => {
                    return Ok(McapRead {
                        cut_short: Some(*index - first),
                    })
                }
                Err(e) => return Err(self.file_err(p, format!("after message {index}: {e}"))),
            };
            let cid = m.channel.id as usize;
            if map.len() <= cid {
                map.resize(cid + 1, None);
            }
            let ti = match map[cid] {
                Some(t) => t,
                None => {
                    let (ty, def) = match &m.channel.schema {
                        Some(s) if s.encoding == "ros2msg" => (
                            s.name.clone(),
                            String::from_utf8_lossy(&s.data).into_owned(),
                        ),
                        Some(s) => (s.name.clone(), String::new()),
                        None => (String::new(), String::new()),
                    };
                    let t = self.topic_index(&m.channel.topic, &ty);
                    if self.topics[t].definition.is_empty() {
                        self.topics[t].definition = def;
                    }
                    if self.topics[t].ty.is_empty() {
                        self.topics[t].ty = ty;
                    }
                    map[cid] = Some(t);
                    t
                }
            };
            self.topics[ti].count += 1;
            let i = *index;
            *index += 1;
            if !want(ti) {
                continue;
            }
            let data: &[u8] = if self.message_zstd {
                buf.clear();
                zstd::stream::copy_decode(&m.data[..], &mut buf)
                    .map_err(|e| self.msg_err(ti, i, format!("zstd: {e}")))?;
                &buf
            } else {
                &m.data
            };
            f(
                self,
                RawMessage {
                    topic: ti,
                    recv_ns: m.log_time,
                    data,
                    index: i,
                },
            )?;
        }
        Ok(McapRead { cut_short: None })
    }

    /// Adds `w` to [`Bag::warnings`] once (a bag is streamed more than once).
    fn warn(&mut self, w: String) {
        if !self.warnings.contains(&w) {
            self.warnings.push(w);
        }
    }

    fn stream_sqlite(
        &mut self,
        p: &Path,
        db: &Path,
        index: &mut u64,
        want: &dyn Fn(usize) -> bool,
        f: &mut dyn FnMut(&Bag, RawMessage) -> Result<(), Ros2Error>,
    ) -> Result<(), Ros2Error> {
        let conn = open_sqlite(db).map_err(|e| self.file_err(p, e))?;
        let topics = sqlite_topics(&conn).map_err(|e| self.file_err(p, e))?;
        let mut map = std::collections::HashMap::new();
        for (id, name, ty, def) in topics {
            let t = self.topic_index(&name, &ty);
            if self.topics[t].definition.is_empty() {
                self.topics[t].definition = def;
            }
            map.insert(id, t);
        }
        let mut stmt = conn
            .prepare("SELECT topic_id, timestamp, data FROM messages ORDER BY timestamp, id")
            .map_err(|e| self.file_err(p, e))?;
        let mut rows = stmt.query([]).map_err(|e| self.file_err(p, e))?;
        let mut buf = Vec::new();
        loop {
            let row = match rows.next() {
                Ok(Some(r)) => r,
                Ok(None) => break,
                Err(e) => return Err(self.file_err(p, format!("after message {index}: {e}"))),
            };
            let i = *index;
            *index += 1;
            let tid: i64 = row.get(0).map_err(|e| self.file_err(p, e))?;
            let Some(&ti) = map.get(&tid) else {
                return Err(self.file_err(p, format!("message {i}: unknown topic id {tid}")));
            };
            self.topics[ti].count += 1;
            if !want(ti) {
                continue;
            }
            let ts: i64 = row.get(1).map_err(|e| self.msg_err(ti, i, e))?;
            let blob = row
                .get_ref(2)
                .and_then(|v| v.as_blob().map_err(Into::into))
                .map_err(|e| self.msg_err(ti, i, e))?;
            let data: &[u8] = if self.message_zstd {
                buf.clear();
                zstd::stream::copy_decode(blob, &mut buf)
                    .map_err(|e| self.msg_err(ti, i, format!("zstd: {e}")))?;
                &buf
            } else {
                blob
            };
            f(
                self,
                RawMessage {
                    topic: ti,
                    recv_ns: ts.max(0) as u64,
                    data,
                    index: i,
                },
            )?;
        }
        Ok(())
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

/// How reading one MCAP file ended.
struct McapRead {
    /// The file ends in the middle of a record, after this many whole
    /// messages.
    cut_short: Option<u64>,
}

/// The warning for MCAP file `p` of `size` bytes cut short after `n`
/// whole messages.
fn cut_short(p: &Path, size: u64, n: u64) -> String {
    format!(
        "{}: the file ends in the middle of a record at byte {size} (a recording stopped before it closed the file?): read the {n} whole messages before it, the rest is lost; `mcap recover {} -o recovered.mcap` may save more (https://mcap.dev/guides/cli)",
        p.display(),
        p.display()
    )
}

/// The largest MCAP record (or decompressed chunk) accepted from a file of
/// `size` bytes: 16 times the file, within 64 MiB to 4 GiB, so a corrupt
/// length cannot make the reader allocate without bound.
fn record_limit(size: u64) -> usize {
    size.saturating_mul(16).clamp(64 << 20, 4 << 30) as usize
}

/// Opens a `.db3` file read-only and immutable (SQLite URI
/// `file:...?mode=ro&immutable=1`): no lock, no `-shm` / `-wal` sidecar
/// files, so a bag on a read-only mount reads and nothing is written
/// beside it. A recording being written is not a bag to read.
fn open_sqlite(p: &Path) -> rusqlite::Result<rusqlite::Connection> {
    rusqlite::Connection::open_with_flags(
        sqlite_uri(p),
        rusqlite::OpenFlags::SQLITE_OPEN_READ_ONLY
            | rusqlite::OpenFlags::SQLITE_OPEN_URI
            | rusqlite::OpenFlags::SQLITE_OPEN_NO_MUTEX,
    )
}

/// The read-only, immutable SQLite URI of file `p`, its path
/// percent-encoded where a URI needs it (`%`, `?`, `#`, non-ASCII ...).
fn sqlite_uri(p: &Path) -> String {
    let abs = std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    let path = abs.to_string_lossy().replace('\\', "/");
    // `file:///tmp/b.db3`, `file:///C:/b.db3`.
    let mut uri = String::from(if path.starts_with('/') {
        "file://"
    } else {
        "file:///"
    });
    for b in path.bytes() {
        match b {
            b'A'..=b'Z' | b'a'..=b'z' | b'0'..=b'9' | b'/' | b'-' | b'_' | b'.' | b'~' => {
                uri.push(b as char)
            }
            _ => uri.push_str(&format!("%{b:02X}")),
        }
    }
    uri + "?mode=ro&immutable=1"
}

/// `(id, name, type, definition)` of every topic in a sqlite3 bag file.
fn sqlite_topics(
    conn: &rusqlite::Connection,
) -> rusqlite::Result<Vec<(i64, String, String, String)>> {
    let mut defs = std::collections::HashMap::new();
    let has_defs: bool = conn
        .query_row(
            "SELECT count(*) FROM sqlite_master WHERE type='table' AND name='message_definitions'",
            [],
            |r| r.get::<_, i64>(0),
        )
        .map(|n| n > 0)?;
    if has_defs {
        let mut s = conn.prepare(
            "SELECT topic_type, encoding, encoded_message_definition FROM message_definitions",
        )?;
        let rows = s.query_map([], |r| {
            Ok((
                r.get::<_, String>(0)?,
                r.get::<_, String>(1)?,
                r.get::<_, String>(2)?,
            ))
        })?;
        for row in rows {
            let (ty, enc, def) = row?;
            if enc == "ros2msg" {
                defs.insert(ty, def);
            }
        }
    }
    let mut s = conn.prepare("SELECT id, name, type FROM topics")?;
    let rows = s.query_map([], |r| {
        Ok((
            r.get::<_, i64>(0)?,
            r.get::<_, String>(1)?,
            r.get::<_, String>(2)?,
        ))
    })?;
    let mut out = Vec::new();
    for row in rows {
        let (id, name, ty) = row?;
        let def = defs.get(&ty).cloned().unwrap_or_default();
        out.push((id, name, ty, def));
    }
    Ok(out)
}

/// Topics listed in an MCAP file's summary section, if it has one.
fn mcap_summary(p: &Path) -> Result<Vec<(String, String, String)>, String> {
    use std::io::{Seek, SeekFrom};
    let mut file = File::open(p).map_err(|e| e.to_string())?;
    let len = file.seek(SeekFrom::End(0)).map_err(|e| e.to_string())?;
    // Footer: opcode, length, summary_start, summary_offset_start, crc, magic.
    let tail = 8 + 1 + 8 + 8 + 8 + 4;
    if len < tail as u64 + 8 {
        return Err("too short".into());
    }
    let mut t = vec![0u8; tail];
    file.seek(SeekFrom::Start(len - tail as u64))
        .map_err(|e| e.to_string())?;
    file.read_exact(&mut t).map_err(|e| e.to_string())?;
    let summary_start = u64::from_le_bytes(t[9..17].try_into().map_err(|_| "footer")?);
    if summary_start == 0 || summary_start >= len {
        return Err("no summary".into());
    }
    let mut buf = vec![0u8; (len - summary_start) as usize];
    file.seek(SeekFrom::Start(summary_start))
        .map_err(|e| e.to_string())?;
    file.read_exact(&mut buf).map_err(|e| e.to_string())?;
    let mut schemas = std::collections::HashMap::new();
    let mut out = Vec::new();
    let mut pos = 0usize;
    while pos + 9 <= buf.len() {
        let op = buf[pos];
        let n = u64::from_le_bytes(buf[pos + 1..pos + 9].try_into().map_err(|_| "rec")?) as usize;
        let Some(body) = buf.get(pos + 9..pos + 9 + n) else {
            break;
        };
        match mcap::parse_record(op, body) {
            Ok(mcap::records::Record::Schema { header, data }) => {
                schemas.insert(
                    header.id,
                    (
                        header.name.clone(),
                        String::from_utf8_lossy(&data).into_owned(),
                    ),
                );
            }
            Ok(mcap::records::Record::Channel(c)) => {
                let (ty, def) = schemas.get(&c.schema_id).cloned().unwrap_or_default();
                out.push((c.topic.clone(), ty, def));
            }
            _ => {}
        }
        pos += 9 + n;
    }
    Ok(out)
}
