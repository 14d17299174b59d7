//! `terraslip-lab odometry-nees`: are the covariances the odometry
//! publishes (`/terraslip/odom`, `estimate --mcap`) honest? The normalised
//! estimation error squared (NEES) of the published twist and pose against
//! a pose reference, with the 95 % band a consistent covariance keeps.
//!
//! - **Twist**: over consecutive windows of `--window` s, the published
//!   twist integrated in the body frame (the displacement and turn it
//!   claims) against the reference's displacement (rotated into the body
//!   frame at the window's start) and turn. The covariance: the published
//!   one's parts carried over the window (parameter uncertainty through the
//!   kinematics at each step, the model noise's diffusion summed over the
//!   steps, the floor), plus the reference's own noise at both ends (2σ²
//!   per axis, σ the noise the run learned for the reference). Over 1 s this
//!   is the published twist covariance times 1 s² (`TWIST_WINDOW_S`).
//! - **Pose**: the run fuses one reference fix every `--fix-every` s; the
//!   published pose at a row with a known heading half-way between two
//!   fused fixes (once a second when every fix is fused) against the
//!   full-rate reference, with the published planar covariance plus the
//!   reference's noise. With every fix fused the estimate shares the
//!   fix's noise, whose error against it has a variance nearer `R - P`
//!   than the `P + R` counted: that figure reads low.
//!
//! The band: the mean of N independent χ²(k) values lies in
//! [χ²(kN; 2.5 %), χ²(kN; 97.5 %)] / N (Wilson–Hilferty quantiles); the
//! windows (twist) and the 1 s rows (pose) are taken as independent.

use std::path::PathBuf;

use anyhow::Context;
use nalgebra::{Matrix2, Matrix3, SMatrix, Vector3};
use terraslip::bag::Topics;
use terraslip::pipeline::{self, EstimateRow, TerrainEvidence};
use terraslip_core::odometry::{twist_jacobian, TwistNoise, TWIST_VARIANCE_FLOOR, TWIST_WINDOW_S};
use terraslip_core::slip::SlipMat;
use terraslip_io::{DriveLog, PoseObs};

use crate::estimators;

/// NEES of the published twist and pose covariances against a reference.
#[derive(clap::Args)]
pub struct Args {
    /// Logs or ROS 2 bags with a pose reference (default: every drive
    /// under ../shared/data/drive).
    logs: Vec<PathBuf>,
    /// Topics file for a bag (as `estimate --topics`).
    #[arg(long)]
    topics: Option<PathBuf>,
    /// Estimator preset or `config:FILE.toml`.
    #[arg(long, default_value = "terraslip")]
    estimator: String,
    /// Window the twist is integrated over, s.
    #[arg(long, default_value_t = terraslip_core::odometry::TWIST_WINDOW_S)]
    window: f64,
    /// Seconds between the reference fixes the run fuses (the rest are
    /// held out for the pose NEES); 0 fuses every one.
    #[arg(long, default_value_t = 1.0)]
    fix_every: f64,
    /// Also print each twist component's mean normalised error squared.
    #[arg(long)]
    components: bool,
}

/// Mean NEES of `n` samples of `k` degrees of freedom, with the share
/// above the χ²(k) 95 % quantile.
#[derive(Debug, Clone, Default)]
pub struct Nees {
    pub n: usize,
    pub k: usize,
    pub sum: f64,
    pub above: usize,
    /// Every sample, for the median and the tail's share.
    pub values: Vec<f64>,
    /// Sum of each component's own normalised error squared (`e_k² /
    /// C_kk`: along-track or east, cross-track or north, heading).
    pub parts: [f64; 3],
}

impl Nees {
    fn add(&mut self, v: f64) {
        if v.is_finite() {
            self.n += 1;
            self.sum += v;
            self.above += usize::from(v > chi2_quantile(self.k as f64, 0.95));
            self.values.push(v);
        }
    }
    /// The median NEES, against χ²(k)'s median (heavy tails leave the
    /// median near it while the mean is far above).
    pub fn median(&self) -> f64 {
        let mut v = self.values.clone();
        v.sort_by(f64::total_cmp);
        match v.len() {
            0 => f64::NAN,
            n if n % 2 == 1 => v[n / 2],
            n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
        }
    }
    /// Share of the NEES sum carried by the largest 5 % of the samples
    /// (about 0.17 for χ²(3)).
    pub fn top_share(&self) -> f64 {
        let mut v = self.values.clone();
        v.sort_by(|a, b| b.total_cmp(a));
        let top: f64 = v.iter().take(v.len().div_ceil(20)).sum();
        top / self.sum.max(f64::MIN_POSITIVE)
    }
    /// The median's test: the share of samples below χ²(k)'s median, the
    /// 95 % band a consistent covariance keeps it in (`0.5 ± 1.96 ·
    /// 0.5 / √n`, the binomial's normal approximation), and the verdict:
    /// "over" (too few small samples: the covariance too narrow at the
    /// median), "under" or "in".
    pub fn median_test(&self) -> (f64, (f64, f64), &'static str) {
        let n = self.n.max(1) as f64;
        let m = chi2_median(self.k as f64);
        let share = self.values.iter().filter(|v| **v < m).count() as f64 / n;
        let half = 1.96 * 0.5 / n.sqrt();
        let verdict = if share < 0.5 - half {
            "over"
        } else if share > 0.5 + half {
            "under"
        } else {
            "in"
        };
        (share, (0.5 - half, 0.5 + half), verdict)
    }
    /// Each component's mean normalised error squared (1 is right).
    pub fn part_means(&self) -> [f64; 3] {
        self.parts.map(|p| p / self.n.max(1) as f64)
    }
    pub fn mean(&self) -> f64 {
        self.sum / self.n.max(1) as f64
    }
    /// The 95 % band of the mean of `n` χ²(k).
    pub fn band(&self) -> (f64, f64) {
        let dof = (self.k * self.n.max(1)) as f64;
        let n = self.n.max(1) as f64;
        (chi2_quantile(dof, 0.025) / n, chi2_quantile(dof, 0.975) / n)
    }
    fn row(&self) -> String {
        let (lo, hi) = self.band();
        let m = self.mean();
        let (below, (b_lo, b_hi), by_median) = self.median_test();
        format!(
            "{:5} | {:7.2} | {:5.2} – {:5.2} | {:5} | {:4.1} % | {:5.2} ({:4.2}) | {:4.2} | {:2.0} % ({:2.0}–{:2.0} %) {}",
            self.n,
            m,
            lo,
            hi,
            if (lo..=hi).contains(&m) {
                "in"
            } else if m > hi {
                "over"
            } else {
                "under"
            },
            100.0 * self.above as f64 / self.n.max(1) as f64,
            self.median(),
            chi2_median(self.k as f64),
            self.top_share(),
            100.0 * below,
            100.0 * b_lo,
            100.0 * b_hi,
            by_median
        )
    }
}

/// Quantile `p` of χ²(`dof`) (Wilson–Hilferty): within 1 % for the
/// band of a mean over many samples (`dof` in the hundreds) and for the
/// upper tail at 3 dof; the lower tail at a few dof it places too low.
pub fn chi2_quantile(dof: f64, p: f64) -> f64 {
    let z = normal_quantile(p);
    let a = 2.0 / (9.0 * dof);
    dof * (1.0 - a + z * a.sqrt()).powi(3)
}

/// Median of χ²(`dof`) (Wilson–Hilferty): 2.38 at 3 dof (2.366 exact).
pub fn chi2_median(dof: f64) -> f64 {
    chi2_quantile(dof, 0.5)
}

/// Quantile of the standard normal (Acklam's rational approximation,
/// relative error < 1.2e-9).
fn normal_quantile(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969683028665376e1,
        2.209460984245205e2,
        -2.759285104469687e2,
        1.38357751867269e2,
        -3.066479806614716e1,
        2.506628277459239,
    ];
    const B: [f64; 5] = [
        -5.447609879822406e1,
        1.615858368580409e2,
        -1.556989798598866e2,
        6.680131188771972e1,
        -1.328068155288572e1,
    ];
    const C: [f64; 6] = [
        -7.784894002430293e-3,
        -3.223964580411365e-1,
        -2.400758277161838,
        -2.5496710104227,
        4.374664141464968,
        2.938163982698783,
    ];
    const D: [f64; 4] = [
        7.784695709041462e-3,
        3.224671290700398e-1,
        2.445134137142996,
        3.754408661907416,
    ];
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p < 0.02425 {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - 0.02425 {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

/// The reference pose at `t` (linear; yaw along the shorter arc), `None`
/// outside it or across a gap over 1 s.
fn reference_at(pose: &[PoseObs], t: f64) -> Option<(f64, f64, Option<f64>)> {
    let k = pose.partition_point(|p| p.t <= t);
    let (a, b) = (pose.get(k.checked_sub(1)?)?, pose.get(k)?);
    if b.t - a.t > 1.0 {
        return None;
    }
    let s = (t - a.t) / (b.t - a.t).max(1e-9);
    let lerp = |x: f64, y: f64| x + s * (y - x);
    let yaw = match (a.yaw, b.yaw) {
        (Some(x), Some(y)) => Some(x + s * wrap(y - x)),
        _ => None,
    };
    Some((lerp(a.east?, b.east?), lerp(a.north?, b.north?), yaw))
}

fn wrap(a: f64) -> f64 {
    let t = std::f64::consts::TAU;
    a - t * ((a + std::f64::consts::PI) / t).floor()
}

/// The log with one fix kept every `every` s (all when 0).
fn thinned(log: &DriveLog, every: f64) -> DriveLog {
    let mut out = log.clone();
    if every > 0.0 {
        let mut next = f64::NEG_INFINITY;
        out.pose.retain(|p| {
            let keep = p.t >= next;
            if keep {
                next = p.t + every;
            }
            keep
        });
    }
    out
}

/// The reference's noise as the run learned it: the white position std
/// per axis (m), the heading std (rad), the slow position error's std (m)
/// and correlation time (s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReferenceNoise {
    pub std_xy: f64,
    pub std_yaw: f64,
    pub slow_std: f64,
    pub slow_time: f64,
}

impl ReferenceNoise {
    /// Variance per axis of the reference's position at one time, m².
    fn position_var(&self) -> f64 {
        self.std_xy * self.std_xy + self.slow_std * self.slow_std
    }

    /// Variance per axis of the reference's displacement over `span` s:
    /// both ends' white noise and how far the slow error moved, m².
    fn displacement_var(&self, span: f64) -> f64 {
        let moved = if self.slow_time > 0.0 {
            1.0 - (-span / self.slow_time).exp()
        } else {
            1.0
        };
        2.0 * self.std_xy * self.std_xy + 2.0 * self.slow_std * self.slow_std * moved
    }
}

/// Which slip noise the twist covariance states.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stated {
    /// The filter's model noise, `q / window` (the pose's random walk).
    ModelNoise,
    /// The noise learned at the published horizon (what is published).
    Learned,
}

/// Twist and pose NEES of one run: the twist's with each of `stated`.
/// `wheels[k]` are row `k`'s tread speeds. `fix_every`: the spacing (s) of
/// the fixes the run fused when it held the rest out; the pose is then
/// taken half-way between fused fixes, where its error is the furthest from
/// sharing a fused fix's noise. `None` (every fix fused): once a second.
pub fn nees(
    rows: &[EstimateRow],
    wheels: &[(f64, f64)],
    reference: &[PoseObs],
    noise: &ReferenceNoise,
    window: f64,
    stated: &[Stated],
    fix_every: Option<f64>,
) -> (Vec<Nees>, Nees, Nees) {
    // A reference with no heading (GNSS fixes): the position alone.
    let k = if reference.iter().any(|p| p.yaw.is_some()) {
        3
    } else {
        2
    };
    let empty = Nees {
        k,
        ..Default::default()
    };
    let mut twist = vec![empty.clone(); stated.len()];
    let mut pose = empty;
    // The position as the reference sees it: with its slow error, which
    // the estimate shares (a GNSS receiver's wanders by metres).
    let mut seen = Nees {
        k: 2,
        ..Default::default()
    };
    let unknown_heading = std::f64::consts::PI.powi(2);
    // Pose: once a second, or half-way between the fused fixes.
    let mut next = f64::NEG_INFINITY;
    let mut armed = fix_every.is_none();
    for r in rows {
        if let (Some(every), true) = (fix_every, r.fused) {
            next = r.t + 0.5 * every;
            armed = true;
        }
        if !armed || r.t < next || r.pose_cov[2][2] >= unknown_heading {
            continue;
        }
        let Some((e, n, yaw)) = reference_at(reference, r.t + r.clock_offset) else {
            continue;
        };
        next = r.t + 1.0;
        armed = fix_every.is_none();
        let e2 = nalgebra::Vector2::new(r.east + r.fix_bias[0] - e, r.north + r.fix_bias[1] - n);
        let c2 = Matrix2::from_fn(|i, k| r.fix_position_cov[i][k])
            + Matrix2::identity() * noise.std_xy * noise.std_xy;
        if let Some(inv) = c2.try_inverse() {
            seen.add((e2.transpose() * inv * e2)[0]);
        }
        let mut c = Matrix3::from_fn(|i, k| r.pose_cov[i][k]);
        c[(0, 0)] += noise.position_var();
        c[(1, 1)] += noise.position_var();
        c[(2, 2)] += noise.std_yaw * noise.std_yaw;
        let v = match yaw {
            Some(yaw) => {
                let err = Vector3::new(r.east - e, r.north - n, wrap(r.yaw - yaw));
                for (p, k) in pose.parts.iter_mut().zip(0..3) {
                    *p += err[k] * err[k] / c[(k, k)];
                }
                c.try_inverse().map(|inv| (err.transpose() * inv * err)[0])
            }
            None => {
                let err = nalgebra::Vector2::new(r.east - e, r.north - n);
                let c2 = c.fixed_view::<2, 2>(0, 0).into_owned();
                c2.try_inverse().map(|inv| (err.transpose() * inv * err)[0])
            }
        };
        if let (Some(v), true) = (v, yaw.is_some() || k == 2) {
            pose.add(v);
        }
    }
    // Twist: consecutive windows.
    let mut i = 0;
    while i + 1 < rows.len() {
        let t0 = rows[i].t;
        let mut j = i;
        while j + 1 < rows.len() && rows[j + 1].t <= t0 + window {
            j += 1;
        }
        if j == i || rows[j].t - t0 < 0.9 * window {
            i = j.max(i + 1);
            continue;
        }
        let r0 = &rows[i];
        let (Some(a), Some(b)) = (
            reference_at(reference, t0 + r0.clock_offset),
            reference_at(reference, rows[j].t + r0.clock_offset),
        ) else {
            i = j;
            continue;
        };
        // The body frame at the start: the reference's heading, else the
        // estimate's.
        let yaw0 = a.2.unwrap_or(r0.yaw);
        let (s, c) = yaw0.sin_cos();
        let (de, dn) = (b.0 - a.0, b.1 - a.1);
        let d_ref = [c * de + s * dn, -s * de + c * dn];
        let turn_ref = match (a.2, b.2) {
            (Some(x), Some(y)) => Some(wrap(y - x)),
            _ => None,
        };
        let span = rows[j].t - t0;
        let claim = integrate(&rows[i..=j], &wheels[i.min(wheels.len())..]);
        let sigma = SlipMat::from_fn(|a, b| r0.icr_cov[a][b]);
        let param = claim.jac * sigma * claim.jac.transpose();
        let e = Vector3::new(
            claim.d[0] - d_ref[0],
            claim.d[1] - d_ref[1],
            turn_ref.map_or(0.0, |tr| wrap(claim.turn - tr)),
        );
        for (out, which) in twist.iter_mut().zip(stated) {
            let mut cov = param
                + match which {
                    Stated::ModelNoise => claim.model_noise,
                    Stated::Learned => claim.learned,
                };
            let r = noise.displacement_var(span);
            cov[(0, 0)] += r;
            cov[(1, 1)] += r;
            cov[(2, 2)] += 2.0 * noise.std_yaw * noise.std_yaw;
            let v = if turn_ref.is_some() {
                cov.try_inverse().map(|inv| (e.transpose() * inv * e)[0])
            } else {
                let e2 = e.fixed_rows::<2>(0).into_owned();
                let c2 = cov.fixed_view::<2, 2>(0, 0).into_owned();
                c2.try_inverse().map(|inv| (e2.transpose() * inv * e2)[0])
            };
            if let Some(v) = v {
                out.add(v);
                for (p, k) in out.parts.iter_mut().zip(0..3) {
                    *p += e[k] * e[k] / cov[(k, k)];
                }
            }
        }
        i = j;
    }
    (twist, pose, seen)
}

/// What the published twist claims over consecutive rows: the displacement
/// (m) and turn (rad) in the body frame at the first row, their derivative
/// with respect to the ICR parameters, and the covariance its slip noise
/// adds (both the filter's model noise and the learned noise, carried as
/// the one-second figures they are: variance per second of the window).
struct Claim {
    d: [f64; 2],
    turn: f64,
    jac: SMatrix<f64, 3, 5>,
    model_noise: Matrix3<f64>,
    learned: Matrix3<f64>,
}

fn integrate(rows: &[EstimateRow], wheels: &[(f64, f64)]) -> Claim {
    let mut c = Claim {
        d: [0.0; 2],
        turn: 0.0,
        jac: SMatrix::zeros(),
        model_noise: Matrix3::zeros(),
        learned: Matrix3::zeros(),
    };
    for (k, r) in rows.iter().enumerate().take(rows.len().saturating_sub(1)) {
        let dt = rows[k + 1].t - r.t;
        let (vl, vr) = wheels.get(k).copied().unwrap_or((0.0, 0.0));
        let p = r.icr();
        let tw = p.twist(vl, vr);
        let (sn, cs) = c.turn.sin_cos();
        c.d[0] += (cs * tw.v_x - sn * tw.v_y) * dt;
        c.d[1] += (sn * tw.v_x + cs * tw.v_y) * dt;
        c.turn += tw.omega * dt;
        let jk = twist_jacobian(&p, vl, vr);
        let rot = Matrix2::new(cs, -sn, sn, cs);
        let xy = rot * jk.fixed_rows::<2>(0) * dt;
        for m in 0..5 {
            c.jac[(0, m)] += xy[(0, m)];
            c.jac[(1, m)] += xy[(1, m)];
            c.jac[(2, m)] += jk[(2, m)] * dt;
        }
        let v = 0.5 * (vl + vr);
        let step = |q: [f64; 3]| {
            // A one-second variance as a diffusion over dt, turned into
            // the start's frame.
            let w = TWIST_WINDOW_S * dt;
            let b =
                rot * Matrix2::new(
                    q[0] + TWIST_VARIANCE_FLOOR,
                    0.0,
                    0.0,
                    q[1] + TWIST_VARIANCE_FLOOR,
                ) * rot.transpose()
                    * w;
            let mut m = Matrix3::zeros();
            m.fixed_view_mut::<2, 2>(0, 0).copy_from(&b);
            m[(2, 2)] = (q[2] + TWIST_VARIANCE_FLOOR) * w;
            m
        };
        c.model_noise += step(TwistNoise::from_model_noise(&r.model_noise).variance(v, tw.omega));
        c.learned += step(r.twist_noise.variance(v, tw.omega));
    }
    c
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let logs = crate::drives::logs_or_default(&a.logs)?;
    let (_, cfg) = estimators::resolve(std::slice::from_ref(&a.estimator))?
        .pop()
        .context("an estimator")?;
    let topics = a.topics.clone().map_or(Topics::ByType, Topics::File);
    println!(
        "NEES of the published covariances; twist over {} s windows, pose with one fix fused every {} s",
        a.window, a.fix_every
    );
    println!(
        "log | what | n | mean NEES (k dof) | 95 % band | | share above χ²(k) 95 % | median (χ²(k)'s) | top 5 %'s share of the sum | below χ²(k)'s median (95 % band), by the median"
    );
    println!("---|---|---:|---:|---|---|---:|---:|---:|---");
    for path in &logs {
        let input = terraslip::bag::read(path, &topics, terraslip::estimate::read_log)?;
        let log = input.log;
        let name = path
            .file_name()
            .map_or(String::new(), |n| n.to_string_lossy().into());
        let run = pipeline::run(
            &thinned(&log, a.fix_every),
            &cfg,
            &TerrainEvidence::None,
            None,
        )?;
        let wheels: Vec<(f64, f64)> = log.wheels.iter().map(|w| (w.v_left, w.v_right)).collect();
        // The reference's error as the run learned it: white and slowly
        // wandering parts.
        let noise = ReferenceNoise {
            std_xy: run.noise.std_xy,
            std_yaw: run.noise.std_yaw,
            slow_std: run.noise.correlated_std,
            slow_time: cfg.measurement.correlation_time,
        };
        let (tw, po, seen) = nees(
            &run.rows,
            &wheels,
            &log.pose,
            &noise,
            a.window,
            &[Stated::Learned, Stated::ModelNoise],
            (a.fix_every > 0.0).then_some(a.fix_every),
        );
        println!("{name} | twist (k = {}) | {}", tw[0].k, tw[0].row());
        println!(
            "{name} | twist, model noise q/window (k = {}) | {}",
            tw[1].k,
            tw[1].row()
        );
        println!("{name} | pose (k = {}) | {}", po.k, po.row());
        println!(
            "{name} | position with the reference's slow error (k = {}) | {}",
            seen.k,
            seen.row()
        );
        if a.components {
            for (what, n) in [
                ("twist", &tw[0]),
                ("twist, model noise", &tw[1]),
                ("pose", &po),
            ] {
                let [x, y, h] = n.part_means();
                let (a, b) = if what == "pose" {
                    ("east", "north")
                } else {
                    ("along", "across")
                };
                println!("{name} | {what}: mean e²/σ² {a} {x:.2}, {b} {y:.2}, heading {h:.2} |");
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi2_quantiles_match_the_tables() {
        // χ²(3): 7.815 (95 %), 9.348 (97.5 %); χ²(100): 74.222 (2.5 %),
        // 129.561 (97.5 %), the tables' figures.
        for (dof, p, want) in [
            (3.0, 0.95, 7.815),
            (3.0, 0.975, 9.348),
            (100.0, 0.025, 74.222),
            (100.0, 0.975, 129.561),
        ] {
            let q = chi2_quantile(dof, p);
            assert!((q - want).abs() < 0.01 * want, "{dof} {p}: {q} vs {want}");
        }
        let n = Nees {
            n: 600,
            k: 3,
            ..Default::default()
        };
        let (lo, hi) = n.band();
        assert!(lo < 3.0 && hi > 3.0 && hi - lo < 0.5, "{lo} {hi}");
    }

    #[test]
    fn a_chi_square_sample_has_its_median_and_a_light_tail() {
        // χ²(3): median 2.366; the largest 5 % carry 3 P(χ²(5) > 7.815) / 3
        // = 0.167 of the sum. A heavy tail (one sample in 20 a hundred times
        // larger) keeps the median and carries most of the sum.
        let mut rng = terraslip_core::rng::SplitMix64::new(7);
        let mut n = Nees {
            k: 3,
            ..Default::default()
        };
        let mut heavy = n.clone();
        for i in 0..20000 {
            let v: f64 = (0..3).map(|_| rng.normal().powi(2)).sum();
            n.add(v);
            heavy.add(if i % 20 == 0 { 100.0 * v } else { v });
        }
        assert!((chi2_median(3.0) - 2.366).abs() < 0.02);
        assert!((n.median() - 2.366).abs() < 0.08, "{}", n.median());
        assert!((n.top_share() - 0.167).abs() < 0.02, "{}", n.top_share());
        assert!((heavy.median() / n.median() - 1.0).abs() < 0.1);
        assert!(heavy.top_share() > 0.7 && heavy.mean() > 10.0);
    }

    #[test]
    fn the_median_test_tells_a_scale_from_a_heavy_tail() {
        // 600 samples, as many as a drive gives: a consistent one is in by
        // its median, one whose covariance is half too narrow (NEES x 1.5)
        // over, one twice too wide under; a heavy tail (one in 20 a
        // hundred times larger) is in by the median, over by the mean.
        let mut rng = terraslip_core::rng::SplitMix64::new(11);
        let blank = Nees {
            k: 3,
            ..Default::default()
        };
        let (mut ok, mut narrow, mut wide, mut heavy) =
            (blank.clone(), blank.clone(), blank.clone(), blank);
        for i in 0..600 {
            let v: f64 = (0..3).map(|_| rng.normal().powi(2)).sum();
            ok.add(v);
            narrow.add(1.5 * v);
            wide.add(0.5 * v);
            heavy.add(if i % 20 == 0 { 100.0 * v } else { v });
        }
        assert_eq!(ok.median_test().2, "in", "{:?}", ok.median_test());
        assert_eq!(narrow.median_test().2, "over", "{:?}", narrow.median_test());
        assert_eq!(wide.median_test().2, "under", "{:?}", wide.median_test());
        assert_eq!(heavy.median_test().2, "in", "{:?}", heavy.median_test());
        assert!(heavy.mean() > heavy.band().1);
    }
}
