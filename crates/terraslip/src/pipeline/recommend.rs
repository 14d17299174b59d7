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
    spread: Sum,
    alpha_l: Sum,
    alpha_r: Sum,
}

impl Block {
    fn merge(&mut self, o: &Block) {
        self.spread.merge(&o.spread);
        self.alpha_l.merge(&o.alpha_l);
        self.alpha_r.merge(&o.alpha_r);
    }

    /// Spread, speed factors and turn spread of the block.
    fn means(&self) -> Option<[f64; 4]> {
        let (s, l, r) = (
            self.spread.mean()?,
            self.alpha_l.mean()?,
            self.alpha_r.mean()?,
        );
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
        let first = *self.first.get_or_insert(r.t);
        if self.blocks.is_empty() {
            self.best_std = [f64::INFINITY; 4];
        }
        let k = (((r.t - first) / BLOCK_S).max(0.0) as usize).min(1 << 24);
        if self.blocks.len() <= k {
            self.blocks.resize(k + 1, Block::default());
        }
        let spread = r.y_l - r.y_r;
        let (sl, sr) = (r.std[6], r.std[7]);
        let b = &mut self.blocks[k];
        b.spread.add(spread, r.std_spread);
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

    /// The whole drive's figures; `None` before any row with finite stds.
    pub fn finish(&self) -> Option<DriveFigures> {
        let mut all = Block::default();
        for b in &self.blocks {
            all.merge(b);
        }
        let whole = all.means()?;
        // Consecutive blocks grouped into stretches of equal length.
        let n = self.blocks.len();
        let per = n.div_ceil(BATCHES).max(1);
        let stretches: Vec<[f64; 4]> = self
            .blocks
            .chunks(per)
            .filter_map(|c| {
                let mut s = Block::default();
                c.iter().for_each(|b| s.merge(b));
                s.means()
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
            Figure {
                value: whole[k],
                std: if best.is_finite() {
                    batch.max(best)
                } else {
                    batch
                },
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
