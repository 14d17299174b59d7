//! Where `terraslip node` keeps what it learned between runs: the
//! parameters file, by default in the user's state directory
//! (`$XDG_STATE_HOME/terraslip/NODE.json`, else
//! `~/.local/state/terraslip/NODE.json`), never in the working directory
//! unless asked; when it was saved and after how much driving.

use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

use anyhow::{bail, Context, Result};
use terraslip::pipeline::EstimateRun;
use terraslip_io::ParamsFile;

/// Key of the wall-clock time the file was saved (UTC, ISO 8601).
const SAVED_AT: &str = "saved_at";
/// Key of the seconds of drive (stamp time) behind the parameters, over
/// every run that recalled the file.
const DRIVEN: &str = "driven_s";

/// The default parameters file of node `name`: `state_home/terraslip/NAME.json`
/// with `state_home` `$XDG_STATE_HOME` (when absolute) or `$HOME/.local/state`.
pub fn default_path(
    name: &str,
    xdg_state_home: Option<&str>,
    home: Option<&str>,
) -> Result<PathBuf> {
    let state = match (xdg_state_home.filter(|d| Path::new(d).is_absolute()), home) {
        (Some(d), _) => PathBuf::from(d),
        (None, Some(h)) if !h.is_empty() => Path::new(h).join(".local/state"),
        _ => bail!(
            "no state directory for the parameters file: neither XDG_STATE_HOME nor HOME is set; give --params FILE"
        ),
    };
    let file = name.trim_start_matches('/').replace('/', "_");
    Ok(state.join("terraslip").join(format!("{file}.json")))
}

/// The default path from this process's environment.
pub fn default_path_from_env(name: &str) -> Result<PathBuf> {
    let var = |k: &str| std::env::var(k).ok();
    default_path(
        name,
        var("XDG_STATE_HOME").as_deref(),
        var("HOME").as_deref(),
    )
}

/// The line that announces a recalled file.
pub fn recalled(path: &Path, pf: &ParamsFile) -> String {
    let saved = pf
        .extra
        .get(SAVED_AT)
        .and_then(|v| v.as_str())
        .unwrap_or("an unknown time");
    let driven = pf
        .extra
        .get(DRIVEN)
        .and_then(|v| v.as_f64())
        .map_or("an unknown time".to_string(), |s| format!("{s:.0} s"));
    format!(
        "recalled {} (saved at {saved}, after {driven} of driving); --fresh starts clean",
        path.display()
    )
}

/// Seconds of driving behind a recalled file (0 for none).
pub fn driven(pf: Option<&ParamsFile>) -> f64 {
    pf.and_then(|p| p.extra.get(DRIVEN)?.as_f64())
        .filter(|s| s.is_finite() && *s >= 0.0)
        .unwrap_or(0.0)
}

/// Writes the learned parameters atomically (creating the directory),
/// with when they were saved, after `before` s of earlier driving, the
/// decisions and the decisions made again (`revisited`, one line each);
/// `false` when the run has made no row yet.
pub fn save(
    path: &Path,
    run: &EstimateRun,
    before: f64,
    decided: Option<serde_json::Value>,
    revisited: &[String],
) -> Result<bool> {
    if run.row_count == 0 {
        return Ok(false);
    }
    let mut pf = run.params_file();
    pf.extra
        .insert(SAVED_AT.into(), utc(SystemTime::now()).into());
    pf.extra
        .insert(DRIVEN.into(), serde_json::json!(before + run.duration()));
    if let Some(d) = decided {
        pf.extra.insert("decided".into(), d);
    }
    if !revisited.is_empty() {
        pf.extra
            .insert("revisited".into(), serde_json::json!(revisited));
    }
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("{}: creating the state directory", dir.display()))?;
    }
    pf.write(path)
        .with_context(|| format!("{}: writing the parameters", path.display()))?;
    Ok(true)
}

/// `t` as UTC, `YYYY-MM-DDTHH:MM:SSZ`.
fn utc(t: SystemTime) -> String {
    let s = t.duration_since(UNIX_EPOCH).map_or(0, |d| d.as_secs()) as i64;
    let (days, rem) = (s.div_euclid(86_400), s.rem_euclid(86_400));
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn the_default_file_is_in_the_state_directory_named_for_the_node() {
        let p = default_path("terraslip", Some("/var/state"), Some("/home/r")).unwrap();
        assert_eq!(p, PathBuf::from("/var/state/terraslip/terraslip.json"));
        let p = default_path("husky", None, Some("/home/r")).unwrap();
        assert_eq!(
            p,
            PathBuf::from("/home/r/.local/state/terraslip/husky.json")
        );
        // A relative XDG_STATE_HOME is ignored, as the spec says.
        let p = default_path("husky", Some("state"), Some("/home/r")).unwrap();
        assert!(p.starts_with("/home/r/.local/state"));
        let e = default_path("husky", None, None).unwrap_err().to_string();
        assert!(e.contains("--params"), "{e}");
    }

    #[test]
    fn a_saved_file_says_when_and_after_how_much_driving() {
        let mut pf = ParamsFile::default();
        pf.extra
            .insert(SAVED_AT.into(), "2026-11-28T14:00:00Z".into());
        pf.extra.insert(DRIVEN.into(), serde_json::json!(395.4));
        let line = recalled(Path::new("/s/husky.json"), &pf);
        assert!(
            line.starts_with(
                "recalled /s/husky.json (saved at 2026-11-28T14:00:00Z, after 395 s of driving)"
            ),
            "{line}"
        );
        assert_eq!(driven(Some(&pf)), 395.4);
        assert_eq!(driven(None), 0.0);
    }

    #[test]
    fn decisions_made_again_are_kept_in_the_file() {
        let d = tempfile::tempdir().unwrap();
        let log = terraslip::testkit::drive(&Default::default());
        let cfg = terraslip::config::EstimatorConfig::default();
        let run = terraslip::pipeline::run(
            &log,
            &cfg,
            &terraslip::pipeline::TerrainEvidence::None,
            None,
        )
        .unwrap();
        let p = d.path().join("s").join("p.json");
        let line = "/imu mounting revisited at stamp 1700000462.000 s".to_string();
        assert!(save(&p, &run, 0.0, None, std::slice::from_ref(&line)).unwrap());
        let pf = ParamsFile::read(&p).unwrap();
        assert_eq!(pf.extra["revisited"], serde_json::json!([line]));
        // Nothing made again: no entry.
        assert!(save(&p, &run, 0.0, None, &[]).unwrap());
        assert!(!ParamsFile::read(&p)
            .unwrap()
            .extra
            .contains_key("revisited"));
    }

    #[test]
    fn utc_is_the_civil_time() {
        let t = UNIX_EPOCH + Duration::from_secs(1_795_860_000);
        assert_eq!(utc(t), "2026-11-28T10:00:00Z");
        assert_eq!(utc(UNIX_EPOCH), "1970-01-01T00:00:00Z");
    }
}
