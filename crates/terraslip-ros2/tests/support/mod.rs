//! The Husky recording the repository ships (`data/husky_test1`, MCAP with
//! zstd chunks), and its sqlite3 copy written at test time, so both storage
//! formats are read on every clone.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use yaml_rust2::YamlLoader;

/// The shipped MCAP bag directory.
pub fn husky_mcap() -> PathBuf {
    terraslip_io::shared::repo_data("husky_test1")
}

/// Writes the shipped recording as a rosbag2 sqlite3 bag directory in
/// `dir` (`metadata.yaml` and `husky_test1.db3`, rosbag2's schema version
/// 4 as `rosbags-convert --dst-storage sqlite3` writes it): every message's
/// topic, receive stamp and bytes as they are in the MCAP, in stamp order.
/// Returns `dir`.
pub fn husky_db3(dir: &Path) -> PathBuf {
    let src = husky_mcap();
    let yaml = std::fs::read_to_string(src.join("metadata.yaml")).unwrap();
    let bytes = std::fs::read(src.join("husky_test1.mcap")).unwrap();
    let hashes = type_hashes(&yaml);

    let db = dir.join("husky_test1.db3");
    let conn = rusqlite::Connection::open(&db).unwrap();
    conn.execute_batch(
        "CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL);
         CREATE TABLE metadata(id INTEGER PRIMARY KEY, metadata_version INTEGER NOT NULL,
             metadata TEXT NOT NULL);
         CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,
             serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL,
             type_description_hash TEXT NOT NULL);
         CREATE TABLE message_definitions(id INTEGER PRIMARY KEY, topic_type TEXT NOT NULL,
             encoding TEXT NOT NULL, encoded_message_definition TEXT NOT NULL,
             type_description_hash TEXT NOT NULL);
         CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL,
             timestamp INTEGER NOT NULL, data BLOB NOT NULL);
         CREATE INDEX timestamp_idx ON messages (timestamp ASC);
         INSERT INTO schema VALUES (4, 'rosbags');",
    )
    .unwrap();
    let db_yaml = yaml
        .replace("husky_test1.mcap", "husky_test1.db3")
        .replace("storage_identifier: mcap", "storage_identifier: sqlite3");
    conn.execute(
        "INSERT INTO metadata VALUES (1, 9, ?1)",
        rusqlite::params![db_yaml],
    )
    .unwrap();

    let mut messages = Vec::new();
    let mut topics: BTreeMap<u16, (String, String, String)> = BTreeMap::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        let schema = m
            .channel
            .schema
            .as_ref()
            .expect("a ROS 2 channel has a schema");
        topics.entry(m.channel.id).or_insert_with(|| {
            let definition = String::from_utf8(schema.data.to_vec()).unwrap();
            (m.channel.topic.clone(), schema.name.clone(), definition)
        });
        messages.push((m.channel.id, m.log_time, m.data.into_owned()));
    }
    messages.sort_by_key(|&(_, t, _)| t);

    let tx = conn.unchecked_transaction().unwrap();
    for (id, (name, ty, definition)) in &topics {
        let hash = &hashes[name];
        tx.execute(
            "INSERT INTO topics VALUES (?1, ?2, ?3, 'cdr', '[]', ?4)",
            rusqlite::params![id, name, ty, hash],
        )
        .unwrap();
        tx.execute(
            "INSERT INTO message_definitions VALUES (?1, ?2, 'ros2msg', ?3, ?4)",
            rusqlite::params![id, ty, definition, hash],
        )
        .unwrap();
    }
    for (topic, t, data) in &messages {
        tx.execute(
            "INSERT INTO messages (topic_id, timestamp, data) VALUES (?1, ?2, ?3)",
            rusqlite::params![topic, *t as i64, data],
        )
        .unwrap();
    }
    tx.commit().unwrap();
    std::fs::write(dir.join("metadata.yaml"), db_yaml).unwrap();
    dir.to_path_buf()
}

/// Each topic's `type_description_hash` in `metadata.yaml`.
fn type_hashes(yaml: &str) -> BTreeMap<String, String> {
    let docs = YamlLoader::load_from_str(yaml).unwrap();
    let info = &docs[0]["rosbag2_bagfile_information"];
    info["topics_with_message_count"]
        .as_vec()
        .unwrap()
        .iter()
        .map(|t| {
            let m = &t["topic_metadata"];
            (
                m["name"].as_str().unwrap().to_string(),
                m["type_description_hash"].as_str().unwrap().to_string(),
            )
        })
        .collect()
}
