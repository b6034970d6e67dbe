//! Input affinities P (van der Maaten & Hinton 2008, §2–3.1; van der Maaten 2014, §4.1).
//!
//! For each point `i`, the conditional `p_{j|i} ∝ exp(−β_i ‖x_i − x_j‖²)` over its neighbours,
//! with the precision `β_i = 1/(2σ_i²)` found by bisection so that the entropy `H(P_i)` (in nats)
//! equals `ln Perp` (eq. 4), as scikit-learn's `_binary_search_perplexity` does: start at
//! `β = 1`, double or halve until the target is bracketed, then bisect, until
//! `|H − ln Perp| ≤ 1e-5` or 200 steps. Distances are shifted by the nearest one before the
//! exponential (the same distribution, no underflow when all distances are large).
//!
//! The joint `p_ij = (p_{j|i} + p_{i|j}) / Σ` (eq. 7, normalised by the actual total as
//! scikit-learn does rather than by `2n`) keeps the union of the neighbour lists: a sparse
//! symmetric matrix with one row per point.

use rayon::prelude::*;

use super::knn::Neighbours;

/// Target precision of the entropy, in nats (scikit-learn's `PERPLEXITY_TOLERANCE`).
pub(super) const ENTROPY_TOLERANCE: f64 = 1e-5;
const MAX_STEPS: usize = 200;

/// Symmetric joint input affinities P of t-SNE: sparse rows, entries summing to 1, no diagonal.
#[derive(Clone, Debug, PartialEq)]
pub struct Affinities {
    row_start: Vec<usize>,
    column: Vec<u32>,
    value: Vec<f64>,
}

impl Affinities {
    /// Number of points.
    pub fn n(&self) -> usize {
        self.row_start.len() - 1
    }

    /// Stored (nonzero) entries.
    pub fn nnz(&self) -> usize {
        self.column.len()
    }

    /// Row `i`: the columns (increasing) and their values `p_ij`.
    pub fn row(&self, i: usize) -> (&[u32], &[f64]) {
        let (a, b) = (self.row_start[i], self.row_start[i + 1]);
        (&self.column[a..b], &self.value[a..b])
    }
}

/// The conditional distribution of one point over its neighbours' squared distances `d`, into
/// `p`; returns the entropy reached (nats).
pub(super) fn calibrate_row(d: &[f64], target: f64, p: &mut [f64]) -> f64 {
    let d_min = d.iter().copied().fold(f64::INFINITY, f64::min);
    let (mut beta, mut lo, mut hi) = (1.0f64, f64::NEG_INFINITY, f64::INFINITY);
    let mut entropy = f64::NAN;
    for _ in 0..MAX_STEPS {
        let mut sum = 0.0;
        for (pj, &dj) in p.iter_mut().zip(d) {
            *pj = (-beta * (dj - d_min)).exp();
            sum += *pj;
        }
        let mut weighted = 0.0;
        for (pj, &dj) in p.iter_mut().zip(d) {
            *pj /= sum;
            weighted += (dj - d_min) * *pj;
        }
        entropy = sum.ln() + beta * weighted;
        let diff = entropy - target;
        if diff.abs() <= ENTROPY_TOLERANCE {
            break;
        }
        if diff > 0.0 {
            lo = beta;
            beta = if hi.is_infinite() {
                beta * 2.0
            } else {
                (beta + hi) / 2.0
            };
        } else {
            hi = beta;
            beta = if lo.is_infinite() {
                beta / 2.0
            } else {
                (beta + lo) / 2.0
            };
        }
    }
    entropy
}

/// The conditional affinities `p_{j|i}`, row-major like `neighbours`, and each row's entropy.
pub(super) fn conditional(neighbours: &Neighbours, perplexity: f64) -> (Vec<f64>, Vec<f64>) {
    let k = neighbours.k;
    let target = perplexity.ln();
    let mut p = vec![0.0; neighbours.sq_dist.len()];
    let entropy = p
        .par_chunks_mut(k)
        .zip(neighbours.sq_dist.par_chunks(k))
        .map(|(p, d)| calibrate_row(d, target, p))
        .collect();
    (p, entropy)
}

/// The symmetric joint P from the conditionals (eq. 7 over the union of the neighbour lists).
pub(super) fn symmetrise(neighbours: &Neighbours, conditional: &[f64]) -> Affinities {
    let k = neighbours.k;
    let n = neighbours.index.len() / k;
    let mut rows: Vec<Vec<(u32, f64)>> = (0..n).map(|_| Vec::with_capacity(k + k / 2)).collect();
    for i in 0..n {
        for (&j, &p) in neighbours.index[i * k..(i + 1) * k]
            .iter()
            .zip(&conditional[i * k..(i + 1) * k])
        {
            rows[i].push((j, p));
            rows[j as usize].push((i as u32, p));
        }
    }
    // Each column appears at most twice in a row (p_{j|i} and p_{i|j}); a sum of two terms
    // does not depend on their order, so the merge is deterministic.
    rows.par_iter_mut().for_each(|row| {
        row.sort_unstable_by_key(|e| e.0);
        let mut out = 0;
        for e in 0..row.len() {
            if out > 0 && row[out - 1].0 == row[e].0 {
                row[out - 1].1 += row[e].1;
            } else {
                row[out] = row[e];
                out += 1;
            }
        }
        row.truncate(out);
    });
    let total: f64 = rows
        .iter()
        .map(|r| r.iter().map(|e| e.1).sum::<f64>())
        .sum();
    let mut row_start = Vec::with_capacity(n + 1);
    row_start.push(0);
    let nnz: usize = rows.iter().map(Vec::len).sum();
    let mut column = Vec::with_capacity(nnz);
    let mut value = Vec::with_capacity(nnz);
    for row in rows {
        for (j, p) in row {
            column.push(j);
            value.push(p / total);
        }
        row_start.push(column.len());
    }
    Affinities {
        row_start,
        column,
        value,
    }
}
