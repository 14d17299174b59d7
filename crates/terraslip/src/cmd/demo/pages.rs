//! The demo's pages: summary.json, table.md, report.md and report.html.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Result;
use terraslip_io::write_atomic;
use terraslip_report::{html_page, Section};
use terraslip_sim::SimRun;

use super::args::Args;
use super::outcome::{short, Outcome, SETTLE};
use super::plots::Written;
use super::table::Table;

const TITLE: &str = "terraslip demo: ICR estimators on the papers' drive";

/// What the pages describe: the run, its scores and its figures.
pub(super) struct Pages<'a> {
    pub sim: &'a SimRun,
    pub outcomes: &'a [Outcome],
    pub outage: Option<(f64, f64)>,
    /// Terrain changes `(t, "terrain")`.
    pub changes: &'a [(f64, String)],
    pub table: &'a Table,
    /// What the table says about each variant on this run, in words.
    pub notes: &'a [String],
    pub figures: &'a [Written],
    pub args: &'a Args,
}

impl Pages<'_> {
    /// Writes every page into `dir`.
    pub fn write(&self, dir: &Path) -> Result<()> {
        write_atomic(dir.join("table.md"), self.table.markdown.as_bytes())?;
        write_atomic(
            dir.join("summary.json"),
            serde_json::to_string_pretty(&self.summary())?.as_bytes(),
        )?;
        write_atomic(dir.join("report.md"), self.markdown().as_bytes())?;
        write_atomic(dir.join("report.html"), self.html().as_bytes())?;
        Ok(())
    }

    fn summary(&self) -> serde_json::Value {
        let sim = self.sim;
        serde_json::json!({
            "scenario": sim.scenario.name,
            "seed": sim.seed,
            "duration_s": sim.scenario.duration(),
            "outage": self.outage.map(|(a, b)| [a, b]),
            "settle_s": SETTLE,
            "notes": self.notes,
            "terrain_changes": self.changes.iter().map(|(t, n)| serde_json::json!({"t": t, "terrain": n})).collect::<Vec<_>>(),
            "variants": self.outcomes.iter().map(|o| serde_json::json!({
                "name": o.name,
                "description": short(&o.name),
                "reconvergence_s": o.card.reconvergence.iter().map(|r| r.seconds).collect::<Vec<_>>(),
                "worst_first_visit_s": o.card.worst_first_visit,
                "worst_revisit_s": o.card.worst_revisit,
                "rms_m": {"d": finite(o.card.rms.d), "y_l": finite(o.card.rms.y_l), "y_r": finite(o.card.rms.y_r), "x_c": finite(o.card.rms.x_c)},
                "outage_drift": o.card.drift.map(|d| serde_json::json!({"percent": d.percent, "error_m": d.error, "distance_m": d.distance, "t0": d.t0, "t1": d.t1})),
                "final_icr": {"y_l": o.run.final_icr.y_l, "y_r": o.run.final_icr.y_r, "x_c": o.run.final_icr.x_c},
            })).collect::<Vec<_>>(),
        })
    }

    fn intro(&self) -> String {
        let sim = self.sim;
        format!(
            "Scenario `{}` (seed {}): {} ({:.0} s; terrains {}). Every variant ran over the same log with the \
             log's terrain labels as evidence; during the outage {} every pose fix (GNSS and compass) was dropped, \
             so the drift is pure dead reckoning on the ICRs each variant had learned. Steady-state RMS counts \
             rows at least {SETTLE:.0} s after each terrain change. Re-convergence: seconds after a change until the \
             spread d = y_l - y_r stays within 2 cm of the truth (5 s means); '> N' = not within the N s segment.",
            sim.scenario.name,
            sim.seed,
            sim.scenario.description,
            sim.scenario.duration(),
            sim.terrains.iter().map(|t| t.name.as_str()).collect::<Vec<_>>().join(", "),
            self.outage.map(|(a, b)| format!("{a:.0}-{b:.0} s")).unwrap_or_else(|| "(none)".into()),
        )
    }

    /// One line per variant: "`name`: what it is".
    fn variants(&self) -> Vec<String> {
        self.outcomes
            .iter()
            .map(|o| format!("`{}`: {}", o.name, short(&o.name)))
            .collect()
    }

    fn reproduce(&self) -> String {
        let a = self.args;
        format!(
            "terraslip demo --out {} --seed {} --scenario {}",
            a.out.display(),
            a.seed,
            a.scenario
        )
    }

    fn markdown(&self) -> String {
        let mut md = String::new();
        let _ = writeln!(md, "# {TITLE}\n");
        let _ = writeln!(md, "{}\n", self.intro());
        let _ = writeln!(md, "{}", self.table.markdown);
        if !self.notes.is_empty() {
            let notes: String = self.notes.iter().map(|n| format!("- {n}\n")).collect();
            let _ = writeln!(md, "On this run:\n\n{notes}");
        }
        let variants: String = self.variants().iter().map(|v| format!("- {v}\n")).collect();
        let _ = writeln!(md, "Variants:\n\n{variants}");
        for (f, cap) in self.figures {
            let _ = writeln!(md, "![{cap}]({f})\n\n*{cap}*\n");
        }
        let _ = writeln!(
            md,
            "Reproduce: `{}`. The simulated log is in `log/`: \
            `terraslip estimate {}/log --out est --terrain-labels`.",
            self.reproduce(),
            self.args.out.display()
        );
        md
    }

    fn html(&self) -> String {
        let mut sections = vec![
            Section::Paragraph(self.intro()),
            Section::Table {
                headers: self.table.headers.clone(),
                rows: self.table.rows.clone(),
            },
        ];
        if !self.notes.is_empty() {
            sections.push(Section::Paragraph("On this run:".into()));
            sections.push(Section::List(self.notes.to_vec()));
        }
        sections.push(Section::List(self.variants()));
        for (f, cap) in self.figures {
            sections.push(Section::Image {
                src: f.clone(),
                caption: cap.clone(),
            });
        }
        sections.push(Section::Pre(self.reproduce()));
        html_page(TITLE, &sections)
    }
}

fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}
