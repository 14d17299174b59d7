//! Recordings for tests, in two places:
//!
//! - the repository's `data/` ([`repo_data`]): ships with every clone, so a
//!   test reading it always runs;
//! - `../shared/data` beside the checkout ([`shared_data`]): the full sets
//!   (every BorealTC run, every DRIVE drive), which CI has and a user's
//!   clone does not. A test that needs them is skipped, saying
//!   "skipped: ... missing" on stderr, unless [`REQUIRE_SHARED`] is `1`;
//!   then it fails.

use std::io::Write;
use std::path::{Path, PathBuf};

/// The variable that makes tests needing `../shared` fail when it is
/// missing (CI sets it), rather than skip.
pub const REQUIRE_SHARED: &str = "TERRASLIP_REQUIRE_SHARED";

/// `data/<name>` in the repository: a recording that ships with it.
///
/// # Panics
/// When it is missing (the checkout is incomplete).
pub fn repo_data(name: &str) -> PathBuf {
    let path = repo_root().join("data").join(name);
    assert!(
        path.exists(),
        "{}: missing from the repository's data/",
        path.display()
    );
    path
}

/// `../shared/data/<rel>` beside the checkout, or `None` (after printing
/// "skipped: ... missing" on stderr) when it is missing and
/// [`REQUIRE_SHARED`] is not `1`.
///
/// # Panics
/// When the path is missing and [`REQUIRE_SHARED`] is `1`: the test fails
/// and says what it needed.
pub fn shared_data(rel: &str) -> Option<PathBuf> {
    let root = shared_root();
    let required = std::env::var(REQUIRE_SHARED).is_ok_and(|v| v == "1");
    match locate(root.join(rel), required) {
        Ok(Some(path)) => Some(path),
        Ok(None) => None,
        Err(message) => panic!("{message}"),
    }
}

/// The repository's root: two levels above a crate's manifest
/// (`crates/<name>/Cargo.toml`), with no `..` in the path a message shows.
fn repo_root() -> &'static Path {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    manifest.parent().and_then(Path::parent).unwrap_or(manifest)
}

/// `shared/data` beside the repository's root.
fn shared_root() -> PathBuf {
    let root = repo_root();
    root.parent().unwrap_or(root).join("shared/data")
}

/// `path` when it exists; else `Ok(None)` after printing why the test is
/// skipped, or the failure's message when the data are `required`.
fn locate(path: PathBuf, required: bool) -> Result<Option<PathBuf>, String> {
    if path.exists() {
        return Ok(Some(path));
    }
    let shown = path.display();
    if required {
        return Err(format!(
            "{shown} is missing: this test needs the shared recordings beside the checkout \
             ({REQUIRE_SHARED}=1)"
        ));
    }
    // Written to the process's stderr, not `eprintln!`: the test harness
    // captures the latter and shows it only for a failing test.
    let _ = writeln!(
        std::io::stderr(),
        "skipped: {shown} is missing (the shared recordings beside the checkout; \
         {REQUIRE_SHARED}=1 makes this a failure)"
    );
    Ok(None)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_recording_is_skipped_unless_required() {
        let missing = PathBuf::from("no/such/recording");
        assert_eq!(locate(missing.clone(), false), Ok(None));
        let message = locate(missing, true).unwrap_err();
        assert!(
            message.contains("no/such/recording is missing") && message.contains(REQUIRE_SHARED),
            "{message}"
        );
        let here = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
        assert_eq!(locate(here.clone(), true), Ok(Some(here)));
    }

    #[test]
    fn a_skipped_test_names_the_shared_path_without_dot_dot() {
        let root = shared_root();
        assert!(root.ends_with("shared/data"), "{}", root.display());
        assert!(
            root.components()
                .all(|c| c != std::path::Component::ParentDir),
            "{}",
            root.display()
        );
    }

    #[test]
    fn the_repository_data_is_found() {
        assert!(repo_data("warthog_gravel").join("meta.toml").is_file());
    }
}
