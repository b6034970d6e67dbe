//! The parameters of [`super::tsne`] (van der Maaten & Hinton 2008; van der Maaten 2014) and
//! what a run reports.

use serde::{Deserialize, Serialize};

use super::interpolation::MAX_INTERVALS;
use crate::{Error, Result};

/// How the gradient's repulsive part is computed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum TsneMethod {
    /// [`TsneMethod::Exact`] up to [`TsneParams::exact_max_points`] points,
    /// [`TsneMethod::Fft`] from [`TsneParams::fft_min_points`], [`TsneMethod::BarnesHut`]
    /// between.
    Auto,
    /// Dense input affinities over all pairs and the exact O(n²) gradient.
    Exact,
    /// Sparse affinities over the ⌊3·perplexity⌋ nearest neighbours and the Barnes–Hut
    /// approximation of the repulsive forces on a quadtree (van der Maaten 2014, §4–5).
    BarnesHut,
    /// Sparse affinities as for Barnes–Hut and the repulsive forces by polynomial
    /// interpolation on a grid with FFT convolutions (FIt-SNE: Linderman et al. 2019).
    Fft,
}

/// How the neighbours of the sparse affinities are found.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum TsneKnn {
    /// [`TsneKnn::Exact`] up to [`TsneParams::exact_knn_max_points`] points, else
    /// [`TsneKnn::Approximate`].
    Auto,
    /// Every pair compared (blocked brute force): O(n²).
    Exact,
    /// Random projection trees, then NN-descent (Dong et al. 2011), as pynndescent does.
    Approximate,
}

/// Where the optimisation starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum TsneInit {
    /// The first two principal components, scaled so that the first has standard deviation
    /// 1e-4: openTSNE's default (Kobak & Berens 2019 show it keeps the global layout better than
    /// a random start). openTSNE's extra jitter is not added; a rank-one input gets a random
    /// second coordinate (std 1e-4) and constant input a random start.
    Pca,
    /// Independent normal coordinates with standard deviation 1e-4 (openTSNE's and the original
    /// implementation's random start).
    Random,
}

/// Parameters of [`super::tsne`]. `Default` gives the usual values (openTSNE and scikit-learn),
/// with the iteration schedule of the issue: 750 iterations, the first 250 with early
/// exaggeration 12.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TsneParams {
    /// `Perp`: the perplexity 2^H(P_i) each conditional distribution P_i is calibrated to
    /// (van der Maaten & Hinton 2008, §2, eq. 4); default 30. At least 2, and at most
    /// (n − 1)/3 so that the ⌊3·Perp⌋ neighbours exist.
    pub perplexity: f64,
    /// Total gradient-descent iterations `T`, early exaggeration included; default 750.
    pub n_iter: usize,
    /// `α`: the factor on P during the first iterations (§3.4 "early exaggeration"); default 12.
    pub early_exaggeration: f64,
    /// Iterations with early exaggeration; default 250.
    pub early_exaggeration_iter: usize,
    /// `η`: the learning rate; `None` = "auto", `max(n / α / 4, 50)` (Belkina et al. 2019, as
    /// scikit-learn writes it: its gradient, like ours, carries the factor 4 of eq. 5, which
    /// openTSNE folds into its `n / α`).
    pub learning_rate: Option<f64>,
    /// Momentum `α(t)` while exaggerating; default 0.5.
    pub initial_momentum: f64,
    /// Momentum afterwards; default 0.8.
    pub final_momentum: f64,
    /// The smallest per-coordinate gain of the delta-bar-delta rule (Jacobs 1988); default 0.01.
    pub min_gain: f64,
    /// `θ`: a quadtree cell of side `s` at distance `d` is summarised when `s / d < θ`
    /// (van der Maaten 2014, §4.2); default 0.5. `θ = 0` gives the exact gradient.
    pub theta: f64,
    /// The method; default [`TsneMethod::Auto`].
    pub method: TsneMethod,
    /// The largest `n` [`TsneMethod::Auto`] runs exactly; default 2,000.
    pub exact_max_points: usize,
    /// The smallest `n` [`TsneMethod::Auto`] runs with [`TsneMethod::Fft`]; default 10,000
    /// (openTSNE's switch; measured in docs/explore.md).
    pub fft_min_points: usize,
    /// `p`: interpolation nodes per box side (Linderman et al. 2019; openTSNE's
    /// `n_interpolation_points`); default 3, at most 8 (equispaced Lagrange interpolation of
    /// higher degree oscillates).
    pub n_interpolation_points: usize,
    /// The fewest boxes per side of the interpolation grid (openTSNE's `min_num_intervals`);
    /// default 50, at most 400 (the grid's cap).
    pub min_num_intervals: usize,
    /// The widest box side, in units of the embedding (openTSNE's `ints_in_interval`): there
    /// are at least `span / ints_in_interval` boxes per side; default 1.
    pub ints_in_interval: f64,
    /// How the neighbours are found (sparse methods only); default [`TsneKnn::Auto`].
    pub knn: TsneKnn,
    /// The largest `n` [`TsneKnn::Auto`] searches exactly; default 20,000.
    pub exact_knn_max_points: usize,
    /// Random projection trees of the approximate search; default 8.
    pub n_trees: usize,
    /// The most points in a tree's leaf (raised to `k + 1`); default 64.
    pub leaf_size: usize,
    /// NN-descent rounds at most; default 10.
    pub nn_descent_iter: usize,
    /// Nearest neighbours and reverse neighbours explored per list and round (pynndescent's
    /// `max_candidates`, `ρ·k` of Dong et al. 2011); default 16.
    pub max_candidates: usize,
    /// `δ`: NN-descent stops when fewer than `δ·n·k` list entries change in a round (Dong et
    /// al. 2011); default 0.001.
    pub nn_descent_delta: f64,
    /// The start; default [`TsneInit::Pca`].
    pub init: TsneInit,
    /// Seed of every random choice (the random start, the PCA's start vectors).
    pub seed: u64,
}

impl Default for TsneParams {
    fn default() -> Self {
        Self {
            perplexity: 30.0,
            n_iter: 750,
            early_exaggeration: 12.0,
            early_exaggeration_iter: 250,
            learning_rate: None,
            initial_momentum: 0.5,
            final_momentum: 0.8,
            min_gain: 0.01,
            theta: 0.5,
            method: TsneMethod::Auto,
            exact_max_points: 2_000,
            fft_min_points: 10_000,
            n_interpolation_points: 3,
            min_num_intervals: 50,
            ints_in_interval: 1.0,
            knn: TsneKnn::Auto,
            exact_knn_max_points: 20_000,
            n_trees: 8,
            leaf_size: 64,
            nn_descent_iter: 10,
            max_candidates: 16,
            nn_descent_delta: 0.001,
            init: TsneInit::Pca,
            seed: 0,
        }
    }
}

fn bad(name: &'static str, value: impl ToString, reason: &'static str) -> Error {
    Error::InvalidParameter {
        name,
        value: value.to_string(),
        reason,
    }
}

impl TsneParams {
    /// Checks every field on its own (the bounds that depend on `n` are checked by
    /// [`super::tsne`]).
    pub fn validate(&self) -> Result<()> {
        if !(self.perplexity.is_finite() && self.perplexity >= 2.0) {
            return Err(bad("perplexity", self.perplexity, "must be at least 2"));
        }
        if self.n_iter == 0 || self.n_iter > 100_000 {
            return Err(bad("n_iter", self.n_iter, "must be in 1..=100000"));
        }
        if !(self.early_exaggeration.is_finite()
            && (1.0..=1000.0).contains(&self.early_exaggeration))
        {
            return Err(bad(
                "early_exaggeration",
                self.early_exaggeration,
                "must be in [1, 1000]",
            ));
        }
        if self.early_exaggeration_iter > self.n_iter {
            return Err(bad(
                "early_exaggeration_iter",
                self.early_exaggeration_iter,
                "must not exceed n_iter",
            ));
        }
        if let Some(eta) = self.learning_rate
            && !(eta.is_finite() && eta > 0.0 && eta <= 1e9)
        {
            return Err(bad("learning_rate", eta, "must be positive and finite"));
        }
        for (name, m) in [
            ("initial_momentum", self.initial_momentum),
            ("final_momentum", self.final_momentum),
        ] {
            if !(m.is_finite() && (0.0..1.0).contains(&m)) {
                return Err(bad(name, m, "must be in [0, 1)"));
            }
        }
        if !(self.min_gain.is_finite() && self.min_gain > 0.0 && self.min_gain <= 1.0) {
            return Err(bad("min_gain", self.min_gain, "must be in (0, 1]"));
        }
        // A cell can be summarised from a point inside it when θ ≥ 1/√2; above 1 the forces
        // are too coarse to be worth having.
        if !(self.theta.is_finite() && (0.0..=1.0).contains(&self.theta)) {
            return Err(bad("theta", self.theta, "must be in [0, 1]"));
        }
        if !(1..=8).contains(&self.n_interpolation_points) {
            return Err(bad(
                "n_interpolation_points",
                self.n_interpolation_points,
                "must be in 1..=8",
            ));
        }
        if !(1..=MAX_INTERVALS).contains(&self.min_num_intervals) {
            return Err(bad(
                "min_num_intervals",
                self.min_num_intervals,
                "must be in 1..=400",
            ));
        }
        if !(self.ints_in_interval.is_finite()
            && self.ints_in_interval > 0.0
            && self.ints_in_interval <= 1e6)
        {
            return Err(bad(
                "ints_in_interval",
                self.ints_in_interval,
                "must be positive and at most 1e6",
            ));
        }
        if !(1..=1000).contains(&self.n_trees) {
            return Err(bad("n_trees", self.n_trees, "must be in 1..=1000"));
        }
        if self.leaf_size == 0 {
            return Err(bad("leaf_size", self.leaf_size, "must be at least 1"));
        }
        if self.nn_descent_iter > 1000 {
            return Err(bad(
                "nn_descent_iter",
                self.nn_descent_iter,
                "must be at most 1000",
            ));
        }
        if self.max_candidates == 0 {
            return Err(bad(
                "max_candidates",
                self.max_candidates,
                "must be at least 1",
            ));
        }
        if !(self.nn_descent_delta.is_finite() && (0.0..=1.0).contains(&self.nn_descent_delta)) {
            return Err(bad(
                "nn_descent_delta",
                self.nn_descent_delta,
                "must be in [0, 1]",
            ));
        }
        Ok(())
    }

    /// `k = ⌊3·Perp⌋`: the neighbours the sparse affinities keep (van der Maaten 2014, §4.1).
    pub fn neighbours(&self) -> usize {
        (3.0 * self.perplexity).floor() as usize
    }
}

/// What a run of [`super::tsne`] did.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TsneInfo {
    /// Points embedded.
    pub n: usize,
    /// Gradient-descent iterations run.
    pub iterations: usize,
    /// `KL(P‖Q)` of the final embedding (without exaggeration). Exact for
    /// [`TsneMethod::Exact`]; otherwise with the normalisation `Z` of the method (the tree or
    /// the grid), the value openTSNE also reports.
    pub kl_divergence: f64,
    /// The method used ([`TsneMethod::Auto`] resolved).
    pub method: TsneMethod,
    /// Neighbours per point in P (`n − 1` for the exact method).
    pub neighbours: usize,
    /// How they were found ([`TsneKnn::Auto`] resolved; [`TsneKnn::Exact`] for the exact
    /// method's all pairs).
    pub knn: TsneKnn,
    /// The learning rate used ("auto" resolved).
    pub learning_rate: f64,
    /// Seconds spent on the input affinities (neighbours and calibration).
    pub affinity_seconds: f64,
    /// Seconds spent on the initialisation.
    pub init_seconds: f64,
    /// Seconds spent on the gradient descent.
    pub optimise_seconds: f64,
}
