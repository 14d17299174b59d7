//! The simulator does what it claims: the truth obeys the ICR kinematics,
//! the sensors have the configured statistics, seeds reproduce.

use std::path::Path;

use terraslip_core::angle::wrap;
use terraslip_sim::{simulate, simulate_draw, Scenario, SimError, SimRun};

fn scenario(text: &str) -> Scenario {
    Scenario::from_toml_str(text, Path::new("test.toml")).unwrap()
}

fn papers(seed: u64) -> SimRun {
    let mut s = Scenario::builtin("papers").unwrap();
    s.camera.rate = 0.0;
    simulate(&s, seed).unwrap()
}

/// Body-frame velocity from central differences of the truth poses agrees
/// with the ICR model's twist of the true tread speeds.
#[test]
fn truth_poses_follow_the_icr_twist() {
    let run = papers(3);
    let tr = &run.truth;
    let mut worst = (0.0f64, 0.0f64, 0.0f64);
    let mut turning = 0;
    for w in tr.windows(3) {
        let (a, m, b) = (&w[0], &w[1], &w[2]);
        let h = b.t - a.t;
        let (de, dn) = ((b.east - a.east) / h, (b.north - a.north) / h);
        let (s, c) = m.yaw.sin_cos();
        let vx = c * de + s * dn;
        let vy = -s * de + c * dn;
        let om = wrap(b.yaw - a.yaw) / h;
        let model = m.icr.twist(m.v_left, m.v_right);
        worst.0 = worst.0.max((vx - model.v_x).abs());
        worst.1 = worst.1.max((vy - model.v_y).abs());
        worst.2 = worst.2.max((om - model.omega).abs());
        if model.omega.abs() > 0.2 {
            turning += 1;
        }
    }
    // Tolerances: the tread speeds change within the 40 ms difference window
    // (acceleration limit 0.5 m/s^2 through a 0.15 s lag).
    assert!(worst.0 < 5e-3, "v_x error {:.2e} m/s", worst.0);
    assert!(worst.1 < 2e-3, "v_y error {:.2e} m/s", worst.1);
    assert!(worst.2 < 1e-2, "omega error {:.2e} rad/s", worst.2);
    assert!(
        turning > tr.len() / 5,
        "the drive hardly turns: {turning} of {}",
        tr.len()
    );
}

/// Integrating the *measured* (quantised) encoder speeds with the true ICRs
/// reproduces the true motion: quantisation only redistributes ticks, so
/// over 10 s the error stays at the level of a few ticks.
#[test]
fn encoders_integrate_to_the_truth_with_true_icrs() {
    let run = papers(4);
    let wheels = &run.log.wheels;
    let tr = &run.truth;
    assert_eq!(
        wheels.len(),
        tr.len(),
        "truth and wheels share the 50 Hz clock"
    );
    let tick =
        std::f64::consts::TAU * run.scenario.robot.wheel_radius / run.scenario.wheels.ticks_per_rev;
    let mut checked = 0;
    for start in (0..wheels.len() - 500).step_by(500) {
        let (mut e, mut n, mut yaw) = (tr[start].east, tr[start].north, tr[start].yaw);
        let mut path = 0.0;
        for k in start + 1..start + 501 {
            let h = wheels[k].t - wheels[k - 1].t;
            // The measurement at k averages the speed over (k-1, k]; the ICR
            // in force then is the one recorded at k-1.
            let tw = tr[k - 1].icr.twist(wheels[k].v_left, wheels[k].v_right);
            let (s, c) = (yaw + 0.5 * tw.omega * h).sin_cos();
            e += (c * tw.v_x - s * tw.v_y) * h;
            n += (s * tw.v_x + c * tw.v_y) * h;
            yaw += tw.omega * h;
            path += tw.v_x.abs() * h;
        }
        let end = &tr[start + 500];
        let pos_err = (e - end.east).hypot(n - end.north);
        let yaw_err = wrap(yaw - end.yaw).abs();
        assert!(
            pos_err < 0.01 + 0.002 * path,
            "t={}: {pos_err:.4} m after {path:.1} m",
            tr[start].t
        );
        // A tick difference between the treads turns the robot by tick/spread.
        assert!(
            yaw_err < 5.0 * tick / 0.3 + 0.002,
            "t={}: yaw {yaw_err:.4}",
            tr[start].t
        );
        checked += 1;
    }
    assert!(checked > 30);
}

#[test]
fn icrs_vary_a_few_percent_with_the_turn_rate() {
    let run = papers(5);
    let sc = &run.scenario;
    let trans = sc.slip.transition + 3.0 * sc.slip.lag;
    for (i, ter) in run.terrains.iter().enumerate() {
        let nominal = ter.icr(&sc.robot);
        let d0 = nominal.spread();
        let steady: Vec<_> = run
            .truth
            .iter()
            .filter(|s| {
                s.terrain == i
                    && run
                        .terrain_changes
                        .iter()
                        .all(|c| (s.t - c).abs() > trans || s.t < *c)
            })
            .collect();
        let slow: Vec<f64> = steady
            .iter()
            .filter(|s| s.twist.omega.abs() < 0.05)
            .map(|s| s.icr.spread() / d0)
            .collect();
        let fast: Vec<f64> = steady
            .iter()
            .filter(|s| s.twist.omega.abs() > 0.3)
            .map(|s| s.icr.spread() / d0)
            .collect();
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        assert!(
            slow.len() > 100 && fast.len() > 100,
            "{}: {} slow, {} fast samples",
            ter.name,
            slow.len(),
            fast.len()
        );
        let (ms, mf) = (mean(&slow), mean(&fast));
        assert!(
            mf - ms > 0.01 && mf - ms < 0.06,
            "{}: slow {ms:.4} fast {mf:.4}",
            ter.name
        );
        for s in &steady {
            let r = s.icr.spread() / d0;
            assert!(
                (0.95..1.05).contains(&r),
                "{} t={}: spread ratio {r}",
                ter.name,
                s.t
            );
            assert_eq!(s.icr.x_c, nominal.x_c);
            assert_eq!(s.icr.alpha_l, nominal.alpha_l);
        }
        assert!(nominal.alpha_l != 1.0 && nominal.alpha_r != 1.0);
    }
}

#[test]
fn terrain_labels_follow_the_segments() {
    let run = papers(1);
    let names: Vec<_> = run.log.terrain.iter().map(|l| l.terrain.as_str()).collect();
    assert_eq!(names, ["soil", "grass", "asphalt"]);
    assert_eq!(run.terrain_changes, [120.0, 230.0]);
    assert_eq!(run.log.terrain_at(125.0), Some("grass"));
    let s = run.truth_at(200.0).unwrap();
    assert_eq!(run.terrains[s.terrain].name, "grass");
    // The operator keeps the robot in the field.
    let far = run
        .truth
        .iter()
        .map(|s| s.east.hypot(s.north))
        .fold(0.0, f64::max);
    assert!(
        far < run.scenario.drive.area_radius + 15.0,
        "{far} m from the start"
    );
}

const STATS: &str = r#"
[[segment]]
terrain = "asphalt"
duration = 2400.0
[gnss]
rate = 1.0
white_std = 0.6
markov_std = 1.5
markov_tau = 10.0
multipath_rate = 0.0
outages = [{ start = 100.0, duration = 30.0 }]
[compass]
rate = 2.0
std_deg = 1.0
bias_deg = 2.0
[imu]
rate = 0.0
[camera]
rate = 0.0
"#;

#[test]
fn gnss_error_has_configured_white_and_correlated_parts() {
    let run = simulate(&scenario(STATS), 11).unwrap();
    let mut err = Vec::new();
    for p in &run.log.pose {
        if let (Some(e), Some(n)) = (p.east, p.north) {
            let s = run.truth_at(p.t).unwrap();
            assert!((s.t - p.t).abs() < 1e-9, "truth sampled at the fix");
            err.push((p.t, e - s.east, n - s.north));
        }
    }
    // The outage: no fix from 100 s to 130 s.
    assert!(err.iter().all(|e| !(100.0..130.0).contains(&e.0)));
    assert_eq!(err.len(), 2401 - 30);
    let xs: Vec<f64> = err.iter().flat_map(|e| [e.1, e.2]).collect();
    let var = xs.iter().map(|x| x * x).sum::<f64>() / xs.len() as f64;
    let total = 0.6f64.hypot(1.5);
    assert!(
        (var.sqrt() / total - 1.0).abs() < 0.12,
        "std {:.3} vs {total:.3}",
        var.sqrt()
    );
    // Consecutive differences: 2 sw^2 + 2 sm^2 (1 - phi).
    let phi = (-0.1f64).exp();
    let mut dvar = 0.0;
    let mut m = 0;
    for w in err.windows(2) {
        if (w[1].0 - w[0].0 - 1.0).abs() < 1e-9 {
            dvar += (w[1].1 - w[0].1).powi(2) + (w[1].2 - w[0].2).powi(2);
            m += 2;
        }
    }
    let sw2 = (dvar / m as f64 - 2.0 * 1.5f64.powi(2) * (1.0 - phi)) / 2.0;
    assert!(
        (sw2.max(0.0).sqrt() - 0.6).abs() < 0.08,
        "white {:.3}",
        sw2.sqrt()
    );
    // Correlation at lag tau: sm^2 e^-1 / total^2.
    let lag = 10;
    let mut cov = 0.0;
    let mut k = 0;
    for i in 0..err.len() - lag {
        if (err[i + lag].0 - err[i].0 - lag as f64).abs() < 1e-9 {
            cov += err[i].1 * err[i + lag].1 + err[i].2 * err[i + lag].2;
            k += 2;
        }
    }
    let rho = cov / k as f64 / var;
    let expect = 1.5f64.powi(2) * (-1.0f64).exp() / total.powi(2);
    assert!((rho - expect).abs() < 0.1, "rho {rho:.3} vs {expect:.3}");
}

#[test]
fn compass_has_configured_bias_and_noise_and_survives_outages() {
    let run = simulate(&scenario(STATS), 12).unwrap();
    let d: Vec<f64> = run
        .log
        .pose
        .iter()
        .filter_map(|p| {
            p.yaw
                .map(|y| wrap(y - run.truth_at(p.t).unwrap().yaw).to_degrees())
        })
        .collect();
    assert_eq!(d.len(), 4801, "2 Hz over 2400 s, outages included");
    let mean = d.iter().sum::<f64>() / d.len() as f64;
    let std = (d.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / d.len() as f64).sqrt();
    assert!((mean - 2.0).abs() < 0.06, "bias {mean:.3}°");
    assert!((std - 1.0).abs() < 0.05, "noise {std:.3}°");
    // GNSS at 1 Hz and compass at 2 Hz share rows at whole seconds.
    let both = run
        .log
        .pose
        .iter()
        .filter(|p| p.east.is_some() && p.yaw.is_some())
        .count();
    assert_eq!(both, 2401 - 30);
}

#[test]
fn encoders_are_quantised_to_whole_ticks() {
    let run = papers(2);
    let tick = std::f64::consts::TAU * 0.065 / 540.0;
    let mut moving = 0;
    for w in run.log.wheels.windows(2) {
        let h = w[1].t - w[0].t;
        assert!((h - 0.02).abs() < 1e-9);
        for v in [w[1].v_left, w[1].v_right] {
            let ticks = v * h / tick;
            assert!((ticks - ticks.round()).abs() < 1e-6, "{ticks} ticks");
            if ticks.abs() >= 1.0 {
                moving += 1;
            }
        }
    }
    assert!(moving > run.log.wheels.len());
}

#[test]
fn scheduled_multipath_jumps_and_outage_appear() {
    let run = simulate(&Scenario::builtin("gnss-outage").unwrap(), 1).unwrap();
    let err_at = |t: f64| {
        let p = run
            .log
            .pose
            .iter()
            .find(|p| (p.t - t).abs() < 1e-9)
            .unwrap();
        let s = run.truth_at(t).unwrap();
        (p.east.map(|e| e - s.east), p.north.map(|n| n - s.north))
    };
    let (e, _) = err_at(61.0);
    assert!((e.unwrap() - 30.0).abs() < 8.0, "jump east {e:?}");
    let (_, n) = err_at(216.0);
    assert!((n.unwrap() + 30.0).abs() < 8.0, "jump north {n:?}");
    let (e, _) = err_at(70.0);
    assert!(e.unwrap().abs() < 8.0, "jump over {e:?}");
    let (e, n) = err_at(170.0);
    assert!(e.is_none() && n.is_none(), "fix during the outage");
}

#[test]
fn vibration_depends_on_terrain_and_speed() {
    let mut s = Scenario::builtin("wang4").unwrap();
    s.camera.rate = 0.0;
    let run = simulate(&s, 1).unwrap();
    let rms = |name: &str, lo: f64, hi: f64| {
        let (mut sum, mut n) = (0.0, 0);
        for m in &run.log.imu {
            let st = run.truth_at(m.t).unwrap();
            let v = st.twist.v_x.abs();
            if run.terrains[st.terrain].name == name && v >= lo && v < hi {
                sum += (m.accel_z - terraslip_sim::GRAVITY).powi(2);
                n += 1;
            }
        }
        assert!(n > 200, "{name} {lo}..{hi}: {n} samples");
        (sum / n as f64).sqrt()
    };
    let soil = rms("soil", 0.6, 1.3);
    let asphalt = rms("asphalt", 0.6, 1.3);
    assert!(soil > 2.0 * asphalt, "soil {soil:.3} asphalt {asphalt:.3}");
    assert!(rms("soil", 0.6, 1.3) > 1.5 * rms("soil", 0.1, 0.4));
    let g = run.log.imu.iter().map(|m| m.accel_z).sum::<f64>() / run.log.imu.len() as f64;
    assert!(
        (g - terraslip_sim::GRAVITY).abs() < 0.05,
        "mean accel_z {g}"
    );
}

#[test]
fn seeds_reproduce_bit_for_bit_and_differ() {
    let a = papers(42);
    let b = papers(42);
    let c = papers(43);
    assert_eq!(a.log, b.log);
    assert_eq!(a.truth, b.truth);
    assert_ne!(a.log.pose, c.log.pose);
    assert_ne!(a.truth, c.truth);
    // Streams are independent: the camera does not change the GNSS noise.
    let with_cam = simulate(&Scenario::builtin("papers").unwrap(), 42).unwrap();
    assert_eq!(with_cam.log.pose, a.log.pose);
    assert!(!with_cam.frames.is_empty() && a.frames.is_empty());
}

#[test]
fn a_sensor_draw_keeps_the_drive_and_redraws_the_noise() {
    let mut s = Scenario::builtin("papers").unwrap();
    s.camera.rate = 0.0;
    let a = simulate(&s, 42).unwrap();
    assert_eq!(simulate_draw(&s, 42, 0).unwrap().log, a.log);
    let b = simulate_draw(&s, 42, 1).unwrap();
    // The same path, terrain and encoders ...
    assert_eq!(b.truth, a.truth);
    assert_eq!(b.log.wheels, a.log.wheels);
    assert_eq!(b.log.terrain, a.log.terrain);
    // ... seen through other noise.
    assert_eq!(b.log.pose.len(), a.log.pose.len());
    assert_ne!(b.log.pose, a.log.pose);
    assert_ne!(simulate_draw(&s, 42, 2).unwrap().log.pose, b.log.pose);
}

#[test]
fn the_antenna_s_mount_and_the_run_s_seed_are_read_back_from_meta_toml() {
    let mut s = Scenario::builtin("papers").unwrap();
    s.segments.truncate(1);
    s.segments[0].duration = 5.0;
    s.gnss.lever_arm = [0.3, -0.1];
    let d = tempfile::tempdir().unwrap();
    simulate(&s, 4).unwrap().write(d.path()).unwrap();
    let meta = terraslip_io::read_meta(&d.path().join("meta.toml")).unwrap();
    let pose = meta.pose.expect("[pose]");
    assert_eq!((pose.lever_arm_x, pose.lever_arm_y), (0.3, -0.1));
    let table: toml::Table = std::fs::read_to_string(d.path().join("meta.toml"))
        .unwrap()
        .parse()
        .unwrap();
    assert_eq!(table["seed"].as_integer(), Some(4));
    assert_eq!(table["scenario"].as_str(), Some("papers"));
}

#[test]
fn written_logs_are_identical_and_readable() {
    let mut s = Scenario::builtin("papers").unwrap();
    s.segments.truncate(1);
    s.segments[0].duration = 20.0;
    s.camera.rate = 0.2;
    s.camera.width = 64;
    s.camera.height = 48;
    let run = simulate(&s, 9).unwrap();
    let d1 = tempfile::tempdir().unwrap();
    let d2 = tempfile::tempdir().unwrap();
    run.write(d1.path()).unwrap();
    simulate(&s, 9).unwrap().write(d2.path()).unwrap();
    for f in [
        "wheels.csv",
        "pose.csv",
        "imu.csv",
        "truth.csv",
        "terrain.csv",
        "meta.toml",
        "images/000002.png",
    ] {
        let a = std::fs::read(d1.path().join(f)).unwrap();
        let b = std::fs::read(d2.path().join(f)).unwrap();
        assert!(a == b, "{f} differs between runs");
    }
    let log = terraslip_io::DriveLog::read(d1.path()).unwrap();
    assert_eq!(log.wheels.len(), run.log.wheels.len());
    assert_eq!(log.truth.len(), run.truth.len());
    assert_eq!(log.images.len(), 5);
    assert_eq!(log.meta.ticks_per_rev, Some(540.0));
    assert_eq!(
        log.meta.pose_reference,
        Some(terraslip_io::PoseReference::Gnss)
    );
    assert!(log.warnings.is_empty(), "{:?}", log.warnings);
    let img = image::open(log.image_path(&log.images[2])).unwrap();
    assert_eq!((img.width(), img.height()), (64, 48));
    let back = Scenario::from_toml_file(d1.path().join("scenario.toml")).unwrap();
    assert_eq!(back, s);
}

#[test]
fn bad_scenarios_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bad.toml");
    std::fs::write(&p, "[[segment]]\nterrain = \"soil\"\nduration = \"long\"\n").unwrap();
    let e = Scenario::from_toml_file(&p).unwrap_err();
    assert!(matches!(e, SimError::Scenario { line: 3, .. }), "{e:?}");
    assert!(e.to_string().contains("bad.toml:3"), "{e}");
    let e = Scenario::from_toml_file(dir.path().join("missing.toml")).unwrap_err();
    assert!(matches!(e, SimError::Io { .. }), "{e:?}");
    // A scenario built in code is validated by simulate() too.
    let mut s = Scenario::builtin("papers").unwrap();
    s.integration.dt = 0.01;
    let e = simulate(&s, 1).unwrap_err().to_string();
    assert!(e.contains("integration.dt"), "{e}");
    s.integration.dt = 0.001;
    s.wheels.ticks_per_rev = f64::NAN;
    assert!(simulate(&s, 1).is_err());
}

#[test]
fn explicit_programme_is_followed() {
    let run = simulate(
        &scenario(
            r#"
[[segment]]
terrain = "concrete"
duration = 40.0
[drive]
manoeuvres = [
  { kind = "straight", speed = 0.5, duration = 10.0 },
  { kind = "spin", rate = 0.5, duration = 10.0 },
  { kind = "stop", duration = 20.0 },
]
[camera]
rate = 0.0
"#,
        ),
        1,
    )
    .unwrap();
    let at = |t: f64| run.truth_at(t).unwrap();
    assert!((at(8.0).twist.v_x - 0.5).abs() < 0.02);
    // Wheel lag and slew limits leave no turn on a straight command.
    assert!(at(8.0).twist.omega.abs() < 0.01);
    // A spin: turning on the spot, slower than commanded (chi < 1).
    let spin = at(18.0);
    let chi = run.terrains[0].chi;
    assert!(spin.twist.v_x.abs() < 0.02 && (spin.twist.omega - 0.5 * chi).abs() < 0.05);
    assert!(at(38.0).twist.v_x.abs() < 1e-6 && at(38.0).twist.omega.abs() < 1e-6);
}

#[test]
fn sample_times_are_exact_multiples_of_the_period() {
    let mut s = Scenario::builtin("wang4").unwrap();
    s.camera.rate = 0.05;
    let run = simulate(&s, 1).unwrap();
    for (k, w) in run.log.wheels.iter().enumerate() {
        assert_eq!(w.t, k as f64 / 50.0);
    }
    for (k, m) in run.log.imu.iter().enumerate() {
        assert_eq!(m.t, k as f64 / 200.0);
    }
    for (k, f) in run.log.images.iter().enumerate() {
        assert_eq!(f.t, k as f64 / 0.05);
    }
    assert_eq!(run.log.wheels.last().unwrap().t, s.duration());
}

/// Odd but valid settings run to the end and give finite numbers.
#[test]
fn edge_scenarios_run_and_stay_finite() {
    let base = "[[segment]]\nterrain = \"sand\"\nduration = 12.0\n[camera]\nrate = 0.0\n";
    for extra in [
        // only stops
        "[drive.mix]\nstraight = 0.0\narc = 0.0\nspin = 0.0\ns_curve = 0.0\nstop = 1.0\n",
        // a tiny field: the operator keeps turning home
        "[drive]\narea_radius = 0.1\n",
        // standing still, no spins, needle-thin arcs
        "[drive]\nspeed = [0.0, 0.0]\nspin_rate = [0.0, 0.0]\nradii = [0.01]\n",
        // every sensor off but the encoders
        "[gnss]\nrate = 0.0\n[compass]\nrate = 0.0\n[imu]\nrate = 0.0\n",
        // no noise, no lag, no slip variation
        "[gnss]\nwhite_std = 0.0\nmarkov_std = 0.0\nmultipath_rate = 0.0\n[slip]\nturn_sensitivity = 0.0\nspeed_sensitivity = 0.0\nlag = 0.0\ntransition = 0.0\n[drive]\nwheel_lag = 0.0\n",
        // fast clocks that do not divide each other
        "[wheels]\nrate = 333.0\n[imu]\nrate = 997.0\n[gnss]\nrate = 7.0\n[compass]\nrate = 3.0\n",
    ] {
        let run = simulate(&scenario(&format!("{base}{extra}")), 3).unwrap();
        let log = &run.log;
        assert!(!log.wheels.is_empty(), "{extra}");
        assert!(log.wheels.iter().all(|w| w.v_left.is_finite() && w.v_right.is_finite()), "{extra}");
        assert!(run.truth.iter().all(|s| s.east.is_finite() && s.north.is_finite() && s.yaw.is_finite()), "{extra}");
        assert!(log.pose.iter().all(|p| p.east.is_none_or(f64::is_finite)), "{extra}");
        assert!(log.imu.iter().all(|m| m.accel_z.is_finite()), "{extra}");
        let last = log.wheels.last().unwrap().t;
        assert!((last - 12.0).abs() < 0.01, "{extra}: ends at {last}");
    }
}
