use std::path::Path;

pub mod bag;
pub mod calibrate;
pub mod demo;
pub mod estimate;
#[cfg(feature = "ros2")]
pub mod import;
pub mod report;
#[cfg(feature = "ros2")]
pub mod ros2out;
pub mod simulate;
pub mod terrain;

/// Reads only what the estimator uses: wheels, pose, meta and terrain.
/// The imu stream alone can be four times the size of everything else;
/// truth is for scoring, not estimating.
pub fn read_log(dir: &Path) -> Result<terraslip_io::DriveLog, terraslip_io::LogError> {
    if !dir.is_dir() {
        return Err(terraslip_io::LogError::Invalid {
            path: dir.to_path_buf(),
            reason: "not a log directory".into(),
        });
    }
    let mut log = terraslip_io::DriveLog {
        dir: dir.to_path_buf(),
        ..Default::default()
    };
    log.wheels = terraslip_io::read_wheels(&dir.join("wheels.csv"), &mut log.warnings)?;
    let pose = dir.join("pose.csv");
    if pose.exists() {
        log.pose = terraslip_io::read_pose(&pose, &mut log.warnings)?;
    }
    let terrain = dir.join("terrain.csv");
    if terrain.exists() {
        log.terrain = terraslip_io::read_terrain(&terrain)?;
    }
    let meta = dir.join("meta.toml");
    if meta.exists() {
        log.meta = terraslip_io::read_meta(&meta)?;
    }
    Ok(log)
}
