//! What `terraslip calibrate` prints on stderr for each parameter set: the
//! segments used and dropped, every method's fit, uncertainties, the
//! turn-rate and traction terms.

use terraslip_calib::SetCalibration;

/// A standard deviation, or `-` where it is not identified.
fn fmt_std(s: f64) -> String {
    if s.is_finite() {
        format!("{s:.4}")
    } else {
        "-".into()
    }
}

/// "selected", or why not.
fn verdict(reason: &Option<String>) -> String {
    match reason {
        None => "selected".to_string(),
        Some(why) => format!("not selected, {why}"),
    }
}

/// The table of one parameter set (one terrain, or all terrains pooled).
pub(super) fn print_set(s: &SetCalibration) {
    let name = s.terrain.as_deref().unwrap_or("all terrains");
    eprintln!(
        "[{name}] {} segments used, {} dropped as outliers (sigma {:.3} m), {} stationary, {} implausible references; {} held and {} mistimed poses dropped; time offset {}",
        s.segments_used,
        s.dropped.len(),
        s.sigma,
        s.stats.stationary,
        s.stats.implausible,
        s.stats.stale_poses,
        s.stats.mistimed_poses,
        s.time_offsets
            .iter()
            .map(|(n, o)| format!("{n}: {o:+.3} s"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    eprintln!("  constant ICRs fitted to {name} (the same at every turn rate):");
    eprintln!("  method      cost(eq.13)      y_l      y_r      x_c  alpha_l  alpha_r");
    for f in &s.fits {
        let p = f.params;
        eprintln!(
            "  {:9} {:12.4} {:8.4} {:8.4} {:8.4} {:8.4} {:8.4}{}",
            f.method.name(),
            f.cost,
            p.y_l,
            p.y_r,
            p.x_c,
            p.alpha_l,
            p.alpha_r,
            if f.method == s.best.method {
                "  <- best"
            } else {
                ""
            }
        );
    }
    if let Some(r) = &s.reduction {
        eprintln!("  {}", r.summary());
        if let Some(f) = r.fit() {
            let p = f.params;
            eprintln!(
                "  held      {:12.4} {:8.4} {:8.4} {:8.4} {:8.4} {:8.4}  <- written",
                f.sse, p.y_l, p.y_r, p.x_c, p.alpha_l, p.alpha_r
            );
        }
    }
    eprintln!(
        "  1-sigma     {:>12} {:>8} {:>8} {:>8} {:>8} {:>8}",
        "",
        fmt_std(s.best.std[0]),
        fmt_std(s.best.std[1]),
        fmt_std(s.best.std[2]),
        fmt_std(s.best.std[3]),
        fmt_std(s.best.std[4])
    );
    if let Some(chi) = s.chi() {
        eprintln!(
            "  steering efficiency chi = {chi:.3}, eccentricity e = {:.3}",
            s.best.params.eccentricity()
        );
    }
    if s.pioneer {
        match s.pioneer_settings() {
            Some((t, r)) => {
                eprintln!("  Pioneer server settings: Ticksmm = {t}, Revcount = {r}")
            }
            None => eprintln!("  Pioneer settings need wheel_radius in meta.toml"),
        }
    }
    for n in &s.notes {
        eprintln!("  note: {n}");
    }
    if let Some(r) = &s.rate {
        let f = &r.fit;
        eprintln!(
            "  turn-rate model: k_spread {:.4} +- {} s/m, k_alpha {:.4} +- {} s/m, BIC {:.1} vs constant {:.1}: {}",
            f.slopes.k_spread,
            fmt_std(f.std[5]),
            f.slopes.k_alpha,
            fmt_std(f.std[6]),
            r.bic_rate,
            r.bic_constant,
            if r.reason.is_none() && (r.traction_selected || r.centripetal_selected) {
                "superseded by a model on top of it".to_string()
            } else {
                verdict(&r.reason)
            }
        );
        if let Some((t, bic)) = &r.traction {
            eprintln!(
                "  traction term: k_acc {:.4} +- {} s^2/m, k_dir {:.4} +- {} s^2/m, BIC {:.1}: {}",
                t.slopes.k_acc,
                fmt_std(t.std[7]),
                t.slopes.k_dir,
                fmt_std(t.std[8]),
                bic,
                verdict(&r.traction_reason)
            );
        }
        if let Some((c, bic)) = &r.centripetal {
            eprintln!(
                "  centripetal terms: k_x_speed {:.4} +- {} s, k_spread_speed {:.4} +- {} s/m, BIC {:.1}: {}",
                c.slopes.k_x_speed,
                fmt_std(c.std[9]),
                c.slopes.k_spread_speed,
                fmt_std(c.std[10]),
                bic,
                verdict(&r.centripetal_reason)
            );
        }
    }
    if !s.unidentified.is_empty() {
        eprintln!(
            "  warning: not identified by this data: {}",
            s.unidentified.join(", ")
        );
    }
}
