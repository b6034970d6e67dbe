//! k-means for the diversity ordering of §5.7.3: Lloyd's algorithm with a k-means++
//! initialisation (Arthur & Vassilvitskii 2007) on the style index's rows, where the Euclidean
//! distance is the learned metric.
//!
//! Deterministic for a seed whatever the thread count: the random draws are sequential, each
//! item's nearest centre is found on its own (ties to the lower centre), and every sum over items
//! is taken per fixed block of rows and the block sums added in block order. A cluster left
//! empty is moved to the item farthest from its centre (ties to the earlier item).

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::index::squared_distances;

/// Rows per block: the unit of parallel work and of the fixed-order sums.
const BLOCK: usize = 2048;

/// What happened in one k-means run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct KMeansInfo {
    /// Clusters.
    pub k: usize,
    /// Points clustered.
    pub points: usize,
    /// Lloyd iterations run.
    pub iterations: usize,
    /// True when the last iteration moved no point.
    pub converged: bool,
    /// Sum of squared distances of points to their centres at the end.
    pub inertia: f64,
    /// Clusters that were empty at some iteration and re-seeded.
    pub reseeded: usize,
}

/// A clustering of rows.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Clusters {
    /// `k × stride` centres.
    pub centroids: Vec<f32>,
    /// Cluster of each point.
    pub assignment: Vec<u16>,
    /// Squared distance of each point to its centre.
    pub distance: Vec<f32>,
    /// The run.
    pub info: KMeansInfo,
}

/// Clusters the rows of `data` (`stride` floats each, a multiple of the scan's lanes) into
/// `min(k, rows)` clusters. `progress(iteration)` is called after each Lloyd iteration.
///
/// # Panics
/// If `k == 0`, `k > 65535`, or `data` is empty or not a whole number of rows (callers validate).
pub(crate) fn kmeans(
    data: &[f32],
    stride: usize,
    k: usize,
    seed: u64,
    max_iterations: usize,
    progress: &mut dyn FnMut(usize),
) -> Clusters {
    assert!(stride > 0 && !data.is_empty() && data.len().is_multiple_of(stride));
    assert!(k > 0 && k <= u16::MAX as usize);
    let n = data.len() / stride;
    let k = k.min(n);
    let mut centroids = init_plus_plus(data, stride, k, seed);
    let mut assignment = vec![0u16; n];
    let mut distance = vec![0.0f32; n];
    let mut info = KMeansInfo {
        k,
        points: n,
        iterations: 0,
        converged: false,
        inertia: 0.0,
        reseeded: 0,
    };
    assign(
        data,
        stride,
        &centroids,
        &mut assignment,
        &mut distance,
        true,
    );
    for iteration in 1..=max_iterations {
        info.reseeded += update(data, stride, &mut centroids, &assignment, &mut distance, k);
        let moved = assign(
            data,
            stride,
            &centroids,
            &mut assignment,
            &mut distance,
            false,
        );
        info.iterations = iteration;
        progress(iteration);
        if moved == 0 {
            info.converged = true;
            break;
        }
    }
    info.inertia = ordered_sum(&distance);
    Clusters {
        centroids,
        assignment,
        distance,
        info,
    }
}

/// Sum in fixed blocks, blocks added in order: the same bits for any thread count.
fn ordered_sum(values: &[f32]) -> f64 {
    let blocks: Vec<f64> = values
        .par_chunks(BLOCK)
        .map(|b| b.iter().map(|&v| f64::from(v)).sum())
        .collect();
    blocks.iter().sum()
}

/// k-means++: the first centre uniformly at random, each next one drawn with probability
/// proportional to the squared distance to the nearest centre chosen so far.
fn init_plus_plus(data: &[f32], stride: usize, k: usize, seed: u64) -> Vec<f32> {
    let n = data.len() / stride;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut centroids = Vec::with_capacity(k * stride);
    let first = rng.random_range(0..n);
    centroids.extend_from_slice(&data[first * stride..(first + 1) * stride]);
    let mut nearest = vec![f32::INFINITY; n];
    let mut scratch = vec![0.0f32; n];
    for c in 1..k {
        let centre = &centroids[(c - 1) * stride..c * stride];
        data.par_chunks(BLOCK * stride)
            .zip(scratch.par_chunks_mut(BLOCK))
            .zip(nearest.par_chunks_mut(BLOCK))
            .for_each(|((rows, d), best)| {
                squared_distances(rows, centre, d);
                for (b, &d) in best.iter_mut().zip(d.iter()) {
                    *b = b.min(d);
                }
            });
        let block_sums: Vec<f64> = nearest
            .par_chunks(BLOCK)
            .map(|b| b.iter().map(|&v| f64::from(v)).sum())
            .collect();
        let total: f64 = block_sums.iter().sum();
        let next = if total > 0.0 {
            draw(&nearest, &block_sums, rng.random::<f64>() * total)
        } else {
            // Fewer distinct points than clusters: any point will do, the empty clusters that
            // result are re-seeded by Lloyd's updates.
            rng.random_range(0..n)
        };
        centroids.extend_from_slice(&data[next * stride..(next + 1) * stride]);
    }
    centroids
}

/// The point where the running sum of `weights` passes `target` (a point of weight 0 is never
/// chosen); `block_sums` are the sums of `weights` per [`BLOCK`].
fn draw(weights: &[f32], block_sums: &[f64], target: f64) -> usize {
    let mut t = target;
    let mut block = block_sums.len() - 1;
    for (b, &s) in block_sums.iter().enumerate() {
        if t < s {
            block = b;
            break;
        }
        t -= s;
    }
    let start = block * BLOCK;
    let mut last = None;
    for (i, &w) in weights.iter().enumerate().skip(start).take(BLOCK) {
        if w > 0.0 {
            last = Some(i);
            if t < f64::from(w) {
                return i;
            }
            t -= f64::from(w);
        }
    }
    // Rounding carried the target past the end: the last point with weight.
    last.unwrap_or_else(|| weights.iter().rposition(|&w| w > 0.0).unwrap_or(0))
}

/// Moves each point to its nearest centre (ties to the lower index); returns how many moved.
fn assign(
    data: &[f32],
    stride: usize,
    centroids: &[f32],
    assignment: &mut [u16],
    distance: &mut [f32],
    first: bool,
) -> usize {
    let k = centroids.len() / stride;
    data.par_chunks(BLOCK * stride)
        .zip(assignment.par_chunks_mut(BLOCK))
        .zip(distance.par_chunks_mut(BLOCK))
        .map(|((rows, labels), dists)| {
            let mut d = vec![0.0f32; k];
            let mut moved = 0;
            for ((row, label), dist) in rows.chunks_exact(stride).zip(labels).zip(dists) {
                squared_distances(centroids, row, &mut d);
                let mut best = 0;
                for (c, &v) in d.iter().enumerate().skip(1) {
                    if v < d[best] {
                        best = c;
                    }
                }
                if first || *label as usize != best {
                    moved += 1;
                }
                *label = best as u16;
                *dist = d[best];
            }
            moved
        })
        .sum()
}

/// Centres as the means of their points, summed in `f64` per block; an empty cluster takes the
/// point farthest from its centre. Returns the number of clusters re-seeded.
fn update(
    data: &[f32],
    stride: usize,
    centroids: &mut [f32],
    assignment: &[u16],
    distance: &mut [f32],
    k: usize,
) -> usize {
    let partial: Vec<(Vec<f64>, Vec<usize>)> = data
        .par_chunks(BLOCK * stride)
        .zip(assignment.par_chunks(BLOCK))
        .map(|(rows, labels)| {
            let mut sums = vec![0.0f64; k * stride];
            let mut counts = vec![0usize; k];
            for (row, &label) in rows.chunks_exact(stride).zip(labels) {
                let c = label as usize;
                counts[c] += 1;
                for (s, &v) in sums[c * stride..(c + 1) * stride].iter_mut().zip(row) {
                    *s += f64::from(v);
                }
            }
            (sums, counts)
        })
        .collect();
    let mut sums = vec![0.0f64; k * stride];
    let mut counts = vec![0usize; k];
    for (s, c) in &partial {
        for (a, b) in sums.iter_mut().zip(s) {
            *a += b;
        }
        for (a, b) in counts.iter_mut().zip(c) {
            *a += b;
        }
    }
    let mut reseeded = 0;
    for c in 0..k {
        let centre = &mut centroids[c * stride..(c + 1) * stride];
        if counts[c] > 0 {
            let n = counts[c] as f64;
            for (v, s) in centre.iter_mut().zip(&sums[c * stride..(c + 1) * stride]) {
                *v = (s / n) as f32;
            }
        } else {
            let far = (0..distance.len())
                .max_by(|&a, &b| distance[a].total_cmp(&distance[b]).then(b.cmp(&a)))
                .expect("points exist");
            centre.copy_from_slice(&data[far * stride..(far + 1) * stride]);
            distance[far] = 0.0;
            reseeded += 1;
        }
    }
    reseeded
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::search::index::LANES;

    /// Three tight blobs far apart, `LANES` floats per row.
    fn blobs(per: usize) -> Vec<f32> {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut data = Vec::new();
        for b in 0..3 {
            for _ in 0..per {
                let mut row = [0.0f32; LANES];
                row[0] = 100.0 * b as f32 + rng.random::<f32>();
                row[1] = rng.random::<f32>();
                data.extend_from_slice(&row);
            }
        }
        data
    }

    #[test]
    fn finds_separated_blobs() {
        let data = blobs(50);
        let c = kmeans(&data, LANES, 3, 1, 100, &mut |_| {});
        assert!(c.info.converged);
        for b in 0..3 {
            let labels = &c.assignment[b * 50..(b + 1) * 50];
            assert!(labels.iter().all(|&l| l == labels[0]), "blob {b} split");
        }
        assert_ne!(c.assignment[0], c.assignment[50]);
        assert_ne!(c.assignment[50], c.assignment[100]);
        assert!(c.info.inertia < 150.0 * 2.0);
    }

    #[test]
    fn more_clusters_than_distinct_points_still_terminates() {
        let data = vec![1.0f32; 5 * LANES];
        let c = kmeans(&data, LANES, 4, 0, 10, &mut |_| {});
        assert_eq!(c.info.k, 4);
        assert!(c.distance.iter().all(|&d| d == 0.0));
    }

    #[test]
    fn same_result_for_one_and_two_threads() {
        let data = blobs(3000);
        let run = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| kmeans(&data, LANES, 10, 7, 50, &mut |_| {}))
        };
        assert_eq!(run(1), run(2));
    }
}
