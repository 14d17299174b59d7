//! rosbag2 `metadata.yaml`, versions 4 to 9 (Foxy to Jazzy): the storage
//! files, their format and compression, and the topics.

use yaml_rust2::{Yaml, YamlLoader};

/// What terraslip needs from `metadata.yaml`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Metadata {
    pub version: i64,
    /// `sqlite3` or `mcap`.
    pub storage: String,
    /// Storage files relative to the bag directory.
    pub files: Vec<String>,
    /// `""` or `zstd`.
    pub compression_format: String,
    /// `""`, `FILE` or `MESSAGE`.
    pub compression_mode: String,
    /// `(name, type)` of each topic.
    pub topics: Vec<(String, String)>,
}

impl Metadata {
    pub fn parse(text: &str) -> Result<Self, String> {
        let docs = YamlLoader::load_from_str(text).map_err(|e| e.to_string())?;
        let root = docs
            .first()
            .map(|d| &d["rosbag2_bagfile_information"])
            .filter(|d| !d.is_badvalue())
            .ok_or("no `rosbag2_bagfile_information` key")?;
        let s = |y: &Yaml| y.as_str().unwrap_or("").to_string();
        let version = root["version"].as_i64().ok_or("no `version`")?;
        if !(1..=9).contains(&version) {
            return Err(format!("version {version} is not one of 1 to 9"));
        }
        let files: Vec<String> = root["relative_file_paths"]
            .as_vec()
            .map(|v| v.iter().map(s).filter(|p| !p.is_empty()).collect())
            .unwrap_or_default();
        for f in &files {
            if std::path::Path::new(f).is_absolute() || f.split(['/', '\\']).any(|c| c == "..") {
                return Err(format!("storage file `{f}` is outside the bag directory"));
            }
        }
        let topics = root["topics_with_message_count"]
            .as_vec()
            .map(|v| {
                v.iter()
                    .map(|t| {
                        let m = &t["topic_metadata"];
                        (s(&m["name"]), s(&m["type"]))
                    })
                    .filter(|(n, _)| !n.is_empty())
                    .collect()
            })
            .unwrap_or_default();
        Ok(Self {
            version,
            storage: s(&root["storage_identifier"]),
            files,
            compression_format: s(&root["compression_format"]),
            compression_mode: s(&root["compression_mode"]),
            topics,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_foxy_v4_and_jazzy_v9() {
        let v4 = "rosbag2_bagfile_information:\n  version: 4\n  storage_identifier: sqlite3\n  relative_file_paths:\n    - b_0.db3.zstd\n  duration:\n    nanoseconds: 5\n  compression_format: zstd\n  compression_mode: FILE\n  topics_with_message_count:\n    - topic_metadata:\n        name: /odom\n        type: nav_msgs/msg/Odometry\n        serialization_format: cdr\n        offered_qos_profiles: \"- history: 3\\n\"\n      message_count: 3\n";
        let m = Metadata::parse(v4).unwrap();
        assert_eq!(m.version, 4);
        assert_eq!(m.files, vec!["b_0.db3.zstd"]);
        assert_eq!(m.compression_mode, "FILE");
        assert_eq!(
            m.topics,
            vec![("/odom".into(), "nav_msgs/msg/Odometry".into())]
        );
        let v9 = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/data/metadata_v9.yaml"
        ))
        .unwrap();
        let m = Metadata::parse(&v9).unwrap();
        assert_eq!(m.version, 9);
        assert_eq!(m.storage, "mcap");
        assert_eq!(m.topics.len(), 3);
        assert!(Metadata::parse("rosbag2_bagfile_information:\n  version: 12\n").is_err());
        assert!(Metadata::parse("a: [").is_err());
        let evil = v9.replace("- test1_mcap.mcap", "- ../../etc/passwd");
        assert!(Metadata::parse(&evil).is_err());
    }
}
