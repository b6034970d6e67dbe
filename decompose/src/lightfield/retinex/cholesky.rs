//! The exact solve of the coarsest multigrid level.

use super::graph::Graph;

/// Cholesky factor of the coarsest level, stored by rows within its band (the largest
/// `|p − q|` of a pair): `n·band²` work to factorise. The aggregates are numbered row-major by
/// grid cell, so the band is about two rows of cells.
pub(super) struct BandCholesky {
    n: usize,
    band: usize,
    /// Row `i` holds `L[i][i − band ..= i]` at `i·(band + 1) ..`.
    factor: Vec<f64>,
}

impl BandCholesky {
    pub fn new(level: &Graph) -> Self {
        let n = level.len();
        let band = (0..n)
            .flat_map(|p| level.row(p).map(move |(q, _)| p.abs_diff(q)))
            .max()
            .unwrap_or(0);
        let stride = band + 1;
        let mut factor = vec![0.0; n * stride];
        // Lower triangle of A: entry (i, j), j ≤ i, at i·stride + band − (i − j).
        for p in 0..n {
            factor[p * stride + band] = level.diagonal()[p];
            for (q, w) in level.row(p) {
                if q < p {
                    factor[p * stride + band - (p - q)] -= w;
                }
            }
        }
        for i in 0..n {
            let lo = i.saturating_sub(band);
            for j in lo..=i {
                let mut s = factor[i * stride + band - (i - j)];
                for k in lo.max(j.saturating_sub(band))..j {
                    s -= factor[i * stride + band - (i - k)] * factor[j * stride + band - (j - k)];
                }
                factor[i * stride + band - (i - j)] = if i == j {
                    // A level's matrix is SPD when μ > 0; the floor only keeps a degenerate
                    // (μ = 0, fully disconnected) level finite.
                    s.max(f64::MIN_POSITIVE).sqrt()
                } else {
                    s / factor[j * stride + band]
                };
            }
        }
        Self { n, band, factor }
    }

    pub fn solve(&self, b: &[f64], x: &mut [f64]) {
        let (n, band, stride) = (self.n, self.band, self.band + 1);
        let y = x;
        y.copy_from_slice(b);
        let l = |i: usize, j: usize| self.factor[i * stride + band - (i - j)];
        for i in 0..n {
            let lo = i.saturating_sub(band);
            let s: f64 = (lo..i).zip(&y[lo..i]).map(|(k, yk)| l(i, k) * yk).sum();
            y[i] = (y[i] - s) / l(i, i);
        }
        for i in (0..n).rev() {
            let hi = (i + band + 1).min(n);
            let s: f64 = (i + 1..hi)
                .zip(&y[i + 1..hi])
                .map(|(k, yk)| l(k, i) * yk)
                .sum();
            y[i] = (y[i] - s) / l(i, i);
        }
    }
}
