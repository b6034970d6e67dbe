//! How well a layout keeps the style distances of the items it shows.
//!
//! * [`spearman`]: Spearman's rank correlation (average ranks for ties, as
//!   `scipy.stats.spearmanr`), and [`layout_spearman`]: between the pairwise style distances and
//!   the pairwise grid distances (Euclidean in rows and columns) of the shown items, over all
//!   pairs up to [`QualityParams::max_pairs`] and over a seeded sample of that many pairs above.
//! * [`dpq`]: the distance preservation quality `DPQ_p` of Barthel et al. 2023, "Improved
//!   evaluation and generation of grid layouts using distance preservation quality and linear
//!   assignment sorting" (Computer Graphics Forum 42(1)), §3. For each shown item and each
//!   `k`, `D̄_k^S` is the mean style distance to its `k` nearest items on the grid (ties in grid
//!   distance taken in increasing style distance, as the authors' code does), `D̄_k^HD` the mean
//!   style distance to its `k` nearest items in style, each averaged over the items, and
//!   `D̄` the mean of all pairwise style distances (the expectation of a random layout). The
//!   gains `ΔD_k = max(0, (D̄ − D̄_k)/D̄)` give `DPQ_p = ‖ΔD^S‖_p / ‖ΔD^HD‖_p` in `[0, 1]`;
//!   `p = 16` (their default) weighs the small neighbourhoods. Above
//!   [`QualityParams::max_anchors`] shown items the averages run over a seeded sample of anchor
//!   items (each still against all shown items).

use rand::seq::index::sample;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::types::{Grid, validate_points};
use crate::{Error, Result};

/// Sampling limits of the quality measures.
#[derive(Clone, Debug, PartialEq)]
pub struct QualityParams {
    /// All pairs up to this many, else a seeded sample of this many. Default 1,000,000.
    pub max_pairs: usize,
    /// All shown items as DPQ anchors up to this many, else a seeded sample. Default 2,000.
    pub max_anchors: usize,
    /// `p` of `DPQ_p`. Default 16.
    pub p: f64,
    /// Seed of the samples.
    pub seed: u64,
}

impl Default for QualityParams {
    fn default() -> Self {
        QualityParams {
            max_pairs: 1_000_000,
            max_anchors: 2_000,
            p: 16.0,
            seed: 0,
        }
    }
}

/// Spearman's rank correlation of two samples of equal length (average ranks for ties).
///
/// Errors: lengths differ, fewer than 2 values, a non-finite value, or a sample with all values
/// tied (the correlation is undefined).
pub fn spearman(a: &[f64], b: &[f64]) -> Result<f64> {
    if a.len() != b.len() {
        return Err(Error::LengthMismatch {
            what: "second sample",
            expected: a.len(),
            got: b.len(),
        });
    }
    if a.len() < 2 {
        return Err(Error::NotEnoughData {
            what: "a rank correlation (values)",
            needed: 2,
            got: a.len(),
        });
    }
    if let Some(v) = a.iter().chain(b).find(|v| !v.is_finite()) {
        return Err(Error::InvalidParameter {
            name: "sample value",
            value: v.to_string(),
            reason: "rank correlation needs finite values",
        });
    }
    let (ra, rb) = (ranks(a), ranks(b));
    let n = a.len() as f64;
    let mean = (n + 1.0) / 2.0;
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in ra.iter().zip(&rb) {
        let (dx, dy) = (x - mean, y - mean);
        sab += dx * dy;
        saa += dx * dx;
        sbb += dy * dy;
    }
    if saa == 0.0 || sbb == 0.0 {
        return Err(Error::ZeroVariance {
            n: a.len(),
            value: if saa == 0.0 { a[0] } else { b[0] },
        });
    }
    Ok(sab / (saa * sbb).sqrt())
}

/// 1-based ranks, ties sharing their average rank.
fn ranks(x: &[f64]) -> Vec<f64> {
    let mut order: Vec<usize> = (0..x.len()).collect();
    order.par_sort_unstable_by(|&i, &j| x[i].total_cmp(&x[j]).then(i.cmp(&j)));
    let mut r = vec![0.0; x.len()];
    let mut start = 0;
    while start < order.len() {
        let mut end = start + 1;
        while end < order.len() && x[order[end]] == x[order[start]] {
            end += 1;
        }
        let average = (start + end + 1) as f64 / 2.0;
        for &i in &order[start..end] {
            r[i] = average;
        }
        start = end;
    }
    r
}

fn style(points: &[f32], dim: usize, i: usize, j: usize) -> f64 {
    points[i * dim..(i + 1) * dim]
        .iter()
        .zip(&points[j * dim..(j + 1) * dim])
        .map(|(a, b)| (*a as f64 - *b as f64).powi(2))
        .sum::<f64>()
        .sqrt()
}

fn shown(points: &[f32], dim: usize, grid: &Grid) -> Result<Vec<(usize, f64, f64)>> {
    let n = validate_points(points, dim, None)?;
    if !grid.holds_each_item_once(n) {
        return Err(Error::LengthMismatch {
            what: "points (the grid does not hold each of them exactly once)",
            expected: grid
                .nodes
                .iter()
                .map(|x| x.hidden.len() + x.shown.is_some() as usize)
                .sum(),
            got: n,
        });
    }
    let s: Vec<(usize, f64, f64)> = grid
        .shown()
        .into_iter()
        .map(|(i, r, c)| (i, r as f64, c as f64))
        .collect();
    if s.len() < 3 {
        return Err(Error::NotEnoughData {
            what: "layout quality (shown items)",
            needed: 3,
            got: s.len(),
        });
    }
    Ok(s)
}

/// Spearman correlation between style and grid distances over pairs of shown items.
///
/// Errors: the grid does not hold the points' items exactly once, fewer than 3 shown items.
pub fn layout_spearman(
    points: &[f32],
    dim: usize,
    grid: &Grid,
    params: &QualityParams,
) -> Result<f64> {
    let s = shown(points, dim, grid)?;
    let m = s.len();
    let all = m * (m - 1) / 2;
    let pairs: Vec<(usize, usize)> = if all <= params.max_pairs {
        (0..m)
            .flat_map(|a| (a + 1..m).map(move |b| (a, b)))
            .collect()
    } else {
        let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
        (0..params.max_pairs)
            .map(|_| {
                let a = rng.random_range(0..m);
                let b = (a + rng.random_range(1..m)) % m;
                (a, b)
            })
            .collect()
    };
    let (d_style, d_grid): (Vec<f64>, Vec<f64>) = pairs
        .par_iter()
        .map(|&(a, b)| {
            let (ia, ra, ca) = s[a];
            let (ib, rb, cb) = s[b];
            (
                style(points, dim, ia, ib),
                ((ra - rb).powi(2) + (ca - cb).powi(2)).sqrt(),
            )
        })
        .unzip();
    spearman(&d_style, &d_grid)
}

/// `DPQ_p` of the shown items (see the module docs).
///
/// Errors: as [`layout_spearman`]; `p` not positive; all shown items at the same style point.
pub fn dpq(points: &[f32], dim: usize, grid: &Grid, params: &QualityParams) -> Result<f64> {
    if !(params.p.is_finite() && params.p > 0.0) {
        return Err(Error::InvalidParameter {
            name: "p",
            value: params.p.to_string(),
            reason: "a positive norm exponent",
        });
    }
    let s = shown(points, dim, grid)?;
    let m = s.len();
    let anchors: Vec<usize> = if m <= params.max_anchors {
        (0..m).collect()
    } else {
        let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
        let mut a = sample(&mut rng, m, params.max_anchors).into_vec();
        a.sort_unstable();
        a
    };
    // Per anchor: the cumulative means of style distances in grid order and in style order, and
    // the mean distance; summed over anchors in a fixed order.
    let per: Vec<(Vec<f64>, Vec<f64>, f64)> = anchors
        .par_iter()
        .map(|&a| {
            let (ia, ra, ca) = s[a];
            let mut by: Vec<(f64, f64)> = (0..m)
                .filter(|&b| b != a)
                .map(|b| {
                    let (ib, rb, cb) = s[b];
                    (
                        (ra - rb).powi(2) + (ca - cb).powi(2),
                        style(points, dim, ia, ib),
                    )
                })
                .collect();
            let mean = by.iter().map(|x| x.1).sum::<f64>() / by.len() as f64;
            by.sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.total_cmp(&y.1)));
            let grid_order = cumulative_means(by.iter().map(|x| x.1));
            let mut hd: Vec<f64> = by.iter().map(|x| x.1).collect();
            hd.sort_unstable_by(f64::total_cmp);
            (grid_order, cumulative_means(hd.into_iter()), mean)
        })
        .collect();
    let k = m - 1;
    let mut d_s = vec![0.0; k];
    let mut d_hd = vec![0.0; k];
    let mut d_mean = 0.0;
    for (g, h, mean) in &per {
        for j in 0..k {
            d_s[j] += g[j];
            d_hd[j] += h[j];
        }
        d_mean += mean;
    }
    let a = per.len() as f64;
    d_mean /= a;
    if d_mean <= 0.0 {
        return Err(Error::ZeroVariance { n: m, value: 0.0 });
    }
    let norm = |d: &[f64]| -> f64 {
        d.iter()
            .map(|x| ((d_mean - x / a) / d_mean).max(0.0).powf(params.p))
            .sum::<f64>()
            .powf(1.0 / params.p)
    };
    Ok(norm(&d_s) / norm(&d_hd))
}

fn cumulative_means(values: impl Iterator<Item = f64>) -> Vec<f64> {
    let mut sum = 0.0;
    values
        .enumerate()
        .map(|(k, v)| {
            sum += v;
            sum / (k + 1) as f64
        })
        .collect()
}
