//! Accuracy of the estimator on the simulator's drives (issue 2 "How good"),
//! with `--terrain-labels`. Tolerances are the issue's targets where the
//! default meets them on these seeds, and the measured figure plus margin
//! where it does not (2 m GNSS); docs/benchmarks-estimator.md has the full
//! tables over several seeds.

use terraslip::config::EstimatorConfig;
use terraslip::metrics::{self, Scorecard};
use terraslip::pipeline::{self, RunOptions, TerrainEvidence};
use terraslip_sim::{simulate, Scenario};

fn score(scenario: &str, seed: u64, cfg: &EstimatorConfig) -> Scorecard {
    let sim = simulate(&Scenario::resolve(scenario).unwrap(), seed).unwrap();
    let log = &sim.log;
    let outage = metrics::find_position_outage(&log.pose, 20.0);
    let ev = TerrainEvidence::Labels(log.terrain.clone());
    let run =
        pipeline::run_with(log, cfg, &ev, None, RunOptions { outage }, &mut |_, _| {}).unwrap();
    assert!(run
        .rows
        .iter()
        .all(|r| r.y_l.is_finite() && r.east.is_finite()));
    metrics::scorecard(&run, &log.truth, &log.terrain, outage, 20.0)
}

#[test]
fn rtk_reference_meets_issue_targets() {
    let c = score("papers-rtk", 1, &EstimatorConfig::default());
    eprintln!("{c:#?}");
    assert!(
        c.worst_first_visit.is_some_and(|s| s <= 10.0),
        "{:?}",
        c.reconvergence
    );
    assert!(c.rms.d <= 0.008, "RMS d {}", c.rms.d);
    assert!(c.rms.y_l <= 0.025 && c.rms.y_r <= 0.025, "{:?}", c.rms);
    let drift = c.drift.expect("papers has a 30 s outage");
    assert!((25.0..=35.0).contains(&(drift.t1 - drift.t0)), "{drift:?}");
    assert!(drift.percent <= 1.0, "{drift:?}");
}

#[test]
fn gnss_2m_close_to_targets_and_beats_the_papers_schemes() {
    let ours = score("papers", 1, &EstimatorConfig::default());
    eprintln!("{ours:#?}");
    // Measured on this seed: RMS d 1.04 cm, y_l 0.82, y_r 0.55 cm, drift
    // 0.56 % (pure dead reckoning, up to the first fix after the outage;
    // before est2 session 2, `factor_coords = "difference"` and
    // `q_alpha_diff = 1e-7`: 1.15, 0.89, 0.56 cm, 0.70 %).
    // The common tread speed factor cannot be learned through 2 m GNSS, and
    // soil's alpha = 0.97 biases d there (with alpha known, RMS d on
    // `papers` is 0.74 cm; see papers_icr3_meets_the_2m_rms_targets).
    assert!(ours.rms.d <= 0.013, "RMS d {}", ours.rms.d);
    assert!(
        ours.rms.y_l <= 0.025 && ours.rms.y_r <= 0.025,
        "{:?}",
        ours.rms
    );
    assert!(
        ours.drift.is_some_and(|d| d.percent <= 1.0),
        "{:?}",
        ours.drift
    );
    for name in ["ekf-qmin", "ta-ekf-boost", "ekf-reset"] {
        let theirs = score("papers", 1, &EstimatorConfig::preset(name).unwrap());
        let msg = format!("{name}: {:?} vs ours {:?}", theirs.rms, ours.rms);
        assert!(ours.rms.d < theirs.rms.d, "{msg}");
        assert!(ours.rms.y_l < 0.33 * theirs.rms.y_l, "{msg}");
        assert!(ours.rms.y_r < 0.33 * theirs.rms.y_r, "{msg}");
    }
}

#[test]
fn revisited_terrains_are_recalled_at_once() {
    let c = score("wang4-rtk", 2, &EstimatorConfig::default());
    let revisits: Vec<_> = c.reconvergence.iter().filter(|r| r.revisit).collect();
    assert!(revisits.len() >= 2, "{:?}", c.reconvergence);
    for r in revisits {
        assert_eq!(r.seconds, Some(0.0), "{r:?}");
    }
    // With 2 m GNSS too: what is remembered is the average over the stay,
    // not the noisy estimate at the moment of leaving (soil's revisit on
    // seed 1 took 8 s with the latter).
    let c = score("wang4", 1, &EstimatorConfig::default());
    let revisits: Vec<_> = c.reconvergence.iter().filter(|r| r.revisit).collect();
    assert!(revisits.len() >= 2, "{:?}", c.reconvergence);
    for r in revisits {
        assert_eq!(r.seconds, Some(0.0), "{r:?}");
    }
    // Without memory the same drive needs time again somewhere.
    let mut no_mem = EstimatorConfig::default();
    no_mem.schedule.memory = false;
    let c = score("wang4-rtk", 2, &no_mem);
    assert!(
        c.reconvergence
            .iter()
            .filter(|r| r.revisit)
            .any(|r| r.seconds != Some(0.0)),
        "{:?}",
        c.reconvergence
    );
}

#[test]
fn papers_icr3_meets_the_2m_rms_targets() {
    // The papers' own slip model (alpha = 1 on every terrain), 2 m GNSS:
    // issue 2's RMS targets hold here (5 seeds: d 0.71 cm); on `papers`
    // (alpha < 1, which 2 m GNSS cannot observe) RMS d stays ~1 cm.
    // Pooled over three seeds like the figures (one seed alone: 0.70-0.79 cm).
    let mut sq = 0.0;
    for seed in 1..=3 {
        let c = score("papers-icr3", seed, &EstimatorConfig::default());
        eprintln!("seed {seed}: {:?}", c.rms);
        assert!(c.rms.y_l <= 0.025 && c.rms.y_r <= 0.025, "{:?}", c.rms);
        sq += c.rms.d * c.rms.d / 3.0;
    }
    assert!(sq.sqrt() <= 0.008, "RMS d {}", sq.sqrt());
}
