//! The outage yardstick over a run ([`terraslip_calib::outage`]): at each
//! start a copy of the estimator dead-reckons on the wheels (and the gyro)
//! with no pose fix, and reports its pose and covariance at each horizon;
//! beside it, no-slip odometry and, where the log has a gyro, odometry
//! with the gyro's turn rate, each from the estimate's pose and heading at
//! the start, as the copy of the estimator sets out.
//! The ends are scored against the reference when the run is over (the
//! reference's positions are kept: 32 bytes per pose row).

use terraslip_calib::outage::{
    End, FilterEnd, OutageEnd, OutageScore, OutageSpec, Start, Track, HORIZONS,
};
use terraslip_calib::prediction::advance;
use terraslip_core::estimator::Estimator;
use terraslip_core::{IcrParams, Twist};
use terraslip_io::{PoseObs, WheelSample};

/// The models of the yardstick, as `summary.json` names them.
pub const ONLINE: &str = "online";
pub const NO_SLIP: &str = "no-slip";
pub const ODOMETRY_GYRO: &str = "odometry + gyro";

/// A pose in a start's frame (x forward, y left, m; yaw rad).
type Relative = (f64, f64, f64);

/// An outage under way.
#[derive(Clone)]
struct Open {
    /// The estimate's pose and clock offset at the start.
    start: Start,
    est: Box<Estimator>,
    /// No-slip odometry and odometry + gyro in the start's frame.
    no_slip: Relative,
    odometry_gyro: Option<Relative>,
    t_prev: f64,
    /// The next horizon to report.
    next: usize,
}

/// An end waiting for the reference.
#[derive(Clone)]
enum Pending {
    Filter(FilterEnd),
    Relative {
        model: usize,
        start: Start,
        h: f64,
        pose: Relative,
    },
}

/// The yardstick as a run goes by.
#[derive(Clone)]
pub(super) struct OutageRun {
    spec: OutageSpec,
    track: Track,
    no_slip: IcrParams,
    next_start: Option<f64>,
    open: Vec<Open>,
    starts: Vec<Start>,
    pending: Vec<Pending>,
    /// The latest gyro rate, rad/s, once the log has given one.
    gyro: Option<f64>,
}

impl OutageRun {
    pub fn new(track_width: f64) -> Self {
        Self {
            spec: OutageSpec::default(),
            track: Track::default(),
            no_slip: IcrParams::no_slip(track_width),
            next_start: None,
            open: Vec::new(),
            starts: Vec::new(),
            pending: Vec::new(),
            gyro: None,
        }
    }

    /// A pose row: part of the reference, never given to the outages.
    pub fn pose(&mut self, p: &PoseObs) {
        self.track.push(p);
    }

    /// A gyro rate (rad/s) at `t` (wheels' clock).
    pub fn gyro(&mut self, t: f64, rate: f64) {
        self.gyro = Some(rate);
        // An estimator that refuses the sample ends its outage.
        self.open.retain_mut(|o| o.est.on_gyro(t, rate).is_ok());
    }

    /// Wheels row `w`, after `estimator` took it (and the fixes before
    /// it): the outages under way step on it; a start due opens one from
    /// the estimator as it now is.
    pub fn wheels(&mut self, w: &WheelSample, estimator: &Estimator, clock: f64) {
        let mut done = Vec::new();
        for (k, o) in self.open.iter_mut().enumerate() {
            if o.est.on_wheels(w.t, w.v_left, w.v_right).is_err() {
                done.push(k);
                continue;
            }
            let dt = w.t - o.t_prev;
            o.t_prev = w.t;
            advance(&mut o.no_slip, dt, self.no_slip.twist(w.v_left, w.v_right));
            if let (Some(p), Some(rate)) = (o.odometry_gyro.as_mut(), self.gyro) {
                let tw = Twist {
                    v_x: 0.5 * (w.v_left + w.v_right),
                    v_y: 0.0,
                    omega: rate,
                };
                advance(p, dt, tw);
            }
            while o.next < HORIZONS.len() && w.t >= o.start.t + HORIZONS[o.next] {
                let h = HORIZONS[o.next];
                let (east, north, _) = o.est.filter().pose();
                let c = o.est.pose_covariance();
                self.pending.push(Pending::Filter(FilterEnd {
                    start: o.start,
                    horizon: h,
                    end: End {
                        east,
                        north,
                        cov: Some([c[(0, 0)], c[(0, 1)], c[(1, 1)]]),
                    },
                }));
                let rel = [Some(o.no_slip), o.odometry_gyro];
                for (model, pose) in rel.into_iter().enumerate() {
                    if let Some(pose) = pose {
                        self.pending.push(Pending::Relative {
                            model,
                            start: o.start,
                            h,
                            pose,
                        });
                    }
                }
                o.next += 1;
            }
            if o.next == HORIZONS.len() {
                done.push(k);
            }
        }
        for k in done.into_iter().rev() {
            self.open.remove(k);
        }
        let next = *self.next_start.get_or_insert(w.t + self.spec.warmup);
        if w.t >= next {
            let (east, north, yaw) = estimator.filter().pose();
            let start = Start {
                t: next,
                east,
                north,
                yaw,
                clock,
            };
            self.starts.push(start);
            self.open.push(Open {
                start,
                est: Box::new(estimator.for_outage()),
                no_slip: (0.0, 0.0, 0.0),
                odometry_gyro: self.gyro.map(|_| (0.0, 0.0, 0.0)),
                t_prev: w.t,
                next: 0,
            });
            let mut n = next;
            while n <= w.t {
                n += self.spec.stride;
            }
            self.next_start = Some(n);
        }
    }

    /// The scored ends of each model (`None` when nothing could be scored).
    pub fn finish(&self) -> Option<OutageScore> {
        let gap = self.spec.max_gap;
        let mut online: Vec<OutageEnd> = Vec::new();
        let mut filter_ends = Vec::new();
        let mut relative: [Vec<OutageEnd>; 2] = [Vec::new(), Vec::new()];
        for p in &self.pending {
            match *p {
                Pending::Filter(f) => {
                    let s = f.start;
                    online.extend(self.track.score(s.t, f.horizon, s.clock, f.end, gap));
                    filter_ends.push(f);
                }
                Pending::Relative {
                    model,
                    start: s,
                    h,
                    pose: (x, y, _),
                } => {
                    let (east, north) = s.place(x, y);
                    let end = End {
                        east,
                        north,
                        cov: None,
                    };
                    relative[model].extend(self.track.score(s.t, h, s.clock, end, gap));
                }
            }
        }
        if online.is_empty() {
            return None;
        }
        let [no_slip, odometry_gyro] = relative;
        let mut models = vec![(ONLINE.to_string(), online), (NO_SLIP.to_string(), no_slip)];
        if self.gyro.is_some() {
            models.push((ODOMETRY_GYRO.to_string(), odometry_gyro));
        }
        Some(OutageScore {
            spec: Some(self.spec),
            models,
            starts: self.starts.clone(),
            filter_ends,
        })
    }
}
