//! `terraslip import BAG --out LOG [--topics FILE.toml]`: a rosbag2 recording
//! to a drive log, a thin command over terraslip-ros2.

use std::path::PathBuf;

use anyhow::{bail, Context, Result};

/// Convert a ROS 2 bag (MCAP or sqlite3) into a drive log.
///
/// Picks the wheel source (JointState, else Odometry or TwistStamped twist),
/// the pose reference (NavSatFix in ENU about the first good fix, else
/// PoseWithCovarianceStamped / PoseStamped, else Odometry pose), the heading
/// (Imu orientation, with a GNSS pose), imu.csv (Imu) and camera frames
/// (CompressedImage, else Image) by message type when the choice is unique;
/// rotates the IMU into base_link by the topics file, else /tf_static, else
/// from the data (gravity, the forward acceleration, the gyro against the
/// treads); leaves out a heading that disagrees with the GNSS course.
/// Without a topics file, an odometry twist's tread speeds are made with a
/// nominal separation (the URDF's wheel joints in /robot_description, else
/// [meta] track_width, else 1 m), and what is learned is in its scale.
/// --topics FILE.toml names topics and values and overrides all of this.
/// Prints topic -> file, counts, rates, gaps and every decision; writes
/// LOG/import.json with the same and the time origin, and, when the wheels
/// came from an odometry twist, LOG/controller.json: the controller's model
/// (spread = separation, x_c 0, speed factors 1) as an --init file.
#[derive(clap::Args, Debug)]
#[command(after_help = AFTER_HELP)]
pub struct Args {
    /// A bag directory with metadata.yaml, or one .mcap or .db3 file.
    pub bag: PathBuf,
    /// Log directory to write (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// Print the import report as one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

const AFTER_HELP: &str = "\
The topics file (--topics, a global option; every key optional):
  [wheels]
  topic = \"/joint_states\"   # JointState, Odometry or TwistStamped
  wheel_radius = 0.165       # JointState: m (velocities are rad/s; default: the URDF's)
  left = [\"left\"]            # JointState: left wheel joint name patterns
  right = [\"right\"]
  separation = 1.04          # Odometry/TwistStamped: the controller's effective
                             # separation S = wheel_separation x multiplier, m
                             # (default: a nominal one; results then in its scale)
  [pose]
  topic = \"/fix\"             # NavSatFix, Odometry, PoseStamped, PoseWithCovarianceStamped; \"\" for none
  lever_arm = [0.3, 0.0]     # m, where it sits from base_link's origin (x forward, y left);
                             # default: /tf_static's chain to the fix's frame_id (an
                             # Odometry's child_frame_id); written to meta.toml [pose]
  [heading]
  topic = \"/imu/data\"        # Imu orientation; \"\" for none
  yaw_offset_deg = 0.0       # yaw = imu_yaw + yaw_offset - declination
  declination_deg = 0.0      # magnetic declination, east positive
  std_deg = 5.0              # when the orientation covariance states none
  mount_rpy_deg = [90, 0, -90]  # the heading IMU's mounting (default: [imu]'s for the same topic)
  [imu]
  topic = \"/imu/data\"
  mount_rpy_deg = [90, 0, -90]  # roll, pitch, yaw (deg) of the IMU frame in base_link,
                             # URDF rpy; overrides /tf_static
  [tf]
  topic = \"/tf_static\"       # static transforms for the IMU's mounting and the pose's
                             # lever arm; \"\" for none
  base_frame = \"base_link\"
  [images]
  topic = \"\"
  [time]
  stamp = \"header\"           # or \"receive\"
  [meta]
  track_width = 0.555        # written to meta.toml

Examples:
  terraslip import husky_bag/ --out husky                       # no settings: decisions printed
  terraslip import husky_bag/ --out husky --topics husky.toml
  terraslip estimate husky_bag/ --topics husky.toml --out est   # the same, without the log";

pub fn run(args: Args) -> Result<()> {
    let bag = &args.bag;
    let out = &args.out;
    let mut inputs = super::inputs();
    inputs.add(bag, "the bag");
    inputs.check_dir("--out", out, &terraslip_io::DriveLog::FILES)?;
    if out.join("metadata.yaml").exists() {
        bail!("--out {} holds a bag; not writing there", out.display());
    }
    let mut cfg = super::bag::topics().config()?;
    cfg.strict |= super::bag::strict();
    let topics = super::bag::topics();
    let (log, report) = terraslip::bag::import_deciding(bag, topics, &cfg, out)?;
    log.write(out)
        .with_context(|| format!("writing log {}", out.display()))?;
    let json = serde_json::to_string_pretty(&report)?;
    terraslip_io::write_atomic(out.join("import.json"), json.as_bytes())?;
    eprint!("{}", report.to_text());
    if let Some(model) = terraslip_ros2::import::controller_model(&log.meta, &report) {
        let path = out.join(terraslip_ros2::import::CONTROLLER_FILE);
        model.write(&path)?;
        eprintln!(
            "{}: the controller's own model (spread = separation, x_c 0, speed factors 1); start from it with --init {}",
            path.display(),
            path.display()
        );
    }
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    eprintln!(
        "import: {} -> {} ({} wheels rows over {:.1} s)",
        bag.display(),
        out.display(),
        log.wheels.len(),
        log.duration()
    );
    if args.json {
        println!("{}", serde_json::to_string(&report)?);
    }
    Ok(())
}
