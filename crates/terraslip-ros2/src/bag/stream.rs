//! Streaming a bag's messages file by file: MCAP chunks and sqlite rows,
//! whole-file decompression, per-message zstd.

use std::fs::File;
use std::io::{BufReader, Read};
use std::path::Path;

use super::files::{Storage, Whole};
use super::tables::{open_sqlite, sqlite_topics};
use super::{Bag, RawMessage};
use crate::Ros2Error;

impl Bag {
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
        if let Some(held) = self.held.clone() {
            let n = self.topics.len();
            for (i, m) in held.iter().enumerate() {
                let t = self.topics.get_mut(m.topic).ok_or_else(|| Ros2Error::Bag {
                    bag: self.path.clone(),
                    reason: format!("a held message names topic {}, of {} topics", m.topic, n),
                })?;
                t.count += 1;
                if want(m.topic) {
                    let raw = RawMessage {
                        topic: m.topic,
                        recv_ns: m.recv_ns,
                        data: &m.data,
                        index: i as u64,
                    };
                    f(self, raw)?;
                }
            }
            return Ok(());
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
    pub(super) fn warn(&mut self, w: String) {
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
