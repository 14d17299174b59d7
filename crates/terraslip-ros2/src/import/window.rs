//! A recording's decisions made from its first window, as `terraslip node`
//! makes them from its warm-up: every candidate topic's messages are held
//! until their stamps span the window (the same [`LiveChoice`] the node
//! holds them in), `import` decides from them which topic feeds which
//! stream, the tread speeds' scale, an IMU's mounting from gravity and
//! whether a heading agrees with the GNSS course, and the whole recording
//! is then read with what was settled, the decisions checked over the rest
//! of it as the node checks them ([`super::revisit`]). A recording shorter
//! than the window is decided from whole, as the node decides at its end.

use std::cell::Cell;
use std::path::Path;

use terraslip_io::DriveLog;

use super::config::TopicsConfig;
use super::import_bag;
use super::live_choice::{LiveChoice, Settled};
use super::report::ImportReport;
use super::revisit::{revisit_log, Revisit};
use crate::{Bag, Ros2Error};

/// [`super::import`] with the decisions made from the first `window` s of
/// stamp time (the node's warm-up window, `cfg` naming no topic).
pub fn import_within(
    bag_path: &Path,
    cfg: &TopicsConfig,
    out_dir: Option<&Path>,
    window: f64,
) -> Result<(DriveLog, ImportReport), Ros2Error> {
    import_bag_within(Bag::open(bag_path)?, cfg, out_dir, window).map(|(log, r, _)| (log, r))
}

/// [`super::import_bag`] with the decisions made from the first `window` s
/// of stamp time.
pub fn import_bag_within(
    bag: Bag,
    cfg: &TopicsConfig,
    out_dir: Option<&Path>,
    window: f64,
) -> Result<(DriveLog, ImportReport, TopicsConfig), Ros2Error> {
    let Some(settled) = first_window(&bag, cfg, window)? else {
        return import_bag(bag, cfg, out_dir);
    };
    let (mut log, mut report, _) = import_bag(bag, &settled.topics, out_dir)?;
    // The decisions made from the window, checked over the rest, as the
    // node checks them.
    let revisit = Revisit::new(cfg, &settled.topics, report.time_origin_ns);
    let revisited: Vec<String> = revisit.map_or_else(Vec::new, |mut r| {
        revisit_log(&mut log, &mut r);
        r.revisions().iter().map(|r| r.line.clone()).collect()
    });
    // The scale as the window found it (read back, it is a given one).
    let m = &settled.log.meta;
    log.meta.separation = m.separation;
    log.meta.separation_source = m.separation_source.clone();
    log.meta.wheel_radius = m.wheel_radius;
    log.meta.wheel_radius_source = m.wheel_radius_source.clone();
    report.decisions = std::iter::once(format!(
        "decided from the first {window} s of the recording, as `terraslip node` decides from its warm-up"
    ))
    .chain(settled.report.decisions)
    .chain(revisited.iter().cloned())
    .collect();
    report.revisited = revisited;
    // What the window's decisions warned of (a heading left out, an IMU
    // not z-up); what reading warns of is the whole recording's.
    let reading =
        |w: &str| w.contains("skipped as not physical") || w.contains("GNSS fixes dropped");
    let decided: Vec<String> = settled
        .report
        .warnings
        .into_iter()
        .filter(|w| !reading(w) && !report.warnings.contains(w))
        .collect();
    report.warnings.splice(0..0, decided);
    // A stream the window left out (a heading) says so.
    for s in settled.report.streams {
        if !report
            .streams
            .iter()
            .any(|r| r.topic == s.topic && r.file == s.file)
        {
            report.streams.push(s);
        }
    }
    Ok((log, report, settled.topics))
}

/// What the first `window` s of `bag` settle; `None` when the recording is
/// shorter (or has no candidate the node would hold, or a header it cannot
/// read: the whole recording then decides, and names the fault).
fn first_window(bag: &Bag, cfg: &TopicsConfig, window: f64) -> Result<Option<Settled>, Ros2Error> {
    let Ok(mut choice) = LiveChoice::new(bag.path.clone(), bag.topics.clone(), cfg) else {
        return Ok(None);
    };
    let candidates = choice.candidates().to_vec();
    let full = Cell::new(false);
    let mut unread = false;
    let mut b = bag.clone();
    b.for_each(&|i| !full.get() && candidates.contains(&i), &mut |_, m| {
        if full.get() || unread {
            return Ok(());
        }
        if choice.hold(m.topic, m.recv_ns, m.data).is_err() {
            unread = true;
        }
        full.set(choice.span() >= window);
        Ok(())
    })?;
    if unread || !full.get() {
        return Ok(None);
    }
    choice.decide(cfg).map(Some)
}
