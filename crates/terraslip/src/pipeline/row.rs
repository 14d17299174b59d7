//! The estimate after each wheels row, and what the rows of a whole run
//! reveal (parameters stuck at a physical limit).

use terraslip_calib::prediction::Timed;
use terraslip_core::estimator::{Estimator, FixSummary};
use terraslip_core::filter::IcrBand;

use super::EstimateRow;

/// The estimate after a wheels row at `t`.
pub fn row(est: &Estimator, t: f64, terrain: Option<usize>, s: &FixSummary) -> EstimateRow {
    let f = est.filter();
    let (east, north, yaw) = f.pose();
    // The ICRs in effect at this row's tread speeds.
    let icr = f.icr_now();
    let pc = est.pose_covariance();
    let ic = f.icr_now_covariance();
    let sd = |v: f64| v.max(0.0).sqrt();
    EstimateRow {
        t,
        east,
        north,
        yaw,
        y_l: icr.y_l,
        y_r: icr.y_r,
        x_c: icr.x_c,
        alpha_l: icr.alpha_l,
        alpha_r: icr.alpha_r,
        std: [
            sd(pc[(0, 0)]),
            sd(pc[(1, 1)]),
            // A heading not yet found from any fix is unknown.
            if f.anchored()[1] {
                sd(pc[(2, 2)])
            } else {
                std::f64::consts::PI
            },
            sd(ic[(0, 0)]),
            sd(ic[(1, 1)]),
            sd(ic[(2, 2)]),
            sd(ic[(3, 3)]),
            sd(ic[(4, 4)]),
        ],
        std_spread: (ic[(0, 0)] + ic[(1, 1)] - 2.0 * ic[(0, 1)]).max(0.0).sqrt(),
        pose_cov: pose_cov(&pc, f.anchored()[1]),
        fix_bias: f.position_bias().into(),
        fix_position_cov: rows_of(&est.fix_position_covariance()),
        icr_cov: rows_of(&ic),
        model_noise: terraslip_core::odometry::ModelNoise::of(f),
        twist_noise: est.twist_noise(),
        terrain,
        fused: s.fused,
        gated: s.gated,
        nis: s.nis_position + s.nis_yaw,
        q_scale: f.schedule_scale(),
        change: s.change,
        clock_offset: f.clock_offset().0,
        prediction_model: prediction_model(f),
        gyro_scale: learned_gyro_scale(f).map(|g| g.scale),
    }
}

/// The gyro's scale and its 1-sigma where the filter learns it (gyro
/// windows fused, scale not held).
pub fn learned_gyro_scale(
    f: &terraslip_core::filter::Filter,
) -> Option<super::recommend::GyroScale> {
    let g = f.gyro_noise();
    (g.scale_learned && g.fused > 0).then_some(super::recommend::GyroScale {
        scale: g.scale,
        std: g.scale_std,
    })
}

/// Matrix `m` as an array of its rows.
fn rows_of<const R: usize, const C: usize>(m: &nalgebra::SMatrix<f64, R, C>) -> [[f64; C]; R] {
    std::array::from_fn(|r| std::array::from_fn(|k| m[(r, k)]))
}

/// The pose covariance `pc` as published: symmetric, and with an unknown
/// heading (`heading_known` false) of variance π² and no cross terms.
fn pose_cov(pc: &nalgebra::Matrix3<f64>, heading_known: bool) -> [[f64; 3]; 3] {
    let mut c: [[f64; 3]; 3] =
        std::array::from_fn(|r| std::array::from_fn(|k| 0.5 * (pc[(r, k)] + pc[(k, r)])));
    if !heading_known {
        for row in c.iter_mut().take(2) {
            row[2] = 0.0;
        }
        c[2] = [0.0, 0.0, std::f64::consts::PI.powi(2)];
    }
    c
}

/// What the 2 s prediction from a start takes of the filter: the ICRs at
/// the start's turn, the centripetal terms applied at each row's speed
/// over the 2 s (and a held speed factors' turn law at each row's tread
/// speeds, as the filter reads it), and the pose stream's clock offset (s).
fn prediction_model(f: &terraslip_core::filter::Filter) -> Timed {
    let (c, _) = f.centripetal();
    let (icr, k_alpha) = f.icr_turn();
    let mut t = Timed::new(icr, f.clock_offset().0);
    t.slopes.k_alpha = k_alpha;
    t.slopes.k_x_speed = c.k_x_speed;
    t.slopes.k_spread_speed = c.k_spread_speed;
    t
}

/// How many rows had a slip parameter on an edge of the physical band,
/// per edge, for [`BandCounts::warnings`].
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct BandCounts {
    at: [usize; 6],
}

/// The edges [`BandCounts`] counts, as the warnings name them.
const EDGES: [&str; 6] = [
    "the spread y_l - y_r at its lower limit",
    "the spread y_l - y_r at its upper limit",
    "a tread speed factor at its lower limit",
    "a tread speed factor at its upper limit",
    "x_c at its limit",
    "the ICR centre at its limit",
];

impl BandCounts {
    /// Counts the edges `r` sits on.
    pub fn add(&mut self, r: &EstimateRow, band: &IcrBand) {
        let near = |v: f64, edge: f64| (v - edge).abs() <= 1e-6 * (1.0 + edge.abs());
        let (lo, hi) = band.alpha_range;
        let on = [
            near(r.y_l - r.y_r, band.min_spread),
            near(r.y_l - r.y_r, band.max_spread),
            near(r.alpha_l, lo) || near(r.alpha_r, lo),
            near(r.alpha_l, hi) || near(r.alpha_r, hi),
            near(r.x_c.abs(), band.max_x_c),
            near((0.5 * (r.y_l + r.y_r)).abs(), band.max_centre),
        ];
        for (n, on) in self.at.iter_mut().zip(on) {
            *n += usize::from(on);
        }
    }

    /// The warning (one, or none) for slip parameters that sat on an edge
    /// of the physical band for more than 5 % of the `rows` rows (a learned
    /// parameter at a clamp is a model or data problem the user must hear
    /// about), naming each such edge and its share.
    pub fn warnings(&self, rows: usize) -> Vec<String> {
        if rows == 0 {
            return Vec::new();
        }
        let n = rows as f64;
        let edges: Vec<String> = EDGES
            .iter()
            .zip(self.at)
            .filter(|&(_, count)| count as f64 / n > 0.05)
            .enumerate()
            .map(|(k, (what, count))| {
                let of = if k == 0 { " of the run" } else { "" };
                format!("{what} for {:.0} %{of}", 100.0 * count as f64 / n)
            })
            .collect();
        if edges.is_empty() {
            return Vec::new();
        }
        vec![format!(
            "{}: the data pull the model beyond what is physical \
             (clock offset, wrong track width in meta.toml, or a model that does not fit)",
            edges.join(", ")
        )]
    }
}

/// The warning for a run whose `x_c` (m) ends near its limit with
/// position fixes fused (`positions`) and no lever arm stated: a pose
/// reference off the axle reads as `x_c`, since a point `l` ahead of the
/// axle moves sideways at ω·(l − x_c) and the fixes tell only the
/// difference; the warning says where to state it.
pub(super) fn off_axle_hint(
    x_c: f64,
    band: &IcrBand,
    stated: bool,
    positions: usize,
) -> Option<String> {
    (!stated && positions > 0 && band.max_x_c > 0.0 && x_c.abs() >= 0.8 * band.max_x_c).then(|| {
        format!(
            "x_c ended at {x_c:+.3} m, near its limit (±{:.3} m): a pose reference off the wheel axle reads as x_c \
             (the fixes tell only the difference of the two); if it is not on the axle, state where it sits: \
             `[pose] lever_arm = [x, y]` (m, base frame) in a --topics file, `[pose] lever_arm_x`, `lever_arm_y` \
             in meta.toml, or the bag's /tf_static",
            band.max_x_c
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_edges_a_run_sat_on_are_one_warning() {
        let counts = BandCounts {
            at: [0, 0, 3, 0, 31, 10],
        };
        let w = counts.warnings(100);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(
            w[0].starts_with(
                "x_c at its limit for 31 % of the run, the ICR centre at its limit for 10 %: "
            ),
            "{w:?}"
        );
        assert!(BandCounts::default().warnings(100).is_empty());
    }
}
