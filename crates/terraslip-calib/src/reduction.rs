//! Reduced ICR models: the five parameters with some held at their
//! no-slip relation, for data too few to identify all five.
//!
//! Each reduction is a full parameter set with constraints, so whatever
//! reads a set (`estimate --init`, `validate`, the controller export) reads
//! it unchanged:
//!
//! - **symmetric ICRs**: `y_r = -y_l` (the tread ICRs' centre on the body's
//!   x axis, as the no-slip model has it);
//! - **`x_c` at 0**: the ICRs level with the body origin;
//! - **equal speed factors**: `alpha_r = alpha_l` (both treads slip alike).
//!
//! The constrained parameters are functions of the free ones (`y_r` of
//! `y_l`, `alpha_r` of `alpha_l`, `x_c` fixed), so a fit in the usual
//! vector `(y_l, y_r, x_c, alpha_l, alpha_r)` holds a reduction by
//! [`Reduction::apply`] and [`Reduction::free`]; with [`Reduction::NONE`]
//! both are the identity.

/// 1-sigma (m) over which an ICR coordinate counts as unresolved: the
/// 5 cm scale of the centripetal shift's identification (5 cm of `x_c`
/// per m/s).
pub const POSITION_SCALE: f64 = 0.05;

/// 1-sigma over which a speed factor counts as unresolved: the speed
/// factors of the two treads differ by 0.02-0.04 from one ground to
/// another on the Warthog drives, which a 1-sigma over 0.01 cannot tell.
pub const SPEED_FACTOR_SCALE: f64 = 0.01;

/// Which no-slip relations a parameter set holds.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Reduction {
    /// `y_r = -y_l`.
    pub symmetric: bool,
    /// `x_c = 0`.
    pub x_c_zero: bool,
    /// `alpha_r = alpha_l`.
    pub equal_alphas: bool,
}

impl Reduction {
    /// The full five-parameter model.
    pub const NONE: Reduction = Reduction {
        symmetric: false,
        x_c_zero: false,
        equal_alphas: false,
    };

    /// Every combination of the three relations, the full model first.
    pub fn all() -> [Reduction; 8] {
        std::array::from_fn(|k| Reduction {
            symmetric: k & 1 != 0,
            x_c_zero: k & 2 != 0,
            equal_alphas: k & 4 != 0,
        })
    }

    /// Whether no relation is held.
    pub fn is_none(self) -> bool {
        self == Self::NONE
    }

    /// Number of parameters the relations remove.
    pub fn removed(self) -> usize {
        [self.symmetric, self.x_c_zero, self.equal_alphas]
            .iter()
            .filter(|&&b| b)
            .count()
    }

    /// Imposes the relations on `(y_l, y_r, x_c, alpha_l, alpha_r)`: `y_r`
    /// from `y_l`, `alpha_r` from `alpha_l`, `x_c` set to 0.
    pub fn apply(self, v: &mut [f64; 5]) {
        if self.symmetric {
            v[1] = -v[0];
        }
        if self.x_c_zero {
            v[2] = 0.0;
        }
        if self.equal_alphas {
            v[4] = v[3];
        }
    }

    /// `free` with the parameters the relations determine taken out.
    pub fn free(self, free: [bool; 5]) -> [bool; 5] {
        [
            free[0],
            free[1] && !self.symmetric,
            free[2] && !self.x_c_zero,
            free[3],
            free[4] && !self.equal_alphas,
        ]
    }

    /// Whether every relation bears on a parameter `free` fits (a relation
    /// among held parameters changes nothing).
    pub fn applies_to(self, free: [bool; 5]) -> bool {
        (!self.symmetric || (free[0] && free[1]))
            && (!self.x_c_zero || free[2])
            && (!self.equal_alphas || (free[3] && free[4]))
    }

    /// Whether every parameter the relations remove is unresolved by the
    /// full fit whose 1-sigma are `std` (of y_l, y_r, x_c, alpha_l,
    /// alpha_r): over [`POSITION_SCALE`] for an ICR coordinate, over
    /// [`SPEED_FACTOR_SCALE`] for a speed factor (either of a pair).
    pub fn unresolved(self, std: &[f64; 5]) -> bool {
        // NaN (no 1-sigma) counts as unresolved.
        let over = |k: usize, scale: f64| std[k].is_nan() || std[k] > scale;
        (!self.symmetric || over(0, POSITION_SCALE) || over(1, POSITION_SCALE))
            && (!self.x_c_zero || over(2, POSITION_SCALE))
            && (!self.equal_alphas || over(3, SPEED_FACTOR_SCALE) || over(4, SPEED_FACTOR_SCALE))
    }

    /// 1-sigma of the five parameters from a fit's `std` in which the
    /// dependent ones are NaN (not fitted): `y_r`'s is `y_l`'s and
    /// `alpha_r`'s is `alpha_l`'s; `x_c` at 0 stays NaN.
    pub fn std(self, mut std: [f64; 5]) -> [f64; 5] {
        if self.symmetric {
            std[1] = std[0];
        }
        if self.equal_alphas {
            std[4] = std[3];
        }
        std
    }

    /// The relations in words, `"none"` for the full model.
    pub fn describe(self) -> String {
        let parts: Vec<&str> = [
            (self.symmetric, "y_r = -y_l"),
            (self.x_c_zero, "x_c = 0"),
            (self.equal_alphas, "alpha_r = alpha_l"),
        ]
        .iter()
        .filter(|p| p.0)
        .map(|p| p.1)
        .collect();
        if parts.is_empty() {
            "none".into()
        } else {
            parts.join(", ")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn none_is_the_identity_and_each_relation_holds() {
        let v0 = [1.1, -0.7, 0.09, 0.91, 0.94];
        let mut v = v0;
        Reduction::NONE.apply(&mut v);
        assert_eq!(v, v0);
        assert_eq!(Reduction::NONE.free([true; 5]), [true; 5]);
        for r in Reduction::all() {
            let mut v = v0;
            r.apply(&mut v);
            assert_eq!(r.symmetric, v[1] == -v[0]);
            assert_eq!(r.x_c_zero, v[2] == 0.0);
            assert_eq!(r.equal_alphas, v[4] == v[3]);
            let n_free = r.free([true; 5]).iter().filter(|&&f| f).count();
            assert_eq!(n_free, 5 - r.removed());
        }
        let x_c_zero = Reduction {
            x_c_zero: true,
            ..Reduction::NONE
        };
        assert!(!x_c_zero.applies_to([false, false, false, true, true]));
        assert!(x_c_zero.unresolved(&[0.01, 0.01, 0.09, 0.001, 0.001]));
        assert!(!x_c_zero.unresolved(&[0.2, 0.2, 0.02, 0.05, 0.05]));
        assert!(Reduction::NONE.unresolved(&[0.0; 5]));
    }
}
