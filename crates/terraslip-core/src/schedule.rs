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
//!   applied, so there is nothing to learn again;
//! * **given sets** (`--init`): a set given for a terrain, or the set the
//!   drive started from, is what a change the slip-change detector finds
//!   falls back to (with the set's own covariance), rather than the
//!   current estimate with its uncertainty raised; once the filter's
//!   estimates on that ground cover `memory_min_dwell` seconds of driving
//!   (taken after half of it, as the memory's average), the fallback is
//!   their mean (the set's covariance kept).
//!
//! Terrains are indices `0..MAX_TERRAINS` (the pipeline maps names).

use crate::filter::{Filter, FilterError, SlipStd};
use crate::kinematics::IcrParams;
use crate::slip::SlipMat;
use crate::terrain_belief::MAX_TERRAINS;

/// Number of slip parameters remembered per terrain.
const K: usize = 5;

/// Settings of the schedule.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ScheduleConfig {
    /// Factor `q_max / q_min` on the ICR noise after a change (1 = no boost).
    pub boost_factor: f64,
    /// Number of pose updates the boost lasts (the papers' k = 5 at 1 Hz).
    pub boost_updates: u32,
    /// Covariance reset `P_B` at a change to an unlearned terrain.
    pub reset: Option<SlipStd>,
    /// Recall learned ICRs when a terrain is revisited.
    pub memory: bool,
    /// Seconds on a terrain (while moving) before what was learned there is
    /// worth remembering; and, taken after half of it, seconds of estimates
    /// a detected change under a given set needs before it falls back to
    /// their mean rather than to the set ([`NoiseSchedule::fallback`]).
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
    pub recall_floor: SlipStd,
}

/// The slip uncertainty a declared change to an unlearned terrain resets
/// to (chen2023's `P_B`). Every parameter is reset, the speed factor
/// difference included: the ground changes it too (the Warthog's
/// calibrations: -0.03 on sand, +0.04 on ice).
pub const RESET_STD: SlipStd = SlipStd {
    spread: 0.1,
    centre: 0.01,
    x_c: 0.02,
    alpha: 0.05,
    alpha_diff: 0.01,
};

/// The shipped schedule: reset at a change to an unlearned terrain, recall
/// on a revisit (the remembered set as it was learned), no boost.
impl Default for ScheduleConfig {
    fn default() -> Self {
        Self {
            boost_factor: 1.0,
            boost_updates: 0,
            reset: Some(RESET_STD),
            memory: true,
            memory_min_dwell: 20.0,
            memory_average: 40.0,
            recall_floor: SlipStd {
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
    /// A declared change the fixes contradicted was undone: the terrain and
    /// the slip state held before it are back (set by the terrain evidence's
    /// trial of a change, not by the schedule).
    Undone,
}

#[derive(Debug, Clone, Copy)]
struct Memory {
    icr: IcrParams,
    cov: SlipMat,
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
    /// The sets given per terrain (`--init`), as given.
    given: [Option<Memory>; MAX_TERRAINS],
    /// The given set the drive started from, while no terrain is known.
    start: Option<Memory>,
    /// Running average of the slip parameters on the current terrain and
    /// the seconds it covers.
    average: [f64; K],
    averaged: f64,
    /// Time integral of the slip parameters over the same stretch, and the
    /// seconds it covers: the plain mean of the stay.
    stay_sum: [f64; K],
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
            given: [None; MAX_TERRAINS],
            start: None,
            average: [0.0; K],
            averaged: 0.0,
            stay_sum: [0.0; K],
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
    pub fn seed(&mut self, terrain: usize, icr: &IcrParams, std: SlipStd) {
        let m = Memory {
            icr: *icr,
            cov: std.icr_cov(),
        };
        if let (Some(slot), Some(given)) =
            (self.memory.get_mut(terrain), self.given.get_mut(terrain))
        {
            *slot = Some(m);
            *given = Some(m);
        }
    }

    /// Records the given set (e.g. an `--init` calibration) the drive
    /// starts from, with standard deviations `std`: what a detected slip
    /// change falls back to while no terrain is declared.
    pub fn start_from(&mut self, icr: &IcrParams, std: SlipStd) {
        self.start = Some(Memory {
            icr: *icr,
            cov: std.icr_cov(),
        });
    }

    /// The slip-change detector fired. With a set given for the current
    /// terrain (or, no terrain declared, the set the drive started from),
    /// the filter's slip parameters fall back with the set's covariance, to
    /// the set itself or, once the stay covers `memory_min_dwell` seconds,
    /// to the mean of the filter's estimates over the stay
    /// ([`Self::fallback`]), and `true` is returned; otherwise nothing is
    /// done (the filter has raised its slip uncertainty itself).
    pub fn on_detected_change(&mut self, filter: &mut Filter) -> Result<bool, FilterError> {
        let given = match self.current {
            Some(k) => self.given.get(k).copied().flatten(),
            None => self.start,
        };
        match given {
            Some(m) => {
                filter.set_slip(&self.fallback(&m.icr), &m.cov)?;
                Ok(true)
            }
            None => Ok(false),
        }
    }

    /// Where a detected change on a ground with a given set `given` falls
    /// back to: the mean of the filter's slip parameters over the stay
    /// (taken after half of `memory_min_dwell`, as the memory's average)
    /// once it covers `memory_min_dwell` seconds of driving (what the drive has
    /// shown of this ground: the estimate at the alarm is what the detector
    /// found wrong, and the mean is taken from the given set onwards, each
    /// earlier fallback included), else `given`. A stay that does not give
    /// a usable set leaves `given`.
    pub fn fallback(&self, given: &IcrParams) -> IcrParams {
        if self.averaged <= 0.0 || self.averaged < self.cfg.memory_min_dwell {
            return *given;
        }
        let mean = from_entries(&self.stay_sum.map(|v| v / self.averaged));
        if mean.validate().is_ok() {
            mean
        } else {
            *given
        }
    }

    /// Counts time on the current terrain; call after each prediction.
    pub fn on_predict(&mut self, filter: &Filter, dt: f64) {
        if !filter.is_still() && dt.is_finite() && dt > 0.0 {
            self.dwell += dt;
            if self.dwell >= 0.5 * self.cfg.memory_min_dwell {
                // A plain mean until one time constant is covered, then
                // exponential: no start-up bias towards zero.
                self.averaged += dt;
                let a = dt / self.averaged.min(self.cfg.memory_average);
                let p = filter.icr();
                let x = [p.y_l, p.y_r, p.x_c, p.alpha_l, p.alpha_r];
                for ((m, s), v) in self.average.iter_mut().zip(&mut self.stay_sum).zip(x) {
                    if self.cfg.memory_average > 0.0 {
                        *m += a * (v - *m);
                    }
                    *s += v * dt;
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
                    let cov = filter.icr_covariance();
                    let mut icr = filter.icr();
                    if self.cfg.memory_average > 0.0
                        && self.averaged > 0.0
                        && self.average.iter().all(|v| v.is_finite())
                    {
                        icr = from_entries(&self.average);
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
        self.stay_sum = [0.0; K];
        if self.cfg.memory {
            if let Some(Some(m)) = self.memory.get(terrain) {
                filter.set_slip(&m.icr, &m.cov)?;
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
            filter.reset_slip(None, &pb)?;
        }
        if self.cfg.boost_factor > 1.0 && self.cfg.boost_updates > 0 {
            self.boost_left = self.cfg.boost_updates;
            filter.set_schedule_scale(self.cfg.boost_factor);
        }
        Ok(ChangeAction::Learning)
    }
}

/// The slip parameters from their entries `(y_l, y_r, x_c, alpha_l,
/// alpha_r)` (m, m, m, 1, 1), the order the schedule averages them in.
fn from_entries(m: &[f64; K]) -> IcrParams {
    IcrParams {
        y_l: m[0],
        y_r: m[1],
        x_c: m[2],
        alpha_l: m[3],
        alpha_r: m[4],
    }
}

/// Raises the variances of `cov` (in `(d, c, x_c)` coordinates) to at least
/// the floor, keeping it symmetric positive-definite.
fn floor_cov(cov: &SlipMat, floor: &SlipStd) -> SlipMat {
    // A filter that lost definiteness (the papers' IEKF can) may hand over
    // an indefinite block: clip its eigenvalues at zero, then add the floor,
    // which is positive-definite, so the sum is too.
    let sym = 0.5 * (cov + cov.transpose());
    let psd = if sym.iter().all(|v| v.is_finite()) {
        let mut eig = sym.symmetric_eigen();
        eig.eigenvalues.apply(|v| *v = v.max(0.0));
        eig.recompose()
    } else {
        SlipMat::zeros()
    };
    0.5 * (psd + psd.transpose()) + floor.icr_cov()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::{FilterConfig, IcrBand, MeasurementConfig, Prior};
    use crate::model::{CLOCK, SLIP};
    use crate::slip::Chart;

    /// A reset `P_B` used by several tests.
    const PB: SlipStd = SlipStd {
        spread: 0.1,
        centre: 0.02,
        x_c: 0.05,
        alpha: 0.01,
        alpha_diff: 0.01,
    };

    fn filter(chart: Chart) -> Filter {
        let cfg = FilterConfig {
            chart,
            ..Default::default()
        };
        let prior = Prior {
            icr: IcrParams::no_slip(0.5),
            std: SlipStd {
                spread: 0.01,
                centre: 0.01,
                x_c: 0.01,
                alpha: 0.001,
                alpha_diff: 0.001,
            },
            turn_law: 0.0,
            turn_law_std: 0.1,
            centripetal: crate::kinematics::CentripetalSlopes::NONE,
            centripetal_std: crate::kinematics::CentripetalSlopes::NONE,
            speed_law: 0.0,
            speed_law_std: 0.0,
        };
        let band = IcrBand {
            min_spread: 0.4,
            max_spread: 2.0,
            max_centre: 0.125,
            max_x_c: 0.25,
            alpha_range: (0.3, 1.5),
        };
        Filter::new(&prior, cfg, MeasurementConfig::default(), band).unwrap()
    }

    fn var_spread(f: &Filter) -> f64 {
        let c = f.icr_covariance();
        c[(0, 0)] + c[(1, 1)] - 2.0 * c[(0, 1)]
    }

    fn var_factor_difference(f: &Filter) -> f64 {
        let c = f.icr_covariance();
        c[(3, 3)] + c[(4, 4)] - 2.0 * c[(3, 4)]
    }

    fn learned(y_l: f64, a: f64, e: f64) -> IcrParams {
        IcrParams {
            y_l,
            y_r: -0.38,
            x_c: 0.0,
            alpha_l: a + 0.5 * e,
            alpha_r: a - 0.5 * e,
        }
    }

    #[test]
    fn boost_lasts_k_updates() {
        let mut f = filter(Chart::Tread);
        let mut s = NoiseSchedule::new(ScheduleConfig {
            boost_factor: 100.0,
            boost_updates: 3,
            ..Default::default()
        });
        assert_eq!(s.on_terrain(&mut f, 0).unwrap(), ChangeAction::Learning);
        assert_eq!(f.schedule_scale(), 1.0, "first terrain: no boost");
        s.on_terrain(&mut f, 1).unwrap();
        assert_eq!(f.schedule_scale(), 100.0);
        for _ in 0..2 {
            s.on_update(&mut f);
            assert_eq!(f.schedule_scale(), 100.0);
        }
        s.on_update(&mut f);
        assert_eq!(f.schedule_scale(), 1.0);
    }

    #[test]
    fn reset_sets_the_slip_block_and_decorrelates_it() {
        for chart in [Chart::Tread, Chart::Gain] {
            let mut f = filter(chart);
            f.predict(0.0, 0.0, 0.0).unwrap();
            for _ in 0..100 {
                f.predict(0.2, 0.6, 0.02).unwrap();
            }
            let (_, p) = f.raw();
            assert!(p[(2, SLIP)].abs() > 0.0);
            let mut s = NoiseSchedule::new(ScheduleConfig {
                reset: Some(PB),
                ..Default::default()
            });
            s.on_terrain(&mut f, 0).unwrap();
            s.on_terrain(&mut f, 1).unwrap();
            let (_, p) = f.raw();
            for i in SLIP..SLIP + 5 {
                for j in (0..SLIP).chain([CLOCK]) {
                    assert_eq!(p[(i, j)], 0.0, "{chart:?}");
                }
            }
            assert!((var_spread(&f) - 0.01).abs() < 1e-9, "{chart:?}");
            assert!((f.icr_covariance()[(2, 2)] - 0.0025).abs() < 1e-9);
        }
    }

    #[test]
    fn reset_reinflates_the_factor_difference_like_the_other_parameters() {
        let mut f = filter(Chart::Gain);
        f.set_slip(&learned(0.25, 0.95, 0.01), &SlipStd::ZERO.icr_cov())
            .unwrap();
        let before = f.icr();
        let mut s = NoiseSchedule::new(ScheduleConfig {
            reset: Some(PB),
            ..Default::default()
        });
        s.on_terrain(&mut f, 0).unwrap();
        s.on_terrain(&mut f, 1).unwrap();
        let e = f.icr().alpha_l - f.icr().alpha_r;
        assert!((e - 0.01).abs() < 1e-9, "the estimate stays");
        assert!((var_spread(&f) - 0.01).abs() < 1e-9);
        assert!(
            (var_factor_difference(&f) - 1e-4).abs() < 1e-9,
            "{}",
            var_factor_difference(&f)
        );
        assert!((f.icr().spread() - before.spread()).abs() < 1e-9);
    }

    #[test]
    fn memory_recalls_a_revisited_terrain_as_it_was_learned() {
        let mut f = filter(Chart::Gain);
        let mut s = NoiseSchedule::new(ScheduleConfig {
            memory: true,
            memory_min_dwell: 1.0,
            reset: Some(PB),
            ..Default::default()
        });
        f.predict(0.0, 0.0, 0.0).unwrap();
        s.on_terrain(&mut f, 2).unwrap();
        let tiny = SlipStd {
            spread: 1e-3,
            centre: 1e-3,
            x_c: 1e-3,
            alpha: 1e-3,
            alpha_diff: 1e-3,
        };
        // Terrain 2's own factor difference: -0.03.
        f.set_slip(&learned(0.4, 0.95, -0.03), &tiny.icr_cov())
            .unwrap();
        for _ in 0..100 {
            f.predict(0.5, 0.5, 0.02).unwrap();
            s.on_predict(&f, 0.02);
        }
        assert_eq!(s.on_terrain(&mut f, 0).unwrap(), ChangeAction::Learning);
        // Terrain 0 has a difference of +0.02.
        f.set_slip(&learned(0.3, 1.0, 0.02), &tiny.icr_cov())
            .unwrap();
        assert!(s.remembers(2) && !s.remembers(0));
        assert_eq!(s.on_terrain(&mut f, 2).unwrap(), ChangeAction::Recalled);
        let p = f.icr();
        assert!(
            (p.y_l - 0.4).abs() < 1e-6 && (p.y_r + 0.38).abs() < 1e-6,
            "{p:?}"
        );
        assert!((0.5 * (p.alpha_l + p.alpha_r) - 0.95).abs() < 1e-6, "{p:?}");
        assert!(
            (p.alpha_l - p.alpha_r + 0.03).abs() < 1e-6,
            "terrain 2's difference, not terrain 0's: {p:?}"
        );
        // Recalled spread std is at least the floor.
        assert!(var_spread(&f) >= 0.004f64.powi(2) - 1e-12);
    }

    /// A calibrated set and its standard deviations.
    fn given_set() -> (IcrParams, SlipStd) {
        let std = SlipStd {
            spread: 0.01,
            centre: 0.01,
            x_c: 0.02,
            alpha: 0.01,
            alpha_diff: 0.003,
        };
        (learned(0.3, 0.85, -0.03), std)
    }

    #[test]
    fn a_detected_change_falls_back_to_the_given_set_not_to_the_estimate() {
        let (given, given_std) = given_set();
        let wandered = learned(0.6, 1.1, 0.02);
        let wide = SlipStd {
            spread: 0.3,
            ..given_std
        };
        // The drive's start (no terrain declared) and a terrain's given set.
        for declared in [None, Some(1)] {
            let mut f = filter(Chart::Gain);
            let mut s = NoiseSchedule::new(ScheduleConfig::default());
            match declared {
                None => s.start_from(&given, given_std),
                Some(k) => {
                    s.seed(k, &given, given_std);
                    s.on_terrain(&mut f, k).unwrap();
                }
            }
            f.set_slip(&wandered, &wide.icr_cov()).unwrap();
            assert!(s.on_detected_change(&mut f).unwrap(), "{declared:?}");
            let p = f.icr();
            assert!((p.spread() - given.spread()).abs() < 1e-9, "{p:?}");
            assert!((p.alpha_l - given.alpha_l).abs() < 1e-9, "{p:?}");
            assert!((p.alpha_r - given.alpha_r).abs() < 1e-9, "{p:?}");
            assert!(
                (var_spread(&f) - 1e-4).abs() < 1e-9,
                "the given set's own covariance: {}",
                var_spread(&f)
            );
        }
        // Nothing given: the filter's own raise stands.
        let mut f = filter(Chart::Gain);
        let mut s = NoiseSchedule::new(ScheduleConfig::default());
        f.set_slip(&wandered, &wide.icr_cov()).unwrap();
        assert!(!s.on_detected_change(&mut f).unwrap());
        assert!((f.icr().spread() - wandered.spread()).abs() < 1e-9);
        // A terrain without a given set does not take another's.
        s.seed(0, &given, given_std);
        s.on_terrain(&mut f, 1).unwrap();
        assert!(!s.on_detected_change(&mut f).unwrap());
    }

    #[test]
    fn a_detected_change_after_a_stay_falls_back_to_the_stays_mean() {
        let (given, given_std) = given_set();
        let cfg = ScheduleConfig {
            memory_min_dwell: 2.0,
            ..Default::default()
        };
        let mut f = filter(Chart::Gain);
        let mut s = NoiseSchedule::new(cfg);
        s.start_from(&given, given_std);
        f.set_slip(&given, &given_std.icr_cov()).unwrap();
        let tiny = SlipStd::ZERO.icr_cov();
        // 1 s before the mean starts, then 2 s at y_l = 0.34 and 1 s at
        // 0.40 (where the filter wandered just before the alarm).
        let drive = |f: &mut Filter, s: &mut NoiseSchedule, steps: usize, y_l: f64| {
            for _ in 0..steps {
                f.predict(0.5, 0.5, 0.02).unwrap();
                f.set_slip(&IcrParams { y_l, ..given }, &tiny).unwrap();
                s.on_predict(f, 0.02);
            }
        };
        drive(&mut f, &mut s, 50, 0.5);
        drive(&mut f, &mut s, 50, 0.34);
        // Under memory_min_dwell of mean: the given set.
        assert!(s.on_detected_change(&mut f).unwrap());
        assert!((f.icr().y_l - given.y_l).abs() < 1e-9, "{:?}", f.icr());
        drive(&mut f, &mut s, 50, 0.34);
        drive(&mut f, &mut s, 50, 0.40);
        assert!(s.on_detected_change(&mut f).unwrap());
        let p = f.icr();
        // Mean of 0.34 over 2 s, 0.40 over 1 s: 0.36.
        assert!((p.y_l - 0.36).abs() < 1e-3, "the stay's mean: {p:?}");
        assert!((p.alpha_l - given.alpha_l).abs() < 1e-9, "{p:?}");
        assert!(
            (var_spread(&f) - 1e-4).abs() < 1e-9,
            "the given set's own covariance: {}",
            var_spread(&f)
        );
        // A new terrain starts a new stay: its given set again.
        s.seed(1, &given, given_std);
        s.on_terrain(&mut f, 1).unwrap();
        assert!(s.on_detected_change(&mut f).unwrap());
        assert!((f.icr().y_l - given.y_l).abs() < 1e-9, "{:?}", f.icr());
    }

    #[test]
    fn memory_keeps_the_average_over_the_stay_not_the_last_value() {
        let mut f = filter(Chart::Tread);
        let mut s = NoiseSchedule::new(ScheduleConfig {
            memory: true,
            memory_min_dwell: 2.0,
            memory_average: 10.0,
            ..Default::default()
        });
        f.predict(0.0, 0.0, 0.0).unwrap();
        s.on_terrain(&mut f, 1).unwrap();
        let cov = SlipStd::ZERO.icr_cov();
        // 1 s settling (not averaged), 3 s at y_l = 0.40 and 1 s at 0.45:
        // remembered 0.4125 (a plain mean: shorter than the time constant).
        for k in 0..250 {
            let y_l = match k {
                0..=49 => 0.5,
                50..=199 => 0.40,
                _ => 0.45,
            };
            f.predict(0.5, 0.5, 0.02).unwrap();
            f.set_slip(&IcrParams::new(y_l, -0.38, 0.0), &cov).unwrap();
            s.on_predict(&f, 0.02);
        }
        s.on_terrain(&mut f, 0).unwrap();
        assert_eq!(s.on_terrain(&mut f, 1).unwrap(), ChangeAction::Recalled);
        let y_l = f.icr().y_l;
        assert!((y_l - 0.4125).abs() < 2e-3, "recalled y_l {y_l}");
    }

    #[test]
    fn indefinite_block_is_stored_positive_definite() {
        let mut bad = SlipMat::from_diagonal_element(1e-4);
        bad[(0, 1)] = 2e-4;
        bad[(1, 0)] = 2e-4;
        bad[(2, 2)] = -1e-5;
        let f = floor_cov(&bad, &ScheduleConfig::default().recall_floor);
        assert!(f.cholesky().is_some());
        let nan = SlipMat::from_element(f64::NAN);
        assert!(floor_cov(&nan, &ScheduleConfig::default().recall_floor)
            .cholesky()
            .is_some());
    }

    #[test]
    fn short_visits_are_not_remembered() {
        let mut f = filter(Chart::Gain);
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
