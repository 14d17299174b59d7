//! Which files a bag is made of: storage kind and whole-file compression
//! by name, split files in recording order.

use std::path::{Path, PathBuf};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Storage {
    Mcap,
    Sqlite,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Whole {
    None,
    Zstd,
    Lz4,
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
pub(super) fn storage_files(dir: &Path) -> Vec<(PathBuf, Storage, Whole)> {
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

pub(super) fn kind_of(p: &Path) -> Option<(Storage, Whole)> {
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
