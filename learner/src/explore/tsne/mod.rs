//! t-SNE (van der Maaten & Hinton 2008) for the style map of Garces et al. 2016,
//! "Style-Based Exploration of Illustration Datasets" (§5.7.1, ch. 6): the items of a library
//! placed in the plane so that items close in the learned style space stay close.
//!
//! * [`tsne()`]: the embedding of `n` points (row-major `f32`, `dim` coordinates each) and a
//!   [`TsneInfo`]. Small inputs (up to [`TsneParams::exact_max_points`], default 2,000) use
//!   dense affinities and the exact gradient; larger ones the sparse affinities over the
//!   ⌊3·perplexity⌋ nearest neighbours (exact up to [`TsneParams::exact_knn_max_points`],
//!   random projection trees and NN-descent above) and the Barnes–Hut gradient on a quadtree
//!   (van der Maaten 2014, "Accelerating t-SNE using tree-based algorithms") or, from
//!   [`TsneParams::fft_min_points`], the FFT-accelerated interpolation of FIt-SNE (Linderman et
//!   al. 2019).
//! * [`affinities()`]: the input affinities P alone, for [`quality::kl_divergence`].
//! * [`quality`]: trustworthiness, kNN preservation and `KL(P‖Q)` of an embedding.
//!
//! The output depends only on the input and the params (the seed included), not on the number
//! of threads: every parallel loop computes per-point values in a fixed order and every sum
//! across points is taken in index order.
//!
//! Deviation from the paper's t-SNE: none in the objective; the defaults follow the current
//! implementations (openTSNE, scikit-learn): PCA start, learning rate `max(n/α/4, 50)`.
//!
//! ```
//! use learner::explore::tsne::{TsneParams, tsne};
//!
//! // Two groups of 20 points in 3-D, far apart: they stay apart in the plane.
//! let points: Vec<f32> = (0..40)
//!     .flat_map(|i| {
//!         let c = if i < 20 { 0.0 } else { 50.0 };
//!         [c + (i % 5) as f32, c + (i % 7) as f32 * 0.5, (i % 3) as f32]
//!     })
//!     .collect();
//! let params = TsneParams { perplexity: 5.0, n_iter: 300, early_exaggeration_iter: 100, ..TsneParams::default() };
//! let (y, info) = tsne(&points, 3, &params, &mut |_, _| {})?;
//! assert_eq!((y.len(), info.iterations), (40, 300));
//! // Every point's nearest neighbour in the map is in its own group.
//! let d = |a: [f32; 2], b: [f32; 2]| (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2);
//! for i in 0..40 {
//!     let nearest = (0..40).filter(|&j| j != i).min_by(|&a, &b| d(y[i], y[a]).total_cmp(&d(y[i], y[b])));
//!     assert_eq!(nearest.unwrap() < 20, i < 20);
//! }
//! # Ok::<(), learner::Error>(())
//! ```

mod affinity;
mod gradient;
mod init;
mod interpolation;
mod knn;
mod nndescent;
mod optimise;
mod params;
mod quadtree;
pub mod quality;

use std::time::Instant;

use rayon::prelude::*;

pub use affinity::Affinities;
pub use params::{TsneInfo, TsneInit, TsneKnn, TsneMethod, TsneParams};

use crate::{Error, Result};
use gradient::Repulsive;
use optimise::Phase;

/// The most points [`tsne`] accepts. The issue's largest case is 200,000 (measured in
/// docs/explore.md with the approximate neighbours and the FFT gradient); P takes about 3 KB
/// per point, and a forced exact neighbour search grows as n² (about 7 minutes on 2 cores at
/// 250,000 × 40). Above it, an error, never a sample.
pub const MAX_POINTS: usize = 250_000;

/// The largest coordinate magnitude accepted: squared distances then stay far from `f32`
/// overflow in the neighbour search.
pub const MAX_COORDINATE: f64 = 1e15;

/// Checks the input and returns `n`.
fn validate(points: &[f32], dim: usize, params: &TsneParams) -> Result<usize> {
    params.validate()?;
    if dim == 0 {
        return Err(Error::InvalidParameter {
            name: "dim",
            value: "0".into(),
            reason: "points need at least one coordinate",
        });
    }
    if !points.len().is_multiple_of(dim) {
        return Err(Error::NotAMatrix {
            len: points.len(),
            dim,
        });
    }
    let n = points.len() / dim;
    if n > MAX_POINTS {
        return Err(Error::TsneTooManyPoints {
            n,
            limit: MAX_POINTS,
        });
    }
    let needed = params.neighbours() + 1;
    if n < needed {
        return Err(Error::TsneTooFewPoints {
            n,
            perplexity: params.perplexity,
            needed,
        });
    }
    if let Some(i) = points
        .iter()
        .position(|v| !v.is_finite() || f64::from(v.abs()) > MAX_COORDINATE)
    {
        return Err(Error::BadCoordinate {
            row: i / dim,
            column: i % dim,
            value: f64::from(points[i]),
            limit: MAX_COORDINATE,
        });
    }
    Ok(n)
}

fn resolve(method: TsneMethod, n: usize, params: &TsneParams) -> TsneMethod {
    match method {
        TsneMethod::Auto if n <= params.exact_max_points => TsneMethod::Exact,
        TsneMethod::Auto if n >= params.fft_min_points => TsneMethod::Fft,
        TsneMethod::Auto => TsneMethod::BarnesHut,
        m => m,
    }
}

fn resolve_knn(method: TsneMethod, n: usize, params: &TsneParams) -> TsneKnn {
    match (method, params.knn) {
        (TsneMethod::Exact, _) => TsneKnn::Exact,
        (_, TsneKnn::Auto) if n <= params.exact_knn_max_points => TsneKnn::Exact,
        (_, TsneKnn::Auto) => TsneKnn::Approximate,
        (_, k) => k,
    }
}

fn build_affinities(
    points: &[f32],
    dim: usize,
    method: TsneMethod,
    knn: TsneKnn,
    params: &TsneParams,
) -> Affinities {
    let k = params.neighbours();
    let neighbours = match (method, knn) {
        (TsneMethod::Exact, _) => knn::all_pairs(points, dim),
        (_, TsneKnn::Approximate) => nndescent::nearest(points, dim, k, &approximate(params)),
        _ => knn::nearest(points, dim, k),
    };
    let (conditional, _) = affinity::conditional(&neighbours, params.perplexity);
    affinity::symmetrise(&neighbours, &conditional)
}

fn approximate(params: &TsneParams) -> nndescent::Approximate {
    nndescent::Approximate {
        n_trees: params.n_trees,
        leaf_size: params.leaf_size,
        n_iter: params.nn_descent_iter,
        max_candidates: params.max_candidates,
        delta: params.nn_descent_delta,
        seed: params.seed,
    }
}

fn interpolation(params: &TsneParams) -> interpolation::Interpolation {
    interpolation::Interpolation {
        points: params.n_interpolation_points,
        min_intervals: params.min_num_intervals,
        ints_in_interval: params.ints_in_interval,
    }
}

/// The joint input affinities P that [`tsne`] would use for these points and params (dense for
/// the exact method, over the ⌊3·perplexity⌋ nearest neighbours otherwise). Same errors as
/// [`tsne`].
pub fn affinities(points: &[f32], dim: usize, params: &TsneParams) -> Result<Affinities> {
    let n = validate(points, dim, params)?;
    let method = resolve(params.method, n, params);
    Ok(build_affinities(
        points,
        dim,
        method,
        resolve_knn(method, n, params),
        params,
    ))
}

/// The fraction of the exact ⌊3·perplexity⌋ nearest neighbours that the approximate search
/// ([`TsneKnn::Approximate`], with these params) finds, order ignored. Runs both searches, the
/// exact one O(n²): for benchmarks. Same errors as [`tsne`].
pub fn approximate_knn_recall(points: &[f32], dim: usize, params: &TsneParams) -> Result<f64> {
    validate(points, dim, params)?;
    let k = params.neighbours();
    let found = nndescent::nearest(points, dim, k, &approximate(params));
    let exact = knn::nearest(points, dim, k);
    let hits: usize = found
        .index
        .par_chunks(k)
        .zip(exact.index.par_chunks(k))
        .map(|(f, e)| {
            let mut e = e.to_vec();
            e.sort_unstable();
            f.iter().filter(|j| e.binary_search(j).is_ok()).count()
        })
        .sum();
    Ok(hits as f64 / exact.index.len() as f64)
}

/// The t-SNE embedding of `points` (row-major, `dim` coordinates per point) in the plane, one
/// `[x, y]` per point in input order, and what the run did. `progress(iteration, total)` is
/// called after every gradient-descent iteration.
///
/// Errors: params out of range ([`TsneParams::validate`]), `dim` 0, a length that is not a
/// multiple of `dim`, fewer than ⌊3·perplexity⌋ + 1 points, more than [`MAX_POINTS`], a
/// coordinate that is not finite or exceeds [`MAX_COORDINATE`], or a descent that leaves
/// finite numbers (a learning rate far too large).
pub fn tsne(
    points: &[f32],
    dim: usize,
    params: &TsneParams,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<(Vec<[f32; 2]>, TsneInfo)> {
    let n = validate(points, dim, params)?;
    let method = resolve(params.method, n, params);
    let knn = resolve_knn(method, n, params);
    let t = Instant::now();
    let p = build_affinities(points, dim, method, knn, params);
    let affinity_seconds = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let mut y = init::initial(points, dim, params.init, params.seed);
    let init_seconds = t.elapsed().as_secs_f64();
    let learning_rate = params
        .learning_rate
        .unwrap_or_else(|| (n as f64 / params.early_exaggeration / 4.0).max(50.0));
    let repulsive = match method {
        TsneMethod::Exact => Repulsive::Exact,
        TsneMethod::Fft => Repulsive::Fft(interpolation(params)),
        _ => Repulsive::BarnesHut(params.theta),
    };
    let phases = [
        Phase {
            iterations: params.early_exaggeration_iter,
            exaggeration: params.early_exaggeration,
            momentum: params.initial_momentum,
        },
        Phase {
            iterations: params.n_iter - params.early_exaggeration_iter,
            exaggeration: 1.0,
            momentum: params.final_momentum,
        },
    ];
    let t = Instant::now();
    let iterations = optimise::descend(
        &p,
        &mut y,
        &phases,
        learning_rate,
        params.min_gain,
        repulsive,
        progress,
    );
    let kl_divergence = gradient::kl_divergence(&p, &y, repulsive);
    let optimise_seconds = t.elapsed().as_secs_f64();
    if let Some(i) = y
        .iter()
        .position(|p| !(p[0].is_finite() && p[1].is_finite()))
    {
        return Err(Error::TsneDiverged {
            point: i,
            learning_rate,
        });
    }
    let info = TsneInfo {
        n,
        iterations,
        kl_divergence,
        method,
        neighbours: match method {
            TsneMethod::Exact => n - 1,
            _ => params.neighbours(),
        },
        knn,
        learning_rate,
        affinity_seconds,
        init_seconds,
        optimise_seconds,
    };
    let y = y.into_iter().map(|p| [p[0] as f32, p[1] as f32]).collect();
    Ok((y, info))
}

#[cfg(test)]
mod tests;

#[cfg(test)]
mod error_tests;

#[cfg(test)]
mod fast_tests;

/// The embeddings against openTSNE's and scikit-learn's (reference values of
/// `scripts/reference/tsne_reference.py`).
#[cfg(test)]
mod opentsne_reference;
