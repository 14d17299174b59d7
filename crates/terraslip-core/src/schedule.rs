//! How terrain evidence changes the filter ([`crate::filter::Filter`]):
//!
//! * **boost** (lv2019, wang2018): after a declared terrain change the ICR
//!   process noise is raised from `q_min` to `q_max` for `k` pose updates,
//!   then restored;
//! * **covariance reset** (chen2023): the ICR covariance block is reset to a
//!   large preset `P_B` at the change;
//! * **terrain memory** (terraslip): when the robot leaves a terrain where
//!   it has learned, the ICRs and their covariance are stored; when it
//!   returns, they are recalled at once and neither boost nor reset is
//!   applied, so there is nothing to learn again.
//!
//! Terrains are indices `0..MAX_TERRAINS` (the pipeline maps names).

use crate::filter::{Filter, FilterError, IcrNoise};
use crate::kinematics::IcrParams;
use crate::model::{self, SlipCov, K, SLIP};
use crate::terrain_belief::MAX_TERRAINS;

/// Standard deviations in the coordinates of [`IcrNoise`]: spread,
/// centre, `x_c` (m), common speed factor and speed factor difference.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IcrStd {
    /// Spread `y_l - y_r`, m.
    pub spread: f64,
    /// Centre `(y_l + y_r)/2`, m.
    pub centre: f64,
    /// `x_c`, m.
    pub x_c: f64,
    /// `(alpha_l + alpha_r)/2`.
    pub alpha: f64,
    /// `alpha_l - alpha_r`.
    pub alpha_diff: f64,
}

impl IcrStd {
    /// Covariance on `(y_l, y_r, x_c, alpha_l, alpha_r)`.
    pub fn to_slip_cov(self) -> SlipCov {
        IcrNoise {
            spread: self.spread * self.spread,
            centre: self.centre * self.centre,
            x_c: self.x_c * self.x_c,
            alpha: self.alpha * self.alpha,
            alpha_diff: self.alpha_diff * self.alpha_diff,
        }
        .to_slip_cov()
    }
}

/// Settings of the schedule.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScheduleConfig {
    /// Factor `q_max / q_min` on the ICR noise after a change (1 = no boost).
    pub boost_factor: f64,
    /// Number of pose updates the boost lasts (the papers' k = 5 at 1 Hz).
    pub boost_updates: u32,
    /// Covariance reset `P_B` at a change to an unlearned terrain.
    pub reset: Option<IcrStd>,
    /// The reset leaves the tread speed factor difference `alpha_l -
    /// alpha_r` as learned (its estimate and variance, in the filter's
    /// [`crate::model::FactorCoords`]; `P_B`'s entry is unused): it belongs to the robot (tyre pressure, wear, gearing), not to
    /// the ground, which acts on both treads alike. Re-inflating it makes a
    /// steady turn after a change ambiguous: there the heading rate sees
    /// `(alpha (v_r - v_l) - (alpha_l - alpha_r)(v_r + v_l)/2) / d`, and with
    /// both speeds constant the difference and `d` trade off freely.
    pub reset_keeps_alpha_diff: bool,
    /// Recall learned ICRs when a terrain is revisited.
    pub memory: bool,
    /// Seconds on a terrain (while moving) before what was learned there is
    /// worth remembering.
    pub memory_min_dwell: f64,
    /// Time constant (s) of the running average of the slip parameters that
    /// is remembered (0 = the estimate at the moment of leaving). Taken
    /// after half of `memory_min_dwell` (the re-convergence after arriving is
    /// left out). The estimate at any one moment wanders with the heading
    /// noise and with the turn rate (ICRs vary a few percent with it); the
    /// average over the stay is the better guess for the next visit.
    pub memory_average: f64,
    /// Floor on the recalled standard deviations: a stored estimate is not
    /// trusted more than this (terrain ICRs vary a little between visits).
    pub recall_floor: IcrStd,
}

impl Default for ScheduleConfig {
    fn default() -> Self {
        Self {
            boost_factor: 1.0,
            boost_updates: 0,
            reset: None,
            reset_keeps_alpha_diff: false,
            memory: false,
            memory_min_dwell: 20.0,
            memory_average: 0.0,
            recall_floor: IcrStd {
                spread: 0.004,
                centre: 0.005,
                x_c: 0.01,
                alpha: 0.003,
                alpha_diff: 0.001,
            },
        }
    }
}

/// What the schedule did at a terrain change.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ChangeAction {
    /// Same terrain as before: nothing.
    None,
    /// Learned ICRs recalled from memory.
    Recalled,
    /// Boost and/or reset started for learning.
    Learning,
}

#[derive(Debug, Clone, Copy)]
struct Memory {
    icr: IcrParams,
    cov: SlipCov,
}

/// Terrain-driven noise schedule and per-terrain ICR memory.
#[derive(Debug, Clone)]
pub struct NoiseSchedule {
    cfg: ScheduleConfig,
    current: Option<usize>,
    /// Seconds spent moving on the current terrain.
    dwell: f64,
    boost_left: u32,
    memory: [Option<Memory>; MAX_TERRAINS],
    /// Running average of the slip parameters on the current terrain and
    /// the seconds it covers.
    average: [f64; K],
    averaged: f64,
}

impl NoiseSchedule {
    /// An empty schedule (no terrain known yet, nothing remembered).
    pub fn new(cfg: ScheduleConfig) -> Self {
        Self {
            cfg,
            current: None,
            dwell: 0.0,
            boost_left: 0,
            memory: [None; MAX_TERRAINS],
            average: [0.0; K],
            averaged: 0.0,
        }
    }

    /// The terrain the schedule believes the robot is on.
    pub fn current(&self) -> Option<usize> {
        self.current
    }

    /// Whether ICRs are remembered for `terrain`.
    pub fn remembers(&self, terrain: usize) -> bool {
        self.memory.get(terrain).is_some_and(|m| m.is_some())
    }

    /// Seeds the memory of `terrain` (e.g. calibrated per-terrain ICRs)
    /// with standard deviations `std`. Out-of-range terrains are ignored.
    pub fn seed(&mut self, terrain: usize, icr: &IcrParams, std: IcrStd) {
        if let Some(slot) = self.memory.get_mut(terrain) {
            *slot = Some(Memory {
                icr: *icr,
                cov: std.to_slip_cov(),
            });
        }
    }

    /// Counts time on the current terrain; call after each prediction.
    pub fn on_predict(&mut self, filter: &Filter, dt: f64) {
        if !filter.is_still() && dt.is_finite() && dt > 0.0 {
            self.dwell += dt;
            if self.cfg.memory_average > 0.0 && self.dwell >= 0.5 * self.cfg.memory_min_dwell {
                // A plain mean until one time constant is covered, then
                // exponential: no start-up bias towards zero.
                self.averaged += dt;
                let a = dt / self.averaged.min(self.cfg.memory_average);
                let x = filter.state();
                for (i, m) in self.average.iter_mut().enumerate() {
                    *m += a * (x[SLIP + i] - *m);
                }
            }
        }
    }

    /// Counts down the boost; call after each pose update.
    pub fn on_update(&mut self, filter: &mut Filter) {
        if self.boost_left > 0 {
            self.boost_left -= 1;
            if self.boost_left == 0 {
                filter.set_schedule_scale(1.0);
            }
        }
    }

    /// The terrain evidence declares the robot is now on `terrain`.
    pub fn on_terrain(
        &mut self,
        filter: &mut Filter,
        terrain: usize,
    ) -> Result<ChangeAction, FilterError> {
        if self.current == Some(terrain) {
            return Ok(ChangeAction::None);
        }
        let first = self.current.is_none();
        if self.cfg.memory {
            if let Some(prev) = self.current {
                if self.dwell >= self.cfg.memory_min_dwell && prev < MAX_TERRAINS {
                    let cov = filter
                        .covariance()
                        .fixed_view::<K, K>(SLIP, SLIP)
                        .into_owned();
                    let mut icr = model::icr_of(&filter.state());
                    if self.averaged > 0.0 && self.average.iter().all(|v| v.is_finite()) {
                        let m = &self.average;
                        icr = IcrParams {
                            y_l: m[0],
                            y_r: m[1],
                            x_c: m[2],
                            alpha_l: m[3],
                            alpha_r: m[4],
                        };
                    }
                    self.memory[prev] = Some(Memory {
                        icr,
                        cov: floor_cov(&cov, &self.cfg.recall_floor),
                    });
                }
            }
        }
        self.current = Some(terrain);
        self.dwell = 0.0;
        self.averaged = 0.0;
        if self.cfg.memory {
            if let Some(Some(m)) = self.memory.get(terrain) {
                if self.cfg.reset_keeps_alpha_diff {
                    // The robot's factor difference as learned now, on the
                    // remembered common factor of this ground.
                    filter.reset_icr_keeping_factor_difference(Some(&m.icr), &m.cov)?;
                } else {
                    filter.reset_icr(Some(&m.icr), &m.cov)?;
                }
                self.boost_left = 0;
                filter.set_schedule_scale(1.0);
                return Ok(ChangeAction::Recalled);
            }
        }
        // The first terrain of a drive starts from the initial covariance:
        // there is no learned state to throw away.
        if first {
            return Ok(ChangeAction::Learning);
        }
        if let Some(pb) = self.cfg.reset {
            if self.cfg.reset_keeps_alpha_diff {
                filter.reset_icr_keeping_factor_difference(None, &pb.to_slip_cov())?;
            } else {
                filter.reset_icr(None, &pb.to_slip_cov())?;
            }
        }
        if self.cfg.boost_factor > 1.0 && self.cfg.boost_updates > 0 {
            self.boost_left = self.cfg.boost_updates;
            filter.set_schedule_scale(self.cfg.boost_factor);
        }
        Ok(ChangeAction::Learning)
    }
}

/// Raises the variances of `cov` (in `(d, c, x_c)` coordinates) to at least
/// the floor, keeping it symmetric positive-definite.
fn floor_cov(cov: &SlipCov, floor: &IcrStd) -> SlipCov {
    // A filter that lost definiteness (the papers' IEKF can) may hand over
    // an indefinite block: clip its eigenvalues at zero, then add the floor,
    // which is positive-definite, so the sum is too.
    let sym = 0.5 * (cov + cov.transpose());
    let psd = if sym.iter().all(|v| v.is_finite()) {
        let mut eig = sym.symmetric_eigen();
        eig.eigenvalues.apply(|v| *v = v.max(0.0));
        eig.recompose()
    } else {
        SlipCov::zeros()
    };
    0.5 * (psd + psd.transpose()) + floor.to_slip_cov()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::{FilterConfig, Variant};
    use crate::kinematics::IcrParams;
    use crate::model::{FactorCoords, MatN, State, FACTOR_DIFF, Y_L, Y_R};

    /// A reset `P_B` used by several tests.
    const PB: IcrStd = IcrStd {
        spread: 0.1,
        centre: 0.02,
        x_c: 0.05,
        alpha: 0.01,
        alpha_diff: 0.01,
    };

    /// Variance of `x[i] - x[j]`.
    fn var_of_difference(f: &Filter, i: usize, j: usize) -> f64 {
        let p = f.covariance();
        p[(i, i)] + p[(j, j)] - 2.0 * p[(i, j)]
    }

    fn filter() -> Filter {
        filter_in(FactorCoords::PerSpread)
    }

    fn filter_in(coords: FactorCoords) -> Filter {
        let mut c = FilterConfig::for_track(0.5);
        c.variant = Variant::Ekf;
        c.factor_coords = coords;
        let x0 = crate::model::state(0.0, 0.0, 0.0, &IcrParams::no_slip(0.5));
        let p0 = MatN::from_diagonal(&State::from([
            1.0, 1.0, 0.01, 1e-4, 1e-4, 1e-4, 1e-6, 1e-6, 1e-12,
        ]));
        Filter::new(x0, p0, c).unwrap()
    }

    #[test]
    fn boost_lasts_k_updates() {
        let mut f = filter();
        let mut s = NoiseSchedule::new(ScheduleConfig {
            boost_factor: 100.0,
            boost_updates: 3,
            ..Default::default()
        });
        assert_eq!(s.on_terrain(&mut f, 0).unwrap(), ChangeAction::Learning);
        assert_eq!(f.icr_noise_scale(), 1.0, "first terrain: no boost");
        s.on_terrain(&mut f, 1).unwrap();
        assert_eq!(f.icr_noise_scale(), 100.0);
        for _ in 0..2 {
            s.on_update(&mut f);
            assert_eq!(f.icr_noise_scale(), 100.0);
        }
        s.on_update(&mut f);
        assert_eq!(f.icr_noise_scale(), 1.0);
    }

    #[test]
    fn reset_sets_icr_block_and_decorrelates() {
        let mut f = filter();
        for _ in 0..100 {
            f.predict(0.2, 0.6, 0.02).unwrap();
        }
        assert!(f.covariance()[(2, 3)].abs() > 0.0);
        let mut s = NoiseSchedule::new(ScheduleConfig {
            reset: Some(PB),
            ..Default::default()
        });
        s.on_terrain(&mut f, 0).unwrap();
        s.on_terrain(&mut f, 1).unwrap();
        let p = f.covariance();
        assert_eq!(p[(2, 3)], 0.0);
        // var(d) = var(y_l) + var(y_r) - 2 cov = 0.01
        assert!((var_of_difference(&f, 3, 4) - 0.01).abs() < 1e-12);
        assert!((p[(5, 5)] - 0.0025).abs() < 1e-12);
    }

    #[test]
    fn reset_can_keep_the_learned_factor_difference() {
        let var_e = |f: &Filter| var_of_difference(f, 6, 7);
        for keep in [false, true] {
            let mut f = filter();
            let before = var_e(&f);
            let z_before = f.factor_difference();
            let mut s = NoiseSchedule::new(ScheduleConfig {
                reset: Some(PB),
                reset_keeps_alpha_diff: keep,
                ..Default::default()
            });
            s.on_terrain(&mut f, 0).unwrap();
            s.on_terrain(&mut f, 1).unwrap();
            assert_eq!(keep, f.factor_difference() == z_before);
            let var_d = var_of_difference(&f, 3, 4);
            assert!((var_d - 0.01).abs() < 1e-12, "d is reset either way");
            let want = if keep { before } else { 1e-4 };
            assert!(
                (var_e(&f) - want).abs() < 1e-12,
                "keep {keep}: {}",
                var_e(&f)
            );
            assert!(f.covariance().cholesky().is_some());
        }
    }

    #[test]
    fn memory_recalls_a_revisited_terrain() {
        let mut f = filter();
        let mut s = NoiseSchedule::new(ScheduleConfig {
            memory: true,
            memory_min_dwell: 1.0,
            reset: Some(PB),
            ..Default::default()
        });
        s.on_terrain(&mut f, 2).unwrap();
        let learned = IcrParams::new(0.4, -0.38, 0.03);
        f.reset_icr(Some(&learned), &SlipCov::from_diagonal_element(1e-6))
            .unwrap();
        for _ in 0..100 {
            f.predict(0.5, 0.5, 0.02).unwrap();
            s.on_predict(&f, 0.02);
        }
        assert_eq!(s.on_terrain(&mut f, 0).unwrap(), ChangeAction::Learning);
        f.reset_icr(
            Some(&IcrParams::new(0.3, -0.3, 0.0)),
            &SlipCov::from_diagonal_element(1e-4),
        )
        .unwrap();
        assert!(s.remembers(2) && !s.remembers(0));
        assert_eq!(s.on_terrain(&mut f, 2).unwrap(), ChangeAction::Recalled);
        let st = f.state();
        assert!((st[Y_L] - 0.4).abs() < 1e-12 && (st[Y_R] + 0.38).abs() < 1e-12);
        // Recalled spread std is at least the floor.
        assert!(var_of_difference(&f, 3, 4) >= 0.004f64.powi(2));
    }

    #[test]
    fn recall_keeps_the_robots_factor_difference() {
        for coords in [FactorCoords::Difference, FactorCoords::PerSpread] {
            let mut f = filter_in(coords);
            let mut s = NoiseSchedule::new(ScheduleConfig {
                memory: true,
                memory_min_dwell: 1.0,
                reset_keeps_alpha_diff: true,
                ..Default::default()
            });
            s.on_terrain(&mut f, 0).unwrap();
            // Terrain 0 learned with common factor 0.95 and no difference.
            let mut p = IcrParams::new(0.4, -0.38, 0.0);
            (p.alpha_l, p.alpha_r) = (0.95, 0.95);
            f.reset_icr(Some(&p), &SlipCov::from_diagonal_element(1e-6))
                .unwrap();
            for _ in 0..100 {
                f.predict(0.5, 0.5, 0.02).unwrap();
                s.on_predict(&f, 0.02);
            }
            s.on_terrain(&mut f, 1).unwrap();
            // Meanwhile the robot's difference is learned as 0.01.
            (p.alpha_l, p.alpha_r) = (1.005, 0.995);
            f.reset_icr(Some(&p), &SlipCov::from_diagonal_element(4e-6))
                .unwrap();
            let (z, var_z) = f.factor_difference();
            assert_eq!(s.on_terrain(&mut f, 0).unwrap(), ChangeAction::Recalled);
            let x = f.state();
            let (a, e) = (0.5 * (x[6] + x[7]), x[6] - x[7]);
            assert!((a - 0.95).abs() < 1e-9, "common factor from memory: {a}");
            // Same spread on both terrains here, so e is kept in either form.
            assert!((e - 0.01).abs() < 1e-9, "{coords:?}: difference kept: {e}");
            assert_eq!(f.factor_difference(), (z, var_z), "{coords:?}");
            let k = FACTOR_DIFF;
            let p = f.filter_covariance();
            assert!((0..model::N).all(|j| j == k || p[(k, j)] == 0.0));
            if coords == FactorCoords::Difference {
                let var_e = var_of_difference(&f, 6, 7);
                assert!((var_e - 8e-6).abs() < 1e-12, "{var_e}");
            }
        }
    }

    #[test]
    fn memory_keeps_the_average_over_the_stay_not_the_last_value() {
        let mut f = filter();
        let mut s = NoiseSchedule::new(ScheduleConfig {
            memory: true,
            memory_min_dwell: 2.0,
            memory_average: 10.0,
            ..Default::default()
        });
        s.on_terrain(&mut f, 1).unwrap();
        let cov = SlipCov::from_diagonal_element(1e-6);
        // 1 s settling (not averaged), 3 s at y_l = 0.40 and 1 s at 0.45:
        // remembered 0.4125 (a plain mean: shorter than the time constant).
        for k in 0..250 {
            let y_l = match k {
                0..=49 => 0.5,
                50..=199 => 0.40,
                _ => 0.45,
            };
            f.predict(0.5, 0.5, 0.02).unwrap();
            f.reset_icr(Some(&IcrParams::new(y_l, -0.38, 0.0)), &cov)
                .unwrap();
            s.on_predict(&f, 0.02);
        }
        s.on_terrain(&mut f, 0).unwrap();
        assert_eq!(s.on_terrain(&mut f, 1).unwrap(), ChangeAction::Recalled);
        let y_l = f.state()[Y_L];
        assert!((y_l - 0.4125).abs() < 2e-3, "recalled y_l {y_l}");
    }

    #[test]
    fn indefinite_block_is_stored_positive_definite() {
        let mut bad = SlipCov::from_diagonal_element(1e-4);
        bad[(0, 1)] = 2e-4;
        bad[(1, 0)] = 2e-4;
        bad[(2, 2)] = -1e-5;
        let f = floor_cov(&bad, &ScheduleConfig::default().recall_floor);
        assert!(f.cholesky().is_some());
        let nan = SlipCov::from_element(f64::NAN);
        assert!(floor_cov(&nan, &ScheduleConfig::default().recall_floor)
            .cholesky()
            .is_some());
    }

    #[test]
    fn short_visits_are_not_remembered() {
        let mut f = filter();
        let mut s = NoiseSchedule::new(ScheduleConfig {
            memory: true,
            ..Default::default()
        });
        s.on_terrain(&mut f, 0).unwrap();
        s.on_terrain(&mut f, 1).unwrap();
        assert!(!s.remembers(0));
        // Out of range seeds are ignored, not a panic.
        s.seed(
            99,
            &IcrParams::new(0.3, -0.3, 0.0),
            ScheduleConfig::default().recall_floor,
        );
    }
}
