//! Reading a sqlite3 bag leaves it as it was: a WAL-mode `.db3` (as
//! `ros2 bag record` writes them) gets no `-shm` / `-wal` sidecar files, and
//! the bag directory's listing and the file's bytes are unchanged.

use std::path::Path;

use terraslip_ros2::msg::CdrWriter;
use terraslip_ros2::{import, TopicsConfig};

const T0: i64 = 1_700_000_000_000_000_000;

/// A one-topic sqlite3 bag (a `TwistStamped` wheel source) in WAL mode.
fn write_wal_db3(db: &Path) {
    let conn = rusqlite::Connection::open(db).unwrap();
    let mode: String = conn
        .query_row("PRAGMA journal_mode=WAL", [], |r| r.get(0))
        .unwrap();
    assert_eq!(mode, "wal");
    conn.execute_batch(
        "CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,
            serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL);
         CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL,
            timestamp INTEGER NOT NULL, data BLOB NOT NULL);
         INSERT INTO topics VALUES(1, '/cmd_odom', 'geometry_msgs/msg/TwistStamped', 'cdr', '');",
    )
    .unwrap();
    for k in 0..50i64 {
        let ns = T0 + k * 100_000_000;
        let mut w = CdrWriter::new();
        w.header(ns as u64, "base_link");
        for c in [1.0, 0.0, 0.0, 0.0, 0.0, 0.2] {
            w.f64(c);
        }
        conn.execute(
            "INSERT INTO messages(topic_id, timestamp, data) VALUES(1, ?1, ?2)",
            rusqlite::params![ns, w.finish()],
        )
        .unwrap();
    }
}

fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn a_wal_mode_db3_is_read_without_writing_beside_it() {
    let tmp = tempfile::tempdir().unwrap();
    let bag = tmp.path().join("my bag #1 é");
    std::fs::create_dir(&bag).unwrap();
    let db = bag.join("bag_0.db3");
    write_wal_db3(&db);
    // The recorder closed the file: its sidecars are gone, WAL stays set.
    assert_eq!(listing(&bag), ["bag_0.db3"]);
    let bytes = std::fs::read(&db).unwrap();
    assert_eq!(bytes[18..20], [2, 2], "the file is in WAL mode");
    let mut perms = std::fs::metadata(&bag).unwrap().permissions();
    perms.set_readonly(true);
    std::fs::set_permissions(&bag, perms.clone()).unwrap();

    let read = import(&bag, &TopicsConfig::default(), None);
    let after = listing(&bag);
    #[allow(clippy::permissions_set_readonly_false)]
    perms.set_readonly(false);
    std::fs::set_permissions(&bag, perms).unwrap();
    let (log, _) = read.unwrap();
    assert_eq!(log.wheels.len(), 50);
    assert_eq!(after, ["bag_0.db3"], "nothing written beside the bag");
    assert_eq!(std::fs::read(&db).unwrap(), bytes, "the file is unchanged");
}
