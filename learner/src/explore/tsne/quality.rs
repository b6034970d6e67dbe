//! How well an embedding keeps the input's neighbourhoods, and its t-SNE cost.
//!
//! * [`trustworthiness`] (Venna & Kaski 2001), as `sklearn.manifold.trustworthiness` defines it:
//!   `T(k) = 1 − 2/(n k (2n − 3k − 1)) Σ_i Σ_{j ∈ U_i} (r(i, j) − k)`, where `U_i` are the points
//!   among `i`'s `k` nearest in the embedding that are not among its `k` nearest in the input,
//!   and `r(i, j)` is `j`'s rank (1 = nearest) by input distance from `i`. 1 means no
//!   intruders.
//! * [`knn_preservation`]: the mean over points of the fraction of their `k` nearest input
//!   neighbours that are also among their `k` nearest in the embedding.
//! * [`kl_divergence`]: `KL(P‖Q)` of an embedding for given affinities, with the exact `Z`.
//!
//! All three are O(n²) (every pair once per point, in parallel, summed in index order) and
//! accept at most [`MAX_POINTS`] points: evaluate a sample of a larger embedding. Distances are
//! Euclidean in `f64`; ties in rank go to the lower index.

use rayon::prelude::*;

use super::affinity::Affinities;
use super::gradient;
use super::knn::sq_dist_f64;
use crate::{Error, Result};

/// The most points the quality measures accept (they are quadratic).
pub const MAX_POINTS: usize = 50_000;

fn check(points: &[f32], dim: usize, embedding: &[[f32; 2]]) -> Result<usize> {
    if dim == 0 || !points.len().is_multiple_of(dim) {
        return Err(Error::NotAMatrix {
            len: points.len(),
            dim,
        });
    }
    let n = points.len() / dim;
    if embedding.len() != n {
        return Err(Error::TsneShapeMismatch {
            what: "the embedding for these points",
            expected: n,
            got: embedding.len(),
        });
    }
    if n > MAX_POINTS {
        return Err(Error::TsneTooManyPoints {
            n,
            limit: MAX_POINTS,
        });
    }
    if let Some(i) = points.iter().position(|v| !v.is_finite()) {
        return Err(Error::BadCoordinate {
            row: i / dim,
            column: i % dim,
            value: f64::from(points[i]),
            limit: f64::from(f32::MAX),
        });
    }
    if let Some(i) = embedding.iter().flatten().position(|v| !v.is_finite()) {
        return Err(Error::BadCoordinate {
            row: i / 2,
            column: i % 2,
            value: f64::from(embedding[i / 2][i % 2]),
            limit: f64::from(f32::MAX),
        });
    }
    Ok(n)
}

fn bad_k(k: usize, reason: &'static str) -> Error {
    Error::InvalidParameter {
        name: "k",
        value: k.to_string(),
        reason,
    }
}

/// Squared distances from point `i` to every point (the point itself at +∞).
fn input_row(points: &[f32], dim: usize, i: usize) -> Vec<f64> {
    let xi = &points[i * dim..(i + 1) * dim];
    points
        .chunks_exact(dim)
        .enumerate()
        .map(|(j, xj)| {
            if j == i {
                f64::INFINITY
            } else {
                sq_dist_f64(xi, xj)
            }
        })
        .collect()
}

fn embedding_row(embedding: &[[f32; 2]], i: usize) -> Vec<f64> {
    let yi = embedding[i];
    embedding
        .iter()
        .enumerate()
        .map(|(j, yj)| {
            if j == i {
                f64::INFINITY
            } else {
                sq_dist_f64(&yi, yj)
            }
        })
        .collect()
}

/// The `k` smallest of `d`, by (value, index).
fn smallest(d: &[f64], k: usize) -> Vec<usize> {
    let mut order: Vec<usize> = (0..d.len()).collect();
    let by = |a: &usize, b: &usize| d[*a].total_cmp(&d[*b]).then(a.cmp(b));
    order.select_nth_unstable_by(k - 1, by);
    order.truncate(k);
    order.sort_by(by);
    order
}

/// Trustworthiness `T(k)` of `embedding` for `points` (row-major, `dim` each); `1 ≤ k < n/2`
/// as scikit-learn requires.
pub fn trustworthiness(
    points: &[f32],
    dim: usize,
    embedding: &[[f32; 2]],
    k: usize,
) -> Result<f64> {
    let n = check(points, dim, embedding)?;
    if k == 0 || 2 * k >= n {
        return Err(bad_k(k, "trustworthiness needs 1 <= k < n/2"));
    }
    let penalties: Vec<f64> = (0..n)
        .into_par_iter()
        .map(|i| {
            let dx = input_row(points, dim, i);
            let near_y = smallest(&embedding_row(embedding, i), k);
            near_y
                .iter()
                .map(|&j| {
                    // Rank of j by input distance: 1 + the points strictly before it.
                    let rank = 1 + dx
                        .iter()
                        .enumerate()
                        .filter(|&(l, &d)| d < dx[j] || (d == dx[j] && l < j))
                        .count();
                    rank.saturating_sub(k) as f64
                })
                .sum()
        })
        .collect();
    let (n, k) = (n as f64, k as f64);
    Ok(1.0 - 2.0 / (n * k * (2.0 * n - 3.0 * k - 1.0)) * penalties.iter().sum::<f64>())
}

/// The mean fraction of each point's `k` nearest input neighbours that are among its `k`
/// nearest in `embedding`; `1 ≤ k < n`.
pub fn knn_preservation(
    points: &[f32],
    dim: usize,
    embedding: &[[f32; 2]],
    k: usize,
) -> Result<f64> {
    let n = check(points, dim, embedding)?;
    if k == 0 || k >= n {
        return Err(bad_k(k, "kNN preservation needs 1 <= k < n"));
    }
    let kept: Vec<usize> = (0..n)
        .into_par_iter()
        .map(|i| {
            let mut a = smallest(&input_row(points, dim, i), k);
            let b = smallest(&embedding_row(embedding, i), k);
            a.sort_unstable();
            b.iter().filter(|j| a.binary_search(j).is_ok()).count()
        })
        .collect();
    Ok(kept.iter().sum::<usize>() as f64 / (n * k) as f64)
}

/// `KL(P‖Q)` of `embedding` for the affinities `p` (from [`super::affinities`]), with the
/// exact normalisation over all pairs; `q` is clamped at machine epsilon as scikit-learn does.
pub fn kl_divergence(p: &Affinities, embedding: &[[f32; 2]]) -> Result<f64> {
    if embedding.len() != p.n() {
        return Err(Error::TsneShapeMismatch {
            what: "the embedding for these affinities",
            expected: p.n(),
            got: embedding.len(),
        });
    }
    if p.n() > MAX_POINTS {
        return Err(Error::TsneTooManyPoints {
            n: p.n(),
            limit: MAX_POINTS,
        });
    }
    let y: Vec<[f64; 2]> = embedding
        .iter()
        .map(|v| [f64::from(v[0]), f64::from(v[1])])
        .collect();
    Ok(gradient::kl_with_z(p, &y, gradient::exact_z(&y)))
}
