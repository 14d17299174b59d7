//! The genetic algorithm of Mandow et al. 2007 (sec. III), real-coded.
//!
//! Each chromosome is the parameter vector (y_l, y_r, x_c, alpha_l, alpha_r)
//! inside configurable gene bounds. The paper codes each gene in 8 bits;
//! [`GaConfig::gene_bits`] reproduces that by snapping genes to a `2^bits`
//! grid over their bounds, `None` keeps them real. Tournament selection,
//! BLX-0.5 crossover, Gaussian mutation shrinking over the generations,
//! elitism. Seeded with its own SplitMix64 generator: the same seed gives the
//! same result on every platform and with any number of threads, because
//! only fitness evaluation runs in parallel (std::thread::scope over chunks
//! of the population).

use terraslip_core::IcrParams;

use crate::model::{from_vec, to_vec};

/// GA settings.
#[derive(Debug, Clone, PartialEq)]
pub struct GaConfig {
    pub population: usize,
    pub generations: usize,
    pub seed: u64,
    /// Gene bounds `(low, high)` of y_l, y_r, x_c (m), alpha_l, alpha_r.
    pub bounds: [(f64, f64); 5],
    /// Bits per gene (the paper: 8); `None` = real-coded.
    pub gene_bits: Option<u32>,
    /// Probability that two parents are recombined.
    pub crossover_rate: f64,
    /// Probability that a gene mutates.
    pub mutation_rate: f64,
    /// Best chromosomes copied unchanged into the next generation.
    pub elite: usize,
    /// Worker threads for fitness evaluation (`None` = all cores).
    pub threads: Option<usize>,
}

impl GaConfig {
    /// Default bounds around a robot of track width `w` (m): tread ICRs from
    /// 0.3 w to 3 w either side, x_c within a track width, alpha 0.5-1.5.
    pub fn for_track_width(w: f64) -> Self {
        Self {
            population: 48,
            generations: 100,
            seed: 1,
            bounds: [
                (0.3 * w, 3.0 * w),
                (-3.0 * w, -0.3 * w),
                (-w, w),
                (0.5, 1.5),
                (0.5, 1.5),
            ],
            gene_bits: None,
            crossover_rate: 0.9,
            mutation_rate: 0.15,
            elite: 2,
            threads: None,
        }
    }
}

pub use terraslip_core::rng::SplitMix64;

/// Result of a GA run.
#[derive(Debug, Clone, PartialEq)]
pub struct GaResult {
    pub params: IcrParams,
    pub fitness: f64,
    /// Best fitness after each generation (non-increasing).
    pub history: Vec<f64>,
    pub evaluations: usize,
}

fn snap(x: f64, (lo, hi): (f64, f64), bits: Option<u32>) -> f64 {
    let x = x.clamp(lo, hi);
    match bits {
        Some(b) if b > 0 && b < 53 => {
            let levels = ((1u64 << b) - 1) as f64;
            lo + ((x - lo) / (hi - lo) * levels).round() / levels * (hi - lo)
        }
        _ => x,
    }
}

/// Evaluates `fitness` on every chromosome, in parallel.
fn evaluate<F>(pop: &[[f64; 5]], fitness: &F, threads: usize) -> Vec<f64>
where
    F: Fn(&IcrParams) -> f64 + Sync,
{
    let mut out = vec![f64::INFINITY; pop.len()];
    let chunk = pop.len().div_ceil(threads.max(1)).max(1);
    std::thread::scope(|s| {
        for (cs, os) in pop.chunks(chunk).zip(out.chunks_mut(chunk)) {
            s.spawn(move || {
                for (c, o) in cs.iter().zip(os.iter_mut()) {
                    let f = fitness(&from_vec(c));
                    *o = if f.is_finite() { f } else { f64::INFINITY };
                }
            });
        }
    });
    out
}

/// Minimises `fitness` over the gene bounds. `start`, if given, joins the
/// random initial population (the paper starts from random chromosomes only;
/// a known-good guess does no harm and makes small runs dependable).
/// `on_generation(g)` is called after each generation (progress bars).
pub fn minimise<F>(
    fitness: &F,
    cfg: &GaConfig,
    start: Option<&IcrParams>,
    on_generation: &dyn Fn(usize),
) -> GaResult
where
    F: Fn(&IcrParams) -> f64 + Sync,
{
    let threads = cfg
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .max(1);
    let n = cfg.population.max(4);
    let mut rng = SplitMix64::new(cfg.seed);
    let b = cfg.bounds;
    let mut pop: Vec<[f64; 5]> = (0..n)
        .map(|_| {
            let mut c = [0.0; 5];
            for k in 0..5 {
                c[k] = snap(
                    b[k].0 + rng.uniform() * (b[k].1 - b[k].0),
                    b[k],
                    cfg.gene_bits,
                );
            }
            c
        })
        .collect();
    if let Some(s) = start {
        let v = to_vec(s);
        for k in 0..5 {
            pop[0][k] = snap(v[k], b[k], cfg.gene_bits);
        }
    }
    let mut fit = evaluate(&pop, fitness, threads);
    let mut evaluations = n;
    let mut history = Vec::with_capacity(cfg.generations);
    let tournament = |rng: &mut SplitMix64, fit: &[f64]| {
        let (a, c) = (rng.below(n), rng.below(n));
        let d = rng.below(n);
        [a, c, d]
            .into_iter()
            .min_by(|&x, &y| fit[x].total_cmp(&fit[y]))
            .unwrap_or(a)
    };
    for g in 0..cfg.generations {
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&x, &y| fit[x].total_cmp(&fit[y]));
        let mut next: Vec<[f64; 5]> = order
            .iter()
            .take(cfg.elite.min(n))
            .map(|&i| pop[i])
            .collect();
        // Mutation spread shrinks from 10 % to 0.5 % of each gene's range.
        let frac = 0.1 * (1.0 - g as f64 / cfg.generations.max(1) as f64) + 0.005;
        while next.len() < n {
            let pa = pop[tournament(&mut rng, &fit)];
            let pb = pop[tournament(&mut rng, &fit)];
            let (mut c1, mut c2) = (pa, pb);
            if rng.uniform() < cfg.crossover_rate {
                for k in 0..5 {
                    let (lo, hi) = (pa[k].min(pb[k]), pa[k].max(pb[k]));
                    let ext = 0.5 * (hi - lo);
                    c1[k] = lo - ext + rng.uniform() * (hi - lo + 2.0 * ext);
                    c2[k] = lo - ext + rng.uniform() * (hi - lo + 2.0 * ext);
                }
            }
            for c in [&mut c1, &mut c2] {
                for k in 0..5 {
                    if rng.uniform() < cfg.mutation_rate {
                        c[k] += rng.normal() * frac * (b[k].1 - b[k].0);
                    }
                    c[k] = snap(c[k], b[k], cfg.gene_bits);
                }
            }
            next.push(c1);
            if next.len() < n {
                next.push(c2);
            }
        }
        let keep = cfg.elite.min(n);
        let new_fit = evaluate(&next[keep..], fitness, threads);
        evaluations += n - keep;
        let mut all_fit: Vec<f64> = order.iter().take(keep).map(|&i| fit[i]).collect();
        all_fit.extend(new_fit);
        pop = next;
        fit = all_fit;
        history.push(fit.iter().copied().fold(f64::INFINITY, f64::min));
        on_generation(g);
    }
    let best = (0..n)
        .min_by(|&x, &y| fit[x].total_cmp(&fit[y]))
        .unwrap_or(0);
    GaResult {
        params: from_vec(&pop[best]),
        fitness: fit[best],
        history,
        evaluations,
    }
}
