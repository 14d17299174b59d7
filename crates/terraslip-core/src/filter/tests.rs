//! Filter tests on small exact-model drives.
#![allow(clippy::field_reassign_with_default)]

use super::*;
use crate::angle;
use crate::kinematics::{IcrParams, Twist};
use crate::model::{self, CLOCK, EAST, LAW, N, NORTH};
use crate::rng::SplitMix64;
use crate::slip::Chart;
use crate::slip::TreadInput;

mod centripetal;
mod speed_law;

fn band(w: f64) -> IcrBand {
    IcrBand {
        min_spread: 0.8 * w,
        max_spread: 4.0 * w,
        max_centre: 0.25 * w,
        max_x_c: 0.5 * w,
        alpha_range: (0.3, 1.5),
    }
}

fn prior(w: f64) -> Prior {
    Prior {
        icr: IcrParams::no_slip(w),
        std: SlipStd {
            spread: 0.5 * w,
            centre: 0.05,
            x_c: 0.1,
            alpha: 0.15,
            alpha_diff: 0.01,
        },
        turn_law: 0.0,
        turn_law_std: 0.15,
        centripetal: crate::kinematics::CentripetalSlopes::NONE,
        centripetal_std: crate::kinematics::CentripetalSlopes::NONE,
        speed_law: 0.0,
        speed_law_std: 0.0,
    }
}

/// The default filter for a 0.5 m track.
fn default_filter() -> Filter {
    Filter::new(
        &prior(0.5),
        FilterConfig::default(),
        MeasurementConfig::default(),
        band(0.5),
    )
    .unwrap()
}

fn papers_cfg() -> (FilterConfig, MeasurementConfig) {
    let mut cfg = FilterConfig::default();
    cfg.chart = Chart::Tread;
    cfg.update_iterations = 1;
    cfg.learn_alpha = false;
    cfg.learn_clock = false;
    cfg.change_window = 0.0;
    cfg.noise_memory = 0.0;
    let mut meas = MeasurementConfig::default();
    meas.correlated_fraction = 0.0;
    meas.clock_offset_std = 0.0;
    (cfg, meas)
}

/// Tread speeds of an operator weaving left and right at 0.5-1 m/s.
fn treads(t: f64) -> (f64, f64) {
    let v = 0.75 + 0.25 * libm::sin(0.05 * t);
    let turn = 0.35 * libm::sin(0.21 * t) + 0.2 * libm::cos(0.077 * t);
    (v - turn, v + turn)
}

/// Settings of [`drive`].
struct Drive {
    truth: IcrParams,
    /// Truth from this time on (a change of ground), with its start.
    change: Option<(f64, IcrParams)>,
    duration: f64,
    fix_hz: f64,
    std_xy: f64,
    std_yaw: f64,
    /// How late the fixes are stamped, s.
    delay: f64,
    heading: bool,
    /// Random constant tread speeds held for 2 s each (the DRIVE
    /// protocol) instead of smooth weaving.
    windows: bool,
    /// How the true ICRs move with the speed.
    centripetal: crate::kinematics::CentripetalSlopes,
    /// The true speed factors' turn law, s/m: both speed factors are
    /// `1 + speed_law |V_r - V_l|` times `truth`'s.
    speed_law: f64,
    seed: u64,
}

impl Default for Drive {
    fn default() -> Self {
        Self {
            truth: IcrParams {
                y_l: 0.52,
                y_r: -0.50,
                x_c: 0.03,
                alpha_l: 0.82,
                alpha_r: 0.83,
            },
            change: None,
            duration: 200.0,
            fix_hz: 5.0,
            std_xy: 0.03,
            std_yaw: 0.005,
            delay: 0.0,
            heading: true,
            windows: false,
            centripetal: crate::kinematics::CentripetalSlopes::NONE,
            speed_law: 0.0,
            seed: 1,
        }
    }
}

/// Runs `f` over an exact-model drive (50 Hz wheels); returns the true
/// pose and ICRs at the end.
fn run(f: &mut Filter, d: &Drive) -> ((f64, f64, f64), IcrParams) {
    let mut rng = SplitMix64::new(d.seed);
    let dt = 0.02;
    let (mut e, mut n, mut yaw) = (0.0f64, 0.0f64, 0.4f64);
    let every = (1.0 / (d.fix_hz * dt)).round().max(1.0) as usize;
    let steps = (d.duration / dt) as usize;
    let mut truth = d.truth;
    // (stamp, fix) waiting for their stamp time.
    let mut pending: Vec<(f64, PoseFix)> = Vec::new();
    f.predict(0.0, 0.0, 0.0).unwrap();
    let mut window = (0.5, 0.5);
    for k in 1..=steps {
        let t = k as f64 * dt;
        if let Some((tc, p)) = d.change {
            if t >= tc {
                truth = p;
            }
        }
        if d.windows && k % 100 == 1 {
            window = (2.0 * rng.uniform() - 0.5, 2.0 * rng.uniform() - 0.5);
        }
        let (vl, vr) = if d.windows { window } else { treads(t) };
        let tw = d.centripetal.at(&truth, vl, vr).twist(vl, vr);
        let tw = tw.scaled(1.0 + d.speed_law * (vr - vl).abs());
        for _ in 0..10 {
            let h = dt / 10.0;
            e += h * (tw.v_x * libm::cos(yaw) - tw.v_y * libm::sin(yaw));
            n += h * (tw.v_x * libm::sin(yaw) + tw.v_y * libm::cos(yaw));
            yaw = angle::wrap(yaw + h * tw.omega);
        }
        f.predict(vl, vr, dt).unwrap();
        if k % every == 0 {
            pending.push((
                t + d.delay,
                PoseFix {
                    position: Some((e + d.std_xy * rng.normal(), n + d.std_xy * rng.normal())),
                    yaw: d
                        .heading
                        .then(|| angle::wrap(yaw + d.std_yaw * rng.normal())),
                    std_xy: d.std_xy,
                    std_yaw: d.std_yaw,
                    stated: true,
                },
            ));
        }
        while pending.first().is_some_and(|(ts, _)| *ts <= t + 1e-9) {
            let (ts, fix) = pending.remove(0);
            f.update(ts, t - ts, &fix).unwrap();
        }
    }
    ((e, n, yaw), truth)
}

fn assert_spd(f: &Filter) {
    let (_, P) = f.raw();
    assert!((P - P.transpose()).abs().max() < 1e-12);
    let eig = P.symmetric_eigen();
    assert!(
        eig.eigenvalues.iter().all(|v| *v > -1e-12),
        "{:?}",
        eig.eigenvalues
    );
}

#[test]
fn learns_spread_and_speed_factor_from_lidar_grade_fixes() {
    let mut f = default_filter();
    let d = Drive::default();
    let ((e, n, _), truth) = run(&mut f, &d);
    let p = f.icr();
    assert!((p.spread() - truth.spread()).abs() < 0.01, "{p:?}");
    assert!((p.alpha_l - truth.alpha_l).abs() < 0.005, "{p:?}");
    assert!((p.alpha_r - truth.alpha_r).abs() < 0.005, "{p:?}");
    let (fe, fn_, _) = f.pose();
    assert!(libm::hypot(fe - e, fn_ - n) < 0.1);
    assert_spd(&f);
    // Honest: the errors are within 3 reported stds.
    let c = f.icr_covariance();
    assert!((p.alpha_l - truth.alpha_l).abs() < 3.0 * c[(3, 3)].sqrt() + 1e-3);
}

#[test]
fn learns_the_clock_offset_of_a_late_pose_stream() {
    for chart in [Chart::Gain, Chart::Tread] {
        let mut cfg = FilterConfig::default();
        cfg.chart = chart;
        let mut f = Filter::new(&prior(0.5), cfg, MeasurementConfig::default(), band(0.5)).unwrap();
        let d = Drive {
            delay: 0.3,
            ..Default::default()
        };
        let (_, truth) = run(&mut f, &d);
        let (clock, sd) = f.clock_offset();
        assert!((clock - 0.3).abs() < 0.03, "{chart:?}: {clock} +- {sd}");
        assert!(
            (f.icr().spread() - truth.spread()).abs() < 0.02,
            "{chart:?}"
        );
    }
}

#[test]
fn a_late_pose_stream_is_blamed_on_the_clock_not_on_the_slip() {
    // Commands that change every 2 s (as in the DRIVE protocol): a pose
    // stream 0.3 s late shows each change of turn 0.3 s after the treads.
    // Without the clock state that lag is read as slip and noise.
    let run_with = |learn_clock: bool| {
        let mut cfg = FilterConfig::default();
        cfg.learn_clock = learn_clock;
        let mut f = Filter::new(&prior(0.5), cfg, MeasurementConfig::default(), band(0.5)).unwrap();
        let d = Drive {
            delay: 0.3,
            windows: true,
            ..Default::default()
        };
        let (_, truth) = run(&mut f, &d);
        let p = f.icr();
        (
            (p.spread() - truth.spread()).abs(),
            (p.alpha_l - truth.alpha_l).abs(),
            f.clock_offset().0,
        )
    };
    let (with, without) = (run_with(true), run_with(false));
    assert!((with.2 - 0.3).abs() < 0.02, "{with:?}");
    assert!(with.0 < 0.01 && with.1 < 0.005, "{with:?}");
    assert!(
        without.0 > 3.0 * with.0 || without.1 > 3.0 * with.1,
        "{with:?} vs {without:?}"
    );
}

#[test]
fn learns_the_pose_noise_when_none_is_stated() {
    let mut f = default_filter();
    let d = Drive::default();
    // Same drive, but the fixes state a configured 1 m / 2 deg guess.
    let mut rng = SplitMix64::new(9);
    let dt = 0.02;
    let (mut e, mut n, mut yaw) = (0.0f64, 0.0f64, 0.4f64);
    f.predict(0.0, 0.0, 0.0).unwrap();
    for k in 1..=10_000 {
        let t = k as f64 * dt;
        let (vl, vr) = treads(t);
        let tw = d.truth.twist(vl, vr);
        e += dt * (tw.v_x * libm::cos(yaw) - tw.v_y * libm::sin(yaw));
        n += dt * (tw.v_x * libm::sin(yaw) + tw.v_y * libm::cos(yaw));
        yaw = angle::wrap(yaw + dt * tw.omega);
        f.predict(vl, vr, dt).unwrap();
        if k % 10 == 0 {
            let fix = PoseFix {
                position: Some((e + 0.03 * rng.normal(), n + 0.03 * rng.normal())),
                yaw: Some(angle::wrap(yaw + 0.005 * rng.normal())),
                std_xy: 1.0,
                std_yaw: 2f64.to_radians(),
                stated: false,
            };
            f.update(t, 0.0, &fix).unwrap();
        }
    }
    // The 0.03 m of the fixes, within a factor of two (part of it may be
    // read as the model's speed noise: both grow the same way here).
    let (sxy, syaw, corr) = f.noise(1.0, 2f64.to_radians());
    assert!(sxy > 0.015 && sxy < 0.06, "{sxy}");
    assert!(syaw > 0.003 && syaw < 0.01, "{syaw}");
    // Its slow part is `correlated_fraction` of it, as for every source.
    let fraction = MeasurementConfig::default().correlated_fraction;
    assert!(
        (corr / (fraction * sxy) - 1.0).abs() < 0.2,
        "{corr} vs {sxy}"
    );
    assert!((f.icr().spread() - d.truth.spread()).abs() < 0.01);
}

#[test]
fn a_multipath_jump_is_gated_and_the_gate_keeps_its_meaning() {
    let mut f = default_filter();
    let d = Drive {
        duration: 60.0,
        fix_hz: 1.0,
        std_xy: 0.5,
        std_yaw: 0.02,
        ..Default::default()
    };
    run(&mut f, &d);
    let before = f.pose();
    let (e, n, _) = before;
    let jump = PoseFix {
        position: Some((e + 30.0, n)),
        yaw: None,
        std_xy: 0.5,
        std_yaw: 0.02,
        stated: true,
    };
    let rep = f.update(60.0, 0.0, &jump).unwrap();
    assert_eq!(rep.position, Fate::Gated);
    assert!(rep.nis_position > 1000.0);
    assert!((f.pose().0 - e).abs() < 1e-9);
    // A 1e308 position is rejected the same way, and the state stays finite.
    let wild = PoseFix {
        position: Some((1e308, n)),
        ..jump
    };
    let rep = f.update(60.1, 0.0, &wild).unwrap();
    assert_eq!(rep.position, Fate::Gated);
    let (x, _) = f.raw();
    assert!(x.iter().all(|v| v.is_finite()));
}

#[test]
fn finds_the_heading_from_position_fixes_alone() {
    let mut f = default_filter();
    let d = Drive {
        heading: false,
        fix_hz: 1.0,
        std_xy: 0.3,
        duration: 300.0,
        ..Default::default()
    };
    let ((_, _, yaw), _) = run(&mut f, &d);
    assert_eq!(f.anchored(), [true, true]);
    let err = angle::wrap(f.pose().2 - yaw);
    assert!(err.abs() < 0.1, "{err}");
}

#[test]
fn the_change_detector_finds_a_new_ground_and_relearns() {
    let mut cfg = FilterConfig::default();
    let new = IcrParams {
        y_l: 0.65,
        y_r: -0.63,
        x_c: 0.03,
        alpha_l: 0.82,
        alpha_r: 0.83,
    };
    let d = Drive {
        change: Some((100.0, new)),
        fix_hz: 1.0,
        std_xy: 0.5,
        std_yaw: 0.0175,
        ..Default::default()
    };
    let mut f = Filter::new(&prior(0.5), cfg, MeasurementConfig::default(), band(0.5)).unwrap();
    run(&mut f, &d);
    let with = (f.icr().spread() - new.spread()).abs();
    cfg.change_window = 0.0;
    let mut g = Filter::new(&prior(0.5), cfg, MeasurementConfig::default(), band(0.5)).unwrap();
    run(&mut g, &d);
    let without = (g.icr().spread() - new.spread()).abs();
    assert!(with < 0.03, "{with}");
    assert!(with < 0.5 * without, "{with} vs {without}");
}

#[test]
fn the_papers_innovation_adaptive_form_can_break_and_is_refused_then() {
    // Tiny innovations make the windowed covariance far smaller than
    // H P H' + R (or singular): the gain exceeds one and (I - K H) P goes
    // indefinite. The update is refused; the state stays finite.
    let (mut cfg, meas) = papers_cfg();
    cfg.variant = Variant::InnovationAdaptive;
    cfg.innovation_window = 3;
    let mut f = Filter::new(&prior(0.5), cfg, meas, band(0.5)).unwrap();
    let fix = |e: f64, n: f64, y: f64| PoseFix {
        position: Some((e, n)),
        yaw: Some(y),
        std_xy: 2.0,
        std_yaw: 0.0175,
        stated: true,
    };
    f.update(0.0, 0.0, &fix(0.0, 0.0, 0.0)).unwrap();
    let mut refused = false;
    for k in 0..10 {
        f.predict(0.3, 0.3, 0.02).unwrap();
        let (e, n, y) = f.pose();
        let eps = 1e-4 * (k as f64 + 1.0);
        match f.update(k as f64, 0.0, &fix(e + eps, n - eps, y + 1e-5)) {
            Err(FilterError::LostDefiniteness | FilterError::SingularInnovation) => refused = true,
            Ok(_) => {}
            Err(e) => panic!("{e}"),
        }
        let (x, P) = f.raw();
        assert!(x.iter().all(|v| v.is_finite()));
        assert!((0..crate::model::N).all(|i| P[(i, i)] >= 0.0));
    }
    assert!(refused, "expected the paper's form to break");
}

#[test]
fn covariance_stays_symmetric_positive_definite_through_anything() {
    let mut rng = SplitMix64::new(11);
    for chart in [Chart::Gain, Chart::Tread] {
        let mut cfg = FilterConfig::default();
        cfg.chart = chart;
        let mut f = Filter::new(&prior(0.5), cfg, MeasurementConfig::default(), band(0.5)).unwrap();
        f.predict(0.0, 0.0, 0.0).unwrap();
        for k in 0..3000 {
            let vl = 2.0 * rng.normal();
            let vr = 2.0 * rng.normal();
            f.predict(vl, vr, 0.01 + 0.05 * rng.uniform()).unwrap();
            if k % 7 == 0 {
                let (e, n, y) = f.pose();
                let fix = PoseFix {
                    position: (rng.uniform() < 0.8)
                        .then(|| (e + 3.0 * rng.normal(), n + 3.0 * rng.normal())),
                    yaw: (rng.uniform() < 0.7).then(|| y + 0.3 * rng.normal()),
                    std_xy: 0.01 + 2.0 * rng.uniform(),
                    std_yaw: 0.001 + 0.1 * rng.uniform(),
                    stated: rng.uniform() < 0.5,
                };
                let lag = 0.3 * rng.normal();
                f.update(k as f64, lag, &fix).unwrap();
            }
            if k % 500 == 0 {
                let std = SlipStd {
                    spread: 0.1,
                    centre: 0.01,
                    x_c: 0.02,
                    alpha: 0.05,
                    alpha_diff: 0.01,
                };
                f.reset_slip(None, &std).unwrap();
            }
        }
        assert_spd(&f);
        let (x, _) = f.raw();
        assert!(x.iter().all(|v| v.is_finite()));
        let p = f.icr();
        let (q, moved) = band(0.5).project(&p);
        assert!(!moved, "{q:?}");
    }
}

/// A gyro's bias is learned at standstill, and driving, its heading change
/// teaches the turning gain: a filter started 30 % off the spread, with no
/// pose fix at all, ends with the gain the gyro shows.
#[test]
fn a_gyro_teaches_its_bias_standing_and_the_turning_gain_driving() {
    let (f, truth) = gyro_drive(FilterConfig::default(), 0.015);
    let icr = f.icr();
    assert!(
        (gain(&icr) / gain(&truth) - 1.0).abs() < 0.03,
        "gain {} against {}",
        gain(&icr),
        gain(&truth)
    );
}

/// Turning gain `a / d`, 1/m.
fn gain(p: &IcrParams) -> f64 {
    0.5 * (p.alpha_l + p.alpha_r) / p.spread()
}

/// Without positions the gyro teaches the turning gain; the held speed
/// factor and ICR centre stay exactly at the prior, their variance too.
#[test]
fn a_gyro_alone_learns_the_turning_and_leaves_the_held_speed_factor() {
    let mut cfg = FilterConfig::default();
    cfg.hold = SlipHold::PositionTaught;
    let before = Filter::new(&prior_gyro(), cfg, MeasurementConfig::default(), band(0.5)).unwrap();
    let (f, truth) = gyro_drive(cfg, 0.015);
    let (s0, s) = (before.raw().0, f.raw().0);
    let (p0, p) = (before.raw().1, f.raw().1);
    for k in Chart::Gain.position_slots() {
        let i = crate::model::SLIP + k;
        assert_eq!(s[i], s0[i], "slot {k} moved");
        assert_eq!(p[(i, i)], p0[(i, i)], "slot {k} variance changed");
    }
    assert!((gain(&f.icr()) / gain(&truth) - 1.0).abs() < 0.03);
    assert_spd(&f);
}

/// The gyro drive's prior: a spread 40 % wider than the truth's.
fn prior_gyro() -> Prior {
    let mut p = prior(0.5);
    p.icr = IcrParams::no_slip(0.63);
    p
}

/// The gyro drives' truth: a spread of 0.9 m, speed factors 0.9.
fn gyro_truth() -> IcrParams {
    IcrParams {
        y_l: 0.45,
        y_r: -0.45,
        x_c: 0.0,
        alpha_l: 0.9,
        alpha_r: 0.9,
    }
}

/// 60 s with a gyro of bias `bias` (rad/s) and no pose fix, standing for
/// the first 20 s; returns the filter and the truth.
fn gyro_drive(cfg: FilterConfig, bias: f64) -> (Filter, IcrParams) {
    let truth = gyro_truth();
    let mut f = Filter::new(&prior_gyro(), cfg, MeasurementConfig::default(), band(0.5)).unwrap();
    let dt = 0.02;
    let mut rng = SplitMix64::new(11);
    for k in 0..3000 {
        let t = k as f64 * dt;
        let (vl, vr) = if t < 20.0 { (0.0, 0.0) } else { treads(t) };
        f.predict(vl, vr, dt).unwrap();
        let omega = truth.twist(vl, vr).omega;
        let rate = omega + bias + 0.005 * rng.normal();
        f.add_gyro(rate * dt, 2.0).unwrap();
        if k == 999 {
            let g = f.gyro_noise();
            assert!((g.bias - bias).abs() < 3.0 * g.bias_std.max(1e-4), "{g:?}");
            assert!(g.fused > 30, "{g:?}");
        }
    }
    (f, truth)
}

/// 200 s weaving with a gyro reading `scale` times the true yaw rate and
/// heading fixes (0.3 degrees at 5 Hz) when `headings`; returns the filter.
fn scaled_gyro_drive(cfg: FilterConfig, scale: f64, headings: bool) -> Filter {
    let truth = gyro_truth();
    let mut f = Filter::new(&prior_gyro(), cfg, MeasurementConfig::default(), band(0.5)).unwrap();
    let dt = 0.02;
    let mut rng = SplitMix64::new(5);
    let mut yaw = 0.0;
    for k in 1..=10_000 {
        let t = k as f64 * dt;
        let (vl, vr) = treads(t);
        f.predict(vl, vr, dt).unwrap();
        let omega = truth.twist(vl, vr).omega;
        yaw = angle::wrap(yaw + omega * dt);
        let rate = scale * omega + 0.003 * rng.normal();
        f.add_gyro(rate * dt, 2.0).unwrap();
        if headings && k % 10 == 0 {
            let fix = PoseFix {
                position: None,
                yaw: Some(angle::wrap(yaw + 0.005 * rng.normal())),
                std_xy: 1.0,
                std_yaw: 0.005,
                stated: true,
            };
            f.update(t, 0.0, &fix).unwrap();
        }
    }
    f
}

/// Headings show the true turn: a gyro reading 3 % high is learned, and
/// the turning gain is the truth's, not the gyro's.
#[test]
fn headings_teach_the_gyro_scale_and_the_true_turning_gain() {
    let mut cfg = FilterConfig::default();
    cfg.hold = SlipHold::PositionTaught;
    let f = scaled_gyro_drive(cfg, 1.03, true);
    let g = f.gyro_noise();
    assert!(
        (g.scale - 1.03).abs() < 0.005 && (g.scale - 1.03).abs() < 3.0 * g.scale_std,
        "{g:?}"
    );
    assert!(
        (gain(&f.icr()) / gain(&gyro_truth()) - 1.0).abs() < 0.01,
        "gain {}",
        gain(&f.icr())
    );
    assert_spd(&f);
}

/// Where the scale is learned its variance walks between fixes
/// (`gyro_scale_walk`^2 per second), so that a scale learned off can come
/// back; a walk of 0 leaves it where the fixes left it.
#[test]
fn a_learned_gyro_scale_walks_between_fixes() {
    let mut cfg = FilterConfig::default();
    cfg.hold = SlipHold::PositionTaught;
    for walk in [MeasurementConfig::default().gyro_scale_walk, 0.0] {
        assert!(walk >= 0.0);
        let mut f = scaled_gyro_drive(cfg, 1.03, true);
        f.meas.gyro_scale_walk = walk;
        let i = crate::model::GYRO_SCALE;
        let before = f.raw().1[(i, i)];
        for _ in 0..5_000 {
            f.predict(1.0, 1.0, 0.02).unwrap();
        }
        let grown = f.raw().1[(i, i)] - before;
        assert!(
            (grown - walk * walk * 100.0).abs() <= 1e-12,
            "walk {walk}: variance grew by {grown} over 100 s"
        );
    }
    assert!(MeasurementConfig::default().gyro_scale_walk > 0.0);
}

/// A walk below 0, above 0.01 or not a number is refused, naming the key.
#[test]
fn a_gyro_scale_walk_out_of_range_is_refused() {
    for walk in [-1e-4, 0.02, f64::NAN] {
        let meas = MeasurementConfig {
            gyro_scale_walk: walk,
            ..MeasurementConfig::default()
        };
        match meas.validate() {
            Err(FilterError::BadConfig(what)) => {
                assert!(what.contains("gyro_scale_walk"), "{what}")
            }
            other => panic!("walk {walk}: {other:?}"),
        }
    }
}

/// Held (the gyro the only turn sensor): the scale and its row of the
/// covariance stay exactly at their start, and the gain absorbs the scale.
#[test]
fn a_held_gyro_scale_stays_exactly_put() {
    let mut cfg = FilterConfig::default();
    cfg.hold = SlipHold::PositionTaught;
    cfg.hold_gyro_scale = true;
    let f = scaled_gyro_drive(cfg, 1.03, false);
    let (x, P) = f.raw();
    let i = crate::model::GYRO_SCALE;
    assert_eq!(x[i], 0.0);
    assert!((0..crate::model::N).all(|j| P[(i, j)] == 0.0 && P[(j, i)] == 0.0));
    let g = f.gyro_noise();
    assert_eq!((g.scale, g.scale_std, g.scale_learned), (1.0, 0.0, false));
    assert!(
        (gain(&f.icr()) / 1.03 - 1.0).abs() < 0.02,
        "{}",
        gain(&f.icr())
    );
    assert_spd(&f);
}

#[test]
fn a_fix_taken_standing_still_leaves_the_clock_offset() {
    // Drive with a late pose stream until the clock is learned (and
    // correlated with the pose), stand still for a second and move off
    // again: the fix stamped during the stop arrives once moving.
    let mut f = default_filter();
    let d = Drive {
        delay: 0.3,
        duration: 60.0,
        ..Default::default()
    };
    run(&mut f, &d);
    for _ in 0..50 {
        f.predict(0.0, 0.0, 0.02).unwrap();
    }
    let (e, n, yaw) = f.pose();
    for _ in 0..5 {
        f.predict(0.5, 0.5, 0.02).unwrap();
    }
    let (_, P) = f.raw();
    assert!(
        P[(CLOCK, EAST)].abs() + P[(CLOCK, NORTH)].abs() > 1e-9,
        "the clock is correlated with the pose"
    );
    let before = f.clock_offset();
    // A fix 2 cm off the pose of the stop, 0.2 s after its stamp: read at
    // the stamp minus the clock offset, the robot stood still.
    let fix = PoseFix {
        position: Some((e + 0.02, n - 0.02)),
        yaw: Some(yaw),
        std_xy: 0.03,
        std_yaw: 0.005,
        stated: true,
    };
    let report = f.update(61.0, 0.2, &fix).unwrap();
    assert!(
        matches!(report.position, Fate::Fused),
        "the fix is used: {report:?}"
    );
    let after = f.clock_offset();
    assert_eq!(before.0, after.0, "clock {before:?} -> {after:?}");
    assert!(after.1 <= before.1 + 1e-15);
    assert_spd(&f);
}

#[test]
fn the_fixes_position_covariance_is_what_a_fix_is_predicted_with() {
    // GNSS-like fixes (1 Hz, position only) whose error has a slow part:
    // the filter carries it as a bias, anti-correlated with the position
    // (the fixes see their sum). At standstill, with no lag and no lever
    // arm, a position fix is predicted with the position plus the bias:
    // its covariance is the innovation's less the fix's white noise.
    let mut f = default_filter();
    let d = Drive {
        heading: false,
        fix_hz: 1.0,
        std_xy: 0.5,
        ..Default::default()
    };
    run(&mut f, &d);
    for _ in 0..10 {
        f.predict(0.0, 0.0, 0.1).unwrap();
    }
    let used = [true, true, false];
    let (_, H) = f.measure(&f.x, 0.0, used);
    let (HP, _) = f.innovation_cov(&H, &[0.0; 3], used);
    let hph = HP * H.transpose();
    let c = f.fix_position_covariance();
    for i in 0..2 {
        for j in 0..2 {
            assert!(
                (c[(i, j)] - hph[(i, j)]).abs() <= 1e-9 * hph[(i, i)].abs().max(1e-12),
                "({i}, {j}): {} against {}",
                c[(i, j)],
                hph[(i, j)]
            );
        }
    }
    // The fixes pin the sum much better than the position alone.
    let p = f.pose_covariance();
    assert!(
        c[(0, 0)] < 0.5 * p[(0, 0)],
        "{} vs {}",
        c[(0, 0)],
        p[(0, 0)]
    );
}
