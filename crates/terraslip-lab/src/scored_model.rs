//! A model `terraslip-lab heldout` scores: a twist per wheels row and a
//! clock offset per start.

use terraslip_core::Twist;
use terraslip_io::WheelSample;

/// A twist of a wheels row for a segment starting at `t` (s).
pub type TwistFn<'a> = Box<dyn Fn(f64, &WheelSample) -> Twist + 'a>;

/// A model to score: its twist of a wheels row for a segment starting at
/// `t` (s), and its clock offset at a start (s).
pub struct Model<'a> {
    pub name: String,
    pub twist: TwistFn<'a>,
    pub clock_at: Box<dyn Fn(f64) -> f64 + 'a>,
}
