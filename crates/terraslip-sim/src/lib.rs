//! A ground-truth drive simulator for skid-steering robots.
//!
//! The truth is the ICR kinematic model ([`IcrParams::twist`]) with
//! per-terrain ICRs that move a few percent with the turn rate and speed,
//! blended over a second at terrain borders, and tread speed factors alpha
//! != 1; it is integrated exactly (constant twist on each step) in steps of at
//! most 1 ms, so the truth is not any filter's discretisation. An operator
//! drives manoeuvres with rate-limited commands through wheel speed
//! controllers with lag. Each sensor samples at its own rate with its own
//! imperfections (see [`scenario`]).
//!
//! Frames: world ENU metres, yaw radians counter-clockwise from east; body
//! REP-103 (x forward, y left). Time in seconds from the start of the drive.
//!
//! ```no_run
//! use terraslip_sim::{simulate, Scenario};
//! let run = simulate(&Scenario::builtin("papers").unwrap(), 1).unwrap();
//! println!("{} wheel samples", run.log.wheels.len());
//! run.write("papers-log").unwrap();
//! ```

// `!(x <= 0.5)` is meant: it is also true for NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
pub mod camera;
pub mod closed_loop;
mod error;
pub mod family;
mod motion;
mod operator;
mod recorder;
pub mod robot;
mod run;
pub mod scenario;
mod sensors;
mod simulate;
mod streams;
pub mod terrain;
mod timeline;
mod truth;

pub use camera::FrameSpec;
pub use error::SimError;
pub use recorder::GRAVITY;
pub use run::SimRun;
pub use scenario::{builtin_names, Scenario};
pub use simulate::{simulate, simulate_draw};
pub use terrain::Terrain;
pub use truth::TruthState;
