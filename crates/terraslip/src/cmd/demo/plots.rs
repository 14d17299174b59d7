//! The demo's figures, each an SVG file in the output directory with the
//! caption the report pages give it.

use std::path::Path;

use anyhow::Result;
use terraslip::pipeline::EstimateRow;
use terraslip_io::{DriveLog, TruthSample};
use terraslip_report::{Figure, LinePlot, Series, SeriesStyle};
use terraslip_sim::SimRun;

use super::outcome::{short, Outcome};

/// Every 10th sample: plots need ~5 Hz, not 50.
const DECIMATE: usize = 10;

/// A written figure: file name in the output directory, and caption.
pub(super) type Written = (String, String);

/// What every time plot marks: terrain changes `(t, "terrain")` and the
/// GNSS outage `(t0, t1)`, s.
pub(super) struct Marks<'a> {
    pub changes: &'a [(f64, String)],
    pub outage: Option<(f64, f64)>,
}

impl Marks<'_> {
    fn on(&self, mut p: LinePlot) -> LinePlot {
        for (t, name) in self.changes {
            p = p.marker(*t, name.clone());
        }
        if let Some((a, b)) = self.outage {
            p = p.marker(a, "GNSS lost").marker(b, "GNSS back");
        }
        p
    }
}

/// The palette colour of the `k`-th variant (0 is the truth's).
fn colour(k: usize) -> usize {
    k % 7 + 1
}

fn truth_series(truth: &[TruthSample], f: impl Fn(&TruthSample) -> f64) -> Vec<(f64, f64)> {
    truth
        .iter()
        .step_by(DECIMATE)
        .map(|s| (s.t, f(s)))
        .collect()
}

/// y range around the truth, wide enough to show a wrong model but not so
/// wide that one runaway variant flattens the others.
fn range_around(points: &[(f64, f64)], margin: f64) -> (f64, f64) {
    let lo = points.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
    let hi = points.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max);
    if lo.is_finite() && hi.is_finite() {
        (lo - margin, hi + margin)
    } else {
        (-1.0, 1.0)
    }
}

/// A time plot of one estimated quantity `(value, std)` of `o` with its
/// 2σ band against the truth `truth`, in `[lo, hi]`.
fn estimate_panel(
    title: String,
    y_label: &str,
    o: &Outcome,
    colour: usize,
    pick: impl Fn(&EstimateRow) -> (f64, f64),
    truth: Vec<(f64, f64)>,
    (lo, hi): (f64, f64),
) -> LinePlot {
    let rows = o.run.rows.iter().step_by(DECIMATE);
    let est: Vec<(f64, f64)> = rows.clone().map(|r| (r.t, pick(r).0)).collect();
    let band: Vec<(f64, f64, f64)> = rows
        .map(|r| {
            let (v, s) = pick(r);
            (r.t, v - 2.0 * s, v + 2.0 * s)
        })
        .collect();
    LinePlot::new(title, "time [s]", y_label)
        .band("estimate ± 2σ", band, Some(colour))
        .series(Series::line("estimate", est).color(colour))
        .series(
            Series::line("truth", truth)
                .style(SeriesStyle::Bold)
                .color(0),
        )
        .y_range(lo, hi)
}

/// Spread d with its 2σ band, one panel per variant.
pub(super) fn spread(
    dir: &Path,
    log: &DriveLog,
    outcomes: &[Outcome],
    marks: &Marks,
) -> Result<Written> {
    let w = log.meta.track_width.unwrap_or(0.0);
    let d_truth = truth_series(&log.truth, |s| s.y_l - s.y_r);
    let (lo, hi) = range_around(&d_truth, 0.08);
    let range = (lo.min(w - 0.02), hi);
    let panels = outcomes
        .iter()
        .enumerate()
        .map(|(k, o)| {
            let p = estimate_panel(
                format!("{}: {}", o.name, short(&o.name)),
                "spread d = y_l - y_r [m]",
                o,
                colour(k),
                |r| (r.y_l - r.y_r, r.std_spread),
                d_truth.clone(),
                range,
            );
            marks.on(p)
        })
        .collect();
    let file = "spread.svg";
    Figure::new(panels).write_svg(&dir.join(file))?;
    Ok((
        file.into(),
        "Spread d = y_l - y_r of every variant with its 2σ band, against the truth; vertical lines: terrain changes and the GNSS outage.".into(),
    ))
}

/// y_l, y_r, x_c with bands for the papers' TA-IEKF and the default.
pub(super) fn icrs(
    dir: &Path,
    log: &DriveLog,
    outcomes: &[Outcome],
    marks: &Marks,
) -> Result<Vec<Written>> {
    type Part = (
        &'static str,
        fn(&TruthSample) -> f64,
        fn(&EstimateRow) -> (f64, f64),
    );
    let parts: [Part; 3] = [
        ("y_l [m] (left tread ICR)", |s| s.y_l, |r| (r.y_l, r.std[3])),
        (
            "y_r [m] (right tread ICR)",
            |s| s.y_r,
            |r| (r.y_r, r.std[4]),
        ),
        (
            "x_c [m] (longitudinal ICR)",
            |s| s.x_c,
            |r| (r.x_c, r.std[5]),
        ),
    ];
    let mut written = Vec::new();
    for (k, o) in outcomes.iter().enumerate() {
        if o.name != "terraslip" && o.name != "ta-iekf" {
            continue;
        }
        let panels = parts
            .iter()
            .map(|&(label, truth, pick)| {
                let tr = truth_series(&log.truth, truth);
                let range = range_around(&tr, 0.06);
                let title = format!("{}: {label}", o.name);
                marks.on(estimate_panel(title, label, o, colour(k), pick, tr, range))
            })
            .collect();
        let file = format!("icr-{}.svg", o.name);
        Figure::new(panels).write_svg(&dir.join(&file))?;
        let caption = format!("{}: y_l, y_r, x_c with 2σ bands against the truth.", o.name);
        written.push((file, caption));
    }
    Ok(written)
}

/// The whole drive: truth, GNSS fixes, the default variant's estimate.
pub(super) fn trajectory(dir: &Path, sim: &SimRun, outcomes: &[Outcome]) -> Result<Written> {
    let log = &sim.log;
    let gnss: Vec<(f64, f64)> = log
        .pose
        .iter()
        .filter_map(|p| Some((p.east?, p.north?)))
        .collect();
    let mut traj = LinePlot::new("Trajectory (world ENU)", "east [m]", "north [m]")
        .equal_aspect(true)
        .size(1000, 800)
        .series(Series::points("GNSS fixes", gnss).color(2))
        .series(
            Series::line(
                "truth",
                log.truth
                    .iter()
                    .step_by(DECIMATE)
                    .map(|s| (s.east, s.north))
                    .collect(),
            )
            .style(SeriesStyle::Bold)
            .color(0),
        );
    if let Some(k) = outcomes.iter().position(|o| o.name == "terraslip") {
        let o = &outcomes[k];
        traj = traj.series(
            Series::line(
                "terraslip estimate",
                o.run
                    .rows
                    .iter()
                    .step_by(DECIMATE)
                    .map(|r| (r.east, r.north))
                    .collect(),
            )
            .color(colour(k)),
        );
    }
    let file = "trajectory.svg";
    traj.write_svg(&dir.join(file))?;
    let g = &sim.scenario.gnss;
    let caption = format!(
        "The drive: truth, GNSS fixes ({:.2} m error per axis, {:.0} % of its variance correlated over {:.0} s{}) and the terraslip estimate.",
        g.total_std(),
        100.0 * g.markov_std.powi(2) / g.total_std().powi(2).max(1e-12),
        g.markov_tau,
        if g.multipath_rate > 0.0 || !g.jumps.is_empty() {
            format!(", the odd {:.0} m multipath jump", g.multipath_jump)
        } else {
            String::new()
        }
    );
    Ok((file.into(), caption))
}

/// Dead reckoning through the outage: each variant's path, aligned to the
/// truth's pose at the start (what the drift metric measures). `None`
/// without an outage or truth in it.
pub(super) fn outage(
    dir: &Path,
    log: &DriveLog,
    outcomes: &[Outcome],
    outage: Option<(f64, f64)>,
) -> Result<Option<Written>> {
    let Some((t0, t1)) = outage else {
        return Ok(None);
    };
    let tr: Vec<&TruthSample> = log.truth.iter().filter(|s| s.t >= t0 && s.t < t1).collect();
    let Some(start) = tr.first() else {
        return Ok(None);
    };
    let mut p = LinePlot::new(
        format!("Dead reckoning through the GNSS outage ({t0:.0}-{t1:.0} s), each variant aligned to the truth at {t0:.0} s"),
        "east [m]",
        "north [m]",
    )
    .equal_aspect(true)
    .size(1000, 800)
    .series(
        Series::line("truth", tr.iter().map(|s| (s.east, s.north)).collect())
            .style(SeriesStyle::Bold)
            .color(0),
    );
    for (k, o) in outcomes.iter().enumerate() {
        let rows: Vec<_> = o
            .run
            .rows
            .iter()
            // The row at t1 has fused the first fix after the
            // outage: stop before it, as the drift metric does.
            .filter(|r| r.t >= t0 && r.t < t1)
            .collect();
        let Some(a) = rows.first() else { continue };
        let rot = start.yaw - a.yaw;
        let (s, c) = rot.sin_cos();
        let path = rows
            .iter()
            .map(|r| {
                let (de, dn) = (r.east - a.east, r.north - a.north);
                (start.east + c * de - s * dn, start.north + s * de + c * dn)
            })
            .collect();
        let pct = o
            .card
            .drift
            .map(|d| format!(" ({:.1} %)", d.percent))
            .unwrap_or_default();
        p = p.series(Series::line(format!("{}{pct}", o.name), path).color(colour(k)));
    }
    let file = "outage.svg";
    p.write_svg(&dir.join(file))?;
    Ok(Some((
        file.into(),
        "Dead reckoning through the outage: each variant's path, aligned to the truth where the outage begins.".into(),
    )))
}
