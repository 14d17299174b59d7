//! `calibrate validate`'s 2 s prediction scores what calibration selected:
//! the turn-rate and centripetal model where one was selected, read with
//! the file's `time_offset_s` (the Warthog's lidar pose is stamped late).

use std::path::Path;

use terraslip_calib::prediction::{score_timed, Timed};
use terraslip_calib::CalibConfig;
use terraslip_io::DriveLog;

#[test]
fn validate_predicts_with_the_selected_model_and_the_stored_offset() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/warthog_gravel");
    let log = DriveLog::read(&dir).unwrap();
    let logs = std::slice::from_ref(&log);
    let pf = terraslip_calib::calibrate(logs, &CalibConfig::default(), &|_| {})
        .unwrap()
        .params_file();
    let offset = terraslip_calib::validate::stored_offset(&pf).unwrap();
    assert!(offset > 0.2, "the lidar pose is stamped late: {offset}");
    let set = &pf.terrains["gravel"];
    assert_eq!(
        set.extra["rate_model"]["selected"],
        serde_json::json!(true),
        "calibration selects a variable model on this drive"
    );

    let scored = terraslip::validation::prediction(logs, &pf).unwrap();
    let w = log.meta.track_width.unwrap();
    let constant = set.params;
    let score = |t: Timed| {
        score_timed(&log.wheels, &log.pose, w, &|_| Some(t), Default::default()).unwrap()
    };
    let on_time = score(Timed::on_time(constant));
    let timed = score(Timed::new(constant, offset));
    assert!(
        scored.stats.mean_m < timed.stats.mean_m && timed.stats.mean_m < on_time.stats.mean_m,
        "selected model with the offset {:.3} m, constant with it {:.3} m, constant as stamped {:.3} m",
        scored.stats.mean_m,
        timed.stats.mean_m,
        on_time.stats.mean_m
    );

    // Without the selected model and the offset the file scores as the
    // constant ICRs read as stamped.
    let mut plain = pf.clone();
    let set = plain.terrains.get_mut("gravel").unwrap();
    set.extra.remove("rate_model");
    set.extra.remove("time_offset_s");
    let plain = terraslip::validation::prediction(logs, &plain).unwrap();
    assert_eq!(plain.segments, on_time.segments);
}
