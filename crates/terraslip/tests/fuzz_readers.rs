//! Fuzz targets for every reader: log CSV files, TOML (meta.toml and the
//! estimator configuration), parameter files, terrain models and images.
//! Each feeds generated hostile input (structured, then mutated) to the
//! reader and checks it never panics, and that it either refuses the input
//! naming the file or returns only finite, ordered data.
//!
//! A plain `cargo test` runs a few hundred cases per target. With
//! `TERRASLIP_FUZZ_SECS=N` each target keeps generating for N seconds:
//! `.ci/run` gives each 10 s, and docs/benchmarks.md has the 10-minute run.

use std::fs;
use std::path::Path;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use proptest::prelude::*;
use proptest::test_runner::{Config, TestCaseError, TestRunner};
use terraslip_io::DriveLog;

/// Runs `test` on values of `strategy`: 256 cases, or as many as fit in
/// `TERRASLIP_FUZZ_SECS` seconds when it is set.
fn fuzz<S: Strategy>(strategy: S, test: impl Fn(S::Value) -> Result<(), TestCaseError>)
where
    S::Value: std::fmt::Debug,
{
    let budget = std::env::var("TERRASLIP_FUZZ_SECS")
        .ok()
        .and_then(|s| s.parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s > 0.0)
        .map(Duration::from_secs_f64);
    let start = Instant::now();
    let mut runner = TestRunner::new(Config {
        cases: 64,
        failure_persistence: None,
        ..Config::default()
    });
    let mut rounds = 0;
    loop {
        if let Err(e) = runner.run(&strategy, &test) {
            panic!("{e}");
        }
        rounds += 1;
        let more = match budget {
            Some(b) => start.elapsed() < b,
            None => rounds < 4,
        };
        if !more {
            break;
        }
    }
}

/// Cells a user or a broken exporter might write.
fn cell() -> impl Strategy<Value = String> {
    prop_oneof![
        4 => (-1e3f64..1e3).prop_map(|v| v.to_string()),
        1 => any::<f64>().prop_map(|v| v.to_string()),
        1 => prop::sample::select(vec![
            "", "0", "-0", "1e308", "-1e308", "1e-320", "nan", "NaN", "inf", "-inf", "1,5",
            "0x10", " 7 ", "\"3\"", "\"a,b\"", "é", "\u{feff}1", "1e", "--1", "+2",
            "9999999999999999999999", "../../etc/passwd", "/abs.png", "a.png",
        ])
        .prop_map(String::from),
        1 => "[ -~]{0,8}",
    ]
}

const COLUMNS: [&str; 16] = [
    "t", "v_left", "v_right", "east", "north", "yaw", "std_xy", "std_yaw", "accel_z", "accel_x",
    "gyro_z", "path", "terrain", "y_l", "y_r", "x_c",
];

/// A CSV file: a header of known (sometimes repeated) and unknown column
/// names, rows of hostile cells, sometimes ragged, sometimes byte-mutated.
fn csv_text() -> impl Strategy<Value = Vec<u8>> {
    let header = prop::collection::vec(
        prop_oneof![
            5 => prop::sample::select(COLUMNS.to_vec()).prop_map(String::from),
            1 => "[a-z_]{0,6}",
        ],
        0..8,
    );
    let rows = prop::collection::vec(prop::collection::vec(cell(), 0..9), 0..12);
    let mutation = prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 0..3);
    (header, rows, mutation, any::<bool>()).prop_map(|(h, rows, muts, sorted_t)| {
        let mut text = h.join(",");
        text.push('\n');
        for (i, r) in rows.iter().enumerate() {
            let mut r = r.clone();
            if sorted_t && !r.is_empty() {
                r[0] = format!("{}", i as f64 * 0.1);
            }
            text.push_str(&r.join(","));
            text.push('\n');
        }
        let mut bytes = text.into_bytes();
        for (i, b) in muts {
            if !bytes.is_empty() {
                let k = i.index(bytes.len());
                bytes[k] = b;
            }
        }
        bytes
    })
}

/// A read log holds only finite numbers in time order.
fn check_log(log: &DriveLog) -> Result<(), TestCaseError> {
    let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
    prop_assert!(log.wheels.windows(2).all(|w| w[0].t <= w[1].t));
    prop_assert!(log
        .wheels
        .iter()
        .all(|w| finite(&[w.t, w.v_left, w.v_right])));
    for p in &log.pose {
        let v = [p.east, p.north, p.yaw, p.std_xy, p.std_yaw];
        prop_assert!(v.iter().flatten().all(|x| x.is_finite()));
        prop_assert!(p.east.is_some() == p.north.is_some());
    }
    for im in &log.images {
        prop_assert!(log.image_path(im).starts_with(&log.dir));
    }
    Ok(())
}

/// Fails the case unless `err` names one of `files`.
fn names_a_file(err: &str, files: &[&str]) -> Result<(), TestCaseError> {
    prop_assert!(files.iter().any(|f| err.contains(f)), "{err}");
    Ok(())
}

#[test]
fn fuzz_log_csv_files() {
    fuzz(
        (
            prop::sample::select(DriveLog::FILES[..6].to_vec()),
            csv_text(),
            csv_text(),
        ),
        |(file, text, wheels)| {
            let d = tempfile::tempdir().unwrap();
            fs::write(d.path().join("wheels.csv"), &wheels).unwrap();
            fs::write(d.path().join(file), &text).unwrap();
            match DriveLog::read(d.path()) {
                Ok(log) => check_log(&log),
                Err(e) => names_a_file(&e.to_string(), &["wheels.csv", file]),
            }
        },
    );
}

/// TOML: a mix of known and unknown keys with values of every type,
/// sometimes cut short or mutated.
fn toml_text(keys: &'static [&'static str]) -> impl Strategy<Value = String> {
    let value = prop_oneof![
        (-1e3f64..1e3).prop_map(|v| format!("{v:?}")),
        any::<f64>().prop_map(|v| format!("{v:?}")),
        any::<i64>().prop_map(|v| v.to_string()),
        prop::sample::select(vec![
            "true", "\"x\"", "[1, 2]", "{a = 1}", "1e300", "-0.0", "nan", "inf", "", "\"", "[[",
            "0.5 # c",
        ])
        .prop_map(String::from),
    ];
    let key = prop_oneof![
        4 => prop::sample::select(keys.to_vec()).prop_map(String::from),
        1 => "[a-z_.]{1,12}",
    ];
    (
        prop::collection::vec((key, value), 0..8),
        any::<prop::sample::Index>(),
        any::<bool>(),
    )
        .prop_map(|(kv, cut, truncate)| {
            let mut s: String = kv.iter().map(|(k, v)| format!("{k} = {v}\n")).collect();
            if truncate && !s.is_empty() {
                let mut k = cut.index(s.len());
                while !s.is_char_boundary(k) {
                    k -= 1;
                }
                s.truncate(k);
            }
            s
        })
}

const META_KEYS: [&str; 6] = [
    "robot",
    "track_width",
    "wheel_radius",
    "length",
    "ticks_per_rev",
    "seed",
];

#[test]
fn fuzz_meta_toml() {
    fuzz(toml_text(&META_KEYS), |text| {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("meta.toml");
        fs::write(&p, &text).unwrap();
        match terraslip_io::read_meta(&p) {
            Ok(m) => {
                for v in [m.track_width, m.wheel_radius, m.length].iter().flatten() {
                    prop_assert!(v.is_finite() && *v > 0.0);
                }
            }
            Err(e) => names_a_file(&e.to_string(), &["meta.toml"])?,
        }
        Ok(())
    });
}

#[test]
fn fuzz_estimator_config() {
    // The estimator configuration: its tables' keys, as dotted keys.
    static KEYS: OnceLock<Vec<&'static str>> = OnceLock::new();
    let keys = KEYS.get_or_init(|| {
        let cfg = terraslip::EstimatorConfig::default().to_toml();
        let mut table = String::new();
        let mut out = Vec::new();
        for line in cfg.lines() {
            if let Some(t) = line.strip_prefix('[') {
                table = t.trim_end_matches(']').to_string();
            } else if let Some((k, _)) = line.split_once(" = ") {
                let key = if table.is_empty() {
                    k.to_string()
                } else {
                    format!("{table}.{k}")
                };
                out.push(&*Box::leak(key.into_boxed_str()));
            }
        }
        out
    });
    fuzz(toml_text(keys), |text| {
        if let Ok(cfg) = terraslip::EstimatorConfig::from_toml(&text) {
            prop_assert!(cfg.validate().is_ok());
        }
        Ok(())
    });
}

#[test]
fn fuzz_params_files() {
    let number = prop_oneof![
        (-2.0f64..2.0).prop_map(|v| format!("{v:?}")),
        any::<f64>()
            .prop_filter("JSON number", |v| v.is_finite())
            .prop_map(|v| format!("{v:?}")),
        prop::sample::select(vec!["null", "\"x\"", "1e999", "[]", "{}"]).prop_map(String::from),
    ];
    let set = prop::collection::vec(number, 5).prop_map(|v| {
        format!(
            r#"{{"y_l": {}, "y_r": {}, "x_c": {}, "alpha_l": {}, "alpha_r": {}}}"#,
            v[0], v[1], v[2], v[3], v[4]
        )
    });
    let file = (set.clone(), set, any::<u8>()).prop_map(|(a, b, shape)| match shape % 4 {
        0 => format!(r#"{{"params": {a}}}"#),
        1 => format!(r#"{{"terrains": {{"sand": {{"params": {a}}}}}}}"#),
        2 => format!(
            r#"{{"params": {a}, "rate_model": {{"selected": true, "params": {b}, "k_spread": 0.1, "k_alpha": 0.0}}}}"#
        ),
        _ => format!(r#"{{"params": {a}, "terrains": {{"": {{"params": {b}}}}}}}"#),
    });
    fuzz(file, |text| {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("params.json");
        fs::write(&p, &text).unwrap();
        match terraslip_io::ParamsFile::read(&p) {
            Ok(pf) => {
                for q in pf
                    .params
                    .iter()
                    .chain(pf.terrains.values().map(|e| &e.params))
                {
                    prop_assert!(terraslip_io::params::check_physical(q).is_ok());
                }
            }
            Err(e) => names_a_file(&e.to_string(), &["params.json"])?,
        }
        Ok(())
    });
}

/// A small trained model as JSON, for the mutations of [`fuzz_terrain_models`].
fn model_json() -> &'static (serde_json::Value, DriveLog) {
    static MODEL: OnceLock<(serde_json::Value, DriveLog)> = OnceLock::new();
    MODEL.get_or_init(|| {
        use terraslip_terrain::synth::vibration_log;
        let names = ["asphalt", "grass"];
        let runs: Vec<DriveLog> = (0..2)
            .map(|k| vibration_log(&names, &[(k, 12.0)], 5 + k as u64, 0.0))
            .collect();
        let mut o = terraslip_terrain::TrainOptions::default();
        o.vibration.window_s = 1.0;
        o.classifier.boost.rounds = 2;
        let m = terraslip_terrain::TerrainModel::train(&runs, &o).unwrap();
        let test = vibration_log(&names, &[(0, 4.0), (1, 4.0)], 9, 0.0);
        (serde_json::to_value(&m).unwrap(), test)
    })
}

/// Replaces the `k`-th leaf (in document order) of `v` with `new`.
fn replace_leaf(v: &mut serde_json::Value, k: &mut usize, new: &serde_json::Value) -> bool {
    match v {
        serde_json::Value::Array(a) => a.iter_mut().any(|x| replace_leaf(x, k, new)),
        serde_json::Value::Object(o) => o.values_mut().any(|x| replace_leaf(x, k, new)),
        leaf => {
            if *k == 0 {
                *leaf = new.clone();
                return true;
            }
            *k -= 1;
            false
        }
    }
}

/// Empties the `k`-th array (in document order) of `v`.
fn empty_array(v: &mut serde_json::Value, k: &mut usize) -> bool {
    match v {
        serde_json::Value::Array(a) => {
            if *k == 0 {
                a.clear();
                return true;
            }
            *k -= 1;
            a.iter_mut().any(|x| empty_array(x, k))
        }
        serde_json::Value::Object(o) => o.values_mut().any(|x| empty_array(x, k)),
        _ => false,
    }
}

#[test]
fn fuzz_terrain_models() {
    use serde_json::json;
    let leaf = prop::sample::select(vec![
        json!(-1.0),
        json!(0),
        json!(1e308),
        json!(-1e308),
        json!(4294967295u64),
        json!(1.5),
        json!(""),
        json!("asphalt"),
        json!(null),
        json!([]),
        json!({}),
        json!(true),
    ]);
    let edits = prop::collection::vec((any::<bool>(), 0usize..4000, leaf), 1..4);
    fuzz(edits, |edits| {
        let (model, test) = model_json();
        let mut v = model.clone();
        for (empty, k, new) in &edits {
            let mut k = *k;
            if *empty {
                empty_array(&mut v, &mut k);
            } else {
                replace_leaf(&mut v, &mut k, new);
            }
        }
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("model.json");
        fs::write(&p, serde_json::to_vec(&v).unwrap()).unwrap();
        match terraslip_terrain::TerrainModel::load(&p) {
            Ok(m) => {
                // A model that loads classifies without panicking, and its
                // probabilities are distributions.
                if let Ok(tl) = m.classify_log(test) {
                    for (_, p) in &tl.frames {
                        let sum: f64 = p.iter().sum();
                        prop_assert!(p.iter().all(|x| x.is_finite()), "{p:?}");
                        prop_assert!(sum <= 1.0 + 1e-6, "{p:?}");
                    }
                }
            }
            Err(e) => names_a_file(&e.to_string(), &["model.json"])?,
        }
        Ok(())
    });
}

#[test]
fn fuzz_images() {
    let shape = (0u32..12, 0u32..12, any::<u64>());
    let mutation = prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 0..4);
    fuzz(
        (
            shape,
            mutation,
            prop::option::of(any::<prop::sample::Index>()),
        ),
        |((w, h, seed), muts, cut)| {
            let d = tempfile::tempdir().unwrap();
            let frame = d.path().join("frame.png");
            let mut png = Vec::new();
            if w > 0 && h > 0 {
                let img = terraslip_terrain::synth::texture(seed as usize % 3, w, h, seed, 1.0);
                img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
                    .unwrap();
            }
            for (i, b) in muts {
                if !png.is_empty() {
                    let k = i.index(png.len());
                    png[k] = b;
                }
            }
            if let Some(c) = cut {
                if !png.is_empty() {
                    png.truncate(c.index(png.len()));
                }
            }
            fs::write(&frame, &png).unwrap();
            check_frame(&frame)
        },
    );
}

/// A frame either gives finite features or an error naming its file.
fn check_frame(frame: &Path) -> Result<(), TestCaseError> {
    use terraslip_terrain::vision;
    let cfg = terraslip_terrain::VisionConfig::default();
    let img = match vision::load_frame(frame) {
        Ok(img) => img,
        Err(e) => return names_a_file(&e.to_string(), &["frame.png"]),
    };
    let mut f = Vec::new();
    if vision::frame_features(&img, &cfg, None, &mut f).is_ok() {
        prop_assert!(f.iter().all(|x| x.is_finite()));
    }
    Ok(())
}
