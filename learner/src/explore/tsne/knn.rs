//! Exact nearest neighbours for the input affinities: every pair is compared (blocked brute
//! force), so P does not depend on an approximate index as openTSNE's (Annoy) and FIt-SNE's do.
//!
//! Candidates are stored transposed in blocks of [`BLOCK`] rows, so one query against one block
//! is [`BLOCK`] independent sums that vectorise without reordering any sum; a task takes
//! [`QUERIES`] queries through every block while the block stays in cache. The ranking uses
//! `f32` squared distances summed in dimension order; the kept neighbours' distances are then
//! recomputed in `f64` for the calibration. The result depends on neither the thread count nor
//! the CPU's vector width.

use std::collections::BinaryHeap;

use rayon::prelude::*;

/// Candidate rows per transposed block.
const BLOCK: usize = 64;
/// Query rows per task.
const QUERIES: usize = 128;

/// The `k` neighbours of each point, row-major `n × k`, nearest first (ties by lower index).
pub(super) struct Neighbours {
    /// Neighbours per point.
    pub k: usize,
    /// Their indices.
    pub index: Vec<u32>,
    /// Their squared Euclidean distances, in `f64`.
    pub sq_dist: Vec<f64>,
}

/// `‖a − b‖²` in `f64`.
pub(super) fn sq_dist_f64(a: &[f32], b: &[f32]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(&x, &y)| {
            let d = f64::from(x) - f64::from(y);
            d * d
        })
        .sum()
}

/// Every other point as a neighbour, in index order (the exact method's dense P).
pub(super) fn all_pairs(points: &[f32], dim: usize) -> Neighbours {
    let n = points.len() / dim;
    let rows: Vec<(Vec<u32>, Vec<f64>)> = (0..n)
        .into_par_iter()
        .map(|i| {
            let xi = &points[i * dim..(i + 1) * dim];
            (0..n)
                .filter(|&j| j != i)
                .map(|j| (j as u32, sq_dist_f64(xi, &points[j * dim..(j + 1) * dim])))
                .unzip()
        })
        .collect();
    flatten(rows, n - 1)
}

fn flatten(rows: Vec<(Vec<u32>, Vec<f64>)>, k: usize) -> Neighbours {
    let mut index = Vec::with_capacity(rows.len() * k);
    let mut sq_dist = Vec::with_capacity(rows.len() * k);
    for (i, d) in rows {
        index.extend(i);
        sq_dist.extend(d);
    }
    Neighbours { k, index, sq_dist }
}

crate::simd::vectorised_fn! {
    /// Squared distances of each query (rows of `block.len() / BLOCK` floats) to the
    /// [`BLOCK`] rows of one transposed block, into `out` (`BLOCK` per query).
    fn block_distances<'a>(block: &'a [f32], queries: &'a [f32], out: &'a mut [f32]) -> () {
        let dim = block.len() / BLOCK;
        for (q, o) in queries.chunks_exact(dim).zip(out.chunks_exact_mut(BLOCK)) {
            let mut acc = [0.0f32; BLOCK];
            for (column, &qd) in block.chunks_exact(BLOCK).zip(q) {
                for r in 0..BLOCK {
                    let d = column[r] - qd;
                    acc[r] += d * d;
                }
            }
            o.copy_from_slice(&acc);
        }
    }
}

/// The exact `k` nearest neighbours of every point (itself excluded). Needs `k < n`.
pub(super) fn nearest(points: &[f32], dim: usize, k: usize) -> Neighbours {
    let n = points.len() / dim;
    let blocks = n.div_ceil(BLOCK);
    let mut transposed = vec![0.0f32; blocks * dim * BLOCK];
    for (i, row) in points.chunks_exact(dim).enumerate() {
        let (b, r) = (i / BLOCK, i % BLOCK);
        let block = &mut transposed[b * dim * BLOCK..(b + 1) * dim * BLOCK];
        for (d, &v) in row.iter().enumerate() {
            block[d * BLOCK + r] = v;
        }
    }
    let rows: Vec<Vec<(Vec<u32>, Vec<f64>)>> = points
        .par_chunks(QUERIES * dim)
        .enumerate()
        .map(|(c, queries)| {
            let first = c * QUERIES;
            let q = queries.len() / dim;
            // Keys order by distance then index: a non-negative f32's bits order as the float.
            let mut heaps: Vec<BinaryHeap<u64>> =
                (0..q).map(|_| BinaryHeap::with_capacity(k + 1)).collect();
            let mut out = vec![0.0f32; q * BLOCK];
            for b in 0..blocks {
                block_distances(
                    &transposed[b * dim * BLOCK..(b + 1) * dim * BLOCK],
                    queries,
                    &mut out,
                );
                let valid = BLOCK.min(n - b * BLOCK);
                for (qi, (heap, dists)) in heaps.iter_mut().zip(out.chunks_exact(BLOCK)).enumerate()
                {
                    let i = first + qi;
                    for (r, &d) in dists[..valid].iter().enumerate() {
                        let j = b * BLOCK + r;
                        if j == i {
                            continue;
                        }
                        let key = (u64::from(d.to_bits()) << 32) | j as u64;
                        if heap.len() < k {
                            heap.push(key);
                        } else if let Some(mut worst) = heap.peek_mut()
                            && key < *worst
                        {
                            *worst = key;
                        }
                    }
                }
            }
            heaps
                .into_iter()
                .enumerate()
                .map(|(qi, heap)| {
                    let xi = &queries[qi * dim..(qi + 1) * dim];
                    let mut found: Vec<(f64, u32)> = heap
                        .into_vec()
                        .into_iter()
                        .map(|key| {
                            let j = (key & 0xffff_ffff) as usize;
                            (sq_dist_f64(xi, &points[j * dim..(j + 1) * dim]), j as u32)
                        })
                        .collect();
                    found.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
                    found.into_iter().map(|(d, j)| (j, d)).unzip()
                })
                .collect()
        })
        .collect();
    flatten(rows.into_iter().flatten().collect(), k)
}
