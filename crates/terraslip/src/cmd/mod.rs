pub mod calibrate;
pub mod demo;
pub mod estimate;
pub mod simulate;
pub mod terrain;
