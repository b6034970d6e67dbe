//! Isomap to two dimensions (Tenenbaum, de Silva & Langford 2000), the embedding of the IsoMatch
//! baseline: a symmetric k-nearest-neighbour graph with Euclidean edge lengths, geodesic
//! distances by Dijkstra, then classical MDS (Torgerson 1952) — the top eigenvectors of
//! `B = −½·J·D²·J`, scaled by the square roots of their eigenvalues.
//!
//! Up to [`IsomapParams::exact_limit`] points, geodesics run from every point and MDS is exact.
//! Above it, Landmark Isomap (de Silva & Tenenbaum 2004, "Sparse multidimensional scaling using
//! landmark points"): geodesics from `L` seeded random landmarks, MDS on the landmarks, every
//! point placed by distance-based triangulation `y_k = −½·v_kᵀ(δ − δ̄)/√λ_k`.
//!
//! A kNN graph that falls apart into components is joined (ours): the component of point 0 gets
//! the shortest edge to any point outside it, until one component remains.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use rayon::prelude::*;

use super::eigen::top_eigen;
use super::types::validate_points;
use crate::{Error, Result};
use rand::SeedableRng;
use rand::seq::index::sample;
use rand_chacha::ChaCha8Rng;

/// Parameters of [`isomap_2d`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct IsomapParams {
    /// `k`: neighbours per point in the graph. Default 10.
    pub k: usize,
    /// Exact Isomap up to this many points. Default 2,000.
    pub exact_limit: usize,
    /// `L`: landmarks above the limit. Default 500.
    pub landmarks: usize,
    /// Seed of the landmarks and of the eigen-solver's start.
    pub seed: u64,
}

impl Default for IsomapParams {
    fn default() -> Self {
        IsomapParams {
            k: 10,
            exact_limit: 2000,
            landmarks: 500,
            seed: 0,
        }
    }
}

/// Two Isomap coordinates per point (`[x, y]`, `x` along the leading eigenvector) and the two
/// eigenvalues.
///
/// Errors: fewer than 3 points, `k` 0, fewer than 3 landmarks, bad points.
pub fn isomap_2d(
    points: &[f32],
    dim: usize,
    params: &IsomapParams,
) -> Result<(Vec<[f64; 2]>, [f64; 2])> {
    let n = validate_points(points, dim, None)?;
    if n < 3 {
        return Err(Error::NotEnoughData {
            what: "Isomap (points)",
            needed: 3,
            got: n,
        });
    }
    if params.k == 0 {
        return Err(Error::InvalidParameter {
            name: "k",
            value: "0".into(),
            reason: "at least one neighbour",
        });
    }
    if params.landmarks < 3 {
        return Err(Error::InvalidParameter {
            name: "landmarks",
            value: params.landmarks.to_string(),
            reason: "at least 3 landmarks",
        });
    }
    let graph = knn_graph(points, dim, n, params.k.min(n - 1));
    if n <= params.exact_limit {
        let d: Vec<Vec<f64>> = (0..n)
            .into_par_iter()
            .map(|s| dijkstra(&graph, s))
            .collect();
        let sq: Vec<f64> = d.iter().flatten().map(|x| x * x).collect();
        let (vectors, values) = mds(&sq, n, params.seed);
        let coords = (0..n)
            .map(|i| {
                [
                    vectors[0][i] * values[0].max(0.0).sqrt(),
                    vectors[1][i] * values[1].max(0.0).sqrt(),
                ]
            })
            .collect();
        return Ok((coords, values));
    }
    let l = params.landmarks.min(n);
    let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
    let mut marks = sample(&mut rng, n, l).into_vec();
    marks.sort_unstable();
    let from: Vec<Vec<f64>> = marks.par_iter().map(|&s| dijkstra(&graph, s)).collect();
    let mut sq = vec![0.0; l * l];
    for a in 0..l {
        for b in 0..l {
            sq[a * l + b] = from[a][marks[b]].powi(2);
        }
    }
    let (vectors, values) = mds(&sq, l, params.seed);
    let mean: Vec<f64> = (0..l)
        .map(|a| sq[a * l..(a + 1) * l].iter().sum::<f64>() / l as f64)
        .collect();
    let coords = (0..n)
        .map(|i| {
            let mut y = [0.0; 2];
            for (k, yk) in y.iter_mut().enumerate() {
                let s: f64 = (0..l)
                    .map(|a| vectors[k][a] * (from[a][i].powi(2) - mean[a]))
                    .sum();
                *yk = -0.5 * s / values[k].max(1e-300).sqrt();
            }
            y
        })
        .collect();
    Ok((coords, values))
}

/// Symmetric kNN graph (an edge when either end is among the other's `k` nearest, ties to the
/// lower index), joined into one component.
pub(crate) fn knn_graph(points: &[f32], dim: usize, n: usize, k: usize) -> Vec<Vec<(usize, f64)>> {
    let dist = |i: usize, j: usize| -> f64 {
        points[i * dim..(i + 1) * dim]
            .iter()
            .zip(&points[j * dim..(j + 1) * dim])
            .map(|(a, b)| (*a as f64 - *b as f64).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    let near: Vec<Vec<(usize, f64)>> = (0..n)
        .into_par_iter()
        .map(|i| {
            let mut all: Vec<(f64, usize)> = (0..n)
                .filter(|&j| j != i)
                .map(|j| (dist(i, j), j))
                .collect();
            all.select_nth_unstable_by(k - 1, |a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            all.truncate(k);
            all.into_iter().map(|(d, j)| (j, d)).collect()
        })
        .collect();
    let mut graph: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n];
    for (i, list) in near.iter().enumerate() {
        for &(j, d) in list {
            graph[i].push((j, d));
            graph[j].push((i, d));
        }
    }
    for list in graph.iter_mut() {
        list.sort_by_key(|e| e.0);
        list.dedup_by_key(|e| e.0);
    }
    loop {
        let reached = dijkstra(&graph, 0);
        if reached.iter().all(|d| d.is_finite()) {
            return graph;
        }
        let inside: Vec<usize> = (0..n).filter(|&i| reached[i].is_finite()).collect();
        let outside: Vec<usize> = (0..n).filter(|&i| !reached[i].is_finite()).collect();
        let (d, a, b) = inside
            .par_iter()
            .map(|&a| {
                outside
                    .iter()
                    .map(|&b| (dist(a, b), a, b))
                    .min_by(|x, y| x.0.total_cmp(&y.0))
                    .expect("a point outside")
            })
            .min_by(|x, y| x.0.total_cmp(&y.0).then((x.1, x.2).cmp(&(y.1, y.2))))
            .expect("a point inside");
        graph[a].push((b, d));
        graph[b].push((a, d));
    }
}

/// Geodesic distances from `source` (infinite where unreachable).
pub(crate) fn dijkstra(graph: &[Vec<(usize, f64)>], source: usize) -> Vec<f64> {
    let mut d = vec![f64::INFINITY; graph.len()];
    let mut heap = BinaryHeap::new();
    d[source] = 0.0;
    heap.push(Reverse((Ordered(0.0), source)));
    while let Some(Reverse((Ordered(du), u))) = heap.pop() {
        if du > d[u] {
            continue;
        }
        for &(v, w) in &graph[u] {
            let nd = du + w;
            if nd < d[v] {
                d[v] = nd;
                heap.push(Reverse((Ordered(nd), v)));
            }
        }
    }
    d
}

/// Classical MDS of a full `n × n` matrix of squared distances: the top two eigenvectors of
/// `B = −½·J·D²·J` (sign fixed so each vector's largest entry is positive) and their eigenvalues.
pub(crate) fn mds(sq: &[f64], n: usize, seed: u64) -> ([Vec<f64>; 2], [f64; 2]) {
    let row: Vec<f64> = (0..n)
        .map(|i| sq[i * n..(i + 1) * n].iter().sum::<f64>() / n as f64)
        .collect();
    let all = row.iter().sum::<f64>() / n as f64;
    let b: Vec<f64> = (0..n * n)
        .into_par_iter()
        .map(|k| -0.5 * (sq[k] - row[k / n] - row[k % n] + all))
        .collect();
    let e = top_eigen(n, 2, seed, |x, y| {
        y.par_iter_mut().enumerate().for_each(|(i, yi)| {
            *yi = b[i * n..(i + 1) * n]
                .iter()
                .zip(x)
                .map(|(a, c)| a * c)
                .sum()
        });
    });
    let mut vectors = [
        e.vectors[0].clone(),
        e.vectors.get(1).cloned().unwrap_or(vec![0.0; n]),
    ];
    for v in vectors.iter_mut() {
        let big = v
            .iter()
            .copied()
            .fold(0.0f64, |m, x| if x.abs() > m.abs() { x } else { m });
        if big < 0.0 {
            v.iter_mut().for_each(|x| *x = -*x);
        }
    }
    (
        vectors,
        [e.values[0], e.values.get(1).copied().unwrap_or(0.0)],
    )
}

/// A total order on finite `f64` for the heap.
#[derive(Clone, Copy, PartialEq)]
struct Ordered(f64);

impl Eq for Ordered {}

impl PartialOrd for Ordered {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Ordered {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0)
    }
}
