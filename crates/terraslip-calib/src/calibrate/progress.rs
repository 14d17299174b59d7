//! Progress events of a calibration, for a command line progress bar.

/// Progress events for a CLI progress bar.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Progress<'a> {
    Stage(&'a str),
    Generation { done: usize, total: usize },
}
