//! The self-organising map (Kohonen 1982) that initialises the balanced grid of Garces et al.
//! 2016 (§6.5.2): an `M × N` lattice of weight vectors in the style space, trained so that
//! neighbouring nodes hold similar styles; each item then belongs to its best-matching node.
//!
//! We train the batch SOM (Kohonen 2001, "Self-Organizing Maps", §3.14): each epoch assigns every
//! item to its best-matching unit (BMU, in parallel: each item independently, so the result does
//! not depend on the thread count) and moves each node towards the neighbourhood-weighted mean
//! of the items, `w_j ← (1 − α)·w_j + α·Σ_i h(j, b_i)·x_i / Σ_i h(j, b_i)`, with the Gaussian
//! neighbourhood `h(j, k) = exp(−‖r_j − r_k‖² / 2σ²)` on lattice positions. The radius decays
//! exponentially, `σ(t) = σ₀·(σ_T/σ₀)^{t/(T−1)}`, and the rate linearly from `α₀` to `α_T`
//! (the usual schedules; `α = 1` is the plain batch SOM). The Gaussian is separable, so the
//! smoothing runs along rows then columns, truncated at 3σ.

use rayon::prelude::*;

use super::eigen::top_eigen;
use super::types::{dot, validate_points, validate_shape};
use crate::Result;
use rand::SeedableRng;
use rand::seq::index::sample;
use rand_chacha::ChaCha8Rng;

/// How the node weights start.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SomInit {
    /// A plane spanned by the first two principal components (±2 standard deviations), the
    /// longer grid side along the first (Kohonen 2001, §3.7, linear initialisation).
    Pca,
    /// Distinct items drawn with the seed (items repeat only when there are fewer items than
    /// nodes).
    Random,
}

/// Parameters of [`som`].
#[derive(Clone, Debug, PartialEq)]
pub struct SomParams {
    /// `M`: grid rows.
    pub rows: usize,
    /// `N`: grid columns.
    pub cols: usize,
    /// `T`: epochs (passes over all items). Default 12.
    pub epochs: usize,
    /// `σ₀`: initial neighbourhood radius in nodes; `None` is `max(M, N)/2`.
    pub sigma0: Option<f64>,
    /// `σ_T`: final radius. Default 0.5 (a node and, faintly, its four neighbours).
    pub sigma_end: f64,
    /// `α₀`: initial rate. Default 1 (plain batch SOM).
    pub alpha0: f64,
    /// `α_T`: final rate. Default 0.5.
    pub alpha_end: f64,
    /// Initialisation. Default [`SomInit::Pca`].
    pub init: SomInit,
    /// Seed of the random initialisation and of the eigen-solver's start.
    pub seed: u64,
}

impl SomParams {
    /// Defaults for an `rows × cols` map.
    pub fn new(rows: usize, cols: usize) -> SomParams {
        SomParams {
            rows,
            cols,
            epochs: 12,
            sigma0: None,
            sigma_end: 0.5,
            alpha0: 1.0,
            alpha_end: 0.5,
            init: SomInit::Pca,
            seed: 0,
        }
    }

    fn validate(&self) -> Result<()> {
        validate_shape(self.rows, self.cols)?;
        let bad = |name, value: f64, reason| {
            Err(crate::Error::InvalidParameter {
                name,
                value: value.to_string(),
                reason,
            })
        };
        if self.epochs == 0 || self.epochs > 10_000 {
            return bad("epochs", self.epochs as f64, "between 1 and 10,000");
        }
        if let Some(s) = self.sigma0
            && !(s.is_finite() && s > 0.0)
        {
            return bad("sigma0", s, "a positive radius in nodes");
        }
        if !(self.sigma_end.is_finite() && self.sigma_end > 0.0) {
            return bad("sigma_end", self.sigma_end, "a positive radius in nodes");
        }
        for (name, a) in [("alpha0", self.alpha0), ("alpha_end", self.alpha_end)] {
            if !(a > 0.0 && a <= 1.0) {
                return bad(name, a, "a rate in (0, 1]");
            }
        }
        Ok(())
    }
}

/// A trained map.
#[derive(Clone, Debug)]
pub struct Som {
    /// Rows.
    pub rows: usize,
    /// Columns.
    pub cols: usize,
    /// Coordinates per weight.
    pub dim: usize,
    /// Node weights, row-major nodes, `dim` each.
    pub weights: Vec<f32>,
    /// Best-matching node (`row·cols + col`) of each item after training.
    pub bmu: Vec<usize>,
    /// Mean squared distance of the items to their best-matching node (quantisation error).
    pub quantisation_error: f64,
}

/// Trains an `M × N` SOM on `points` (row-major, `dim` per item).
///
/// Errors: bad shape or parameters, no points, a non-finite coordinate.
pub fn som(points: &[f32], dim: usize, params: &SomParams) -> Result<Som> {
    params.validate()?;
    let n = validate_points(points, dim, None)?;
    let (rows, cols) = (params.rows, params.cols);
    let mut weights = match params.init {
        SomInit::Pca => pca_plane(points, n, dim, rows, cols, params.seed),
        SomInit::Random => {
            let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
            let cells = rows * cols;
            let picks: Vec<usize> = if n >= cells {
                sample(&mut rng, n, cells).into_vec()
            } else {
                (0..cells).map(|k| k % n).collect()
            };
            picks
                .iter()
                .flat_map(|&i| points[i * dim..(i + 1) * dim].iter().copied())
                .collect()
        }
    };
    let sigma0 = params
        .sigma0
        .unwrap_or(rows.max(cols) as f64 / 2.0)
        .max(params.sigma_end);
    let t_last = (params.epochs - 1).max(1) as f64;
    let mut bmu = vec![0usize; n];
    for t in 0..params.epochs {
        let f = t as f64 / t_last;
        let sigma = sigma0 * (params.sigma_end / sigma0).powf(f);
        let alpha = params.alpha0 + (params.alpha_end - params.alpha0) * f;
        best_matching(points, dim, &weights, &mut bmu);
        update(points, dim, rows, cols, &bmu, sigma, alpha, &mut weights);
    }
    let qe = best_matching(points, dim, &weights, &mut bmu);
    Ok(Som {
        rows,
        cols,
        dim,
        weights,
        bmu,
        quantisation_error: qe,
    })
}

/// Sets each item's BMU (lowest node index on ties) and returns the mean squared distance.
/// `‖x − w‖² = ‖x‖² − 2x·w + ‖w‖²`; only the last two terms decide the BMU. The weights are
/// transposed into blocks of 8 nodes so one item meets 8 nodes per vector operation (the lanes
/// are nodes, not coordinates: no horizontal sums in the inner loop).
pub(crate) fn best_matching(points: &[f32], dim: usize, weights: &[f32], bmu: &mut [usize]) -> f64 {
    const L: usize = 8;
    let cells = weights.len() / dim;
    let blocks = cells.div_ceil(L);
    let mut wt = vec![[0f32; L]; blocks * dim];
    let mut norms = vec![[f32::INFINITY; L]; blocks];
    for (j, w) in weights.chunks_exact(dim).enumerate() {
        let (b, l) = (j / L, j % L);
        for (d, v) in w.iter().enumerate() {
            wt[b * dim + d][l] = *v;
        }
        norms[b][l] = dot(w, w);
    }
    let errors: Vec<f64> = bmu
        .par_iter_mut()
        .zip(points.par_chunks_exact(dim))
        .map(|(out, x)| {
            let mut best = (f32::INFINITY, 0usize);
            for (b, (block, norm)) in wt.chunks_exact(dim).zip(&norms).enumerate() {
                let mut acc = [0f32; L];
                for (lanes, &xd) in block.iter().zip(x) {
                    for l in 0..L {
                        acc[l] += lanes[l] * xd;
                    }
                }
                for l in 0..L {
                    let d = norm[l] - 2.0 * acc[l];
                    if d < best.0 {
                        best = (d, b * L + l);
                    }
                }
            }
            *out = best.1;
            (best.0 + dot(x, x)).max(0.0) as f64
        })
        .collect();
    errors.iter().sum::<f64>() / errors.len() as f64
}

#[allow(clippy::too_many_arguments)]
fn update(
    points: &[f32],
    dim: usize,
    rows: usize,
    cols: usize,
    bmu: &[usize],
    sigma: f64,
    alpha: f64,
    weights: &mut [f32],
) {
    // Per-node sums and counts (sequential: a fixed summation order), with the count as an extra
    // coordinate so one smoothing pass handles both.
    let w = dim + 1;
    let mut sums = vec![0.0f64; rows * cols * w];
    for (x, &b) in points.chunks_exact(dim).zip(bmu) {
        let s = &mut sums[b * w..(b + 1) * w];
        for (si, xi) in s.iter_mut().zip(x) {
            *si += *xi as f64;
        }
        s[dim] += 1.0;
    }
    let reach = (3.0 * sigma).ceil() as usize;
    let g: Vec<f64> = (0..=reach)
        .map(|d| (-((d * d) as f64) / (2.0 * sigma * sigma)).exp())
        .collect();
    // Along each row.
    let mut across = vec![0.0f64; rows * cols * w];
    across
        .par_chunks_exact_mut(cols * w)
        .zip(sums.par_chunks_exact(cols * w))
        .for_each(|(out, src)| {
            for c in 0..cols {
                let o = &mut out[c * w..(c + 1) * w];
                for c2 in c.saturating_sub(reach)..(c + reach + 1).min(cols) {
                    let gk = g[c.abs_diff(c2)];
                    for (oi, si) in o.iter_mut().zip(&src[c2 * w..(c2 + 1) * w]) {
                        *oi += gk * si;
                    }
                }
            }
        });
    // Along each column, then the update.
    weights
        .par_chunks_exact_mut(cols * dim)
        .enumerate()
        .for_each(|(r, out)| {
            let mut acc = vec![0.0f64; w];
            for c in 0..cols {
                acc.iter_mut().for_each(|a| *a = 0.0);
                for r2 in r.saturating_sub(reach)..(r + reach + 1).min(rows) {
                    let gk = g[r.abs_diff(r2)];
                    let k = r2 * cols + c;
                    for (ai, si) in acc.iter_mut().zip(&across[k * w..(k + 1) * w]) {
                        *ai += gk * si;
                    }
                }
                if acc[dim] > 1e-12 {
                    let o = &mut out[c * dim..(c + 1) * dim];
                    for (oi, ai) in o.iter_mut().zip(&acc) {
                        let target = ai / acc[dim];
                        *oi = ((1.0 - alpha) * *oi as f64 + alpha * target) as f32;
                    }
                }
            }
        });
}

/// Node weights on the plane of the first two principal components, ±2 standard deviations.
fn pca_plane(
    points: &[f32],
    n: usize,
    dim: usize,
    rows: usize,
    cols: usize,
    seed: u64,
) -> Vec<f32> {
    let mut mean = vec![0.0f64; dim];
    for x in points.chunks_exact(dim) {
        for (m, v) in mean.iter_mut().zip(x) {
            *m += *v as f64;
        }
    }
    mean.iter_mut().for_each(|m| *m /= n as f64);
    let mut cov = vec![0.0f64; dim * dim];
    for x in points.chunks_exact(dim) {
        for i in 0..dim {
            let xi = x[i] as f64 - mean[i];
            for j in 0..=i {
                cov[i * dim + j] += xi * (x[j] as f64 - mean[j]);
            }
        }
    }
    for i in 0..dim {
        for j in 0..=i {
            let v = cov[i * dim + j] / n as f64;
            cov[i * dim + j] = v;
            cov[j * dim + i] = v;
        }
    }
    let k = 2.min(dim);
    let e = top_eigen(dim, k, seed, |x, y| {
        for i in 0..dim {
            y[i] = cov[i * dim..(i + 1) * dim]
                .iter()
                .zip(x)
                .map(|(a, b)| a * b)
                .sum();
        }
    });
    let axis = |a: usize| -> Vec<f64> {
        match (e.vectors.get(a), e.values.get(a)) {
            (Some(v), Some(&l)) => v.iter().map(|c| c * 2.0 * l.max(0.0).sqrt()).collect(),
            _ => vec![0.0; dim],
        }
    };
    // The longer side along the first component.
    let (along_rows, along_cols) = if rows > cols {
        (axis(0), axis(1))
    } else {
        (axis(1), axis(0))
    };
    let span = |i: usize, len: usize| {
        if len > 1 {
            2.0 * i as f64 / (len - 1) as f64 - 1.0
        } else {
            0.0
        }
    };
    let mut w = Vec::with_capacity(rows * cols * dim);
    for r in 0..rows {
        for c in 0..cols {
            let (fr, fc) = (span(r, rows), span(c, cols));
            for d in 0..dim {
                w.push((mean[d] + fr * along_rows[d] + fc * along_cols[d]) as f32);
            }
        }
    }
    w
}
