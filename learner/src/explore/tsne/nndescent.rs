//! Approximate nearest neighbours for the input affinities of large inputs: a forest of random
//! projection trees (Dasgupta & Freund 2008; the "Annoy" split of a hyperplane between two
//! random points, as pynndescent seeds its graph) and then rounds of NN-descent (Dong, Moses &
//! Li 2011, "Efficient k-nearest neighbor graph construction for generic similarity measures":
//! a neighbour of a neighbour is likely a neighbour).
//!
//! 1. Each of `n_trees` trees splits the points recursively by the hyperplane halfway between
//!    two random members until a leaf holds at most `leaf_size`; every point's first list is
//!    the `k` nearest among the members of its leaves.
//! 2. Each NN-descent round rebuilds every list from the old ones: point `i` compares itself with
//!    the neighbours and reverse neighbours of its nearest `max_candidates` neighbours and
//!    reverse neighbours (all lists read from the previous round, so the round is a pure function of
//!    it, unlike the in-place updates of the paper). Rounds stop when fewer than `δ·n·k` list
//!    entries change (the paper's early termination) or after `n_iter` rounds.
//!
//! Deterministic for any thread count: each tree draws from its own generator seeded by (seed,
//! tree), each point's list is computed on its own, and the reverse lists are gathered in index
//! order. Distances rank by `f32` sums of eight interleaved partial sums (a fixed order, so the
//! same on every CPU); the kept neighbours' distances are recomputed in `f64` as the exact
//! search does.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::knn::{Neighbours, sq_dist_f64};

/// Parameters of the approximate search.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Approximate {
    /// Random projection trees.
    pub n_trees: usize,
    /// The most points in a leaf (raised to `k + 1` when smaller).
    pub leaf_size: usize,
    /// NN-descent rounds at most.
    pub n_iter: usize,
    /// Nearest neighbours (and reverse neighbours) of each list explored per round (`ρ·k` in
    /// the paper; pynndescent's `max_candidates`).
    pub max_candidates: usize,
    /// `δ`: rounds stop when fewer than `δ·n·k` entries change.
    pub delta: f64,
    /// Seed of the trees.
    pub seed: u64,
}

/// `‖a − b‖²` in `f32`, in eight interleaved partial sums added in a fixed order.
fn sq_dist(a: &[f32], b: &[f32]) -> f32 {
    let mut acc = [0.0f32; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for ((a, &u), &v) in acc.iter_mut().zip(x).zip(y) {
            let d = u - v;
            *a += d * d;
        }
    }
    for (l, (x, y)) in ra.iter().zip(rb).enumerate() {
        let d = x - y;
        acc[l] += d * d;
    }
    ((acc[0] + acc[4]) + (acc[1] + acc[5])) + ((acc[2] + acc[6]) + (acc[3] + acc[7]))
}

/// A candidate key: a non-negative `f32`'s bits order as the float, ties by index.
fn key(d: f32, j: u32) -> u64 {
    (u64::from(d.to_bits()) << 32) | u64::from(j)
}

/// The leaves of one tree: a permutation of the points cut into ranges.
fn tree(points: &[f32], dim: usize, leaf: usize, rng: &mut ChaCha8Rng) -> (Vec<u32>, Vec<usize>) {
    let n = points.len() / dim;
    let mut order: Vec<u32> = (0..n as u32).collect();
    let mut bounds = vec![0];
    let mut stack = vec![(0, n)];
    let row = |i: u32| &points[i as usize * dim..(i as usize + 1) * dim];
    let mut normal = vec![0.0f32; dim];
    while let Some((start, end)) = stack.pop() {
        if end - start <= leaf {
            bounds.push(end);
            continue;
        }
        let members = &mut order[start..end];
        let a = rng.random_range(0..members.len());
        let mut b = rng.random_range(0..members.len() - 1);
        if b >= a {
            b += 1;
        }
        let (xa, xb) = (row(members[a]), row(members[b]));
        let mut offset = 0.0f32;
        for ((w, &u), &v) in normal.iter_mut().zip(xa).zip(xb) {
            *w = u - v;
            offset += *w * (u + v) / 2.0;
        }
        // Stable partition: points on `a`'s side first.
        let side = |i: u32| row(i).iter().zip(&normal).map(|(x, w)| x * w).sum::<f32>() >= offset;
        let mut left: Vec<u32> = members.iter().copied().filter(|&i| side(i)).collect();
        let mut split = left.len();
        left.extend(members.iter().copied().filter(|&i| !side(i)));
        if split == 0 || split == members.len() {
            // Coincident or hyperplane-degenerate members: halve them in order.
            split = members.len() / 2;
        }
        members.copy_from_slice(&left);
        // Right half pushed first so the left leaf comes first in `bounds`.
        stack.push((start + split, end));
        stack.push((start, start + split));
    }
    (order, bounds)
}

/// The approximate `k` nearest neighbours of every point (itself excluded), nearest first.
/// Needs `k < n`.
pub(super) fn nearest(points: &[f32], dim: usize, k: usize, params: &Approximate) -> Neighbours {
    let n = points.len() / dim;
    let row = |i: usize| &points[i * dim..(i + 1) * dim];
    let leaf = params.leaf_size.max(k + 1);
    // Each tree: for every point, the range of its leaf in the tree's order.
    let forest: Vec<(Vec<u32>, Vec<u32>, Vec<usize>)> = (0..params.n_trees)
        .into_par_iter()
        .map(|t| {
            let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
            rng.set_stream(t as u64 + 1);
            let (order, bounds) = tree(points, dim, leaf, &mut rng);
            let mut leaf_of = vec![0u32; n];
            for (l, w) in bounds.windows(2).enumerate() {
                for &i in &order[w[0]..w[1]] {
                    leaf_of[i as usize] = l as u32;
                }
            }
            (order, leaf_of, bounds)
        })
        .collect();
    let mut lists: Vec<Vec<u64>> = (0..n)
        .into_par_iter()
        .map(|i| {
            let mut candidates: Vec<u32> = forest
                .iter()
                .flat_map(|(order, leaf_of, bounds)| {
                    // A small leaf is widened to its neighbours in the tree's order (its
                    // sibling subtrees) so that every point has `k` candidates.
                    let l = leaf_of[i] as usize;
                    let (mut s, e) = (bounds[l], bounds[l + 1]);
                    if e - s < k + 1 {
                        s = s.saturating_sub((k + 1 - (e - s)).div_ceil(2));
                    }
                    let e = (s + (k + 1)).max(e).min(n);
                    let s = s.min(e - (k + 1).min(e));
                    order[s..e].iter().copied()
                })
                .filter(|&j| j as usize != i)
                .collect();
            candidates.sort_unstable();
            candidates.dedup();
            best(
                candidates
                    .into_iter()
                    .map(|j| key(sq_dist(row(i), row(j as usize)), j)),
                k,
            )
        })
        .collect();
    let explored = params.max_candidates.clamp(1, k);
    for _ in 0..params.n_iter {
        // Reverse lists, gathered in index order and capped at `explored` entries.
        let mut reverse: Vec<Vec<u32>> = vec![Vec::new(); n];
        for (i, list) in lists.iter().enumerate() {
            for &e in &list[..explored] {
                let r = &mut reverse[(e & 0xffff_ffff) as usize];
                if r.len() < explored {
                    r.push(i as u32);
                }
            }
        }
        let near = |i: usize| {
            lists[i][..explored]
                .iter()
                .map(|&e| (e & 0xffff_ffff) as u32)
                .chain(reverse[i].iter().copied())
        };
        let next: Vec<(Vec<u64>, usize)> = (0..n)
            .into_par_iter()
            .map(|i| {
                let mut known: Vec<u32> = lists[i].iter().map(|&e| e as u32).collect();
                known.sort_unstable();
                let mut candidates: Vec<u32> = near(i)
                    .flat_map(|j| near(j as usize))
                    .filter(|&j| j as usize != i && known.binary_search(&j).is_err())
                    .collect();
                candidates.sort_unstable();
                candidates.dedup();
                let list = best(
                    lists[i].iter().copied().chain(
                        candidates
                            .into_iter()
                            .map(|j| key(sq_dist(row(i), row(j as usize)), j)),
                    ),
                    k,
                );
                let changed = list
                    .iter()
                    .filter(|&&e| known.binary_search(&(e as u32)).is_err())
                    .count();
                (list, changed)
            })
            .collect();
        let changed: usize = next.iter().map(|e| e.1).sum();
        lists = next.into_iter().map(|e| e.0).collect();
        if (changed as f64) < params.delta * (n * k) as f64 {
            break;
        }
    }
    let mut index = Vec::with_capacity(n * k);
    let mut sq_dist_out = Vec::with_capacity(n * k);
    let rows: Vec<Vec<(f64, u32)>> = lists
        .par_iter()
        .enumerate()
        .map(|(i, list)| {
            let mut found: Vec<(f64, u32)> = list
                .iter()
                .map(|&e| {
                    let j = (e & 0xffff_ffff) as u32;
                    (sq_dist_f64(row(i), row(j as usize)), j)
                })
                .collect();
            found.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            found
        })
        .collect();
    for found in rows {
        for (d, j) in found {
            index.push(j);
            sq_dist_out.push(d);
        }
    }
    Neighbours {
        k,
        index,
        sq_dist: sq_dist_out,
    }
}

/// The `k` smallest keys, increasing.
fn best(keys: impl Iterator<Item = u64>, k: usize) -> Vec<u64> {
    let mut all: Vec<u64> = keys.collect();
    if all.len() > k {
        all.select_nth_unstable(k - 1);
        all.truncate(k);
    }
    all.sort_unstable();
    all
}
