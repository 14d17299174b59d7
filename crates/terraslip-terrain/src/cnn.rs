//! A small 1D convolutional network over a window's vibration spectra
//! (candle, CPU): the per-channel band log powers and band shares of the
//! `full` feature set form the input channels (one per IMU channel and
//! kind), convolved along the frequency bands; the other features (speed,
//! turn, slip, currents, moments) join the convolved spectra in a dense
//! layer. Trained with AdamW on the softmax cross-entropy; initial weights
//! and batch order come from a SplitMix64 seed.

use candle_core::{DType, Device, Tensor, Var, D};
use candle_nn::{AdamW, Optimizer, ParamsAdamW};
use serde::{Deserialize, Serialize};

use crate::classify::SplitMix64;
use crate::error::{Result, TerrainError};

/// Training settings of the network.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CnnParams {
    /// Passes over the training windows.
    pub epochs: usize,
    /// Windows per gradient step.
    pub batch: usize,
    pub learning_rate: f64,
    pub weight_decay: f64,
    /// Filters of each of the two convolution layers (kernel 3 bands).
    pub filters: usize,
    /// Units of the dense hidden layer.
    pub hidden: usize,
    /// Which non-spectral features join the dense layer.
    pub dense: DenseInputs,
    pub seed: u64,
}

/// The features fed to the dense layer beside the convolved spectra.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DenseInputs {
    /// Every non-spectral feature.
    All,
    /// Only the tread speed, the tread speed difference and the commanded yaw rate.
    Manoeuvre,
    /// None: the spectra alone.
    None,
}

impl Default for CnnParams {
    fn default() -> Self {
        Self {
            epochs: 40,
            batch: 64,
            learning_rate: 1e-3,
            weight_decay: 1e-2,
            filters: 16,
            hidden: 32,
            dense: DenseInputs::All,
            seed: 7,
        }
    }
}

const KERNEL: usize = 3;

/// A trained network. `grid[c][b]`: the feature index of input channel `c`
/// at band `b`; `rest`: the feature indices fed to the dense layer
/// directly. Weights row-major: `w1` `[filters, channels, 3]`, `w2`
/// `[filters, filters, 3]`, `w3` `[filters·bands + rest, hidden]`, `w4`
/// `[hidden, classes]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Cnn {
    pub grid: Vec<Vec<usize>>,
    pub rest: Vec<usize>,
    pub filters: usize,
    pub hidden: usize,
    pub classes: usize,
    pub w1: Vec<f32>,
    pub b1: Vec<f32>,
    pub w2: Vec<f32>,
    pub b2: Vec<f32>,
    pub w3: Vec<f32>,
    pub b3: Vec<f32>,
    pub w4: Vec<f32>,
    pub b4: Vec<f32>,
}

fn err(e: candle_core::Error) -> TerrainError {
    TerrainError::Training(format!("cnn: {e}"))
}

/// The spectral grid of a feature list: rows `(channel, kind)` for the
/// names `{ch}_band{b}` (log power) and `{ch}_band{b}_share`, every row
/// with bands `0..n`; the other indices go to `rest`.
pub fn spectral_grid(names: &[String]) -> (Vec<Vec<usize>>, Vec<usize>) {
    let mut rows: Vec<(String, Vec<(usize, usize)>)> = Vec::new();
    let mut rest = Vec::new();
    for (i, n) in names.iter().enumerate() {
        let (stem, share) = match n.strip_suffix("_share") {
            Some(s) => (s, true),
            None => (n.as_str(), false),
        };
        let band = stem
            .rsplit_once("_band")
            .and_then(|(ch, b)| b.parse::<usize>().ok().map(|b| (ch, b)));
        match band {
            Some((ch, b)) => {
                let key = format!("{ch}/{share}");
                match rows.iter_mut().find(|(k, _)| *k == key) {
                    Some((_, r)) => r.push((b, i)),
                    None => rows.push((key, vec![(b, i)])),
                }
            }
            None => rest.push(i),
        }
    }
    let grid: Vec<Vec<usize>> = rows
        .into_iter()
        .map(|(_, mut r)| {
            r.sort();
            r.into_iter().map(|(_, i)| i).collect()
        })
        .collect();
    (grid, rest)
}

struct Weights {
    w1: Tensor,
    b1: Tensor,
    w2: Tensor,
    b2: Tensor,
    w3: Tensor,
    b3: Tensor,
    w4: Tensor,
    b4: Tensor,
}

struct Layout {
    grid: Tensor,
    rest: Tensor,
    channels: usize,
    bands: usize,
}

impl Layout {
    fn new(grid: &[Vec<usize>], rest: &[usize], dev: &Device) -> Result<Self> {
        let flat: Vec<u32> = grid.iter().flatten().map(|&i| i as u32).collect();
        let rest: Vec<u32> = rest.iter().map(|&i| i as u32).collect();
        Ok(Self {
            channels: grid.len(),
            bands: grid.first().map_or(0, Vec::len),
            grid: Tensor::from_vec(flat.clone(), flat.len(), dev).map_err(err)?,
            rest: Tensor::from_vec(rest.clone(), rest.len(), dev).map_err(err)?,
        })
    }

    /// Logits `[n, classes]` of standardised rows `x` `[n, d]`.
    fn forward(&self, w: &Weights, x: &Tensor) -> candle_core::Result<Tensor> {
        let n = x.dim(0)?;
        let spec = x
            .index_select(&self.grid, 1)?
            .reshape((n, self.channels, self.bands))?;
        let bias = |b: &Tensor| b.reshape((1, (), 1));
        let h = spec
            .conv1d(&w.w1, 1, 1, 1, 1)?
            .broadcast_add(&bias(&w.b1)?)?
            .relu()?;
        let h = h
            .conv1d(&w.w2, 1, 1, 1, 1)?
            .broadcast_add(&bias(&w.b2)?)?
            .relu()?;
        let z = Tensor::cat(&[h.flatten_from(1)?, x.index_select(&self.rest, 1)?], 1)?;
        let h = z.matmul(&w.w3)?.broadcast_add(&w.b3)?.relu()?;
        h.matmul(&w.w4)?.broadcast_add(&w.b4)
    }
}

impl Cnn {
    /// Trains on standardised rows `x` (feature `names`), labels `y` in
    /// `0..k`. An error when the features hold no spectral bands.
    pub fn fit(
        x: &[Vec<f64>],
        y: &[usize],
        k: usize,
        names: &[String],
        p: &CnnParams,
    ) -> Result<Self> {
        let (grid, mut rest) = spectral_grid(names);
        match p.dense {
            DenseInputs::All => {}
            DenseInputs::Manoeuvre => rest.retain(|&i| {
                ["tread_speed", "tread_speed_diff", "wheel_yaw_rate"].contains(&names[i].as_str())
            }),
            DenseInputs::None => rest.clear(),
        }
        let bands = grid.first().map_or(0, Vec::len);
        let d = x.first().map_or(0, Vec::len);
        if grid.is_empty() || bands < KERNEL || grid.iter().any(|r| r.len() != bands) {
            return Err(TerrainError::Config(
                "the cnn classifier needs the `full` feature set's spectral bands \
                 (at least 3 per channel)"
                    .into(),
            ));
        }
        if names.len() != d {
            return Err(TerrainError::Training(format!(
                "{} feature names for {d} features",
                names.len()
            )));
        }
        if p.epochs == 0
            || p.batch == 0
            || p.filters == 0
            || p.hidden == 0
            || !(p.learning_rate > 0.0 && p.learning_rate.is_finite())
            || !(p.weight_decay >= 0.0 && p.weight_decay.is_finite())
        {
            return Err(TerrainError::Config(format!(
                "the cnn needs epochs, batch, filters, hidden >= 1, learning rate > 0, \
                 weight decay >= 0; got {p:?}"
            )));
        }
        let dev = Device::Cpu;
        let layout = Layout::new(&grid, &rest, &dev)?;
        let (c, f, h) = (grid.len(), p.filters, p.hidden);
        let dense_in = f * bands + rest.len();
        let mut rng = SplitMix64(p.seed);
        // He-uniform initial weights, zero biases.
        let mut init = |shape: &[usize], fan_in: usize| -> Result<Var> {
            let a = (6.0 / fan_in as f64).sqrt();
            let n: usize = shape.iter().product();
            let v: Vec<f32> = (0..n)
                .map(|_| (a * (2.0 * rng.uniform() - 1.0)) as f32)
                .collect();
            Var::from_vec(v, shape, &dev).map_err(err)
        };
        let zeros = |n: usize| Var::zeros(n, DType::F32, &dev).map_err(err);
        let vars = [
            init(&[f, c, KERNEL], c * KERNEL)?,
            zeros(f)?,
            init(&[f, f, KERNEL], f * KERNEL)?,
            zeros(f)?,
            init(&[dense_in, h], dense_in)?,
            zeros(h)?,
            init(&[h, k], h)?,
            zeros(k)?,
        ];
        let weights = |v: &[Var; 8]| Weights {
            w1: v[0].as_tensor().clone(),
            b1: v[1].as_tensor().clone(),
            w2: v[2].as_tensor().clone(),
            b2: v[3].as_tensor().clone(),
            w3: v[4].as_tensor().clone(),
            b3: v[5].as_tensor().clone(),
            w4: v[6].as_tensor().clone(),
            b4: v[7].as_tensor().clone(),
        };
        let mut opt = AdamW::new(
            vars.to_vec(),
            ParamsAdamW {
                lr: p.learning_rate,
                weight_decay: p.weight_decay,
                ..Default::default()
            },
        )
        .map_err(err)?;
        let rows: Vec<f32> = x.iter().flatten().map(|&v| v as f32).collect();
        let all = Tensor::from_vec(rows, (x.len(), d), &dev).map_err(err)?;
        let labels: Vec<u32> = y.iter().map(|&c| c as u32).collect();
        let labels = Tensor::from_vec(labels, y.len(), &dev).map_err(err)?;
        let mut order: Vec<u32> = (0..x.len() as u32).collect();
        let w = weights(&vars);
        for _ in 0..p.epochs {
            for i in (1..order.len()).rev() {
                let j = (rng.next_u64() as usize) % (i + 1);
                order.swap(i, j);
            }
            for chunk in order.chunks(p.batch) {
                let idx = Tensor::from_slice(chunk, chunk.len(), &dev).map_err(err)?;
                let xb = all.index_select(&idx, 0).map_err(err)?;
                let yb = labels.index_select(&idx, 0).map_err(err)?;
                let logits = layout.forward(&w, &xb).map_err(err)?;
                let loss = candle_nn::loss::cross_entropy(&logits, &yb).map_err(err)?;
                opt.backward_step(&loss).map_err(err)?;
            }
        }
        let flat = |v: &Var| -> Result<Vec<f32>> {
            v.as_tensor()
                .flatten_all()
                .and_then(|t| t.to_vec1::<f32>())
                .map_err(err)
        };
        let cnn = Self {
            grid,
            rest,
            filters: f,
            hidden: h,
            classes: k,
            w1: flat(&vars[0])?,
            b1: flat(&vars[1])?,
            w2: flat(&vars[2])?,
            b2: flat(&vars[3])?,
            w3: flat(&vars[4])?,
            b3: flat(&vars[5])?,
            w4: flat(&vars[6])?,
            b4: flat(&vars[7])?,
        };
        if !cnn.is_consistent(k, d) {
            return Err(TerrainError::Training(
                "cnn: training diverged (non-finite weights)".into(),
            ));
        }
        Ok(cnn)
    }

    /// Whether the network fits `k` classes and `d` features: a
    /// rectangular grid of at least 3 bands, indices below `d`, weight
    /// lengths that match the shapes, finite weights.
    pub fn is_consistent(&self, k: usize, d: usize) -> bool {
        let bands = self.grid.first().map_or(0, Vec::len);
        let (c, f, h) = (self.grid.len(), self.filters, self.hidden);
        let dense_in = f
            .checked_mul(bands)
            .and_then(|v| v.checked_add(self.rest.len()));
        let len_ok = |w: &[f32], n: Option<usize>| n == Some(w.len());
        let mul = |a: usize, b: usize| a.checked_mul(b);
        c > 0
            && bands >= KERNEL
            && f > 0
            && h > 0
            && self.classes == k
            && self.grid.iter().all(|r| r.len() == bands)
            && self.grid.iter().flatten().chain(&self.rest).all(|&i| i < d)
            && len_ok(&self.w1, mul(f, c).and_then(|v| v.checked_mul(KERNEL)))
            && len_ok(&self.b1, Some(f))
            && len_ok(&self.w2, mul(f, f).and_then(|v| v.checked_mul(KERNEL)))
            && len_ok(&self.b2, Some(f))
            && len_ok(&self.w3, dense_in.and_then(|v| v.checked_mul(h)))
            && len_ok(&self.b3, Some(h))
            && len_ok(&self.w4, mul(h, k))
            && len_ok(&self.b4, Some(k))
            && [
                &self.w1, &self.b1, &self.w2, &self.b2, &self.w3, &self.b3, &self.w4, &self.b4,
            ]
            .iter()
            .all(|w| w.iter().all(|v| v.is_finite()))
    }

    /// Class probabilities of one standardised row, written to `out`
    /// (length k); zeros when the row or the weights do not fit.
    pub fn proba(&self, x: &[f64], out: &mut [f64]) {
        if let Ok(p) = self.proba_checked(x) {
            for (o, v) in out.iter_mut().zip(p) {
                *o = f64::from(v);
            }
        }
    }

    fn proba_checked(&self, x: &[f64]) -> candle_core::Result<Vec<f32>> {
        if self
            .grid
            .iter()
            .flatten()
            .chain(&self.rest)
            .any(|&i| i >= x.len())
        {
            return Err(candle_core::Error::Msg(
                "row shorter than the network's input".into(),
            ));
        }
        let dev = Device::Cpu;
        let bands = self.grid.first().map_or(0, Vec::len);
        let (c, f, h, k) = (self.grid.len(), self.filters, self.hidden, self.classes);
        let t = |v: &[f32], shape: &[usize]| Tensor::from_slice(v, shape, &dev);
        let w = Weights {
            w1: t(&self.w1, &[f, c, KERNEL])?,
            b1: t(&self.b1, &[f])?,
            w2: t(&self.w2, &[f, f, KERNEL])?,
            b2: t(&self.b2, &[f])?,
            w3: t(&self.w3, &[f * bands + self.rest.len(), h])?,
            b3: t(&self.b3, &[h])?,
            w4: t(&self.w4, &[h, k])?,
            b4: t(&self.b4, &[k])?,
        };
        let layout = Layout::new(&self.grid, &self.rest, &dev)
            .map_err(|e| candle_core::Error::Msg(e.to_string()))?;
        let row: Vec<f32> = x.iter().map(|&v| v as f32).collect();
        let xr = Tensor::from_vec(row, (1, x.len()), &dev)?;
        let logits = layout.forward(&w, &xr)?;
        let p = candle_nn::ops::softmax(&logits, D::Minus1)?;
        p.flatten_all()?.to_vec1::<f32>()
    }
}
