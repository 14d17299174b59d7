//! The centripetal terms learned online: a robot whose `x_c` moves with
//! the speed, a constant-ICR robot, and no position reference.

use super::*;
use crate::kinematics::CentripetalSlopes;

/// The prior of [`prior`] with room for the centripetal terms (the
/// estimator's defaults: 0.2 s, 0.1 s/m).
fn prior_terms(w: f64) -> Prior {
    Prior {
        centripetal_std: CentripetalSlopes {
            k_x_speed: 0.2,
            k_spread_speed: 0.1,
        },
        ..prior(w)
    }
}

/// A filter with the default configuration started from `prior`.
pub(super) fn filter(prior: &Prior) -> Filter {
    Filter::new(
        prior,
        FilterConfig::default(),
        MeasurementConfig::default(),
        band(0.5),
    )
    .unwrap()
}

/// Mean 2 s position error of `model` (a twist of tread speeds) against
/// `truth` over starts every 2 s of random DRIVE windows, from the same
/// pose.
fn prediction_error(
    truth: &dyn Fn(f64, f64) -> Twist,
    model: &dyn Fn(f64, f64) -> Twist,
    seed: u64,
) -> f64 {
    let mut rng = SplitMix64::new(seed);
    let (dt, starts) = (0.02, 200);
    let mut sum = 0.0;
    for _ in 0..starts {
        let (vl, vr) = (2.0 * rng.uniform() - 0.5, 2.0 * rng.uniform() - 0.5);
        let (mut a, mut b) = ([0.0f64; 3], [0.0f64; 3]);
        for _ in 0..100 {
            for (p, tw) in [(&mut a, truth(vl, vr)), (&mut b, model(vl, vr))] {
                p[0] += dt * (tw.v_x * libm::cos(p[2]) - tw.v_y * libm::sin(p[2]));
                p[1] += dt * (tw.v_x * libm::sin(p[2]) + tw.v_y * libm::cos(p[2]));
                p[2] += dt * tw.omega;
            }
        }
        sum += libm::hypot(a[0] - b[0], a[1] - b[1]);
    }
    sum / starts as f64
}

/// The filter's own model of a window's twist: the ICRs at its turn
/// (the turn law's input settled) with the centripetal terms at its speed.
fn model_twist(f: &Filter, vl: f64, vr: f64) -> Twist {
    let chart = f.config().chart;
    let (x, _) = f.raw();
    let u = TreadInput {
        v_left: vl,
        v_right: vr,
    };
    let (t, ..) = chart.twist_with_terms(
        &model::slip_of(x),
        x[LAW],
        (vr - vl).abs(),
        &model::centripetal_of(x),
        u,
    );
    t
}

fn drive(truth: CentripetalSlopes, seed: u64) -> Drive {
    Drive {
        windows: true,
        centripetal: truth,
        duration: 300.0,
        seed,
        ..Default::default()
    }
}

#[test]
fn learns_an_x_c_that_moves_with_the_speed_and_predicts_better_than_the_constant_model() {
    let truth = CentripetalSlopes {
        k_x_speed: 0.15,
        k_spread_speed: 0.0,
    };
    for seed in [1, 2, 3] {
        let d = drive(truth, seed);
        let mut f = filter(&prior_terms(0.5));
        let mut held = filter(&prior(0.5));
        let (_, p) = run(&mut f, &d);
        run(&mut held, &d);
        assert!(f.learns_centripetal() && !held.learns_centripetal());
        let (c, sd) = f.centripetal();
        assert!(
            (c.k_x_speed - truth.k_x_speed).abs() < 0.03,
            "seed {seed}: {c:?} +- {sd:?}"
        );
        // Honest: within 3 of its own stds.
        assert!(
            (c.k_x_speed - truth.k_x_speed).abs() < 3.0 * sd.k_x_speed + 1e-3,
            "seed {seed}: {c:?} +- {sd:?}"
        );
        assert!(c.k_spread_speed.abs() < 3.0 * sd.k_spread_speed + 0.01);
        assert_spd(&f);
        let real = |vl, vr| truth.at(&p, vl, vr).twist(vl, vr);
        let learned = prediction_error(&real, &|vl, vr| model_twist(&f, vl, vr), 7);
        let constant = prediction_error(&real, &|vl, vr| model_twist(&held, vl, vr), 7);
        assert!(
            learned < 0.3 * constant,
            "seed {seed}: learned {learned:.3} m, constant {constant:.3} m"
        );
    }
}

#[test]
fn a_constant_icr_robot_keeps_the_terms_near_zero() {
    for seed in [1, 2, 3] {
        let d = drive(CentripetalSlopes::NONE, seed);
        let mut f = filter(&prior_terms(0.5));
        let (_, p) = run(&mut f, &d);
        let (c, sd) = f.centripetal();
        assert!(c.k_x_speed.abs() < 0.02, "seed {seed}: {c:?} +- {sd:?}");
        assert!(
            c.k_spread_speed.abs() < 0.02,
            "seed {seed}: {c:?} +- {sd:?}"
        );
        assert!(c.k_x_speed.abs() < 3.0 * sd.k_x_speed + 1e-3);
        let real = |vl, vr| p.twist(vl, vr);
        let err = prediction_error(&real, &|vl, vr| model_twist(&f, vl, vr), 7);
        assert!(err < 0.05, "seed {seed}: {err:.3} m");
    }
}

#[test]
fn without_a_position_reference_the_terms_are_held_exactly() {
    let mut cfg = FilterConfig::default();
    cfg.hold = SlipHold::PositionTaught;
    let mut start = prior_terms(0.5);
    start.centripetal.k_x_speed = 0.1;
    let mut f = Filter::new(&start, cfg, MeasurementConfig::default(), band(0.5)).unwrap();
    assert!(!f.learns_centripetal());
    let d = drive(
        CentripetalSlopes {
            k_x_speed: 0.3,
            k_spread_speed: 0.2,
        },
        1,
    );
    run(&mut f, &d);
    let (c, sd) = f.centripetal();
    assert_eq!(c.k_x_speed, 0.1);
    assert_eq!(c.k_spread_speed, 0.0);
    assert_eq!((sd.k_x_speed, sd.k_spread_speed), (0.0, 0.0));
    let (_, P) = f.raw();
    for i in [model::K_X_SPEED, model::K_SPREAD_SPEED] {
        assert!((0..N).all(|j| P[(i, j)] == 0.0 && P[(j, i)] == 0.0));
    }
}

#[test]
fn a_term_with_no_prior_std_is_held_and_the_other_learned() {
    let mut start = prior_terms(0.5);
    start.centripetal_std.k_spread_speed = 0.0;
    let mut f = filter(&start);
    run(
        &mut f,
        &drive(
            CentripetalSlopes {
                k_x_speed: 0.15,
                k_spread_speed: 0.2,
            },
            1,
        ),
    );
    let (c, sd) = f.centripetal();
    assert_eq!((c.k_spread_speed, sd.k_spread_speed), (0.0, 0.0));
    assert!(sd.k_x_speed > 0.0 && c.k_x_speed > 0.05, "{c:?}");
}

#[test]
fn the_x_c_in_effect_carries_the_term_s_uncertainty() {
    let mut f = filter(&prior_terms(0.5));
    f.predict(0.8, 1.2, 0.02).unwrap();
    let v = 1.0;
    // var(x_c) + v^2 var(k_x_speed): the prior's 0.1 m and 0.2 s.
    let c = f.icr_now_covariance();
    assert!(
        (c[(2, 2)] - (0.1f64.powi(2) + v * v * 0.2f64.powi(2))).abs() < 1e-6,
        "{}",
        c[(2, 2)]
    );
    assert!((f.icr_covariance()[(2, 2)] - 0.1f64.powi(2)).abs() < 1e-6);
}

#[test]
fn terms_out_of_range_are_refused() {
    let mut start = prior_terms(0.5);
    start.centripetal.k_x_speed = 2.0;
    let r = Filter::new(
        &start,
        FilterConfig::default(),
        MeasurementConfig::default(),
        band(0.5),
    );
    assert!(matches!(r, Err(FilterError::BadInput(m)) if m.contains("k_x_speed")));
}
