//! Why a filter step could not be taken.

/// Why a filter step could not be taken. The filter is unchanged then.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FilterError {
    /// An input (speed, time step, measurement, std) is NaN/inf or out of range.
    BadInput(&'static str),
    /// A setting is out of range (the message names the key).
    BadConfig(&'static str),
    /// The innovation covariance (or the innovation-adaptive gain's window)
    /// is not positive-definite.
    SingularInnovation,
    /// The step would produce a non-finite state or covariance.
    NonFinite,
    /// The papers' innovation-adaptive update would leave a negative
    /// variance; the update is refused.
    LostDefiniteness,
}

impl core::fmt::Display for FilterError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::BadInput(what) => write!(f, "bad filter input: {what}"),
            Self::BadConfig(what) => write!(f, "invalid configuration: {what}"),
            Self::SingularInnovation => {
                write!(f, "innovation covariance is not positive-definite")
            }
            Self::NonFinite => write!(f, "filter step would produce non-finite values"),
            Self::LostDefiniteness => write!(f, "update would leave a negative variance"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for FilterError {}
