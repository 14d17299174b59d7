//! One parameter set calibrated on its segments: the methods, the
//! turn-rate and reduced models, the identifiability checks.

use terraslip_core::IcrParams;

use super::identify::{check_identified, ga_at_bounds, hold_tread_icrs};
use super::offset_profile::spread_from_yaw;
use super::rate::choose_rate;
use super::reduction::{choose_reduction, reduced_best};
use super::{
    CalibConfig, DroppedSegment, Method, MethodFit, Progress, RateChoice, RateModel,
    ReductionChoice, SetCalibration,
};
use crate::ga::{self, GaConfig};
use crate::lm;
use crate::model::{self};
use crate::reduction::Reduction;
use crate::segment::{SegmentStats, Segments};
use crate::symmetric::{self, SymmetricMissing};
use crate::CalibError;

/// Most chained segments the genetic algorithm scores each individual on;
/// a longer drive gives it this many, evenly spread over the drive
/// ([`Segments::evenly_spread`]). A 600 s drive has about 600. On a
/// simulated 24 h drive the GA's answer then costs 0.1 % more (eq. 13)
/// than the LM's, the one written there (docs/benchmarks.md, "Scale").
pub const GA_SEGMENTS: usize = 1000;

pub(super) fn calibrate_set(
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
