use super::*;
use terraslip_core::filter::Variant;

#[test]
fn default_round_trips_through_toml() {
    let c = EstimatorConfig::default();
    let back = EstimatorConfig::from_toml(&c.to_toml()).unwrap();
    assert_eq!(c, back);
}

#[test]
fn print_config_documents_every_key_and_round_trips() {
    let mut c = EstimatorConfig::preset("ta-iekf").unwrap();
    c.filter.q_pos = 3e-4;
    assert_eq!(c.undocumented_keys(), Vec::<String>::new());
    let text = c.to_commented_toml();
    let keys = text
        .lines()
        .filter(|l| l.contains(" = ") && !l.starts_with('#'))
        .count();
    let comments = text.lines().filter(|l| l.starts_with("# ")).count();
    assert!(comments > keys, "{text}");
    assert!(text.contains("[filter]\n"), "{text}");
    assert!(text.contains("# Spread y_l - y_r, m.\nspread = "), "{text}");
    assert_eq!(EstimatorConfig::from_toml(&text).unwrap(), c);
}

#[test]
fn unknown_keys_and_bad_values_are_errors_naming_the_key() {
    let e = EstimatorConfig::from_toml("[filter]\nq_spred = 1.0\n").unwrap_err();
    assert!(e.to_string().contains("q_spred"), "{e}");
    for (text, key) in [
        ("[filter]\nq_pos = -1.0\n", "q_pos"),
        ("[filter]\ninnovation_window = 0\n", "innovation_window"),
        ("[filter]\nupdate_iterations = 0\n", "update_iterations"),
        (
            "[filter.slip_walk]\nspread = -1.0\ncentre = 0.0\nx_c = 0.0\nalpha = 0.0\nalpha_diff = 0.0\n",
            "slip_walk",
        ),
        ("[measurement]\nstd_xy = 0.0\n", "std_xy"),
        ("[measurement]\nclock_offset = 5.0\n", "clock_offset"),
        ("[band]\nmin_spread = 5.0\n", "min_spread"),
        ("[init]\nstd_alpha = -1.0\n", "std_alpha"),
        (
            "[schedule.reset_std]\nspread = 0.1\ncentre = 0.0\nx_c = -1.0\nalpha = 0.0\nalpha_diff = 0.0\n",
            "reset_std",
        ),
    ] {
        let e = EstimatorConfig::from_toml(text).unwrap_err();
        assert!(e.to_string().contains(key), "{text}: {e}");
    }
    let e = EstimatorConfig::from_toml("[filter]\nvariant = \"iekf\"\n").unwrap_err();
    assert!(e.to_string().contains("iekf"), "{e}");
}

#[test]
fn partial_file_keeps_defaults() {
    let c = EstimatorConfig::from_toml("[filter]\nvariant = \"innovation-adaptive\"\n").unwrap();
    assert_eq!(c.filter.variant, Variant::InnovationAdaptive);
    assert_eq!(c.init, InitSection::default());
    assert_eq!(c.measurement, MeasurementConfig::default());
}

#[test]
fn presets_are_valid_and_distinct_and_the_papers_keep_their_model() {
    let p = EstimatorConfig::presets();
    assert_eq!(p.len(), 7);
    for (name, c) in &p {
        c.validate().unwrap_or_else(|e| panic!("{name}: {e}"));
        if *name != "terraslip" {
            // The papers' six-state EKF: ICRs in their own coordinates,
            // fixed speed factors, white noise as stated, nothing learned
            // about the sensors or the clock.
            assert_eq!(c.filter.chart, terraslip_core::Chart::Tread, "{name}");
            assert!(!c.filter.learn_alpha && !c.filter.learn_clock, "{name}");
            assert_eq!(c.filter.noise_memory, 0.0, "{name}");
            assert_eq!(c.filter.change_window, 0.0, "{name}");
            assert_eq!(c.measurement.correlated_fraction, 0.0, "{name}");
        }
    }
    for i in 0..p.len() {
        for j in i + 1..p.len() {
            assert_ne!(p[i].1, p[j].1, "{} == {}", p[i].0, p[j].0);
        }
    }
    assert_eq!(
        EstimatorConfig::preset("terraslip"),
        Some(EstimatorConfig::default())
    );
    assert!(EstimatorConfig::preset("nope").is_none());
}
