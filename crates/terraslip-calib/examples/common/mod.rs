//! What the real-drive examples share: the drives of a data directory.

use terraslip_io::DriveLog;

/// The data directory: the first argument, by default `../shared/data/drive`.
pub fn data_dir(args: &[String]) -> String {
    args.first()
        .cloned()
        .unwrap_or_else(|| "../shared/data/drive".into())
}

/// Every readable log directory in `dir` whose path contains `filter`, in
/// name order; exits with the reason when `dir` cannot be read.
pub fn drives(dir: &str, filter: &str) -> Vec<DriveLog> {
    let mut paths: Vec<_> = match std::fs::read_dir(dir) {
        Ok(d) => d.filter_map(|e| e.ok()).map(|e| e.path()).collect(),
        Err(e) => {
            eprintln!("{dir}: {e}");
            std::process::exit(1);
        }
    };
    paths.sort();
    paths
        .iter()
        .filter(|p| p.to_string_lossy().contains(filter))
        .filter_map(|p| DriveLog::read(p).ok())
        .collect()
}
