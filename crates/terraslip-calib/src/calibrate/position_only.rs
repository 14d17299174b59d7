//! Calibration from a position-only reference (GNSS fixes without a
//! heading): the model's path over windows of fixes, compared up to a rigid
//! motion ([`crate::track`]). Only the LM applies; the turn-rate model and
//! the centripetal terms are not fitted (windows of 20 s average over turn
//! rates and speeds).

use terraslip_core::IcrParams;
use terraslip_io::DriveLog;

use super::identify::{check_identified, hold_tread_icrs, unidentified_by_std};
use super::offset_warnings::offset_at_edge;
use super::per_terrain::terrain_sets;
use super::result::TurnFigures;
use super::robot::RobotFacts;
use super::{
    Calibration, DroppedSegment, Method, MethodFit, Progress, RateModel, SetCalibration, TimeOffset,
};
use crate::course::{self, CourseConfig, Odometry};
use crate::segment::SegmentStats;
use crate::track::{self, TrackConfig, Tracks};
use crate::track_fit;
use crate::{CalibConfig, CalibError};

/// Fewest windows (counted as non-overlapping ones) a set needs.
pub const MIN_WINDOWS: usize = 6;

/// Fewest windows (non-overlapping count) turning more than
/// [`TURNING_RAD`] under the no-slip model for the spread and `x_c` to be
/// identifiable.
pub const MIN_TURNING_WINDOWS: usize = 3;

/// A window turns when its no-slip heading change exceeds this, rad.
pub const TURNING_RAD: f64 = 0.5;

/// Grid step of the time-offset search, s: a 20 s window's fit hardly
/// changes over less.
const OFFSET_STEP: f64 = 0.05;

/// Calibrates logs whose reference is position-only.
pub(super) fn calibrate(
    logs: &[DriveLog],
    cfg: &CalibConfig,
    progress: &dyn Fn(Progress),
    mut warnings: Vec<String>,
) -> Result<Calibration, CalibError> {
    let tcfg = TrackConfig {
        t_min: cfg.segment.t_min,
        t_max: cfg.segment.t_max,
        ..cfg.track.clone()
    };
    let facts = RobotFacts::of(logs);
    // The tread speeds' own scale: the separation they were made with
    // (nominal or the controller's), else the track width.
    let width = logs
        .iter()
        .find_map(|l| l.meta.separation)
        .or(facts.track_width)
        .filter(|w| w.is_finite() && *w > 0.0)
        .unwrap_or(1.0);
    let start = IcrParams::no_slip(width);
    if let Some(m) = cfg.method.filter(|&m| m != Method::Lm) {
        warnings.push(format!(
            "position-only reference: method `{}` needs headings; the LM fit on windows of fixes is used",
            m.name()
        ));
    }
    progress(Progress::Stage("aligning wheel and pose streams"));
    let mut offsets = Vec::with_capacity(logs.len());
    for log in logs {
        let o = match cfg.time_offset {
            TimeOffset::Fixed(o) => o,
            TimeOffset::Auto { max, step } => {
                match search_offset(log, &tcfg, &start, max, step.max(OFFSET_STEP)) {
                    Some(o) => {
                        if o.abs() >= max - 0.5 * step.max(OFFSET_STEP) {
                            warnings.push(offset_at_edge(log, o, max));
                        }
                        o
                    }
                    None => {
                        warnings.push(format!(
                            "{}: too few moving windows of fixes to estimate the time offset; using 0 s",
                            log.dir.display()
                        ));
                        0.0
                    }
                }
            }
        };
        offsets.push(o);
    }
    let refs: Vec<&DriveLog> = logs.iter().collect();
    let all = Tracks::build(&refs, &offsets, &tcfg);
    let names = terrain_sets(all.windows.iter().map(|w| &w.terrain));
    let n_sets = names.len();
    let mut sets = Vec::new();
    let mut first_err = None;
    for name in names {
        let mut t = all.clone();
        t.retain(|w| w.terrain == name);
        let label = name.clone().unwrap_or_else(|| "all".into());
        progress(Progress::Stage(&label));
        // The course check needs whole logs: only when one set takes them.
        let whole = (n_sets == 1).then_some((refs.as_slice(), offsets.as_slice()));
        match calibrate_set(&t, &label, &start, cfg, &tcfg, whole, &mut warnings) {
            Ok(mut set) => {
                set.terrain = name;
                let mut used: Vec<usize> = t.windows.iter().map(|w| w.log).collect();
                used.sort_unstable();
                used.dedup();
                set.time_offsets = used.iter().map(|&i| (logs[i].name(), offsets[i])).collect();
                for d in &mut set.dropped {
                    if let Ok(i) = d.log.parse::<usize>() {
                        d.log = logs.get(i).map(|l| l.name()).unwrap_or_default();
                    }
                }
                set.track_width = facts.track_width;
                set.wheel_radius = facts.wheel_radius;
                set.pioneer = facts.pioneer;
                set.stats = SegmentStats {
                    stale_poses: all.stats.held_fixes,
                    gaps: all.stats.gaps,
                    stationary: all.stats.stationary,
                    terrain_change: all.stats.terrain_change,
                    ..SegmentStats::default()
                };
                sets.push(set);
            }
            Err(e) if n_sets > 1 => {
                warnings.push(format!("terrain `{label}` not calibrated: {e}"));
                first_err.get_or_insert(e);
            }
            Err(e) => return Err(e),
        }
    }
    if sets.is_empty() {
        if let Some(e) = first_err {
            return Err(e);
        }
    }
    Ok(Calibration { sets, warnings })
}

/// The wheel/pose time offset of one log (s) on a `step` grid within
/// `±max`: the profile of the fit, the parameters refitted at every
/// offset (a shift in time bends the path as a spread does, so the two
/// are found together), the offset with the lowest mean squared residual
/// over all its windows.
fn search_offset(
    log: &DriveLog,
    tcfg: &TrackConfig,
    start: &IcrParams,
    max: f64,
    step: f64,
) -> Option<f64> {
    let k = (max / step).floor() as i64;
    let mut best: Option<(f64, f64)> = None;
    for i in -k..=k {
        let o = i as f64 * step;
        let t = Tracks::build(&[log], &[o], tcfg);
        let all = vec![true; t.windows.len()];
        let Some(f) = track_fit::fit(&t, start, &track_fit::DIFF_DRIVE, &all) else {
            continue;
        };
        let m: usize = t.windows.iter().map(|w| 2 * w.fixes.len()).sum();
        let c = track::cost(&f.params, &t, &all) / m.max(1) as f64;
        if best.is_none_or(|(lowest, _)| c < lowest) {
            best = Some((c, o));
        }
    }
    best.map(|b| b.1)
}

fn calibrate_set(
    t: &Tracks,
    label: &str,
    start: &IcrParams,
    cfg: &CalibConfig,
    tcfg: &TrackConfig,
    whole: Option<(&[&DriveLog], &[f64])>,
    warnings: &mut Vec<String>,
) -> Result<SetCalibration, CalibError> {
    let n = t.windows.len();
    let coverage = t.coverage();
    let independent = |k: usize| (k as f64 / coverage).round() as usize;
    let hint = || {
        format!(
            "a position-only reference is fitted on windows of {} s with at least {} fixes \
             and no gap over {} s in the fixes or {} s in the wheels, in which the treads \
             travel {} m: is the robot moving while the fixes are valid?",
            tcfg.window, tcfg.min_fixes, tcfg.max_fix_gap, tcfg.max_wheel_gap, tcfg.min_travel
        )
    };
    let too_few = |k: usize| CalibError::TooFewSegments {
        set: label.into(),
        moving: independent(k),
        needed: MIN_WINDOWS,
        hint: hint(),
    };
    let enough = |k: usize| match independent(k) < MIN_WINDOWS {
        true => Err(too_few(k)),
        false => Ok(()),
    };
    enough(n)?;
    let width = start.spread();
    let turning = independent(
        t.windows
            .iter()
            .filter(|w| (w.int_diff / width).abs() > TURNING_RAD)
            .count(),
    );
    let mut notes = vec![format!(
        "position-only reference (no heading): fitted on windows of {} s of fixes (each \
         fix in about {coverage:.1}), the model's path of each placed on its fixes by the \
         rotation and translation that fit best (the start heading and position are not \
         estimated with the ICRs)",
        tcfg.window
    )];
    let mut unidentified: Vec<&'static str> = Vec::new();
    let mut free = track_fit::ALL;
    if turning < MIN_TURNING_WINDOWS {
        let reason = format!(
            "only {turning} of {} windows turn more than {TURNING_RAD} rad (need \
             {MIN_TURNING_WINDOWS}): the fixes never bend enough to separate the tread ICRs",
            independent(n)
        );
        hold_tread_icrs(
            reason,
            (label, cfg.allow_partial),
            &mut unidentified,
            &mut notes,
        )?;
        free = track_fit::SPEED_ONLY;
    }
    if cfg.rate_model != RateModel::Off || cfg.centripetal != RateModel::Off {
        notes.push(
            "turn-rate and centripetal terms not fitted: windows of fixes average over turn \
             rates and speeds"
                .to_string(),
        );
    }
    let fit = |free: &track_fit::Free| {
        track_fit::fit(t, start, free, &vec![true; n]).ok_or_else(|| too_few(0))
    };
    let mut f = fit(&free)?;
    let weak = unidentified_by_std(&f.std, f.params.spread(), &track_fit::moved(&free));
    if free == track_fit::ALL && weak.iter().any(|w| ["y_l", "y_r", "x_c"].contains(w)) {
        // The fixes tell the spread but not where the ICRs sit: the
        // differential-drive model, which is what a controller holds.
        notes.push(format!(
            "x_c and the ICRs' centre (y_l + y_r)/2 held at 0: the fixes do not pin them \
             down (1-sigma of y_l, y_r, x_c with them free: {:.3}, {:.3}, {:.3} m); the \
             spread and the speed factors are fitted",
            f.std[0], f.std[1], f.std[2]
        ));
        free = track_fit::DIFF_DRIVE;
        f = fit(&free)?;
    }
    notes.push(format!(
        "spread y_l - y_r from the windows = {:.4} ± {:.4} m (1-sigma)",
        f.params.spread(),
        f.spread_std
    ));
    let used = f.inliers.iter().filter(|&&b| b).count();
    enough(used)?;
    check_identified(
        &f.std,
        f.params.spread(),
        &track_fit::moved(&free),
        (label, cfg.allow_partial),
        &mut unidentified,
        &mut notes,
    )?;
    let course = whole.and_then(|(logs, offsets)| {
        let c = course_check(&mut f, width, logs, offsets, tcfg, &mut notes)?;
        let (d, s) = (c.windows.0 - c.course.0, c.windows.1.hypot(c.course.1));
        if d.abs() > 2.0 * s {
            warnings.push(format!(
                "set `{label}`: the windows' turn factor {:.3} ± {:.3} and the course check's \
                 {:.3} ± {:.3} differ by {:.1} of their joint 1-sigma; the parameters carry \
                 their combination {:.3} ± {:.3}: look at the fixes (a reference that wanders) \
                 or the time offset",
                c.windows.0,
                c.windows.1,
                c.course.0,
                c.course.1,
                d.abs() / s,
                c.combined.0,
                c.combined.1
            ));
        }
        f.cost = track::cost(&f.params, t, &f.inliers);
        Some(c)
    });
    let rms = track::window_rms(&f.params, t);
    let dropped = t
        .windows
        .iter()
        .zip(&f.inliers)
        .zip(&rms)
        .filter(|((_, &k), _)| !k)
        .map(|((w, _), &r)| DroppedSegment {
            log: w.log.to_string(),
            t0: w.t0,
            t1: w.t1,
            residual: r,
        })
        .collect();
    let best = MethodFit {
        method: Method::Lm,
        params: f.params,
        cost: f.cost,
        robust_cost: f.cost,
        std: f.std,
    };
    Ok(SetCalibration {
        terrain: None,
        fits: vec![best.clone()],
        best,
        segments_used: used,
        dropped,
        stats: SegmentStats::default(),
        sigma: f.sigma,
        noise: crate::sandwich::ResidualNoise {
            pose_xy: f.sigma,
            ..Default::default()
        },
        time_offsets: Vec::new(),
        unidentified,
        notes,
        yaw_weight: cfg.yaw_weight,
        track_width: None,
        wheel_radius: None,
        pioneer: false,
        rate: None,
        reduction: None,
        coverage,
        course,
    })
}

/// The course check of `logs` against the odometry of the windows' fit
/// `f` (separation `s`, its speed factors), combined with the windows'
/// turn factor by inverse variances; `f`'s spread and its 1-sigma are set
/// to the combination, and the speed factors' ratio to the course check's
/// asymmetry (equal when it holds it at 0; their mean and the ICRs' centre
/// kept).
/// `None`, with a note, when too few straight stretches pair up.
fn course_check(
    f: &mut track_fit::TrackFit,
    s: f64,
    logs: &[&DriveLog],
    offsets: &[f64],
    tcfg: &TrackConfig,
    notes: &mut Vec<String>,
) -> Option<TurnFigures> {
    let p = f.params;
    let ccfg = CourseConfig {
        t_min: tcfg.t_min,
        t_max: tcfg.t_max,
        ..CourseConfig::default()
    };
    let odo = Odometry {
        separation: s,
        alpha: (p.alpha_l, p.alpha_r),
    };
    let Some(c) = course::check(logs, offsets, &odo, &ccfg) else {
        notes.push(format!(
            "no course check: fewer than 3 straight stretches ({} s, treads turning under \
             {} rad, fixes {} m apart) at least {} rad of turning apart",
            ccfg.stretch, ccfg.max_turn, ccfg.min_chord, ccfg.min_baseline
        ));
        return None;
    };
    let am = 0.5 * (p.alpha_l + p.alpha_r);
    let kw = p.spread() / (am * s);
    // The speed factors move together: the mean's 1-sigma is about theirs.
    let sa = 0.5 * (f.std[3] + f.std[4]);
    let sw = kw * ((f.spread_std / p.spread()).powi(2) + (sa / am).powi(2)).sqrt();
    let sc = c.std.max(1e-9);
    let (k, sk) = if sw.is_finite() && sw > 0.0 {
        let (a, b) = (sw.powi(-2), sc.powi(-2));
        ((a * kw + b * c.turn_factor) / (a + b), (a + b).powf(-0.5))
    } else {
        (c.turn_factor, sc)
    };
    let spread = k * am * s;
    let spread_std = sk * am * s;
    // The treads' ratio as the long baselines tell it: a radius ratio off
    // by 0.1 % turns the odometry by a radian over a few hundred metres.
    let ratio = c.asymmetry.map_or(0.0, |a| a.0);
    f.params.alpha_l = am * (1.0 - ratio);
    f.params.alpha_r = am * (1.0 + ratio);
    let centre = 0.5 * (p.y_l + p.y_r);
    // y_l, y_r: the centre's share of their variance kept, the spread's replaced.
    for i in 0..2 {
        let rest = (f.std[i].powi(2) - (0.5 * f.spread_std).powi(2)).max(0.0);
        f.std[i] = (rest + (0.5 * spread_std).powi(2)).sqrt();
    }
    f.params.y_l = centre + 0.5 * spread;
    f.params.y_r = centre - 0.5 * spread;
    f.spread_std = spread_std;
    let figures = TurnFigures {
        separation: s,
        windows: (kw, sw),
        course: (c.turn_factor, c.std),
        stretches: c.stretches.len(),
        pairs: c.pairs.len(),
        asymmetry: c.asymmetry,
        combined: (k, sk),
    };
    let asym = match c.asymmetry {
        Some((a, sa)) => format!("the treads' asymmetry (alpha_r - alpha_l) / (alpha_r + alpha_l) fitted: {a:.5} ± {sa:.5}"),
        None => format!(
            "the treads taken as equal (their asymmetry, {:.5} ± {:.5}, is within {} sigma of 0)",
            c.asymmetry_free.0, c.asymmetry_free.1, course::ASYMMETRY_SIGMAS
        ),
    };
    notes.push(format!(
        "turn factor spread / (mean speed factor × S), S = {s} m: windows {kw:.3} ± {sw:.3}, \
         course check {:.3} ± {:.3} ({} straight stretches, {} pairs over {} rad of turning \
         apart; {asym}); the parameters carry their inverse-variance combination {k:.3} ± {sk:.3} \
         (spread {spread:.4} ± {spread_std:.4} m at the windows' mean speed factor {am:.4}, \
         split between the treads by that asymmetry: {:.4} / {:.4})",
        c.turn_factor,
        c.std,
        figures.stretches,
        figures.pairs,
        ccfg.min_baseline,
        f.params.alpha_l,
        f.params.alpha_r
    ));
    Some(figures)
}
