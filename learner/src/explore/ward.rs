//! Exact agglomerative clustering with Ward's criterion (Ward 1963), the clustering behind the
//! style taxonomy of Garces et al. 2016 (§6.5.1).
//!
//! Ward merges, at each step, the two clusters whose union least increases the total
//! within-cluster sum of squares. Its cost is reducible, so the nearest-neighbour-chain algorithm
//! (Benzécri 1982; Müllner 2011, "Modern hierarchical, agglomerative clustering algorithms", §3)
//! finds the exact tree in O(n²) time with the O(n²) condensed matrix of squared Euclidean
//! distances, updated after a merge of `x` and `y` by the Lance–Williams formula for Ward
//! (Lance & Williams 1967; Müllner 2011, Fig. 2), for every other cluster `i`:
//!
//! `d²(x∪y, i) = ((n_i + n_x)·d²(x, i) + (n_i + n_y)·d²(y, i) − n_i·d²(x, y)) / (n_x + n_y + n_i)`
//!
//! The height of a merge is `√d²(x, y)`, the value scipy reports: for two points their Euclidean
//! distance, in general `√(2·n_x·n_y/(n_x+n_y))·‖c_x − c_y‖`. We keep squared distances (scipy
//! keeps unsquared ones and squares them in each update); both are exact formulas and agree to
//! rounding.
//!
//! Ties, and the rows' order, follow scipy's `linkage(X, 'ward')` so trees compare row for row:
//! a chain step prefers the chain's previous element, then the lowest cluster index; a merged
//! cluster takes the higher index's slot; the merges are then stably sorted by height and
//! renumbered (`n + i` for merge `i`, smaller id first). Under exact ties in the data the tree
//! is one of the equally valid ones and may still differ from scipy's by rounding.

use rayon::prelude::*;

use super::linkage::{Linkage, Merge};
use crate::{Error, Result};

/// The most points [`ward`] accepts: the condensed matrix of `n(n−1)/2` `f64` distances takes
/// 6.4 GB at 40,000 points (a quarter more points would take 10 GB), a quarter of the memory of
/// the machines this runs on. Above it, an error; never a sample or a truncation.
pub const MAX_POINTS: usize = 40_000;

/// The largest coordinate magnitude [`ward`] accepts: squared distances and their
/// Lance–Williams combinations (weights up to `n`) then stay far from `f64` overflow.
pub const MAX_COORDINATE: f64 = 1e100;

/// Ward's hierarchical clustering of `points` (row-major, `dim` coordinates per point; `f32` or
/// `f64`), the same tree as `scipy.cluster.hierarchy.linkage(X, 'ward')`: `n − 1` merges in
/// non-decreasing height. Distances are computed in `f64`, in parallel.
///
/// Errors: fewer than 2 points, `dim` 0, a length that is not a multiple of `dim`, a coordinate
/// that is not finite or exceeds [`MAX_COORDINATE`], more than [`MAX_POINTS`] points, or memory
/// for the distance matrix that cannot be allocated.
pub fn ward<T: Copy + Into<f64> + Sync>(points: &[T], dim: usize) -> Result<Linkage> {
    let n = validate(points, dim)?;
    let mut d = condensed_squared_distances(points, n, dim, None)?;
    let merges = nn_chain(&mut d, &vec![1.0; n]);
    drop(d);
    Linkage::new(n, label(merges, n))
}

/// Ward's clustering of `points` that stand for groups of `weights[i]` items each (k-means
/// centres with their cluster sizes): the tree Ward builds on the items once every group has
/// been merged, because Ward's merge cost depends only on the clusters' sizes and centroids,
/// `Δ(A, B) = |A||B|/(|A|+|B|) · ‖c_A − c_B‖²` (Ward 1963). The leaves of the returned
/// [`Linkage`] are the points (its `size` counts points, not items); the heights are in the
/// same scale as [`ward`]'s, `√(2Δ)`, so with unit weights the two agree.
///
/// Errors: those of [`ward`], a `weights` of another length, or a zero weight.
pub fn ward_weighted<T: Copy + Into<f64> + Sync>(
    points: &[T],
    dim: usize,
    weights: &[usize],
) -> Result<Linkage> {
    let n = validate(points, dim)?;
    if weights.len() != n {
        return Err(Error::InvalidParameter {
            name: "weights",
            value: format!("{} weights for {n} points", weights.len()),
            reason: "every point needs the number of items it stands for",
        });
    }
    if weights.contains(&0) {
        return Err(Error::InvalidParameter {
            name: "weights",
            value: "0".into(),
            reason: "a point must stand for at least one item",
        });
    }
    let w: Vec<f64> = weights.iter().map(|&v| v as f64).collect();
    let mut d = condensed_squared_distances(points, n, dim, Some(&w))?;
    let merges = nn_chain(&mut d, &w);
    drop(d);
    Linkage::new(n, label(merges, n))
}

fn validate<T: Copy + Into<f64>>(points: &[T], dim: usize) -> Result<usize> {
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
    if n < 2 {
        return Err(Error::NotEnoughData {
            what: "Ward clustering (points)",
            needed: 2,
            got: n,
        });
    }
    if n > MAX_POINTS {
        return Err(Error::TooManyPoints {
            what: "Ward clustering",
            n,
            limit: MAX_POINTS,
            bytes: pairs_bytes(n),
        });
    }
    if let Some(i) = points
        .iter()
        .position(|v| !(*v).into().is_finite() || (*v).into().abs() > MAX_COORDINATE)
    {
        return Err(Error::BadCoordinate {
            row: i / dim,
            column: i % dim,
            value: points[i].into(),
            limit: MAX_COORDINATE,
        });
    }
    Ok(n)
}

fn pairs_bytes(n: usize) -> u128 {
    let n = n as u128;
    n * (n - 1) / 2 * std::mem::size_of::<f64>() as u128
}

/// Position of the pair `i < j` in the condensed (upper-triangle, row-major) matrix.
#[inline]
fn at(n: usize, i: usize, j: usize) -> usize {
    let (i, j) = if i < j { (i, j) } else { (j, i) };
    i * (2 * n - i - 1) / 2 + (j - i - 1)
}

/// The condensed matrix of squared Euclidean distances, one row of pairs per rayon task. Each
/// distance is a plain sum of squared differences in `f64` (not `‖x‖² + ‖y‖² − 2x·y`, which
/// loses the small distances that decide the first merges). With `weights`, the squared Ward
/// distance of groups, `2·w_i·w_j/(w_i + w_j) · ‖x_i − x_j‖²` (which is `‖x_i − x_j‖²` for
/// unit weights, the scale the Lance–Williams update keeps).
fn condensed_squared_distances<T: Copy + Into<f64> + Sync>(
    points: &[T],
    n: usize,
    dim: usize,
    weights: Option<&[f64]>,
) -> Result<Vec<f64>> {
    let len = n * (n - 1) / 2;
    let mut d: Vec<f64> = Vec::new();
    d.try_reserve_exact(len).map_err(|_| Error::OutOfMemory {
        what: "the Ward distance matrix",
        bytes: pairs_bytes(n),
    })?;
    d.resize(len, 0.0);
    let x: Vec<f64> = points.iter().map(|v| (*v).into()).collect();
    let mut rows: Vec<(usize, &mut [f64])> = Vec::with_capacity(n - 1);
    let mut rest = d.as_mut_slice();
    for i in 0..n - 1 {
        let (row, tail) = rest.split_at_mut(n - 1 - i);
        rows.push((i, row));
        rest = tail;
    }
    rows.into_par_iter().for_each(|(i, row)| {
        let xi = &x[i * dim..(i + 1) * dim];
        for (k, out) in row.iter_mut().enumerate() {
            let j = i + 1 + k;
            let xj = &x[j * dim..(j + 1) * dim];
            let squared: f64 = xi.iter().zip(xj).map(|(a, b)| (a - b) * (a - b)).sum();
            *out = match weights {
                Some(w) => 2.0 * w[i] * w[j] / (w[i] + w[j]) * squared,
                None => squared,
            };
        }
    });
    Ok(d)
}

/// A merge as the chain finds it: the slots of the two clusters (`x < y`; the union takes slot
/// `y`) and the squared Ward distance between them.
type SlotMerge = (usize, usize, f64);

/// The nearest-neighbour chain (Müllner 2011, Fig. 3): grow a chain of nearest neighbours from
/// any cluster until its last two elements are each other's nearest, merge them, and continue
/// from what is left of the chain. With a reducible criterion such as Ward's, every merge made
/// this way is one the greedy algorithm also makes, so the tree is exact.
fn nn_chain(d: &mut [f64], weights: &[f64]) -> Vec<SlotMerge> {
    let n = weights.len();
    // Items in the cluster held by each slot; 0 once the slot is merged away.
    let mut size = weights.to_vec();
    let mut chain: Vec<usize> = Vec::with_capacity(n);
    let mut merges = Vec::with_capacity(n - 1);
    for _ in 0..n - 1 {
        if chain.is_empty() {
            let first = size
                .iter()
                .position(|s| *s > 0.0)
                .expect("two clusters remain");
            chain.push(first);
        }
        let (x, y, dxy) = loop {
            let x = chain[chain.len() - 1];
            let previous = (chain.len() > 1).then(|| chain[chain.len() - 2]);
            // Start from the previous element so that a tie never lets the chain cycle.
            let (mut y, mut best) = match previous {
                Some(p) => (p, d[at(n, x, p)]),
                None => (usize::MAX, f64::INFINITY),
            };
            for (i, s) in size.iter().enumerate() {
                if *s == 0.0 || i == x {
                    continue;
                }
                let v = d[at(n, x, i)];
                if v < best {
                    best = v;
                    y = i;
                }
            }
            if previous == Some(y) {
                break (x, y, best);
            }
            chain.push(y);
        };
        chain.truncate(chain.len() - 2);
        let (x, y) = (x.min(y), x.max(y));
        let (nx, ny) = (size[x], size[y]);
        size[y] += size[x];
        size[x] = 0.0;
        for (i, &ni) in size.iter().enumerate() {
            if ni == 0.0 || i == y {
                continue;
            }
            let (xi, yi) = (at(n, x, i), at(n, y, i));
            d[yi] = ((ni + nx) * d[xi] + (ni + ny) * d[yi] - ni * dxy) / (nx + ny + ni);
        }
        merges.push((x, y, dxy));
    }
    merges
}

/// Sorts the chain's merges by height (stably, as scipy does: the chain finds them out of
/// order) and renames slots to scipy's cluster ids with a union-find.
fn label(mut merges: Vec<SlotMerge>, n: usize) -> Vec<Merge> {
    merges.sort_by(|a, b| a.2.total_cmp(&b.2));
    let mut parent: Vec<usize> = (0..2 * n - 1).collect();
    let mut size = vec![1usize; 2 * n - 1];
    let find = |parent: &mut Vec<usize>, mut c: usize| {
        let mut root = c;
        while parent[root] != root {
            root = parent[root];
        }
        while parent[c] != root {
            let next = parent[c];
            parent[c] = root;
            c = next;
        }
        root
    };
    merges
        .into_iter()
        .enumerate()
        .map(|(i, (x, y, dxy))| {
            let (rx, ry) = (find(&mut parent, x), find(&mut parent, y));
            let new = n + i;
            parent[rx] = new;
            parent[ry] = new;
            size[new] = size[rx] + size[ry];
            Merge {
                a: rx.min(ry),
                b: rx.max(ry),
                // Rounding in the update can leave −1e−17 where two clusters coincide.
                height: dxy.max(0.0).sqrt(),
                size: size[new],
            }
        })
        .collect()
}

#[cfg(test)]
mod tests;
