//! Reads back `estimate.csv` and `prediction.csv` (what `terraslip
//! estimate` writes), for plots and reports.

use std::path::Path;

use crate::csv_table::read_csv_table;
use crate::LogError;

/// One row of `estimate.csv`: pose (ENU m, rad), the ICRs in effect (m)
/// and speed factors, their standard deviations, the believed terrain.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct EstimateRecord {
    pub t: f64,
    pub east: f64,
    pub north: f64,
    pub yaw: f64,
    pub y_l: f64,
    pub y_r: f64,
    pub x_c: f64,
    pub std_east: f64,
    pub std_north: f64,
    pub std_yaw: f64,
    pub std_y_l: f64,
    pub std_y_r: f64,
    pub std_x_c: f64,
    /// Empty when no terrain evidence was used.
    pub terrain: String,
    /// 1 where the file has no speed factor columns.
    pub alpha_l: f64,
    pub alpha_r: f64,
    pub std_alpha_l: f64,
    pub std_alpha_r: f64,
    /// Std of the spread `y_l - y_r`, m (0 where absent).
    pub std_spread: f64,
    /// How late the pose stream is stamped against the wheels, s (0 where
    /// absent).
    pub clock_offset: f64,
}

impl EstimateRecord {
    /// The ICR parameters in effect at this row.
    pub fn icr(&self) -> terraslip_core::IcrParams {
        terraslip_core::IcrParams {
            y_l: self.y_l,
            y_r: self.y_r,
            x_c: self.x_c,
            alpha_l: self.alpha_l,
            alpha_r: self.alpha_r,
        }
    }
}

/// Reads `estimate.csv`; the contract's columns are required, the others
/// optional.
pub fn read_estimate(path: &Path) -> Result<Vec<EstimateRecord>, LogError> {
    let mut tab = read_csv_table(path)?;
    let req = |n: &str| tab.require(n);
    let cols = [
        req("east")?,
        req("north")?,
        req("yaw")?,
        req("y_l")?,
        req("y_r")?,
        req("x_c")?,
        req("std_east")?,
        req("std_north")?,
        req("std_yaw")?,
        req("std_y_l")?,
        req("std_y_r")?,
        req("std_x_c")?,
    ];
    let terrain = tab.optional("terrain");
    let opt = [
        "alpha_l",
        "alpha_r",
        "std_alpha_l",
        "std_alpha_r",
        "std_spread",
        "clock_offset",
    ]
    .map(|n| tab.optional(n));
    let mut out = Vec::new();
    tab.each_timed_row(|tab, line, t, rec| {
        let mut v = [0.0; 12];
        for (k, c) in cols.iter().enumerate() {
            v[k] = tab.req_f64(line, rec, *c)?;
        }
        let mut o = [1.0, 1.0, 0.0, 0.0, 0.0, 0.0];
        for (k, c) in opt.iter().enumerate() {
            if let Some(x) = tab.opt_f64(line, rec, *c)? {
                o[k] = x;
            }
        }
        out.push(EstimateRecord {
            t,
            east: v[0],
            north: v[1],
            yaw: v[2],
            y_l: v[3],
            y_r: v[4],
            x_c: v[5],
            std_east: v[6],
            std_north: v[7],
            std_yaw: v[8],
            std_y_l: v[9],
            std_y_r: v[10],
            std_x_c: v[11],
            terrain: terrain.map_or("", |i| tab.cell(rec, i)).to_string(),
            alpha_l: o[0],
            alpha_r: o[1],
            std_alpha_l: o[2],
            std_alpha_r: o[3],
            std_spread: o[4],
            clock_offset: o[5],
        });
        Ok(())
    })?;
    Ok(out)
}

/// One row of `prediction.csv`: a start of the 2 s prediction `estimate`
/// scored for `summary.json`'s `prediction`.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PredictionRecord {
    /// Start time, s (the wheels' clock).
    pub t: f64,
    /// Position error of the learned model's prediction, m.
    pub error_m: f64,
    /// Position error of the no-slip model's prediction, m.
    pub no_slip_m: f64,
}

/// Reads `prediction.csv` (`t,error_m,no_slip_m`; a header alone when
/// no start could be scored).
pub fn read_prediction(path: &Path) -> Result<Vec<PredictionRecord>, LogError> {
    let mut tab = read_csv_table(path)?;
    let (error, no_slip) = (tab.require("error_m")?, tab.require("no_slip_m")?);
    let mut out = Vec::new();
    tab.each_timed_row(|tab, line, t, rec| {
        out.push(PredictionRecord {
            t,
            error_m: tab.req_f64(line, rec, error)?,
            no_slip_m: tab.req_f64(line, rec, no_slip)?,
        });
        Ok(())
    })?;
    Ok(out)
}
