//! Reading the drives a calibration or validation is given.

use std::path::PathBuf;

use anyhow::bail;

use terraslip_io::DriveLog;

/// Reads the logs; a bag without a pose reference is refused naming its
/// topics (a log directory's is told by the calibration).
pub(super) fn read_logs(paths: &[PathBuf]) -> anyhow::Result<Vec<DriveLog>> {
    let read = |p: &PathBuf| {
        let log = super::super::bag::read_full(p)?;
        if log.pose.is_empty() {
            if let Some(topics) = super::super::bag::bag_topics(p) {
                bail!(
                    "{}: no pose reference among its topics ({topics}); calibration needs \
                     positions: sensor_msgs/NavSatFix or a pose (Odometry, PoseStamped, \
                     PoseWithCovarianceStamped); an IMU heading helps only beside them",
                    p.display()
                );
            }
        }
        Ok(log)
    };
    paths.iter().map(read).collect()
}
