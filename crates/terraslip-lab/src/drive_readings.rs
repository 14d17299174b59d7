//! DRIVE's learned slip model in `terraslip-lab heldout`, two readings:
//! by this port ([`crate::blr`]) and by DRIVE's own protocol
//! ([`crate::drive_protocol`]).

use anyhow::Context;
use terraslip_io::{DriveLog, WheelSample};

use crate::blr::{Blr, OFFSETS};
use crate::drive_protocol;
use crate::scored_model::Model;

/// DRIVE's model by this port's steady rows.
pub const DRIVE: &str = "DRIVE's model";
/// DRIVE's model by DRIVE's own protocol.
pub const DRIVE_PROTOCOL: &str = "DRIVE's model (DRIVE's protocol)";

/// DRIVE's model, with the clock offset it was trained with.
pub fn drive_model<'a>(blr: Blr, name: &str) -> Model<'a> {
    Model {
        name: name.into(),
        twist: Box::new(move |_, s: &WheelSample| blr.twist(s)),
        clock_at: Box::new(move |_| blr.clock_offset),
    }
}

/// DRIVE's model trained on `log`'s `[t0, t1)` by DRIVE's protocol
/// ([`crate::drive_protocol`], else the port's) and by this port's.
pub fn drive_models<'a>(log: &DriveLog, t0: f64, t1: f64) -> anyhow::Result<[Model<'a>; 2]> {
    let w = log.meta.track_width.unwrap_or(0.5);
    let port = Blr::fit_timed(log, w, t0, t1).context("DRIVE's model: too few steady rows")?;
    let windows = drive_protocol::Windows::of(&log.wheels);
    let protocol = windows
        .and_then(|windows| drive_protocol::fit_timed(log, &windows, w, t0, t1, &OFFSETS))
        .unwrap_or_else(|| {
            let why = match windows {
                Some(_) => "too few steady windows in the training span",
                None => "not a log of DRIVE's 2 s windows",
            };
            eprintln!("  DRIVE's protocol: {why}; its column repeats the port");
            port
        });
    Ok([
        drive_model(protocol, DRIVE_PROTOCOL),
        drive_model(port, DRIVE),
    ])
}
