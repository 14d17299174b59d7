//! The quick symmetric calibration of Mandow et al. eqs. 11-12.
//!
//! From spin-in-place segments (equal and opposite tread speeds), the
//! half-spread follows from the turned angle: `x_ICR = alpha (int V_r - int V_l) / (2 phi)`
//! (eq. 11, with alpha applied to the measured speeds so both equations
//! describe the same model); from straight segments, `alpha = 2 d / (int V_r + int V_l)`
//! (eq. 12). Each is pooled over all qualifying segments by least squares.
//! The result is symmetric: `y_l = -y_r = x_ICR`, `x_c = 0`, `alpha_l = alpha_r`.

use terraslip_core::IcrParams;

use crate::segment::Segments;

/// How many segments each equation used.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SymmetricFit {
    pub params: IcrParams,
    pub spin_segments: usize,
    pub straight_segments: usize,
}

/// What was missing for the quick calibration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SymmetricMissing {
    Spins,
    Straights,
}

/// A segment is a spin when its mean tread travel `int (V_r + V_l)/2` is
/// under 15 % of its half differential travel `int (V_r - V_l)/2` and it
/// turned at least 0.2 rad; straight when the half differential travel is
/// under 5 % of the mean travel, it moved over 5 cm and turned under 0.05 rad.
pub fn fit(segs: &Segments, active: &[bool]) -> Result<SymmetricFit, SymmetricMissing> {
    let (mut a_num, mut a_den, mut n_straight) = (0.0, 0.0, 0usize);
    let (mut x_num, mut x_den, mut n_spin) = (0.0, 0.0, 0usize);
    for (s, _) in segs.segments.iter().zip(active).filter(|(_, &a)| a) {
        let r = s.reference;
        let half_diff = 0.5 * s.int_diff.abs();
        if half_diff < 0.05 * s.int_mean.abs() && r.dyaw.abs() < 0.05 && s.int_mean.abs() > 0.05 {
            // d = alpha * int_mean (signed: reversing counts too)
            a_num += r.dx * s.int_mean;
            a_den += s.int_mean * s.int_mean;
            n_straight += 1;
        }
        if s.int_mean.abs() < 0.15 * half_diff && r.dyaw.abs() > 0.2 {
            // phi = alpha * int_diff / (2 x_ICR)  =>  (2 phi) * k = int_diff, k = x_ICR/alpha
            x_num += 2.0 * r.dyaw * s.int_diff;
            x_den += 4.0 * r.dyaw * r.dyaw;
            n_spin += 1;
        }
    }
    if n_straight == 0 || a_den <= 0.0 {
        return Err(SymmetricMissing::Straights);
    }
    if n_spin == 0 || x_den <= 0.0 {
        return Err(SymmetricMissing::Spins);
    }
    let alpha = a_num / a_den;
    let x_icr = alpha * x_num / x_den;
    Ok(SymmetricFit {
        params: IcrParams {
            y_l: x_icr,
            y_r: -x_icr,
            x_c: 0.0,
            alpha_l: alpha,
            alpha_r: alpha,
        },
        spin_segments: n_spin,
        straight_segments: n_straight,
    })
}
