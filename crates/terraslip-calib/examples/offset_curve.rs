//! Prints the stream-alignment score against the time offset for a log.
//! `cargo run --release -p terraslip-calib --example offset_curve -- LOG [max_s]`
use terraslip_calib::offset::estimate_offset;
use terraslip_calib::{SegmentConfig, Segments};
use terraslip_io::DriveLog;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let log = DriveLog::read(&args[1]).expect("log");
    let max: f64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(2.0);
    let cfg = SegmentConfig::default();
    let segs = Segments::build(&[&log], &[0.0], &cfg);
    println!("segments {} stats {:?}", segs.len(), segs.stats);
    if let Some((o, curve)) = estimate_offset(&log, &cfg, max, 0.05) {
        for (t, s) in curve {
            println!("{t:6.2} {s:.4}");
        }
        println!("best {o:.3}");
    }
}
