use super::*;

fn setup<'a>(grounds: &'a [String], cfg: &'a EstimatorConfig) -> Setup<'a> {
    let live = CompensateConfig::new(1.0);
    Setup {
        grounds,
        laps: 2,
        estimator: cfg,
        correction_rate: live.max_correction_rate,
        engage_after: live.engage_after,
        hold_after_change: terraslip::belief::HOLD_AFTER_CHANGE,
        live_on_untuned: false,
        uncorrelated_gnss: false,
    }
}

/// On the ground the multiplier was tuned on, live compensation on the
/// controller of that multiplier drives no worse than the multiplier:
/// before the estimate is believed it is the multiplier. Seed 14's
/// estimate is not believed on asphalt for most of the drive.
#[test]
fn where_the_multiplier_was_tuned_live_is_no_worse_than_it() {
    let grounds = vec!["asphalt".to_string()];
    let cfg = EstimatorConfig::default();
    for seed in [1, 14] {
        let (_, scores) = run_seed(
            &setup(&grounds, &cfg),
            &[Variant::Static, Variant::Live],
            seed,
        )
        .unwrap();
        let (stat, live) = (
            scores[0].grounds[0].cross_track_rms_m,
            scores[1].grounds[0].cross_track_rms_m,
        );
        assert!(
            live <= 1.1 * stat,
            "seed {seed}: live {live} m, static {stat} m"
        );
    }
}

#[test]
fn on_sand_live_compensation_beats_none_in_cross_track() {
    let grounds = vec!["sand".to_string()];
    let cfg = EstimatorConfig::default();
    let s = setup(&grounds, &cfg);
    for seed in 1..=3 {
        let (m, scores) = run_seed(&s, &[Variant::None, Variant::Live], seed).unwrap();
        // The turn test on sand: a little under half the turn is lost.
        assert!(m > 1.6 && m < 2.4, "seed {seed}: multiplier {m}");
        let (none, live) = (&scores[0], &scores[1]);
        assert!(
            none.time_s.is_finite() && live.time_s.is_finite(),
            "seed {seed}: finished"
        );
        assert!(
            live.grounds[0].cross_track_rms_m < 0.7 * none.grounds[0].cross_track_rms_m,
            "seed {seed}: live {} m, none {} m",
            live.grounds[0].cross_track_rms_m,
            none.grounds[0].cross_track_rms_m
        );
    }
}

/// After crossing from grass onto sand the first sand turn is the first
/// the new ground shows in: the estimate learns it there, and the
/// compensator takes it as soon as it is known again rather than holding
/// the grass model through the turn. These seeds' worlds held it 3 s
/// after the detected change and were out for 13-15 s.
#[test]
fn after_a_change_of_ground_live_is_back_within_its_settled_error_in_10_s() {
    let grounds = vec!["grass".to_string(), "sand".to_string()];
    let cfg = EstimatorConfig::default();
    let s = setup(&grounds, &cfg);
    for seed in [7, 8, 15, 16] {
        let (_, scores) = run_seed(&s, &[Variant::Live], seed).unwrap();
        let back = scores[0].grounds[1].recovery_s;
        assert!(back <= 10.0, "seed {seed}: back in {back} s");
    }
}

#[test]
fn a_static_multiplier_tuned_on_the_ground_beats_none_there() {
    let grounds = vec!["asphalt".to_string()];
    let cfg = EstimatorConfig::default();
    let (_, scores) =
        run_seed(&setup(&grounds, &cfg), &[Variant::None, Variant::Static], 2).unwrap();
    assert!(scores[1].grounds[0].cross_track_rms_m < 0.7 * scores[0].grounds[0].cross_track_rms_m);
}

#[test]
fn the_table_judges_the_done_lines_on_the_seeds() {
    let score = |rms: [f64; 2], rec: f64| RunScore {
        grounds: rms
            .iter()
            .enumerate()
            .map(|(g, r)| score::GroundScore {
                cross_track_rms_m: *r,
                turn_heading_deg: 1.0,
                time_s: 60.0,
                recovery_s: if g == 0 { f64::NAN } else { rec },
            })
            .collect(),
        cross_track_rms_m: rms[1],
        time_s: 120.0,
    };
    let grounds = vec!["asphalt".to_string(), "sand".to_string()];
    let runs: Vec<table::SeedRuns> = (1..=3)
        .map(|seed| table::SeedRuns {
            seed,
            multiplier: 1.4,
            // none, static, live
            scores: vec![
                score([0.04, 0.08], 0.0),
                score([0.0160, 0.04], 0.0),
                score([0.015, 0.03], 4.0 * seed as f64),
            ],
        })
        .collect();
    let t = table::Table::new(&grounds, &runs);
    let text = t.text();
    assert!(
        text.contains("[met] sand: live cuts cross-track RMS against none by 62 %"),
        "{text}"
    );
    assert!(text.contains("[met] asphalt (static tuned here)"), "{text}");
    // The worst seed's recovery (12 s) decides.
    assert!(
        text.contains("[NOT met] asphalt -> sand (mid-course)"),
        "{text}"
    );
    let j = t.to_json();
    assert_eq!(j["rows"].as_array().unwrap().len(), 3 * 3);
    assert_eq!(j["done_lines"][2]["met"], false);
    // "No worse" is judged at the table's 0.1 cm: 1.604 against 1.600 cm
    // ties, 1.66 does not.
    for (live, met) in [(0.01604, true), (0.0166, false)] {
        let mut runs = runs.clone();
        for r in &mut runs {
            r.scores[2].grounds[0].cross_track_rms_m = live;
        }
        let text = table::Table::new(&grounds, &runs).text();
        let line = if met {
            "[met] asphalt"
        } else {
            "[NOT met] asphalt"
        };
        assert!(text.contains(line), "{live}: {text}");
    }
}

/// Seed 19's second turn on its first sand lap is out of 1.5 x its
/// settled error until 30.5 s after the grass -> sand change, with the
/// compensator applying the settled lap's model there: the estimate's own
/// sideways error on that turn, which is the RTK receiver's slowly
/// wandering error (1 cm, 20 s) passed on. With the same error all white
/// the seed is back within 10 s.
#[test]
fn with_a_white_receiver_error_the_late_bump_after_the_change_is_gone() {
    let grounds: Vec<String> = ["asphalt", "grass", "sand", "mud"]
        .map(String::from)
        .to_vec();
    let cfg = EstimatorConfig::default();
    let mut s = setup(&grounds, &cfg);
    s.uncorrelated_gnss = true;
    let (_, scores) = run_seed(&s, &[Variant::Live], 19).unwrap();
    let back = scores[0].grounds[2].recovery_s;
    assert!(back <= 10.0, "back in {back} s");
}
