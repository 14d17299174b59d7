//! Names a user meets in `--help`, in outputs and in the docs: the
//! estimator presets and the papers' short names. `docs/glossary.md` holds
//! the same tables for readers of the docs.

/// An estimator preset and what it is.
pub struct Preset {
    pub name: &'static str,
    /// A few words, for table rows and plot titles.
    pub short: &'static str,
    /// A sentence, for `--help` and the docs.
    pub what: &'static str,
}

/// Every estimator preset (`estimate --preset NAME`, the rows of `demo`),
/// in the order of [`EstimatorConfig::presets`](crate::config::EstimatorConfig::presets).
pub const PRESETS: &[Preset] = &[
    Preset {
        name: "terraslip",
        short: "terraslip default: adaptive, observability-aware, terrain memory",
        what: "the default: learns the ICRs, speed factors, turn law, the pose source's noise and clock; finds terrain changes in the data; remembers each terrain",
    },
    Preset {
        name: "no-slip",
        short: "no-slip differential drive (y = ±W/2), nothing learned",
        what: "the ideal differential drive of the track width (y_l = -y_r = W/2); nothing learned: the baseline",
    },
    Preset {
        name: "ekf-qmin",
        short: "EKF, fixed small ICR process noise (papers' q_min)",
        what: "lv2019's plain EKF on (y_l, y_r, x_c) with a small ICR random walk (q_min); speed factors fixed at 1",
    },
    Preset {
        name: "ekf-qmax",
        short: "EKF, fixed large ICR process noise (papers' q_max)",
        what: "the same EKF with a large ICR random walk (q_max)",
    },
    Preset {
        name: "ta-ekf-boost",
        short: "papers' terrain-adaptive EKF: q_max for k steps after a change",
        what: "terrain-adaptive EKF (lv2019, wang2018): the walk boosted from q_min to q_max for 5 fixes after each declared terrain change",
    },
    Preset {
        name: "ta-iekf",
        short: "papers' terrain-adaptive innovation-based EKF (lv2019, wang2018)",
        what: "terrain-adaptive innovation-based EKF (lv2019, wang2018): the boost plus a gain from the recent innovations (the papers' IEKF: innovation-based, not iterated)",
    },
    Preset {
        name: "ekf-reset",
        short: "covariance reset at each terrain change (chen2023)",
        what: "ekf-qmin with the ICR covariance reset at each declared terrain change (chen2023)",
    },
];

/// The papers' short names, as the help, outputs and docs cite them.
pub const PAPERS: &[(&str, &str)] = &[
    (
        "lv2019",
        "W. Lv, J. Chang, Y. Kang, Y.-B. Zhao, Z. Li, \"Terrain Vision Aided Online Estimation of Instantaneous Centers of Rotation for Skid-Steering Mobile Robots\", 2019: the ICR EKF, the terrain-adaptive innovation-based EKF, vision terrain classification",
    ),
    (
        "wang2018",
        "Wang et al., 2018: ICR estimation for a tracked robot with an innovation-based EKF, vibration terrain classification and a Bayesian terrain filter",
    ),
    (
        "chen2023",
        "Y. Chen, Y. Wu, W. Zeng, S. Du, \"Kinematics Model Estimation of 4W Skid-Steering Mobile Robots Using Visual Terrain Classification\", 2023: the covariance reset at terrain changes",
    ),
    (
        "Mandow 2007",
        "A. Mandow, J. L. Martínez, J. Morales, J. L. Blanco, A. García-Cerezo, J. González, \"Experimental kinematics for wheeled skid-steer mobile robots\", 2007: offline calibration (genetic algorithm), steering efficiency and eccentricity",
    ),
];

/// Preset `name`; `None` for a name that is not a preset.
pub fn preset(name: &str) -> Option<&'static Preset> {
    PRESETS.iter().find(|p| p.name == name)
}

/// The few words on preset `name`.
pub fn short(name: &str) -> Option<&'static str> {
    preset(name).map(|p| p.short)
}

/// Both tables as plain text for `--help`, wrapped to `width` columns.
pub fn help_text(width: usize) -> String {
    let mut out = String::from("Presets (--preset NAME):\n");
    let presets: Vec<(&str, &str)> = PRESETS.iter().map(|p| (p.name, p.what)).collect();
    push_table(&mut out, &presets, width);
    out.push_str("\nPapers:\n");
    push_table(&mut out, PAPERS, width);
    out
}

/// `  name   text` rows, the text wrapped and indented under itself.
fn push_table(out: &mut String, rows: &[(&str, &str)], width: usize) {
    let name_width = rows.iter().map(|(n, _)| n.len()).max().unwrap_or(0);
    let indent = 2 + name_width + 2;
    let text_width = width.saturating_sub(indent).max(20);
    for (name, text) in rows {
        for (k, line) in wrap(text, text_width).iter().enumerate() {
            push_row(out, if k == 0 { name } else { "" }, line, name_width);
        }
    }
}

/// `text`'s words in lines of at most `width` characters (a longer word
/// gets a line of its own).
pub fn wrap(text: &str, width: usize) -> Vec<String> {
    let mut lines = Vec::new();
    let mut line = String::new();
    for word in text.split_whitespace() {
        if !line.is_empty() && line.chars().count() + 1 + word.chars().count() > width {
            lines.push(std::mem::take(&mut line));
        }
        if !line.is_empty() {
            line.push(' ');
        }
        line.push_str(word);
    }
    if !line.is_empty() || lines.is_empty() {
        lines.push(line);
    }
    lines
}

fn push_row(out: &mut String, name: &str, text: &str, name_width: usize) {
    out.push_str(&format!("  {name:<name_width$}  {text}\n"));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::EstimatorConfig;

    #[test]
    fn every_preset_is_described_in_order() {
        let presets: Vec<&str> = EstimatorConfig::presets().iter().map(|p| p.0).collect();
        let described: Vec<&str> = PRESETS.iter().map(|p| p.name).collect();
        assert_eq!(presets, described);
    }

    #[test]
    fn help_text_wraps_under_the_name_column() {
        let text = help_text(80);
        assert!(text.lines().all(|l| l.chars().count() <= 80), "{text}");
        assert!(
            text.contains("\n  ta-ekf-boost  terrain-adaptive EKF"),
            "{text}"
        );
        assert!(text.contains("\n  Mandow 2007  A. Mandow"), "{text}");
        // A continuation line starts under the text, not the name.
        let cont = text
            .lines()
            .find(|l| l.starts_with("                "))
            .expect("a wrapped row");
        assert!(!cont.trim().is_empty());
    }
}
