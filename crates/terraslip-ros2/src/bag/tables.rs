//! The storage files' own topic tables: the sqlite3 `topics` table and the
//! MCAP summary's channels and schemas.

use std::fs::File;
use std::io::Read;
use std::path::Path;

/// Opens a `.db3` file read-only and immutable (SQLite URI
/// `file:...?mode=ro&immutable=1`): no lock, no `-shm` / `-wal` sidecar
/// files, so a bag on a read-only mount reads and nothing is written
/// beside it. A recording being written is not a bag to read.
pub(super) fn open_sqlite(p: &Path) -> rusqlite::Result<rusqlite::Connection> {
    rusqlite::Connection::open_with_flags(
        sqlite_uri(p),
        rusqlite::OpenFlags::SQLITE_OPEN_READ_ONLY
            | rusqlite::OpenFlags::SQLITE_OPEN_URI
            | rusqlite::OpenFlags::SQLITE_OPEN_NO_MUTEX,
    )
}

/// The read-only, immutable SQLite URI of file `p`, its path
/// percent-encoded where a URI needs it (`%`, `?`, `#`, non-ASCII ...).
pub(super) fn sqlite_uri(p: &Path) -> String {
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
pub(super) fn sqlite_topics(
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
pub(super) fn mcap_summary(p: &Path) -> Result<Vec<(String, String, String)>, String> {
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
