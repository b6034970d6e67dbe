//! A simulated crowd for end-to-end checks of the metric learner (issue 3, "simulated crowd
//! test"): items with standard-normal features, a hidden sparse ground-truth `w*`, and workers
//! who answer triplets with the logistic model of eq. 5.6 under `w*`, except spammers who answer
//! with a fair coin. Several workers answer each tuple, as on Mechanical Turk (§5.4).

use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::objective::sigmoid;
use crate::table::FeatureTable;
use crate::triplets::Triplet;
use crate::{Error, Result};

/// What to simulate. Defaults: 400 items × 40 features, 6 informative, 25,000 answers from
/// 5 workers per tuple, 100 workers of whom 10% are spammers.
#[derive(Debug, Clone, PartialEq)]
pub struct SimulationParams {
    /// Number of items.
    pub items: usize,
    /// Number of features.
    pub dim: usize,
    /// Number of non-zero entries of `w*` (the first `support` after a seeded shuffle).
    pub support: usize,
    /// Total answered triplets (rows).
    pub triplets: usize,
    /// Workers answering each tuple.
    pub raters_per_tuple: usize,
    /// Number of workers.
    pub workers: usize,
    /// Fraction of workers who answer at random.
    pub spammer_fraction: f64,
    /// Seed for everything.
    pub seed: u64,
}

impl Default for SimulationParams {
    fn default() -> Self {
        Self {
            items: 400,
            dim: 40,
            support: 6,
            triplets: 25_000,
            raters_per_tuple: 5,
            workers: 100,
            spammer_fraction: 0.1,
            seed: 1,
        }
    }
}

/// A simulated data set.
#[derive(Debug, Clone)]
pub struct Simulation {
    /// Items (`item0`…) × features (`f0`…).
    pub table: FeatureTable,
    /// Row-major features (the table's values).
    pub features: Vec<f64>,
    /// Number of features.
    pub dim: usize,
    /// The hidden `w*`.
    pub true_weights: Vec<f64>,
    /// The answered triplets, with workers and tuples.
    pub triplets: Vec<Triplet>,
    spammer: Vec<bool>,
    params: SimulationParams,
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    // Box–Muller; rand's own normal lives in rand_distr, which is not a dependency.
    let u: f64 = rng.random_range(f64::EPSILON..1.0);
    let v: f64 = rng.random();
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

/// Builds a simulation.
pub fn simulate(params: &SimulationParams) -> Result<Simulation> {
    let p = params;
    if p.items < 3 || p.dim == 0 || p.support == 0 || p.support > p.dim {
        return Err(Error::InvalidParameter {
            name: "simulation",
            value: format!("items {}, dim {}, support {}", p.items, p.dim, p.support),
            reason: "need ≥ 3 items and 1 ≤ support ≤ dim",
        });
    }
    if p.raters_per_tuple == 0 || p.workers < p.raters_per_tuple {
        return Err(Error::InvalidParameter {
            name: "raters_per_tuple",
            value: p.raters_per_tuple.to_string(),
            reason: "must be ≥ 1 and ≤ workers",
        });
    }
    let mut rng = ChaCha8Rng::seed_from_u64(p.seed);
    let features: Vec<f64> = (0..p.items * p.dim).map(|_| normal(&mut rng)).collect();
    let mut order: Vec<usize> = (0..p.dim).collect();
    order.shuffle(&mut rng);
    let mut true_weights = vec![0.0; p.dim];
    for &k in &order[..p.support] {
        true_weights[k] = rng.random_range(0.5..1.5);
    }
    let spammers = (p.workers as f64 * p.spammer_fraction).round() as usize;
    let spammer: Vec<bool> = (0..p.workers).map(|w| w < spammers).collect();
    let names = (0..p.dim).map(|k| format!("f{k}")).collect();
    let ids = (0..p.items).map(|i| format!("item{i}")).collect();
    let table = FeatureTable::new(names, ids, features.clone())?;
    let mut sim = Simulation {
        table,
        features,
        dim: p.dim,
        true_weights,
        triplets: Vec::new(),
        spammer,
        params: p.clone(),
    };
    sim.triplets = sim.answers(p.triplets, &mut rng);
    Ok(sim)
}

impl Simulation {
    /// `P(q = 1)` under `w*` for rows `a, b, c`.
    pub fn true_probability(&self, a: u32, b: u32, c: u32) -> f64 {
        let d = |i: u32, j: u32| {
            let (xi, xj) = (self.row(i), self.row(j));
            (0..self.dim)
                .map(|k| self.true_weights[k] * (xi[k] - xj[k]).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        sigmoid(d(a, c) - d(a, b))
    }

    fn row(&self, i: u32) -> &[f64] {
        let i = i as usize;
        &self.features[i * self.dim..(i + 1) * self.dim]
    }

    fn answers(&self, n: usize, rng: &mut ChaCha8Rng) -> Vec<Triplet> {
        let p = &self.params;
        let mut out = Vec::with_capacity(n);
        let mut tuple = 0u32;
        let mut workers: Vec<u32> = (0..p.workers as u32).collect();
        while out.len() < n {
            let a = rng.random_range(0..p.items) as u32;
            let (b, c) = loop {
                let b = rng.random_range(0..p.items) as u32;
                let c = rng.random_range(0..p.items) as u32;
                if a != b && a != c && b != c {
                    break (b, c);
                }
            };
            let prob = self.true_probability(a, b, c);
            workers.shuffle(rng);
            for &w in workers.iter().take(p.raters_per_tuple) {
                if out.len() == n {
                    break;
                }
                let q = if self.spammer[w as usize] {
                    rng.random_bool(0.5)
                } else {
                    rng.random_bool(prob)
                };
                out.push(Triplet {
                    a,
                    b,
                    c,
                    q,
                    worker: Some(w),
                    tuple,
                });
            }
            tuple += 1;
        }
        out
    }

    /// `n` fresh answers from the same crowd (new tuples), seeded independently.
    pub fn fresh(&self, n: usize, seed: u64) -> Vec<Triplet> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x9e37_79b9_7f4a_7c15);
        self.answers(n, &mut rng)
    }
}
