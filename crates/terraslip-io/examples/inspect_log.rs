//! Reads each log directory given on the command line and prints what it
//! holds, or the error, one line per log:
//! `cargo run -p terraslip-io --release --example inspect_log -- LOG...`.
fn main() {
    let mut failed = false;
    for dir in std::env::args().skip(1) {
        match terraslip_io::DriveLog::read(&dir) {
            Ok(log) => {
                println!(
                    "{dir}: {:.1} s, wheels {}, pose {}, imu {}, images {}, terrain {:?}, truth {}, warnings {}",
                    log.duration(),
                    log.wheels.len(),
                    log.pose.len(),
                    log.imu.len(),
                    log.images.len(),
                    log.terrain_names(),
                    log.truth.len(),
                    log.warnings.len()
                );
                for w in &log.warnings {
                    println!("  warning: {w}");
                }
            }
            Err(e) => {
                failed = true;
                println!("{dir}: error: {e}");
            }
        }
    }
    if failed {
        std::process::exit(1);
    }
}
