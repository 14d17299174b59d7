//! What the demo's table says about each variant on this run, in words:
//! a re-convergence of 0 s (the estimate never left the tolerance, not an
//! instant jump), one that never came, and the run's own warnings that no
//! other variant had (e.g. the papers' innovation-adaptive update refusing
//! fixes), with when the variant last fused a fix.

use terraslip::metrics::{self, ReconvergenceSpec};
use terraslip_io::TruthSample;

use super::outcome::Outcome;

/// One sentence per notable figure of each variant, computed from the runs.
pub(super) fn notes(outcomes: &[Outcome], truth: &[TruthSample]) -> Vec<String> {
    let spec = ReconvergenceSpec::default();
    let mut out = Vec::new();
    for o in outcomes {
        for r in &o.card.reconvergence {
            let t1 = r.t_change + r.segment;
            match r.seconds {
                Some(0.0) => {
                    let step = spread_step(truth, r.t_change, spec.window);
                    let peak = metrics::largest_spread_error(&o.run, truth, r.t_change, t1);
                    let peak = peak.map_or(String::new(), |(t, e)| {
                        format!(
                            "; its largest single-row error was {:.1} cm, {:.1} s after the change",
                            100.0 * e.abs(),
                            t - r.t_change
                        )
                    });
                    out.push(format!(
                        "`{}`, re-conv. to {} 0.0 s: every {:.0} s mean of its spread error stayed within \
                         {:.0} cm of the truth through the change, so there was nothing to re-converge by \
                         this measure (the true spread moved {:.1} cm there{peak})",
                        o.name,
                        r.terrain,
                        spec.window,
                        100.0 * spec.tolerance,
                        100.0 * step,
                    ));
                }
                None => {
                    let end = o
                        .run
                        .rows
                        .iter()
                        .take_while(|row| row.t < t1)
                        .last()
                        .map_or(f64::NAN, |row| 100.0 * row.std_spread);
                    out.push(format!(
                        "`{}`, re-conv. to {}: its spread was not within {:.0} cm of the truth (5 s means) \
                         before the next change, {:.0} s later (its own spread std there: {end:.1} cm)",
                        o.name,
                        r.terrain,
                        100.0 * spec.tolerance,
                        r.segment
                    ));
                }
                Some(_) => {}
            }
        }
        for w in &o.run.warnings {
            if outcomes.iter().all(|p| p.run.warnings.contains(w)) {
                continue;
            }
            let fused = o
                .run
                .rows
                .iter()
                .rev()
                .find(|row| row.fused)
                .map(|row| row.t);
            let last = match (w.contains("could not be fused"), fused) {
                (true, Some(t)) => format!(
                    "; its last fix was fused at {t:.0} s, and its ICRs stay where they were from then on"
                ),
                _ => String::new(),
            };
            out.push(format!("`{}`: {w}{last}", o.name));
        }
    }
    out
}

/// How far the true spread moved across a change at `t0`: from just
/// before it to `after` s after it, m.
fn spread_step(truth: &[TruthSample], t0: f64, after: f64) -> f64 {
    let d = |t| metrics::truth_at(truth, t).map_or(f64::NAN, |s| s.y_l - s.y_r);
    (d(t0 + after) - d(t0 - 0.1)).abs()
}
