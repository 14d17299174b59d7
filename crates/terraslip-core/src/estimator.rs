//! The online estimator as a robot runs it: tread speeds, pose fixes and
//! terrain evidence in, pose and slip parameters out, event by event on
//! their own timestamps.
//!
//! * [`Estimator::on_wheels`]`(t, v_left, v_right)`: the tread speeds (m/s)
//!   measured over the interval that ends at `t` (s); the state is
//!   predicted to `t`. A gap longer than `max_wheel_gap` is not integrated
//!   with held speeds: the pose uncertainty grows by as far as the robot
//!   could have gone instead.
//! * [`Estimator::on_pose`]`(t, fix)`: a pose fix stamped `t` on the pose
//!   stream's clock. It describes the robot at wheel time
//!   `t - clock_offset`; fixes for a time the wheels have not reached yet
//!   wait (up to [`MAX_PENDING`] of them) and are fused when the next
//!   tread speeds arrive, the prediction split at their time.
//! * [`Estimator::on_gyro`]`(t, rate)`: a sample of the yaw-rate gyro
//!   (rad/s, body z, on the wheels' clock), integrated between samples (the
//!   mean of neighbours) and compared with the model's heading change over
//!   short windows (`filter/gyro.rs`). A gap of more than [`GYRO_HOLD`]
//!   between samples abandons the window in progress.
//! * [`Estimator::on_terrain`]`(k)`: the terrain evidence declares terrain
//!   `k` (labels, or a classifier's belief): the schedule resets or recalls
//!   the slip parameters.
//! * Once no fix has arrived for [`OUTAGE_AFTER_S`] of driving, the
//!   pose's variance grows at the rate of the twist noise learned at the
//!   one-second horizon, where it exceeds the filter's model noise
//!   (`outage_noise.rs`): dead reckoning states what its slips do.
//! * While the gate rejects a part of the fixes, the stated pose holds
//!   what the last rejected one showed beyond its spread (`gated_fix.rs`).
//!
//! Events must come in time order per stream; across streams any order
//! works.

use crate::filter::{Fate, Filter, FilterError, PoseFix, UpdateReport};
use crate::gated_fix::GatedDisagreement;
use crate::odometry::{ModelNoise, TwistNoise};
use crate::outage_growth::{with_position_variance, DriftCurve};
use crate::outage_noise::{excess_diffusion, OUTAGE_AFTER_S};
use crate::schedule::{ChangeAction, NoiseSchedule};
use crate::twist_noise::{FixSeen, TwistNoiseLearner};

/// Pose fixes that can wait for the wheels.
pub const MAX_PENDING: usize = 32;

/// Longest the last gyro sample is held, s.
pub const GYRO_HOLD: f64 = 0.2;

/// The gyro's rate integrated over the current wheels interval.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct GyroIntegral {
    /// The last sample `(t, rate)`.
    last: Option<(f64, f64)>,
    /// Start of the current wheels interval, s.
    from: f64,
    /// Integral of the rate from `from` to the last sample, rad.
    angle: f64,
    /// Samples in the interval.
    samples: u32,
}

impl GyroIntegral {
    fn push(&mut self, t: f64, rate: f64) {
        if let Some((tp, rp)) = self.last {
            if t > tp && t > self.from {
                self.angle += 0.5 * (rp + rate) * (t - tp.max(self.from));
            }
        }
        self.last = Some((t, rate));
        self.samples = self.samples.saturating_add(1);
    }

    /// The integral over `[from, t]` (the last sample held to `t`) and the
    /// samples in it, or `None` if the gyro has been silent too long; starts
    /// the next interval at `t`.
    fn take(&mut self, t: f64) -> Option<(f64, u32)> {
        let out = match self.last {
            Some((tl, rl)) if t - tl <= GYRO_HOLD => Some((
                self.angle + rl * (t - tl.max(self.from)).max(0.0),
                self.samples,
            )),
            _ => None,
        };
        self.from = t;
        self.angle = 0.0;
        self.samples = 0;
        out
    }
}

/// Counters of what happened to the fixes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FixCounts {
    /// Position parts fused.
    pub position_fused: usize,
    /// Position parts rejected by the gate.
    pub position_gated: usize,
    /// Heading parts fused.
    pub yaw_fused: usize,
    /// Heading parts rejected by the gate.
    pub yaw_gated: usize,
    /// Parts taken as the pose (first fix, or after too many rejections).
    pub anchored: usize,
    /// Slip changes the detector found.
    pub changes_detected: usize,
    /// Updates the filter refused (e.g. the papers' innovation-adaptive gain
    /// losing definiteness).
    pub refused: usize,
    /// Predictions.
    pub predictions: usize,
}

/// What the last fused fixes did, since the last call to
/// [`Estimator::take_fix_summary`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FixSummary {
    /// A part was fused.
    pub fused: bool,
    /// A part was gated.
    pub gated: bool,
    /// NIS of the last fix's position part (2 dof; 0 if none).
    pub nis_position: f64,
    /// NIS of the last fix's heading part (1 dof; 0 if none).
    pub nis_yaw: f64,
    /// The slip-change detector fired.
    pub change: bool,
    /// The slip parameters were projected into the band.
    pub at_band: bool,
}

#[derive(Debug, Clone, Copy)]
struct Pending {
    t: f64,
    fix: PoseFix,
}

/// Filter + terrain schedule + the timing of three streams.
#[derive(Debug, Clone)]
pub struct Estimator {
    filter: Filter,
    schedule: NoiseSchedule,
    /// Time of the state (wheels' clock); `None` before the first wheels row.
    t: Option<f64>,
    pending: [Option<Pending>; MAX_PENDING],
    pending_len: usize,
    max_wheel_gap: f64,
    max_speed: f64,
    counts: FixCounts,
    summary: FixSummary,
    gyro: GyroIntegral,
    /// The model's twist error learned at the published horizon.
    twist_noise: TwistNoiseLearner,
    /// How far the fixes have disagreed with the estimate so far.
    misfit: Misfit,
    /// How far the gyro's windows have disagreed with the model's turn so
    /// far.
    gyro_misfit: Misfit,
    /// Wheel time since a fix last reached the filter (fused or gated), s.
    since_fix: f64,
    /// How far dead reckoning drifts, learned from the fixes.
    drift: DriftCurve,
    /// What the last gated fix parts left unexplained.
    gated: GatedDisagreement,
}

/// Largest NIS one fix part (or gyro window) adds to [`Misfit::nis`]: a
/// fix far off (an outlier the gate rejects) counts as a clear
/// disagreement, not as an unbounded one.
pub const MISFIT_NIS_CAP: f64 = 25.0;

/// The fixes' disagreement with the estimate accumulated since the start:
/// the sum of each fused or gated part's normalised innovation squared
/// (capped at [`MISFIT_NIS_CAP`]), and the number of parts. Two estimators
/// fed the same fixes compare by the difference of their sums over a
/// stretch: the one whose slip the fixes bear out has the smaller. The
/// gyro's windows are counted apart ([`Estimator::gyro_misfit`]).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Misfit {
    /// Sum of the capped NIS, 1.
    pub nis: f64,
    /// Fix parts counted.
    pub parts: u64,
}

impl Misfit {
    /// Counts one part of normalised innovation squared `nis` (a
    /// non-finite one is not counted).
    fn add(&mut self, nis: f64) {
        if nis.is_finite() {
            self.nis += nis.clamp(0.0, MISFIT_NIS_CAP);
            self.parts += 1;
        }
    }
}

impl Estimator {
    /// An estimator around `filter` with terrain schedule `schedule`;
    /// wheel gaps longer than `max_wheel_gap` s are not integrated.
    pub fn new(filter: Filter, schedule: NoiseSchedule, max_wheel_gap: f64) -> Self {
        Self {
            filter,
            schedule,
            t: None,
            pending: [None; MAX_PENDING],
            pending_len: 0,
            max_wheel_gap: if max_wheel_gap > 0.0 {
                max_wheel_gap
            } else {
                f64::INFINITY
            },
            max_speed: 0.0,
            counts: FixCounts::default(),
            summary: FixSummary::default(),
            gyro: GyroIntegral::default(),
            twist_noise: TwistNoiseLearner::new(),
            misfit: Misfit::default(),
            gyro_misfit: Misfit::default(),
            since_fix: 0.0,
            drift: DriftCurve::new(),
            gated: GatedDisagreement::default(),
        }
    }

    /// The fixes' disagreement with the estimate so far.
    pub fn misfit(&self) -> Misfit {
        self.misfit
    }

    /// The gyro's disagreement with the model's turn so far: each fused
    /// window's normalised innovation squared, counted as [`Misfit`] counts
    /// fix parts. What a change of terrain is tried on where no fixes come.
    pub fn gyro_misfit(&self) -> Misfit {
        self.gyro_misfit
    }

    /// The filter (state, covariance, learned noise).
    pub fn filter(&self) -> &Filter {
        &self.filter
    }

    /// The terrain schedule.
    pub fn schedule(&self) -> &NoiseSchedule {
        &self.schedule
    }

    /// Time of the state, s (wheels' clock).
    pub fn time(&self) -> Option<f64> {
        self.t
    }

    /// Counters since the start.
    pub fn counts(&self) -> FixCounts {
        self.counts
    }

    /// What the fixes fused since the last call did (and clears it).
    pub fn take_fix_summary(&mut self) -> FixSummary {
        core::mem::take(&mut self.summary)
    }

    /// Tread speeds `v_left`, `v_right` (m/s) over the interval ending at
    /// `t` (s).
    pub fn on_wheels(&mut self, t: f64, v_left: f64, v_right: f64) -> Result<(), FilterError> {
        if !(t.is_finite() && v_left.is_finite() && v_right.is_finite()) {
            return Err(FilterError::BadInput("wheels row not finite"));
        }
        self.max_speed = self.max_speed.max(v_left.abs()).max(v_right.abs());
        let Some(t0) = self.t else {
            self.t = Some(t);
            self.gyro.take(t);
            self.filter.predict(v_left, v_right, 0.0)?;
            return self.fuse_due(t);
        };
        if t < t0 {
            return Err(FilterError::BadInput("wheels time went backwards"));
        }
        let gap = t - t0 > self.max_wheel_gap;
        let (vl, vr) = if gap { (0.0, 0.0) } else { (v_left, v_right) };
        // The gyro's heading change over the interval, shared among the
        // interval's steps by their length.
        let gyro = self
            .gyro
            .take(t)
            .filter(|_| !gap && t > t0)
            .map(|(angle, n)| (angle / (t - t0), n as f64 / (t - t0)));
        let mut now = t0;
        while let Some(due) = self.next_due().filter(|d| *d <= t) {
            if due > now {
                self.advance(vl, vr, due - now, gap)?;
                self.fuse_gyro(gyro, due - now)?;
                now = due;
            }
            self.t = Some(now);
            self.fuse_front()?;
        }
        if t > now {
            self.advance(vl, vr, t - now, gap)?;
            self.fuse_gyro(gyro, t - now)?;
        }
        self.t = Some(t);
        Ok(())
    }

    /// A copy to carry on with no more fixes (an outage, a dead reckoning):
    /// with no fix waiting, what only a fix reads (the drift's probes, the
    /// twist noise's running window) is left behind, so that the copy's
    /// steps skip them; its estimate and stated covariance are those of a
    /// plain copy given no fixes.
    pub fn for_outage(&self) -> Self {
        let mut copy = self.clone();
        if copy.pending_len == 0 {
            copy.drift.break_probes();
            copy.twist_noise.break_window();
        }
        copy
    }

    /// A yaw-rate gyro sample `rate` (rad/s, counter-clockwise about body z)
    /// at `t` (s, the wheels' clock).
    pub fn on_gyro(&mut self, t: f64, rate: f64) -> Result<(), FilterError> {
        if !(t.is_finite() && rate.is_finite()) {
            return Err(FilterError::BadInput("gyro sample not finite"));
        }
        self.gyro.push(t, rate);
        Ok(())
    }

    /// Adds the gyro's heading change over a step of `dt` s (its mean rate
    /// and samples per second over the interval) to the filter's window.
    fn fuse_gyro(&mut self, gyro: Option<(f64, f64)>, dt: f64) -> Result<(), FilterError> {
        let Some((rate, per_s)) = gyro else {
            self.filter.break_gyro();
            return Ok(());
        };
        let r = self.filter.add_gyro(rate * dt, per_s * dt);
        if let Ok(Some(nis)) = r {
            self.gyro_misfit.add(nis);
        }
        self.count_refused(r.map(|_| ()))
    }

    /// Bad input is an error; any other failed update is refused (the
    /// filter unchanged) and counted.
    fn count_refused(&mut self, r: Result<(), FilterError>) -> Result<(), FilterError> {
        match r {
            Err(FilterError::BadInput(what)) => Err(FilterError::BadInput(what)),
            Err(_) => {
                self.counts.refused += 1;
                Ok(())
            }
            Ok(()) => Ok(()),
        }
    }

    /// A pose fix stamped `t` (s, the pose stream's clock).
    pub fn on_pose(&mut self, t: f64, fix: PoseFix) -> Result<(), FilterError> {
        if !t.is_finite() {
            return Err(FilterError::BadInput("fix time not finite"));
        }
        if self.pending_len == MAX_PENDING {
            self.fuse_front()?;
        }
        let i = (0..MAX_PENDING)
            .find(|&i| self.pending[i].is_none())
            .unwrap_or(0);
        self.pending[i] = Some(Pending { t, fix });
        self.pending_len += 1;
        match self.t {
            Some(now) => self.fuse_due(now),
            None => Ok(()),
        }
    }

    /// The terrain evidence declares terrain `k`.
    pub fn on_terrain(&mut self, k: usize) -> Result<ChangeAction, FilterError> {
        self.schedule.on_terrain(&mut self.filter, k)
    }

    /// Seeds the terrain memory (e.g. with calibrated per-terrain ICRs).
    pub fn schedule_mut(&mut self) -> &mut NoiseSchedule {
        &mut self.schedule
    }

    fn advance(&mut self, vl: f64, vr: f64, dt: f64, gap: bool) -> Result<(), FilterError> {
        if gap {
            let reach = self.max_speed * dt;
            self.filter
                .inflate_pose(reach * reach, core::f64::consts::PI * core::f64::consts::PI);
        }
        self.filter.predict(vl, vr, dt)?;
        if gap {
            self.twist_noise.break_window();
            self.drift.break_probes();
        } else {
            if self.twist_noise.is_open() {
                self.twist_noise.step(&self.filter.icr_now(), vl, vr, dt);
            }
            self.since_fix += dt;
            // Through an outage the probes are dropped (the copies that
            // dead-reckon one need none).
            if self.since_fix > OUTAGE_AFTER_S {
                self.drift.break_probes();
            } else if self.gyro.last.is_none() {
                self.drift.step(vl, vr, dt);
            }
            if self.since_fix > OUTAGE_AFTER_S && !self.filter.is_still() {
                self.grow_beyond_fixes(vl, vr, dt);
            }
        }
        self.schedule.on_predict(&self.filter, dt);
        self.counts.predictions += 1;
        Ok(())
    }

    /// An outage: the pose's variance grows over `dt` s at the one-second
    /// twist noise's rate where it exceeds the filter's model noise
    /// (`outage_noise.rs`); the heading's not while a gyro holds it.
    fn grow_beyond_fixes(&mut self, vl: f64, vr: f64, dt: f64) {
        let f = &self.filter;
        let omega = f.twist().omega;
        let (xy, yaw) = excess_diffusion(
            &self.twist_noise(),
            &ModelNoise::of(f),
            0.5 * (vl + vr),
            omega,
        );
        let yaw = if f.gyro_noise().fused > 0 { 0.0 } else { yaw };
        self.filter.inflate_pose(xy * dt, yaw * dt);
    }

    /// Covariance of `(east, north, yaw)` as the estimator states it: the
    /// filter's, with what the last gated fix parts left unexplained
    /// (`gated_fix.rs`), except through an outage of more than
    /// [`OUTAGE_AFTER_S`] where no gyro holds the heading: there the
    /// position's follows the drift learned from the fixes
    /// (`outage_growth.rs`), once there is one. The filter's own
    /// covariance, and so the estimate, is left as it is.
    pub fn pose_covariance(&self) -> nalgebra::Matrix3<f64> {
        let c = self.gated.widen(&self.filter.pose_covariance());
        let drift = (self.since_fix > OUTAGE_AFTER_S && self.gyro.last.is_none())
            .then(|| self.drift.variance(self.since_fix))
            .flatten();
        match drift {
            Some(v) => with_position_variance(&c, v),
            None => c,
        }
    }

    /// [`Filter::fix_position_covariance`] with the gated widening, m².
    pub fn fix_position_covariance(&self) -> nalgebra::Matrix2<f64> {
        self.gated
            .widen_position(&self.filter.fix_position_covariance())
    }

    /// How far dead reckoning drifts, as learned from the fixes so far.
    pub fn drift(&self) -> &DriftCurve {
        &self.drift
    }

    /// Wheel time at which the oldest waiting fix is due.
    fn next_due(&self) -> Option<f64> {
        let (clock, _) = self.filter.clock_offset();
        self.oldest().map(|(_, p)| p.t - clock)
    }

    fn oldest(&self) -> Option<(usize, Pending)> {
        let mut best: Option<(usize, Pending)> = None;
        for (i, p) in self.pending.iter().enumerate() {
            if let Some(p) = p {
                if best.is_none_or(|(_, b)| p.t < b.t) {
                    best = Some((i, *p));
                }
            }
        }
        best
    }

    /// Fuses every waiting fix due at or before `now` (the filter's time).
    fn fuse_due(&mut self, now: f64) -> Result<(), FilterError> {
        while self.next_due().is_some_and(|d| d <= now) {
            self.fuse_front()?;
        }
        Ok(())
    }

    /// Fuses the oldest waiting fix at the filter's current time.
    fn fuse_front(&mut self) -> Result<(), FilterError> {
        let Some((i, p)) = self.oldest() else {
            return Ok(());
        };
        self.pending[i] = None;
        self.pending_len -= 1;
        let now = self.t.unwrap_or(p.t);
        let r = self.filter.update(p.t, now - p.t, &p.fix);
        if let Ok(rep) = &r {
            self.record(rep);
            if rep.change {
                self.schedule.on_detected_change(&mut self.filter)?;
            }
        }
        let fused = r.is_ok();
        if fused {
            self.since_fix = 0.0;
        }
        self.count_refused(r.map(|_| ()))?;
        self.schedule.on_update(&mut self.filter);
        if fused {
            self.learn_twist_noise(&p.fix);
        }
        Ok(())
    }

    /// The variance of the model's twist error averaged over
    /// [`crate::odometry::TWIST_WINDOW_S`], as learned from the fixes so far
    /// (the filter's model noise before any).
    pub fn twist_noise(&self) -> TwistNoise {
        self.twist_noise.noise(&ModelNoise::of(&self.filter))
    }

    /// Twist-noise windows learned from so far.
    pub fn twist_noise_windows(&self) -> u64 {
        self.twist_noise.windows()
    }

    /// Hands a fix just taken to the twist noise learner.
    fn learn_twist_noise(&mut self, fix: &PoseFix) {
        let f = &self.filter;
        // A sensor's stated noise is its own; a configured guess is
        // replaced by what the filter learned (between fixes a tenth of a
        // second apart it cannot tell a steady slip from the sensor's
        // noise, so a stated std is not replaced here).
        let (learned_xy, learned_yaw, bias_std) = f.noise(fix.std_xy, fix.std_yaw);
        let (std_xy, std_yaw) = if fix.stated {
            (fix.std_xy, fix.std_yaw)
        } else {
            (learned_xy, learned_yaw)
        };
        let seen = FixSeen {
            position: fix.position,
            yaw: fix.yaw,
            std_xy,
            std_yaw,
            bias_std,
            bias_time: f.measurement().correlation_time,
            filter_yaw: f.pose().2,
            heading_known: f.anchored()[1],
            lever_arm: f.lever_arm(),
        };
        self.twist_noise
            .on_fix(&seen, &f.icr_now_covariance(), &ModelNoise::of(f));
        if let Some(at) = fix.position.filter(|_| self.gyro.last.is_none()) {
            let var_fix = std_xy * std_xy;
            self.drift
                .on_fix(at, var_fix, f.lever_arm(), &f.dead_reckoning());
        }
    }

    fn record(&mut self, rep: &UpdateReport) {
        self.gated.record(rep);
        let c = &mut self.counts;
        let s = &mut self.summary;
        for (fate, fused, gated, nis) in [
            (
                rep.position,
                &mut c.position_fused,
                &mut c.position_gated,
                rep.nis_position,
            ),
            (rep.yaw, &mut c.yaw_fused, &mut c.yaw_gated, rep.nis_yaw),
        ] {
            if matches!(fate, Fate::Fused | Fate::Gated) {
                self.misfit.add(nis);
            }
            match fate {
                Fate::Fused => {
                    *fused += 1;
                    s.fused = true;
                }
                Fate::Gated => {
                    *gated += 1;
                    s.gated = true;
                }
                Fate::Anchored => {
                    c.anchored += 1;
                    s.fused = true;
                }
                Fate::Absent => {}
            }
        }
        if rep.position != Fate::Absent {
            s.nis_position = rep.nis_position;
        }
        if rep.yaw != Fate::Absent {
            s.nis_yaw = rep.nis_yaw;
        }
        if rep.change {
            c.changes_detected += 1;
            s.change = true;
        }
        s.at_band |= rep.at_band;
    }
}
