//! The speed factors' turn law learned online: treads that lose speed in
//! a turn, driven in DRIVE's 2 s command windows.

use super::centripetal::filter;
use super::*;

/// Mean 2 s position error of the filter's model against the truth
/// (`truth` straight-line, speed factors scaled by `1 + law |dv|`) over
/// random command windows, from the same pose.
fn prediction_error(f: &Filter, truth: &IcrParams, law: f64, seed: u64) -> f64 {
    let mut rng = SplitMix64::new(seed);
    let (dt, starts) = (0.02, 200);
    let (x, _) = f.raw();
    let mut sum = 0.0;
    for _ in 0..starts {
        let (vl, vr) = (2.0 * rng.uniform() - 0.5, 2.0 * rng.uniform() - 0.5);
        let u = TreadInput {
            v_left: vl,
            v_right: vr,
        };
        let dv = (vr - vl).abs();
        let t = truth.twist(vl, vr);
        let real = t.scaled(1.0 + law * dv);
        let (model, ..) = model::twist_at(x, f.config().chart, u, model::LawInputs::both(dv));
        let (mut a, mut b) = ([0.0f64; 3], [0.0f64; 3]);
        for _ in 0..100 {
            for (p, tw) in [(&mut a, real), (&mut b, model)] {
                p[0] += dt * (tw.v_x * libm::cos(p[2]) - tw.v_y * libm::sin(p[2]));
                p[1] += dt * (tw.v_x * libm::sin(p[2]) + tw.v_y * libm::cos(p[2]));
                p[2] += dt * tw.omega;
            }
        }
        sum += libm::hypot(a[0] - b[0], a[1] - b[1]);
    }
    sum / starts as f64
}

/// Without the law (the slope held at 0) the speed factors follow each
/// window's turn, and a straight after turning is predicted short; with
/// it the straight-line speed factors are the ground's.
#[test]
fn learns_speed_factors_that_fall_in_turns_and_predicts_better_than_without() {
    let law = -0.1;
    for seed in [1, 2, 3] {
        let d = Drive {
            windows: true,
            speed_law: law,
            duration: 300.0,
            seed,
            ..Default::default()
        };
        let learning = Prior {
            speed_law_std: 0.05,
            ..prior(0.5)
        };
        let mut f = filter(&learning);
        let mut held = filter(&prior(0.5));
        let (_, p) = run(&mut f, &d);
        run(&mut held, &d);
        let (k, sd) = f.speed_law();
        assert!((k - law).abs() < 0.03, "seed {seed}: {k} +- {sd}");
        assert!(
            (k - law).abs() < 3.0 * sd + 1e-3,
            "seed {seed}: {k} +- {sd}"
        );
        assert_eq!(held.speed_law(), (0.0, 0.0));
        let a = f.icr();
        for (got, want) in [(a.alpha_l, p.alpha_l), (a.alpha_r, p.alpha_r)] {
            assert!(
                (got / want - 1.0).abs() < 0.03,
                "seed {seed}: {a:?} vs {p:?}"
            );
        }
        assert_spd(&f);
        let learned = prediction_error(&f, &p, law, 7);
        let without = prediction_error(&held, &p, law, 7);
        assert!(
            learned < 0.6 * without,
            "seed {seed}: learned {learned:.3} m, without {without:.3} m"
        );
    }
}

/// Where the speed factors do not change with the turn the slope stays
/// near 0.
#[test]
fn a_robot_without_the_law_keeps_the_slope_near_zero() {
    for seed in [4, 5] {
        let d = Drive {
            windows: true,
            duration: 300.0,
            seed,
            ..Default::default()
        };
        let mut f = filter(&Prior {
            speed_law_std: 0.05,
            ..prior(0.5)
        });
        run(&mut f, &d);
        let (k, sd) = f.speed_law();
        assert!(
            k.abs() < 0.02 && k.abs() < 3.0 * sd + 1e-3,
            "seed {seed}: {k} +- {sd}"
        );
    }
}

/// Held (an `--init` calibration's), the law is `calibrate`'s model: it
/// scales the speed factors at each instant's tread speed difference,
/// and a prediction applies it row by row. Learned, it reads the turn
/// law's lagged input, and a prediction takes the factors at the start's
/// turn.
#[test]
fn a_held_speed_law_reads_each_instants_turn_and_a_learned_one_the_lagged_turn() {
    let k = -0.1;
    for (std, held) in [(0.0, true), (0.05, false)] {
        let mut f = filter(&Prior {
            speed_law: k,
            speed_law_std: std,
            ..prior(0.5)
        });
        for _ in 0..40 {
            f.predict(1.0, 1.0, 0.05).unwrap();
        }
        // A step from straight to 2 m/s of tread speed difference.
        f.predict(0.0, 2.0, 0.05).unwrap();
        let straight = f.icr();
        let a = 1.0 - libm::exp(-0.05 / f.config().turn_law_lag);
        let dv = if held { 2.0 } else { 2.0 * a };
        let now = f.icr_now();
        assert!(
            (now.alpha_l / straight.alpha_l - (1.0 + k * dv)).abs() < 1e-12,
            "held {held}: {now:?} against {straight:?}"
        );
        let (start, slope) = f.icr_turn();
        if held {
            assert_eq!(slope, k);
            assert!((start.alpha_r - straight.alpha_r).abs() < 1e-12);
        } else {
            assert_eq!(slope, 0.0);
            assert!((start.alpha_r - now.alpha_r).abs() < 1e-12);
        }
    }
}
