//! Reading the drives a terrain command learns from or is scored on.

use std::path::PathBuf;

use terraslip_io::DriveLog;

use super::progress::Progress;

pub(super) fn read_logs(paths: &[PathBuf], quiet: bool) -> anyhow::Result<Vec<DriveLog>> {
    let mut bar = Progress::new(paths.len() as u64, "reading logs", quiet);
    let mut logs = Vec::with_capacity(paths.len());
    for p in paths {
        let log = super::super::bag::read_full(p)?;
        logs.push(log);
        bar.inc();
    }
    bar.finish();
    Ok(logs)
}
