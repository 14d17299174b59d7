pub mod calibrate;
pub mod demo;
pub mod estimate;
pub mod report;
pub mod simulate;
pub mod terrain;

pub use terraslip::estimate::read_log;
