//! Atomic file output: write to a temporary file beside the target, flush,
//! then rename over it, so a reader (or a crash) never sees half a file.
//! The temporary `.NAME.PID.tmp` that a killed process leaves is removed by
//! the next writer of NAME.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::LogError;

/// A file being written; it appears under its final name only on
/// [`AtomicFile::commit`]. Dropped without commit, the temporary is removed.
pub struct AtomicFile {
    target: PathBuf,
    tmp: PathBuf,
    writer: Option<BufWriter<File>>,
}

impl AtomicFile {
    /// Starts writing `target` (its parent directory must exist), removing
    /// the temporaries of `target` left by processes that are gone.
    pub fn create(target: impl AsRef<Path>) -> Result<Self, LogError> {
        let target = target.as_ref().to_path_buf();
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "out".into());
        remove_stale_temps(parent_dir(&target), &[&name]);
        let tmp = target.with_file_name(format!(".{name}.{}.tmp", std::process::id()));
        let file = File::create(&tmp).map_err(|e| LogError::io(&tmp, e))?;
        Ok(Self {
            target,
            tmp,
            writer: Some(BufWriter::new(file)),
        })
    }

    /// The final path.
    pub fn path(&self) -> &Path {
        &self.target
    }

    /// Flushes, syncs and renames into place, then syncs the directory so
    /// that the rename survives a power loss too.
    pub fn commit(mut self) -> Result<(), LogError> {
        if let Some(w) = self.writer.take() {
            let file = w
                .into_inner()
                .map_err(|e| LogError::io(&self.tmp, e.into_error()))?;
            file.sync_all().map_err(|e| LogError::io(&self.tmp, e))?;
        }
        std::fs::rename(&self.tmp, &self.target).map_err(|e| LogError::io(&self.target, e))?;
        // Best effort: some filesystems cannot sync a directory, and the
        // file is in place (whole) either way.
        if let Ok(dir) = File::open(parent_dir(&self.target)) {
            let _ = dir.sync_all();
        }
        Ok(())
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match self.writer.as_mut() {
            Some(w) => w.write(buf),
            None => Err(std::io::Error::other("file already committed")),
        }
    }
    fn flush(&mut self) -> std::io::Result<()> {
        match self.writer.as_mut() {
            Some(w) => w.flush(),
            None => Ok(()),
        }
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.writer.is_some() {
            self.writer = None;
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Writes `bytes` to `path` atomically.
pub fn write_atomic(path: impl AsRef<Path>, bytes: &[u8]) -> Result<(), LogError> {
    let mut f = AtomicFile::create(path)?;
    let tmp = f.tmp.clone();
    f.write_all(bytes).map_err(|e| LogError::io(&tmp, e))?;
    f.commit()
}

/// An output directory held by one run while it writes: `DIR/.terraslip.lock`
/// holds the process id of its owner and is removed when the lock is
/// dropped. A lock left by a process that no longer runs is taken over.
pub struct DirLock {
    lock: PathBuf,
}

impl DirLock {
    /// Name of the lock file inside the directory.
    pub const FILE: &'static str = ".terraslip.lock";

    /// Creates `dir` if needed and locks it, or fails naming the run that
    /// holds it.
    pub fn acquire(dir: &Path) -> Result<Self, LogError> {
        std::fs::create_dir_all(dir).map_err(|e| LogError::io(dir, e))?;
        let lock = dir.join(Self::FILE);
        for _ in 0..2 {
            match std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&lock)
            {
                Ok(mut f) => {
                    let _ = write!(f, "{}", std::process::id());
                    return Ok(Self { lock });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let owner = lock_owner(&lock);
                    match owner {
                        Some(pid) if process_alive(pid) => {
                            return Err(LogError::Invalid {
                                path: dir.to_path_buf(),
                                reason: format!(
                                    "another run (process {pid}) is writing into this \
                                     directory; wait for it to finish or choose another --out"
                                ),
                            })
                        }
                        // Stale (its process is gone) or half-written: take it over.
                        _ => {
                            let _ = std::fs::remove_file(&lock);
                        }
                    }
                }
                Err(e) => return Err(LogError::io(&lock, e)),
            }
        }
        Err(LogError::Invalid {
            path: dir.to_path_buf(),
            reason: format!(
                "cannot take the lock {}; another run is starting, try again",
                Self::FILE
            ),
        })
    }

    /// Removes the temporaries [`AtomicFile`] left for `names` by processes
    /// that are gone (killed mid-run); a live process's are its own.
    pub fn remove_stale_temps(&self, names: &[&str]) {
        remove_stale_temps(parent_dir(&self.lock), names);
    }
}

/// The directory a file of `path` goes in (`.` for a bare name).
fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Removes from `dir` the temporaries `.NAME.PID.tmp` of `names` whose
/// process is gone; a live process's are its own.
fn remove_stale_temps(dir: &Path, names: &[&str]) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let file = entry.file_name();
        let file = file.to_string_lossy();
        let stale = names.iter().any(|n| {
            file.strip_prefix(&format!(".{n}."))
                .and_then(|rest| rest.strip_suffix(".tmp"))
                .and_then(|pid| pid.parse::<u32>().ok())
                .is_some_and(|pid| !process_alive(pid))
        });
        if stale {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

impl Drop for DirLock {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.lock);
    }
}

/// Whether process `pid` runs. Where that cannot be told (no `/proc`),
/// every process is taken to run, so a lock is never stolen.
/// The process id in the lock file `lock`. A run writes it just after
/// creating the file, so an empty file is read again for up to a second
/// before it counts as left behind.
fn lock_owner(lock: &Path) -> Option<u32> {
    for _ in 0..50 {
        let text = std::fs::read_to_string(lock).unwrap_or_default();
        if !text.trim().is_empty() {
            return text.trim().parse().ok();
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    None
}

fn process_alive(pid: u32) -> bool {
    if pid == std::process::id() {
        return true;
    }
    let proc = Path::new("/proc");
    !proc.is_dir() || proc.join(pid.to_string()).exists()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uncommitted_file_leaves_nothing_and_keeps_old_content() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.csv");
        write_atomic(&p, b"old").unwrap();
        {
            let mut f = AtomicFile::create(&p).unwrap();
            f.write_all(b"new half").unwrap();
            // dropped without commit: simulates an error mid-way
        }
        assert_eq!(std::fs::read(&p).unwrap(), b"old");
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(names.len(), 1, "temporary file left behind");
    }
}

#[cfg(test)]
mod lock_tests {
    use super::*;

    #[test]
    fn a_held_directory_is_refused_and_a_stale_lock_taken_over() {
        let dir = tempfile::tempdir().unwrap();
        let lock = DirLock::acquire(dir.path()).unwrap();
        let err = DirLock::acquire(dir.path())
            .err()
            .expect("held")
            .to_string();
        assert!(err.contains("another run (process"), "{err}");
        drop(lock);
        assert!(!dir.path().join(DirLock::FILE).exists());
        // A pid beyond any real one: its process is gone.
        std::fs::write(dir.path().join(DirLock::FILE), "4294967295").unwrap();
        std::fs::write(dir.path().join(".estimate.csv.4294967295.tmp"), "half").unwrap();
        std::fs::write(dir.path().join(".other.csv.12.tmp"), "not ours").unwrap();
        let live = dir
            .path()
            .join(format!(".estimate.csv.{}.tmp", std::process::id()));
        std::fs::write(&live, "being written").unwrap();
        let lock = DirLock::acquire(dir.path()).expect("stale lock taken over");
        lock.remove_stale_temps(&["estimate.csv"]);
        assert!(!dir.path().join(".estimate.csv.4294967295.tmp").exists());
        assert!(dir.path().join(".other.csv.12.tmp").exists());
        assert!(live.exists(), "a live process's temporary file is kept");
        drop(lock);
        // A lock file still empty after a second was left behind.
        std::fs::write(dir.path().join(DirLock::FILE), "").unwrap();
        DirLock::acquire(dir.path()).expect("empty lock taken over");
    }
}
