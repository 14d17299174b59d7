//! The project's shared recordings for tests: `../shared/data` beside the
//! checkout (CI has it there). A test that needs them fails when they are
//! missing, unless `TERRASLIP_ALLOW_NO_SHARED=1` is set; then it says
//! "skipped" on stderr and gets `None`.

use std::path::{Path, PathBuf};

/// The variable that lets tests needing `../shared` skip (visibly).
pub const ALLOW_NO_SHARED: &str = "TERRASLIP_ALLOW_NO_SHARED";

/// `../shared/data/<rel>` beside the checkout, or `None` (after printing
/// "skipped: ...") when it is missing and [`ALLOW_NO_SHARED`] is `1`.
///
/// # Panics
/// When the path is missing and skipping was not allowed: the test fails
/// and says what it needed.
pub fn shared_data(rel: &str) -> Option<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data");
    let path = root.join(rel);
    if path.exists() {
        return Some(path);
    }
    let shown = path.display();
    if std::env::var(ALLOW_NO_SHARED).is_ok_and(|v| v == "1") {
        eprintln!("skipped: {shown} is missing ({ALLOW_NO_SHARED}=1)");
        return None;
    }
    panic!(
        "{shown} is missing: this test needs the shared recordings beside the checkout \
         (set {ALLOW_NO_SHARED}=1 to skip it)"
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_recording_fails_unless_skipping_is_allowed() {
        // The only test of this binary that reads the variable.
        let before = std::env::var(ALLOW_NO_SHARED).ok();
        std::env::remove_var(ALLOW_NO_SHARED);
        let failed = std::panic::catch_unwind(|| shared_data("no/such/recording"));
        let message = failed.unwrap_err();
        let message = message.downcast_ref::<String>().unwrap();
        assert!(
            message.contains("no/such/recording is missing"),
            "{message}"
        );
        std::env::set_var(ALLOW_NO_SHARED, "1");
        assert_eq!(shared_data("no/such/recording"), None);
        match before {
            Some(v) => std::env::set_var(ALLOW_NO_SHARED, v),
            None => std::env::remove_var(ALLOW_NO_SHARED),
        }
    }
}
