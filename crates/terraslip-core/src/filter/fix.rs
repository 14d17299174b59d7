//! A pose fix and what the update made of each of its parts.

/// One absolute pose observation. `None` = not measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseFix {
    /// `(east, north)`, m, world ENU.
    pub position: Option<(f64, f64)>,
    /// Yaw, rad, counter-clockwise from east (any branch).
    pub yaw: Option<f64>,
    /// Stated standard deviation of each position coordinate, m.
    pub std_xy: f64,
    /// Stated standard deviation of yaw, rad.
    pub std_yaw: f64,
    /// Whether the sensor stated these stds (false: they are a configured
    /// guess, which the noise learning replaces after a few fixes).
    pub stated: bool,
}

/// What happened to one part of a fix.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fate {
    /// Not in the fix.
    Absent,
    /// Fused.
    Fused,
    /// Rejected by the chi-square gate.
    Gated,
    /// Taken as the pose without the gate: the first fix of its kind, or
    /// after too many rejections.
    Anchored,
}

/// Result of one update.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpdateReport {
    /// Fate of the position part.
    pub position: Fate,
    /// Fate of the heading part.
    pub yaw: Fate,
    /// Normalised innovation squared of the position part (2 dof; 0 if absent).
    pub nis_position: f64,
    /// Normalised innovation squared of the heading part (1 dof; 0 if absent).
    pub nis_yaw: f64,
    /// The slip-change detector fired on this fix (the slip uncertainty was
    /// raised before fusing it).
    pub change: bool,
    /// The slip parameters had to be projected into the physical band.
    pub at_band: bool,
    /// Per part (position per axis, m²; heading, rad²), the variance a
    /// gated part's innovation left unexplained by its covariance
    /// (`max(0, ν² − S)`); 0 for a part not gated.
    pub unexplained: [f64; 2],
}
