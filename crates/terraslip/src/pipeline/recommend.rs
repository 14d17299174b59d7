//! The whole drive's slip figures, for the controller's recommendation:
//! the estimator's ICRs in effect at each row averaged over the drive,
//! each row weighted by its information (1 / variance), with an
//! uncertainty from the drive itself.
//!
//! The uncertainty of each figure is the larger of
//! * the batch-means standard error: the drive cut into [`BATCHES`]
//!   consecutive stretches, each stretch's own weighted average taken, and
//!   their spread divided by √(stretches) (the rows of one stretch are
//!   correlated through the filter; stretches of a minute or more hardly
//!   are), and
//! * the filter's own 1-sigma at its best-informed row: an average of
//!   correlated estimates does not know the figure better than the best
//!   of them did.
//!
//! The spread is taken in the gyro's final scale. Where the gyro tells the
//! turn, the filter learns the spread against it: each row's spread is
//! what makes the model turn as the gyro reads, divided by the gyro's
//! scale as believed at that row. A scale learned slowly (from positions
//! alone, a few percent over minutes) leaves the spread of the drive's
//! best-informed rows in a scale the end of the drive corrects, so each
//! row's spread is re-expressed in the final scale (`g_final / g_row`),
//! and the final scale's own 1-sigma is added to the spread's and the turn
//! spread's.
//!
//! The estimator's last state (`summary.json`'s `icr`) answers a different
//! question: where the filter ended, which on a real drive follows the
//! last seconds' ground and manoeuvres.

use super::EstimateRow;

/// Stretches of the drive whose averages give the batch-means error.
pub const BATCHES: usize = 8;

/// Length of the sums kept while the drive streams by, s (grouped into
/// [`BATCHES`] stretches at the end).
const BLOCK_S: f64 = 5.0;

/// A figure and its 1-sigma.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Figure {
    pub value: f64,
    pub std: f64,
}

/// The whole drive's figures: the spread y_l − y_r (m, the scale of the
/// tread speeds), both speed factors, and the turn factor spread / mean
/// speed factor (m: what the odometry's turn is off by, times the
/// separation the tread speeds were made with).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriveFigures {
    pub spread: Figure,
    pub alpha_l: Figure,
    pub alpha_r: Figure,
    pub turn_spread: Figure,
    /// Stretches the batch-means error was taken over.
    pub batches: usize,
}

/// The gyro's scale (it reads `scale` times the true yaw rate) and its
/// 1-sigma, where the filter learns it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GyroScale {
    pub scale: f64,
    pub std: f64,
}

impl GyroScale {
    fn usable(self) -> Option<Self> {
        (self.scale.is_finite() && self.scale > 0.0 && self.std.is_finite() && self.std >= 0.0)
            .then_some(self)
    }
}

/// What the drive's figures take of one row: its time (s), spread (m),
/// speed factors, their 1-sigma, and the gyro's scale the row's spread was
/// learned against (`None`: no gyro, or its scale held).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RowFigures {
    pub t: f64,
    pub spread: f64,
    pub std_spread: f64,
    pub alpha_l: f64,
    pub std_alpha_l: f64,
    pub alpha_r: f64,
    pub std_alpha_r: f64,
    pub gyro_scale: Option<f64>,
}

impl From<&EstimateRow> for RowFigures {
    fn from(r: &EstimateRow) -> Self {
        Self {
            t: r.t,
            spread: r.y_l - r.y_r,
            std_spread: r.std_spread,
            alpha_l: r.alpha_l,
            std_alpha_l: r.std[6],
            alpha_r: r.alpha_r,
            std_alpha_r: r.std[7],
            gyro_scale: r.gyro_scale,
        }
    }
}

/// Information-weighted sums of one quantity.
#[derive(Debug, Clone, Copy, Default)]
struct Sum {
    w: f64,
    wx: f64,
}

impl Sum {
    fn add(&mut self, x: f64, std: f64) {
        let var = std * std;
        if x.is_finite() && var.is_finite() && var > 1e-18 {
            self.w += 1.0 / var;
            self.wx += x / var;
        }
    }

    fn merge(&mut self, o: &Sum) {
        self.w += o.w;
        self.wx += o.wx;
    }

    fn mean(&self) -> Option<f64> {
        (self.w > 0.0).then(|| self.wx / self.w)
    }
}

/// The sums of one block of [`BLOCK_S`] s.
#[derive(Debug, Clone, Copy, Default)]
struct Block {
    /// The spread of every row.
    spread: Sum,
    /// Of rows learned against a gyro: their spread, and their spread over
    /// the gyro's scale at the row (same weights).
    gyro_rows: Sum,
    per_gyro: Sum,
    alpha_l: Sum,
    alpha_r: Sum,
}

impl Block {
    fn merge(&mut self, o: &Block) {
        self.spread.merge(&o.spread);
        self.gyro_rows.merge(&o.gyro_rows);
        self.per_gyro.merge(&o.per_gyro);
        self.alpha_l.merge(&o.alpha_l);
        self.alpha_r.merge(&o.alpha_r);
    }

    /// Spread, speed factors and turn spread of the block; with the gyro's
    /// final scale `g`, the spread of rows learned against the gyro in it.
    fn means(&self, g: Option<f64>) -> Option<[f64; 4]> {
        let spread = match g {
            Some(g) => Sum {
                w: self.spread.w,
                wx: self.spread.wx - self.gyro_rows.wx + g * self.per_gyro.wx,
            },
            None => self.spread,
        };
        let (s, l, r) = (spread.mean()?, self.alpha_l.mean()?, self.alpha_r.mean()?);
        let a = 0.5 * (l + r);
        (a.abs() > 1e-9).then_some([s, l, r, s / a])
    }
}

/// The whole drive's sums as its rows stream by (memory: one block per
/// [`BLOCK_S`] s of drive).
#[derive(Debug, Clone, Default)]
pub struct DriveAverage {
    first: Option<f64>,
    blocks: Vec<Block>,
    /// Smallest 1-sigma of spread, speed factors and turn spread seen.
    best_std: [f64; 4],
}

impl DriveAverage {
    /// One row of `estimate.csv`.
    pub fn add(&mut self, r: &EstimateRow) {
        self.add_figures(&RowFigures::from(r));
    }

    /// One row's figures.
    pub fn add_figures(&mut self, r: &RowFigures) {
        let first = *self.first.get_or_insert(r.t);
        if self.blocks.is_empty() {
            self.best_std = [f64::INFINITY; 4];
        }
        let k = (((r.t - first) / BLOCK_S).max(0.0) as usize).min(1 << 24);
        if self.blocks.len() <= k {
            self.blocks.resize(k + 1, Block::default());
        }
        let spread = r.spread;
        let (sl, sr) = (r.std_alpha_l, r.std_alpha_r);
        let b = &mut self.blocks[k];
        b.spread.add(spread, r.std_spread);
        if let Some(g) = r.gyro_scale.filter(|g| g.is_finite() && *g > 0.0) {
            b.gyro_rows.add(spread, r.std_spread);
            b.per_gyro.add(spread / g, r.std_spread);
        }
        b.alpha_l.add(r.alpha_l, sl);
        b.alpha_r.add(r.alpha_r, sr);
        // The turn spread's 1-sigma to first order (the spread and the
        // speed factors taken as independent).
        let a = 0.5 * (r.alpha_l + r.alpha_r);
        let turn_std = if a.abs() > 1e-9 && spread.abs() > 1e-9 {
            (spread / a).abs()
                * ((r.std_spread / spread).powi(2) + (0.5 * sl.hypot(sr) / a).powi(2)).sqrt()
        } else {
            f64::INFINITY
        };
        for (best, s) in self
            .best_std
            .iter_mut()
            .zip([r.std_spread, sl, sr, turn_std])
        {
            if s.is_finite() && s > 0.0 {
                *best = best.min(s);
            }
        }
    }

    /// The whole drive's figures, the spread in the gyro's final scale
    /// `gyro` where rows learned it against the gyro; `None` before any row
    /// with finite stds.
    pub fn finish(&self, gyro: Option<GyroScale>) -> Option<DriveFigures> {
        let gyro = gyro.and_then(GyroScale::usable);
        let g = gyro.map(|g| g.scale);
        let mut all = Block::default();
        for b in &self.blocks {
            all.merge(b);
        }
        let whole = all.means(g)?;
        // The final scale's own 1-sigma, relative, where it rescaled rows.
        let rel_g = match gyro {
            Some(gs) if all.gyro_rows.w > 0.0 => gs.std / gs.scale * all.gyro_rows.w / all.spread.w,
            _ => 0.0,
        };
        // Consecutive blocks grouped into stretches of equal length.
        let n = self.blocks.len();
        let per = n.div_ceil(BATCHES).max(1);
        let stretches: Vec<[f64; 4]> = self
            .blocks
            .chunks(per)
            .filter_map(|c| {
                let mut s = Block::default();
                c.iter().for_each(|b| s.merge(b));
                s.means(g)
            })
            .collect();
        let m = stretches.len();
        let figure = |k: usize| {
            let batch = if m >= 2 {
                let mean = stretches.iter().map(|s| s[k]).sum::<f64>() / m as f64;
                let var =
                    stretches.iter().map(|s| (s[k] - mean).powi(2)).sum::<f64>() / (m - 1) as f64;
                (var / m as f64).sqrt()
            } else {
                f64::INFINITY
            };
            let best = self.best_std[k];
            let std = if best.is_finite() {
                batch.max(best)
            } else {
                batch
            };
            // The spread and the turn spread carry the gyro scale's.
            let from_gyro = if k == 0 || k == 3 {
                whole[k] * rel_g
            } else {
                0.0
            };
            Figure {
                value: whole[k],
                std: std.hypot(from_gyro),
            }
        };
        Some(DriveFigures {
            spread: figure(0),
            alpha_l: figure(1),
            alpha_r: figure(2),
            turn_spread: figure(3),
            batches: m,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A drive whose turn the filter learns against a gyro reading 4 %
    /// over the true yaw rate, its scale believed 1.00 for the first half
    /// (where the spread is best known) and found only by the end: each
    /// row's spread is what turns the model as that gyro reads, the true
    /// spread 0.96 m over the scale believed at the row.
    fn drive(gyro: bool) -> DriveAverage {
        let mut d = DriveAverage::default();
        for i in 0..4000 {
            let t = 0.1 * f64::from(i);
            let g = if t < 200.0 {
                1.0
            } else {
                1.0 + 0.04 * (t - 200.0) / 200.0
            };
            let std_spread = if t < 200.0 { 0.03 } else { 0.08 };
            d.add_figures(&RowFigures {
                t,
                spread: 0.96 / 1.04 * g,
                std_spread,
                alpha_l: 0.98,
                std_alpha_l: 0.02,
                alpha_r: 0.98,
                std_alpha_r: 0.02,
                gyro_scale: gyro.then_some(g),
            });
        }
        d
    }

    #[test]
    fn the_spread_is_taken_in_the_gyros_final_scale() {
        let gyro = GyroScale {
            scale: 1.04,
            std: 0.01,
        };
        let f = drive(true).finish(Some(gyro)).unwrap();
        assert!((f.spread.value - 0.96).abs() < 1e-9, "{:?}", f.spread);
        assert!((f.turn_spread.value - 0.96 / 0.98).abs() < 1e-9);
        // The final scale's 1-sigma (1 %) is in the spread's.
        assert!(f.spread.std >= 0.96 * 0.01 / 1.04 * 0.99, "{:?}", f.spread);
        assert!(f.alpha_l.std < 0.021, "{:?}", f.alpha_l);
    }

    #[test]
    fn without_a_learned_gyro_scale_the_spread_is_the_rows_own() {
        let plain = |d: DriveAverage, g: Option<GyroScale>| d.finish(g).unwrap().spread.value;
        let gyro = Some(GyroScale {
            scale: 1.04,
            std: 0.01,
        });
        // Rows learned with no gyro scale, or no final one: as averaged.
        let a = plain(drive(false), gyro);
        let b = plain(drive(true), None);
        assert_eq!(a, b);
        assert!(a < 0.94, "{a}");
        // A scale that never moved rescales nothing.
        let mut d = DriveAverage::default();
        for i in 0..100 {
            d.add_figures(&RowFigures {
                t: f64::from(i),
                spread: 0.9,
                std_spread: 0.05,
                alpha_l: 1.0,
                std_alpha_l: 0.02,
                alpha_r: 1.0,
                std_alpha_r: 0.02,
                gyro_scale: Some(1.02),
            });
        }
        let same = GyroScale {
            scale: 1.02,
            std: 0.0,
        };
        assert!((d.finish(Some(same)).unwrap().spread.value - 0.9).abs() < 1e-12);
    }
}
