//! The physical limits of the filter's states besides the slip band.

/// Largest clock offset of the pose stream the filter accepts, s.
pub const MAX_CLOCK_OFFSET: f64 = 1.0;
/// Largest turn law slope, s/m.
pub const MAX_TURN_LAW: f64 = 1.0;
/// Largest gyro scale error `|k_g|` the filter accepts.
pub const MAX_GYRO_SCALE: f64 = 0.2;
/// Largest centripetal term `|k_x_speed|`, s (`x_c` moves by at most a
/// metre per m/s).
pub const MAX_K_X_SPEED: f64 = 1.0;
/// Largest centripetal term `|k_spread_speed|`, s/m.
pub const MAX_K_SPREAD_SPEED: f64 = 1.0;
