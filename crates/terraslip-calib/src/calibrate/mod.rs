//! The whole offline calibration: segments, time offset, the three methods,
//! identifiability checks, one parameter set per terrain ([`calibrate()`]).
//!
//! - `config`: what is asked ([`CalibConfig`]);
//! - `offset_profile`: the model-based second stage of the time offset;
//! - `rate`: the turn-rate and traction terms and the criterion that keeps them;
//! - `result`: what was found ([`Calibration`]) and the parameter file.

use terraslip_core::IcrParams;
use terraslip_io::DriveLog;

use crate::ga::{self, GaConfig};
use crate::lm;
use crate::model::{self, PARAM_NAMES};
use crate::offset::estimate_offset;
use crate::reduction::Reduction;
use crate::segment::{SegmentConfig, SegmentStats, Segments};
use crate::symmetric::{self, SymmetricMissing};
use crate::CalibError;

mod config;
mod criterion;
mod json;
mod method_fit;
mod offset_profile;
mod position_only;
mod rate;
mod reduction;
mod result;

use offset_profile::{refine_offset, spread_from_yaw, ProfiledOffset};
use rate::choose_rate;
use reduction::{choose_reduction, reduced_best};

pub use config::{CalibConfig, GaSettings, Method, RateModel, TimeOffset};
pub use method_fit::MethodFit;
pub use rate::RateChoice;
pub use reduction::ReductionChoice;
pub use result::{Calibration, DroppedSegment, SetCalibration, TurnFigures};

/// Most chained segments the genetic algorithm scores each individual on;
/// a longer drive gives it this many, evenly spread over the drive
/// ([`Segments::evenly_spread`]). A 600 s drive has about 600. On a
/// simulated 24 h drive the GA's answer then costs 0.1 % more (eq. 13)
/// than the LM's, the one written there (docs/benchmarks.md, "Scale").
pub const GA_SEGMENTS: usize = 1000;

/// Most fit segments one parameter set is calibrated on; a set with more
/// (a long drive) is thinned to this many, evenly spread
/// ([`Segments::evenly_spread`]), and every method fits on those. A 600 s
/// drive has about 2500.
pub const FIT_SEGMENTS: usize = 20_000;

/// Progress events for a CLI progress bar.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Progress<'a> {
    Stage(&'a str),
    Generation { done: usize, total: usize },
}

/// Calibrates from `logs` (each must have `pose.csv`).
pub fn calibrate(
    logs: &[DriveLog],
    cfg: &CalibConfig,
    progress: &dyn Fn(Progress),
) -> Result<Calibration, CalibError> {
    if logs.is_empty() {
        return Err(CalibError::NoLogs);
    }
    let mut warnings = Vec::new();
    for log in logs {
        if log.pose.is_empty() {
            return Err(CalibError::NoPose {
                log: log.dir.clone(),
            });
        }
        warnings.extend(log.warnings.iter().cloned());
    }
    if logs.iter().all(crate::track::position_only) {
        return position_only::calibrate(logs, cfg, progress, warnings);
    }
    let scfg = cfg.segment.for_logs(logs);
    // The offset search compares candidates on the segments usable at
    // every one ([`crate::offset::common_keys`]): a segment from every
    // pose, so that a pose dropped at one candidate (mistimed, gated)
    // removes only the segments that touch it. Chained segments shift
    // their phase at such a pose and lose every later segment to the
    // comparison (44 of 190 kept on the first half of the ice drive).
    let ocfg = SegmentConfig {
        overlap: Some(0.0),
        ..scfg.clone()
    };
    // The offset is the joint least-squares estimate with the model; a set
    // that holds a reduced model ([`crate::reduction`]) has it profiled
    // again with that model, until the selection stands.
    let mut held: Vec<(Option<String>, Reduction)> = Vec::new();
    let mut pass = 1;
    loop {
        let mut w = warnings.clone();
        let offsets = search_offsets(logs, cfg, &ocfg, &held, &mut w, progress);
        let cal = calibrate_sets(logs, cfg, &scfg, &offsets, progress, w)?;
        let selected: Vec<(Option<String>, Reduction)> = cal
            .sets
            .iter()
            .filter_map(|s| Some((s.terrain.clone(), s.reduction.as_ref()?.selected)))
            .filter(|h| !h.1.is_none())
            .collect();
        if selected == held
            || pass >= OFFSET_PASSES
            || !matches!(cfg.time_offset, TimeOffset::Auto { .. })
        {
            return Ok(cal);
        }
        held = selected;
        pass += 1;
    }
}

/// Most rounds of the offset search and the calibration when a reduced
/// model is selected: the second profiles the offset with it, a third
/// settles a selection that the offset changed.
const OFFSET_PASSES: usize = 3;

/// Each log's time offset (s) and its 1-sigma, searched (or given) as
/// `cfg.time_offset` says, the profile's fits holding `held`'s reduced
/// models; warnings about offsets the data do not pin go to `warnings`.
fn search_offsets(
    logs: &[DriveLog],
    cfg: &CalibConfig,
    ocfg: &SegmentConfig,
    held: &[(Option<String>, Reduction)],
    warnings: &mut Vec<String>,
    progress: &dyn Fn(Progress),
) -> Vec<(f64, Option<f64>)> {
    progress(Progress::Stage("aligning wheel and pose streams"));
    let mut offsets = Vec::with_capacity(logs.len());
    for full in logs {
        // A long drive's offset is searched on evenly spread windows of it.
        let log = &*crate::offset::thinned(full, crate::offset::OFFSET_POSES);
        let o = match cfg.time_offset {
            TimeOffset::Fixed(o) => o,
            TimeOffset::Auto { max, step } => match estimate_offset(log, ocfg, max, step) {
                Some((o, _)) => o,
                None => {
                    warnings.push(format!(
                        "{}: too few moving segments to estimate the time offset; using 0 s",
                        log.dir.display()
                    ));
                    0.0
                }
            },
        };
        let (o, std) = match cfg.time_offset {
            TimeOffset::Auto { max, step } => {
                let p = refine_offset(log, ocfg, o, (max, cfg.yaw_weight), held);
                if p.offset.abs() >= max - 0.5 * step {
                    warnings.push(offset_at_edge(log, p.offset, max));
                } else if !p.pinned() {
                    warnings.push(offset_not_pinned(log, &p));
                }
                (p.offset, p.std)
            }
            TimeOffset::Fixed(_) => (o, None),
        };
        offsets.push((o, std));
    }
    offsets
}

/// One parameter set per terrain (or one pooled), the logs read with
/// `offsets` (s, with their 1-sigma).
fn calibrate_sets(
    logs: &[DriveLog],
    cfg: &CalibConfig,
    scfg: &SegmentConfig,
    offset_found: &[(f64, Option<f64>)],
    progress: &dyn Fn(Progress),
    mut warnings: Vec<String>,
) -> Result<Calibration, CalibError> {
    let offsets: Vec<f64> = offset_found.iter().map(|o| o.0).collect();
    let offset_stds: Vec<Option<f64>> = offset_found.iter().map(|o| o.1).collect();
    let refs: Vec<&DriveLog> = logs.iter().collect();
    let all = Segments::build(&refs, &offsets, scfg);
    let names = terrain_sets(all.segments.iter().map(|s| &s.terrain));
    let RobotFacts {
        track_width,
        wheel_radius,
        pioneer,
    } = RobotFacts::of(logs);
    let mut sets = Vec::new();
    let n_sets = names.len();
    let mut first_err: Option<CalibError> = None;
    for name in names {
        let mut segs = all.clone();
        segs.retain(|s| s.terrain == name);
        let found = segs.len();
        let thinned = found > FIT_SEGMENTS;
        if thinned {
            segs = segs.subset(&Segments::evenly_spread(&vec![true; found], FIT_SEGMENTS));
        }
        let label = name.clone().unwrap_or_else(|| "all".into());
        progress(Progress::Stage(&label));
        let mut set = match calibrate_set(&segs, &label, track_width, cfg, progress, &mut warnings)
        {
            Ok(s) => s,
            // One terrain patch too short to calibrate must not sink the others.
            Err(e) if n_sets > 1 => {
                warnings.push(format!("terrain `{label}` not calibrated: {e}"));
                first_err.get_or_insert(e);
                continue;
            }
            Err(e) => return Err(e),
        };
        set.terrain = name;
        if thinned {
            set.notes.push(format!(
                "fitted on {FIT_SEGMENTS} of its {found} segments, evenly spread over the \
                 drive (the bound that keeps long drives fast)"
            ));
        }
        // Counts and offsets of the logs that drove on this terrain.
        let mut used_logs: Vec<usize> = segs.segments.iter().map(|s| s.log).collect();
        used_logs.dedup();
        used_logs.sort_unstable();
        used_logs.dedup();
        for &i in &used_logs {
            if let Some(st) = all.per_log.get(i) {
                set.stats.add(st);
            }
        }
        set.time_offsets = used_logs
            .iter()
            .map(|&i| (logs[i].name(), offsets[i]))
            .collect();
        if matches!(cfg.time_offset, TimeOffset::Auto { .. }) {
            set.notes.extend(
                used_logs
                    .iter()
                    .map(|&i| offset_note(&logs[i], offset_stds[i])),
            );
        }
        set.track_width = track_width;
        set.wheel_radius = wheel_radius;
        set.pioneer = pioneer;
        for d in &mut set.dropped {
            if let Ok(i) = d.log.parse::<usize>() {
                d.log = logs.get(i).map(|l| l.name()).unwrap_or_default();
            }
        }
        sets.push(set);
    }
    if sets.is_empty() {
        if let Some(e) = first_err {
            return Err(e);
        }
    }
    Ok(Calibration { sets, warnings })
}

/// The parameter sets, one per terrain label in order of appearance
/// (`None`, the pooled set, for unlabelled data; just that when there is
/// nothing).
fn terrain_sets<'a>(labels: impl Iterator<Item = &'a Option<String>>) -> Vec<Option<String>> {
    let mut names: Vec<Option<String>> = Vec::new();
    for l in labels {
        if !names.contains(l) {
            names.push(l.clone());
        }
    }
    if names.is_empty() {
        names.push(None);
    }
    names
}

/// The warning for a time offset `o` (s) found at the edge of `±max`.
fn offset_at_edge(log: &DriveLog, o: f64, max: f64) -> String {
    format!(
        "{}: the time offset {o:+.3} s is at the edge of its search range \
         (±{max} s), so the true offset may lie beyond it; check the two \
         clocks, or give it with --time-offset SECONDS",
        log.dir.display()
    )
}

/// The warning for a profiled offset `p` inside its search range whose
/// 1-sigma is over [`ProfiledOffset::PINNED_STD`] or unknown.
fn offset_not_pinned(log: &DriveLog, p: &ProfiledOffset) -> String {
    let how = match p.std {
        Some(s) => format!("its 1-sigma is {s:.3} s"),
        None => "the profile of the fit has no minimum around it".into(),
    };
    format!(
        "{}: the time offset {:+.3} s is not pinned by the data ({how}); the \
         parameters depend on it, check the two clocks, or give it with \
         --time-offset SECONDS",
        log.dir.display(),
        p.offset
    )
}

/// The set's note on a searched offset's 1-sigma (`None`: not bracketed).
fn offset_note(log: &DriveLog, std: Option<f64>) -> String {
    match std {
        Some(s) => format!(
            "time offset of {}: 1-sigma {s:.3} s (profile of the fit)",
            log.name()
        ),
        None => format!(
            "time offset of {}: not bracketed by the profile of the fit (no 1-sigma)",
            log.name()
        ),
    }
}

/// What the logs' `meta.toml` tell about the robot.
struct RobotFacts {
    /// m, of the first log that gives one.
    track_width: Option<f64>,
    wheel_radius: Option<f64>,
    /// A Pioneer P3-AT (its server settings are written).
    pioneer: bool,
}

impl RobotFacts {
    fn of(logs: &[DriveLog]) -> Self {
        Self {
            track_width: logs.iter().find_map(|l| l.meta.track_width),
            wheel_radius: logs.iter().find_map(|l| l.meta.wheel_radius),
            pioneer: logs.iter().any(|l| {
                l.meta.robot.as_deref().is_some_and(|r| {
                    let r = r.to_ascii_lowercase();
                    r.contains("p3at") || r.contains("p3-at") || r.contains("pioneer")
                })
            }),
        }
    }
}

/// Identifiability thresholds on the Jacobian uncertainties: a parameter
/// whose 1-sigma exceeds this is reported as not identified.
fn unidentified_by_std(std: &[f64; 5], spread: f64, free: &[bool; 5]) -> Vec<&'static str> {
    let limits = [0.25 * spread, 0.25 * spread, 0.25 * spread, 0.1, 0.1];
    (0..5)
        .filter(|&k| free[k] && (std[k].is_nan() || std[k] > limits[k]))
        .map(|k| PARAM_NAMES[k])
        .collect()
}

/// The data never turn enough: fails, or with `allow_partial` lists
/// y_l, y_r and x_c as held at their no-slip values, for `reason`.
fn hold_tread_icrs(
    reason: String,
    (label, allow_partial): (&str, bool),
    unidentified: &mut Vec<&'static str>,
    notes: &mut Vec<String>,
) -> Result<(), CalibError> {
    let names = vec!["y_l", "y_r", "x_c"];
    if !allow_partial {
        return Err(CalibError::Unobservable {
            set: label.into(),
            params: names,
            reason,
        });
    }
    notes.push(format!(
        "{} kept at the no-slip values: {reason}",
        names.join(", ")
    ));
    unidentified.extend(names);
    Ok(())
}

/// Fails on the first free parameter [`unidentified_by_std`] names, or with
/// `allow_partial` lists each in `unidentified` and `notes`.
fn check_identified(
    std: &[f64; 5],
    spread: f64,
    free: &[bool; 5],
    (label, allow_partial): (&str, bool),
    unidentified: &mut Vec<&'static str>,
    notes: &mut Vec<String>,
) -> Result<(), CalibError> {
    for name in unidentified_by_std(std, spread, free) {
        if !allow_partial {
            return Err(CalibError::Unobservable {
                set: label.into(),
                params: vec![name],
                reason: format!(
                    "its 1-sigma uncertainty ({:.3}) is too large for the data to pin it down",
                    std[PARAM_NAMES.iter().position(|n| *n == name).unwrap_or(0)]
                ),
            });
        }
        if !unidentified.contains(&name) {
            unidentified.push(name);
            notes.push(format!("{name} is poorly identified (large uncertainty)"));
        }
    }
    Ok(())
}

/// A warning for each gene of the GA's answer `p` that sits on a bound of
/// its search range (genes fixed at one value excepted): the best value
/// may lie beyond it.
fn ga_at_bounds(label: &str, p: &IcrParams, bounds: &[(f64, f64); 5]) -> Vec<String> {
    let v = model::to_vec(p);
    (0..5)
        .filter_map(|k| {
            let (lo, hi) = bounds[k];
            let tol = 1e-3 * (hi - lo);
            let edge = if hi <= lo {
                return None;
            } else if v[k] <= lo + tol {
                ("lower", lo)
            } else if v[k] >= hi - tol {
                ("upper", hi)
            } else {
                return None;
            };
            Some(format!(
                "set `{label}`: the genetic algorithm's {} = {:.4} is at the {} bound {} of \
                 its search range, so the best value may lie beyond it; check track_width \
                 in meta.toml, or widen the bounds",
                PARAM_NAMES[k], v[k], edge.0, edge.1
            ))
        })
        .collect()
}

fn calibrate_set(
    segs: &Segments,
    label: &str,
    track_width: Option<f64>,
    cfg: &CalibConfig,
    progress: &dyn Fn(Progress),
    warnings: &mut Vec<String>,
) -> Result<SetCalibration, CalibError> {
    let n = segs.len();
    // Overlapping segments share their poses: count and weigh the evidence
    // as the equivalent chained segments.
    let coverage = segs.coverage();
    let chained = |k: usize| (k as f64 / coverage).round() as usize;
    if chained(n) < cfg.min_segments {
        return Err(CalibError::TooFewSegments {
            set: label.into(),
            moving: chained(n),
            needed: cfg.min_segments,
            hint: segs.stats.hint(n),
        });
    }
    let mut notes = Vec::new();
    let mut unidentified: Vec<&'static str> = Vec::new();
    let turning = chained(
        segs.segments
            .iter()
            .filter(|s| s.reference.dyaw.abs() > 0.1)
            .count(),
    );
    let mut lm_cfg = cfg.lm.clone();
    if turning < cfg.min_turning_segments {
        let reason = format!(
            "only {turning} of {n} moving segments turn more than 0.1 rad (need {}): the reference never turns enough to separate the tread ICRs",
            cfg.min_turning_segments
        );
        hold_tread_icrs(
            reason,
            (label, cfg.allow_partial),
            &mut unidentified,
            &mut notes,
        )?;
        lm_cfg.free = [false, false, false, true, true];
    }
    let width = match track_width.or_else(|| spread_from_yaw(segs)) {
        Some(w) => w,
        None => {
            return Err(CalibError::Unobservable {
                set: label.into(),
                params: vec!["y_l", "y_r"],
                reason: "no track_width in meta.toml and the yaw changes do not give one".into(),
            })
        }
    };
    let start = IcrParams::no_slip(width);
    let active = vec![true; n];
    progress(Progress::Stage("levenberg-marquardt"));
    let lm_fit = lm::fit(segs, &start, &active, cfg.yaw_weight, &lm_cfg).ok_or_else(|| {
        CalibError::TooFewSegments {
            set: label.into(),
            moving: 0,
            needed: cfg.min_segments,
            hint: segs.stats.hint(0),
        }
    })?;
    if lm_fit.capped {
        warnings.push(format!(
            "set `{label}`: the Levenberg-Marquardt fit used all {} iterations of a round \
             without converging, so its parameters may not be the best fit; look for \
             segments no model explains (the dropped segments, the residual noise)",
            lm_cfg.max_iterations
        ));
    }
    let inlier: Vec<bool> = lm_fit.weights.iter().map(|&w| w > 0.0).collect();
    let used = inlier.iter().filter(|&&b| b).count();
    if chained(used) < cfg.min_segments {
        return Err(CalibError::TooFewSegments {
            set: label.into(),
            moving: chained(used),
            needed: cfg.min_segments,
            hint: segs.stats.hint(used),
        });
    }
    let c = cfg.lm.cauchy_c * lm_fit.sigma;
    let ones: Vec<f64> = inlier.iter().map(|&b| if b { 1.0 } else { 0.0 }).collect();
    let score = |method: Method, p: IcrParams| MethodFit {
        method,
        params: p,
        cost: model::cost(&p, segs, &ones, cfg.yaw_weight),
        robust_cost: model::robust_cost(&p, segs, &inlier, cfg.yaw_weight, c),
        std: lm::uncertainties(
            &model::to_vec(&p),
            segs,
            &lm_fit.weights,
            cfg.yaw_weight,
            &lm_cfg.free,
        ),
    };
    let mut fits = Vec::new();
    let wants = |m: Method| cfg.method.is_none() || cfg.method == Some(m);
    if wants(Method::Lm) {
        fits.push(score(Method::Lm, lm_fit.params));
    }
    if wants(Method::Ga) {
        let mut gcfg = GaConfig::for_track_width(width);
        gcfg.population = cfg.ga.population;
        gcfg.generations = cfg.ga.generations;
        gcfg.seed = cfg.ga.seed;
        gcfg.gene_bits = cfg.ga.gene_bits;
        gcfg.threads = cfg.ga.threads;
        if let Some(b) = cfg.ga.bounds {
            gcfg.bounds = b;
        }
        // Genes the data cannot identify stay at the start value.
        let sv = model::to_vec(&start);
        for ((b, &v), &free) in gcfg.bounds.iter_mut().zip(&sv).zip(&lm_cfg.free) {
            if !free {
                *b = (v, v);
            }
        }
        // Mandow's GA scores chained segments: one pass over the drive per
        // individual, so overlapping segments would multiply its cost; its
        // answer is then scored on every segment like the others.
        let chained_inliers: Vec<bool> = segs
            .chained_mask()
            .iter()
            .zip(&inlier)
            .map(|(&a, &b)| a && b)
            .collect();
        // On a long drive, a bounded subset of them spread over the whole
        // drive ([`GA_SEGMENTS`]).
        let scored = Segments::evenly_spread(&chained_inliers, GA_SEGMENTS);
        let fitness = |p: &IcrParams| model::robust_cost(p, segs, &scored, cfg.yaw_weight, c);
        let total = gcfg.generations;
        progress(Progress::Stage("genetic algorithm"));
        let r = ga::minimise(&fitness, &gcfg, Some(&start), &|g| {
            progress(Progress::Generation { done: g + 1, total })
        });
        warnings.extend(ga_at_bounds(label, &r.params, &gcfg.bounds));
        fits.push(score(Method::Ga, r.params));
    }
    if wants(Method::Symmetric) {
        progress(Progress::Stage("symmetric fit"));
        match symmetric::fit(segs, &inlier) {
            Ok(s) => {
                notes.push(format!(
                    "symmetric: {} spin-in-place and {} straight segments",
                    s.spin_segments, s.straight_segments
                ));
                fits.push(score(Method::Symmetric, s.params));
            }
            Err(missing) => {
                let what = match missing {
                    SymmetricMissing::Spins => "spin-in-place segments",
                    SymmetricMissing::Straights => "straight segments",
                };
                if cfg.method == Some(Method::Symmetric) {
                    return Err(CalibError::SymmetricNeeds {
                        set: label.into(),
                        what,
                    });
                }
                notes.push(format!(
                    "symmetric calibration skipped: the drive has no {what}"
                ));
            }
        }
    }
    let best = fits
        .iter()
        .min_by(|a, b| a.robust_cost.total_cmp(&b.robust_cost))
        .cloned()
        .ok_or(CalibError::NoLogs)?;
    check_identified(
        &best.std,
        best.params.spread(),
        &lm_cfg.free,
        (label, cfg.allow_partial),
        &mut unidentified,
        &mut notes,
    )?;
    let rate_for = |best: &MethodFit, held: Reduction| match cfg.rate_model {
        RateModel::Off => None,
        m => choose_rate(
            segs,
            (best, held),
            &lm_fit.weights,
            cfg.yaw_weight,
            &lm_cfg,
            m,
            (cfg.traction, cfg.traction_signed),
            cfg.centripetal,
            coverage,
        ),
    };
    let rate = rate_for(&best, Reduction::NONE);
    // Terms are removed only where none is added: a drive that pays for a
    // variable model has the data for all five constant parameters.
    let variable = rate.as_ref().is_some_and(|r| r.selected);
    let mut reduction = cfg.reduced_models.then(|| {
        if variable {
            return ReductionChoice::not_tried(
                "a variable model is selected: the data pay for more terms, not fewer",
            );
        }
        choose_reduction(
            segs,
            &best,
            &lm_fit.weights,
            cfg.yaw_weight,
            &lm_cfg,
            coverage,
        )
    });
    // The reduced set and the variable models on top of it (holding its
    // relations) against the full set and its variable models: the
    // selected model of each, by the same criterion.
    let (best, rate) = match reduction.as_mut() {
        Some(r) if !r.selected.is_none() => {
            let held = r.selected;
            let reduced = r
                .fit()
                .map(|f| reduced_best(&best, f, segs, (&inlier, &ones), cfg.yaw_weight, c))
                .unwrap_or_else(|| best.clone());
            let reduced_rate = rate_for(&reduced, held);
            let full_bic = rate.as_ref().map_or(r.bic_full, RateChoice::selected_bic);
            let reduced_bic = reduced_rate
                .as_ref()
                .map_or(r.bic_reduced(), RateChoice::selected_bic);
            r.selected_bics = Some((full_bic, reduced_bic));
            if reduced_bic < full_bic {
                (reduced, reduced_rate)
            } else {
                r.selected = Reduction::NONE;
                (best, rate)
            }
        }
        _ => (best, rate),
    };
    let dropped = segs
        .segments
        .iter()
        .zip(&inlier)
        .filter(|(_, &k)| !k)
        .map(|(s, _)| {
            let r = model::residual(&best.params, segs, s, cfg.yaw_weight);
            DroppedSegment {
                log: s.log.to_string(),
                t0: s.t0,
                t1: s.t1,
                residual: (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt(),
            }
        })
        .collect();
    Ok(SetCalibration {
        terrain: None,
        best,
        fits,
        segments_used: used,
        dropped,
        stats: SegmentStats::default(),
        sigma: lm_fit.sigma,
        noise: lm_fit.noise,
        time_offsets: Vec::new(),
        unidentified,
        notes,
        yaw_weight: cfg.yaw_weight,
        track_width,
        wheel_radius: None,
        pioneer: false,
        rate,
        reduction,
        coverage,
        course: None,
    })
}
