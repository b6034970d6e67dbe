//! The few leading eigenpairs of a symmetric matrix, for the first principal components (SOM
//! initialisation) and classical MDS (Isomap): block subspace iteration with a Rayleigh–Ritz step
//! (Saad 2011, "Numerical Methods for Large Eigenvalue Problems", §5.2), and cyclic Jacobi for the
//! small projected matrix. Seeded, so the result is the same for any thread count.

// Index loops read like the matrix formulas they implement.
#![allow(clippy::needless_range_loop)]

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Eigenpairs of a symmetric operator, largest eigenvalue first.
pub(crate) struct Eigen {
    /// Eigenvalues, in decreasing (algebraic) order.
    pub values: Vec<f64>,
    /// Eigenvectors, `values.len()` columns of length `n`, stored one after the other.
    pub vectors: Vec<Vec<f64>>,
}

/// The `k` algebraically largest eigenpairs of the symmetric `n × n` operator `apply`
/// (`apply(x, y)` sets `y = A·x`), assuming they are also among the `k + 2` largest in magnitude
/// (true for covariance matrices and for the double-centred matrix of classical MDS on data that
/// is close to Euclidean). Stops when the Ritz values change by less than 1e-13 relative, or after
/// 3,000 iterations.
pub(crate) fn top_eigen(
    n: usize,
    k: usize,
    seed: u64,
    apply: impl Fn(&[f64], &mut [f64]),
) -> Eigen {
    let b = (k + 2).min(n);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut q: Vec<Vec<f64>> = (0..b)
        .map(|_| (0..n).map(|_| rng.random_range(-1.0..1.0)).collect())
        .collect();
    orthonormalise(&mut q);
    let mut y = vec![vec![0.0; n]; b];
    let mut previous = vec![f64::NAN; b];
    for _ in 0..3000 {
        for (qj, yj) in q.iter().zip(y.iter_mut()) {
            apply(qj, yj);
        }
        let mut h = vec![vec![0.0; b]; b];
        for i in 0..b {
            for j in 0..b {
                h[i][j] = dot(&q[i], &y[j]);
            }
        }
        for i in 0..b {
            for j in 0..i {
                let m = 0.5 * (h[i][j] + h[j][i]);
                h[i][j] = m;
                h[j][i] = m;
            }
        }
        let (vals, vecs) = jacobi(h);
        // Order the Ritz pairs by magnitude so the subspace keeps the dominant directions.
        let mut order: Vec<usize> = (0..b).collect();
        order.sort_by(|&a, &c| vals[c].abs().total_cmp(&vals[a].abs()));
        let values: Vec<f64> = order.iter().map(|&i| vals[i]).collect();
        let rotation: Vec<Vec<f64>> = order
            .iter()
            .map(|&i| (0..b).map(|r| vecs[r][i]).collect())
            .collect();
        let scale = values
            .iter()
            .fold(0.0f64, |m, v| m.max(v.abs()))
            .max(1e-300);
        let converged = values
            .iter()
            .zip(&previous)
            .take(k)
            .all(|(v, p)| (v - p).abs() <= 1e-13 * scale);
        previous = values;
        // q ← orth(Y·V): the images of the Ritz vectors.
        q = combine(&y, &rotation);
        orthonormalise(&mut q);
        if converged {
            break;
        }
    }
    // A last Rayleigh–Ritz step on the final basis gives the Ritz pairs themselves.
    for (qj, yj) in q.iter().zip(y.iter_mut()) {
        apply(qj, yj);
    }
    let mut h = vec![vec![0.0; b]; b];
    for i in 0..b {
        for j in 0..b {
            h[i][j] = 0.5 * (dot(&q[i], &y[j]) + dot(&q[j], &y[i]));
        }
    }
    let (vals, vecs) = jacobi(h);
    let mut order: Vec<usize> = (0..b).collect();
    order.sort_by(|&a, &c| vals[c].total_cmp(&vals[a]));
    order.truncate(k);
    let rot: Vec<Vec<f64>> = order
        .iter()
        .map(|&i| (0..b).map(|r| vecs[r][i]).collect())
        .collect();
    Eigen {
        values: order.iter().map(|&i| vals[i]).collect(),
        vectors: combine(&q, &rot),
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// `Σ_r basis[r] · coefficients[c][r]` for each column `c`.
fn combine(basis: &[Vec<f64>], coefficients: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let n = basis[0].len();
    coefficients
        .iter()
        .map(|c| {
            let mut v = vec![0.0; n];
            for (w, row) in c.iter().zip(basis) {
                for (vi, ri) in v.iter_mut().zip(row) {
                    *vi += w * ri;
                }
            }
            v
        })
        .collect()
}

/// Modified Gram–Schmidt, twice (enough for full working accuracy). A vector that vanishes is
/// replaced by a unit vector along the first coordinate it can still use.
fn orthonormalise(q: &mut [Vec<f64>]) {
    for _ in 0..2 {
        for j in 0..q.len() {
            for i in 0..j {
                let (head, tail) = q.split_at_mut(j);
                let p = dot(&head[i], &tail[0]);
                for (t, h) in tail[0].iter_mut().zip(&head[i]) {
                    *t -= p * h;
                }
            }
            let norm = dot(&q[j], &q[j]).sqrt();
            if norm > 1e-300 {
                q[j].iter_mut().for_each(|v| *v /= norm);
            } else {
                let n = q[j].len();
                q[j] = (0..n).map(|r| if r == j % n { 1.0 } else { 0.0 }).collect();
            }
        }
    }
}

/// Cyclic Jacobi eigen-decomposition of a small symmetric matrix: eigenvalues and the matrix
/// whose columns are the eigenvectors.
pub(crate) fn jacobi(mut a: Vec<Vec<f64>>) -> (Vec<f64>, Vec<Vec<f64>>) {
    let n = a.len();
    let mut v: Vec<Vec<f64>> = (0..n)
        .map(|i| (0..n).map(|j| if i == j { 1.0 } else { 0.0 }).collect())
        .collect();
    for _ in 0..100 {
        let off: f64 = (0..n)
            .flat_map(|i| (0..n).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| a[i][j] * a[i][j])
            .sum();
        let diag: f64 = (0..n).map(|i| a[i][i] * a[i][i]).sum();
        if off <= 1e-32 * diag || off == 0.0 {
            break;
        }
        for p in 0..n {
            for r in p + 1..n {
                if a[p][r] == 0.0 {
                    continue;
                }
                let theta = (a[r][r] - a[p][p]) / (2.0 * a[p][r]);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..n {
                    let (akp, akr) = (a[k][p], a[k][r]);
                    a[k][p] = c * akp - s * akr;
                    a[k][r] = s * akp + c * akr;
                }
                for k in 0..n {
                    let (apk, ark) = (a[p][k], a[r][k]);
                    a[p][k] = c * apk - s * ark;
                    a[r][k] = s * apk + c * ark;
                }
                for row in v.iter_mut() {
                    let (vp, vr) = (row[p], row[r]);
                    row[p] = c * vp - s * vr;
                    row[r] = s * vp + c * vr;
                }
            }
        }
    }
    ((0..n).map(|i| a[i][i]).collect(), v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_eigen_matches_a_diagonalised_matrix() {
        // A = R diag(5, 3, 1, -0.5, 0.1) Rᵀ with a rotation R from Jacobi of a random matrix.
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let n = 5;
        let mut s = vec![vec![0.0; n]; n];
        for i in 0..n {
            for j in 0..=i {
                let x: f64 = rng.random_range(-1.0..1.0);
                s[i][j] = x;
                s[j][i] = x;
            }
        }
        let (_, r) = jacobi(s);
        let d = [5.0, 3.0, 1.0, -0.5, 0.1];
        let a: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| (0..n).map(|k| r[i][k] * d[k] * r[j][k]).sum())
                    .collect()
            })
            .collect();
        let e = top_eigen(n, 2, 1, |x, y| {
            for i in 0..n {
                y[i] = dot(&a[i], x);
            }
        });
        assert!((e.values[0] - 5.0).abs() < 1e-10, "{:?}", e.values);
        assert!((e.values[1] - 3.0).abs() < 1e-10, "{:?}", e.values);
        for (c, v) in e.vectors.iter().enumerate() {
            let truth: Vec<f64> = (0..n).map(|i| r[i][c]).collect();
            assert!((dot(v, &truth).abs() - 1.0).abs() < 1e-9);
        }
    }
}
