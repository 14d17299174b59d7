//! What a calibration says about a time offset the data do not pin down.

use terraslip_io::DriveLog;

use super::offset_profile::ProfiledOffset;

/// The warning for a time offset `o` (s) found at the edge of `±max`.
pub(super) fn offset_at_edge(log: &DriveLog, o: f64, max: f64) -> String {
    format!(
        "{}: the time offset {o:+.3} s is at the edge of its search range \
         (±{max} s), so the true offset may lie beyond it; check the two \
         clocks, or give it with --time-offset SECONDS",
        log.dir.display()
    )
}

/// The warning for a profiled offset `p` inside its search range whose
/// 1-sigma is over [`ProfiledOffset::PINNED_STD`] or unknown.
pub(super) fn offset_not_pinned(log: &DriveLog, p: &ProfiledOffset) -> String {
    let how = match p.std {
        Some(s) => format!("its 1-sigma is {s:.3} s"),
        None => "the profile of the fit has no minimum around it".into(),
    };
    format!(
        "{}: the time offset {:+.3} s is not pinned by the data ({how}); the \
         parameters depend on it, check the two clocks, or give it with \
         --time-offset SECONDS",
        log.dir.display(),
        p.offset
    )
}

/// The set's note on a searched offset's 1-sigma (`None`: not bracketed).
pub(super) fn offset_note(log: &DriveLog, std: Option<f64>) -> String {
    match std {
        Some(s) => format!(
            "time offset of {}: 1-sigma {s:.3} s (profile of the fit)",
            log.name()
        ),
        None => format!(
            "time offset of {}: not bracketed by the profile of the fit (no 1-sigma)",
            log.name()
        ),
    }
}
