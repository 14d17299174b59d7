//! Every slip parameter belongs to the ground, the tread speed factor
//! difference `alpha_l - alpha_r` included. The world of issue 25: the
//! difference is +0.02 on grass and -0.03 on the soil after it (spread
//! 0.81 m, a mild turn law, 1 Hz GNSS of 2 m with a slow part, a 1 degree
//! compass), terrain labels given, a 30 s outage on the soil. And a set
//! given for the ground (`--init`) is what a change the slip-change
//! detector finds falls back to.

use terraslip::config::EstimatorConfig;
use terraslip::pipeline::{self, EstimateRun, RunOptions, TerrainEvidence};
use terraslip_core::IcrParams;
use terraslip_io::{ParamEntry, ParamsFile};
use terraslip_sim::family::{world, Subset, World};
use terraslip_sim::scenario::{Segment, Window};
use terraslip_sim::terrain::TerrainSpec;
use terraslip_sim::{simulate, SimRun};

const GRASS: (f64, f64) = (0.96, 0.94);
const SOIL: (f64, f64) = (0.84, 0.87);
const SPREAD: f64 = 0.81;
/// The grass stretch, then the soil, s.
const GRASS_S: f64 = 150.0;
const SOIL_S: f64 = 180.0;
/// The outage on the soil, s.
const OUTAGE: (f64, f64) = (GRASS_S + 90.0, GRASS_S + 120.0);

fn terrain(alpha: (f64, f64)) -> TerrainSpec {
    TerrainSpec {
        y_l: Some(0.5 * SPREAD),
        y_r: Some(-0.5 * SPREAD),
        x_c: Some(0.0),
        alpha_l: Some(alpha.0),
        alpha_r: Some(alpha.1),
        ..Default::default()
    }
}

/// Issue 25's world on the sensors of the family's `gnss2m` subset.
fn issue_world(seed: u64) -> World {
    let mut w = world(seed, Subset::Gnss2m);
    let sc = &mut w.scenario;
    sc.robot.track_width = 0.45;
    sc.robot.wheel_radius = 0.12 * 0.45;
    sc.robot.length = 0.6;
    sc.robot.max_tread_speed = 1.5;
    sc.drive.speed = [0.4, 1.0];
    sc.drive.radii = vec![1.0, 2.0, 4.0, 8.0];
    sc.drive.area_radius = 25.0;
    sc.terrains.clear();
    sc.terrains.insert("grass".into(), terrain(GRASS));
    sc.terrains.insert("soil".into(), terrain(SOIL));
    sc.segments = vec![
        Segment {
            terrain: "grass".into(),
            duration: GRASS_S,
        },
        Segment {
            terrain: "soil".into(),
            duration: SOIL_S,
        },
    ];
    // A mild turn law: the spread moves about 1.5 % with the turn rate.
    sc.slip.turn_sensitivity = 0.015;
    sc.slip.speed_sensitivity = 0.0;
    sc.gnss.outages = vec![Window {
        start: OUTAGE.0,
        duration: OUTAGE.1 - OUTAGE.0,
    }];
    w.outage = OUTAGE;
    w.clock_offset = 0.0;
    sc.validate().unwrap();
    w
}

fn run(sim: &SimRun, cfg: &EstimatorConfig, init: Option<&ParamsFile>) -> (EstimateRun, f64) {
    let r = pipeline::run_with(
        &sim.log,
        cfg,
        &TerrainEvidence::Labels(sim.log.terrain.clone()),
        init,
        RunOptions {
            outage: Some(OUTAGE),
        },
        &mut |_, _| {},
    )
    .unwrap();
    let d = terraslip::metrics::outage_drift(&r, &sim.log.truth, OUTAGE.0, OUTAGE.1)
        .map_or(f64::NAN, |d| d.percent);
    (r, d)
}

/// The largest errors of the common speed factor and of the factor
/// difference on the soil from `from` s after the change on (outage
/// excluded).
fn soil_factor_error(r: &EstimateRun, from: f64) -> (f64, f64) {
    let common = 0.5 * (SOIL.0 + SOIL.1);
    let diff = SOIL.0 - SOIL.1;
    r.rows
        .iter()
        .filter(|x| x.t >= GRASS_S + from && !(OUTAGE.0..OUTAGE.1).contains(&x.t))
        .fold((0.0f64, 0.0f64), |(c, e), x| {
            (
                c.max((0.5 * (x.alpha_l + x.alpha_r) - common).abs()),
                e.max((x.alpha_l - x.alpha_r - diff).abs()),
            )
        })
}

#[test]
fn the_soil_factors_are_learned_not_taken_from_the_grass() {
    for seed in [1, 2] {
        let w = issue_world(seed);
        let sim = simulate(&w.scenario, seed).unwrap();
        let (r, drift) = run(&sim, &EstimatorConfig::default(), None);
        let (common, diff) = soil_factor_error(&r, 60.0);
        // Speed noise learned per square-root second, relative.
        let speed_noise = r.noise.model.0.sqrt();
        eprintln!(
            "seed {seed}: soil common factor error {common:.4}, difference error {diff:.4}, speed noise {speed_noise:.3}, drift {drift:.2} %"
        );
        // The difference is learned as the soil's; the common factor
        // (true 0.855) is left up to 11 % off by its trade-off with the
        // spread at 2 m GNSS. The learned speed noise is not bounded here:
        // it ends near 120 % per square-root second (docs/benchmarks.md,
        // "Every slip parameter changes with the ground").
        assert!(diff < 0.025, "seed {seed}: difference off by {diff}");
        assert!(common < 0.12, "seed {seed}: common factor off by {common}");
        assert!(drift < 10.0, "seed {seed}: {drift} %");
    }
}

#[test]
fn recalled_sets_are_used_as_given() {
    // Every terrain's true parameters from --init, nothing learned: the
    // soil's own difference must be used on the soil.
    let mut pf = ParamsFile::default();
    for (name, a) in [("grass", GRASS), ("soil", SOIL)] {
        let p = IcrParams {
            y_l: 0.5 * SPREAD,
            y_r: -0.5 * SPREAD,
            x_c: 0.0,
            alpha_l: a.0,
            alpha_r: a.1,
        };
        pf.terrains.insert(name.into(), ParamEntry::new(p));
    }
    let mut cfg = EstimatorConfig::default();
    cfg.filter.learn_icr = false;
    cfg.filter.learn_alpha = false;
    cfg.filter.noise_memory = 0.0;
    cfg.filter.change_window = 0.0;
    let seed = 1;
    let w = issue_world(seed);
    let sim = simulate(&w.scenario, seed).unwrap();
    let (r, drift) = run(&sim, &cfg, Some(&pf));
    let on_soil: Vec<_> = r.rows.iter().filter(|x| x.t > GRASS_S + 2.0).collect();
    assert!(!on_soil.is_empty());
    for x in on_soil {
        let e = x.alpha_l - x.alpha_r;
        assert!((e - (SOIL.0 - SOIL.1)).abs() < 1e-6, "t {}: {e}", x.t);
    }
    eprintln!("--init, learning off: drift {drift:.2} %");
    assert!(drift < 3.0, "{drift} %");
}

/// `--init` from a calibration of the ground. Issue 25's robot and sensors:
/// 150 s on sand (the `--init` set is sand's truth), 90 s on a softer
/// patch nothing labels (slower treads, a wider spread), 150 s on the sand
/// again, no outage, no terrain evidence. A change the slip-change detector
/// finds falls back to the given set, not to wherever the filter had
/// wandered. Raising the uncertainty at each detected change instead (no
/// fallback), seed 1 read 0.112 back on the sand. On the patch itself the
/// speed factor stays about 0.15 off with `--init` (0.19 without the
/// fallback): 90 s of 2 m GNSS do not teach it either way, and a set given
/// as the ground's is held to it.
#[test]
fn back_on_the_calibrated_ground_the_filter_falls_back_to_the_calibration() {
    const SAND: (f64, f64) = (0.85, 0.87);
    const PATCH: (f64, f64) = (0.70, 0.71);
    const SAND_S: f64 = 150.0;
    const PATCH_S: f64 = 90.0;
    let back = SAND_S + PATCH_S;
    let sand = IcrParams {
        y_l: 0.5 * SPREAD,
        y_r: -0.5 * SPREAD,
        x_c: 0.0,
        alpha_l: SAND.0,
        alpha_r: SAND.1,
    };
    let mut init = ParamsFile::default();
    init.terrains.insert("sand".into(), ParamEntry::new(sand));
    // The speed factor's RMS error over `[t0, t1)` s against `truth`.
    let rms = |r: &EstimateRun, t0: f64, t1: f64, truth: (f64, f64)| {
        let a = 0.5 * (truth.0 + truth.1);
        let e: Vec<f64> = r
            .rows
            .iter()
            .filter(|x| (t0..t1).contains(&x.t))
            .map(|x| 0.5 * (x.alpha_l + x.alpha_r) - a)
            .collect();
        (e.iter().map(|v| v * v).sum::<f64>() / e.len().max(1) as f64).sqrt()
    };
    for seed in [1, 2, 3] {
        let mut w = issue_world(seed);
        let sc = &mut w.scenario;
        let mut patch = terrain(PATCH);
        patch.y_l = Some(0.55);
        patch.y_r = Some(-0.55);
        sc.terrains.clear();
        sc.terrains.insert("sand".into(), terrain(SAND));
        sc.terrains.insert("soil".into(), patch);
        sc.segments = [("sand", SAND_S), ("soil", PATCH_S), ("sand", SAND_S)]
            .iter()
            .map(|(t, d)| Segment {
                terrain: (*t).into(),
                duration: *d,
            })
            .collect();
        sc.slip.turn_sensitivity = 0.0;
        sc.gnss.outages.clear();
        sc.gnss.multipath_rate = 0.0;
        sc.validate().unwrap();
        let sim = simulate(&w.scenario, seed).unwrap();
        let go = |init: Option<&ParamsFile>| {
            pipeline::run_with(
                &sim.log,
                &EstimatorConfig::default(),
                &TerrainEvidence::None,
                init,
                RunOptions::default(),
                &mut |_, _| {},
            )
            .unwrap()
        };
        let (with, without) = (go(Some(&init)), go(None));
        let after_with = rms(&with, back + 20.0, back + SAND_S, SAND);
        let after_without = rms(&without, back + 20.0, back + SAND_S, SAND);
        let patch_with = rms(&with, SAND_S + 30.0, back, PATCH);
        let fired = with.stats.fixes.changes_detected;
        eprintln!(
            "seed {seed}: back on sand, speed factor RMS error {after_with:.4} with --init, {after_without:.4} without; on the patch {patch_with:.4} with --init; changes detected {fired}"
        );
        assert!(fired > 0, "seed {seed}: the detector never fired");
        assert!(
            after_with < 0.015,
            "seed {seed}: back on sand the speed factor is {after_with} off with --init"
        );
        assert!(after_with < after_without, "seed {seed}");
    }
}
