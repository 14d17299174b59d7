//! Options of one run besides the configuration.

/// Options of one run besides the configuration.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct RunOptions {
    /// Drop every pose fix with `t0 <= t < t1` (a simulated GNSS + compass
    /// outage, to measure dead reckoning).
    pub outage: Option<(f64, f64)>,
}
