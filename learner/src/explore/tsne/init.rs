//! The start of the optimisation: the first two principal components scaled to a standard
//! deviation of 1e-4 (openTSNE's default, `initialization="pca"`), or random normal coordinates
//! with that standard deviation.
//!
//! The components come from the covariance matrix (accumulated over fixed blocks of rows in
//! parallel, the blocks' sums added in order) by subspace iteration and a 2×2 Rayleigh–Ritz
//! step; each component's sign is chosen so that its largest coordinate is positive. Nothing
//! depends on the thread count.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use super::params::TsneInit;

/// The standard deviation of the start's first coordinate.
pub(super) const START_STD: f64 = 1e-4;
const ROWS_PER_BLOCK: usize = 2048;

/// Standard normal values (Box–Muller), from the seed.
fn normals(rng: &mut ChaCha8Rng, len: usize) -> Vec<f64> {
    (0..len)
        .map(|_| {
            let u: f64 = 1.0 - rng.random::<f64>();
            let v: f64 = rng.random();
            (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
        })
        .collect()
}

/// The initial embedding.
pub(super) fn initial(points: &[f32], dim: usize, init: TsneInit, seed: u64) -> Vec<[f64; 2]> {
    let n = points.len() / dim;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let random = |rng: &mut ChaCha8Rng| -> Vec<[f64; 2]> {
        normals(rng, 2 * n)
            .chunks_exact(2)
            .map(|c| [c[0] * START_STD, c[1] * START_STD])
            .collect()
    };
    if init == TsneInit::Random {
        return random(&mut rng);
    }
    let mean: Vec<f64> = (0..dim)
        .map(|d| {
            points
                .iter()
                .skip(d)
                .step_by(dim)
                .map(|&v| f64::from(v))
                .sum::<f64>()
                / n as f64
        })
        .collect();
    let components = principal_axes(points, dim, &mean, &mut rng);
    let mut y: Vec<[f64; 2]> = points
        .par_chunks_exact(dim)
        .map(|row| {
            let mut out = [0.0; 2];
            for (c, axis) in components.iter().enumerate() {
                out[c] = row
                    .iter()
                    .zip(&mean)
                    .zip(axis)
                    .map(|((&x, m), a)| (f64::from(x) - m) * a)
                    .sum();
            }
            out
        })
        .collect();
    let std = |y: &[[f64; 2]], c: usize| {
        let m = y.iter().map(|p| p[c]).sum::<f64>() / n as f64;
        (y.iter().map(|p| (p[c] - m).powi(2)).sum::<f64>() / n as f64).sqrt()
    };
    let s0 = std(&y, 0);
    if !(s0.is_finite() && s0 > 0.0) {
        // Constant input: no direction to start from.
        return random(&mut rng);
    }
    for c in 0..2 {
        let largest = y
            .iter()
            .map(|p| p[c])
            .fold(0.0f64, |a, v| if v.abs() > a.abs() { v } else { a });
        if largest < 0.0 {
            y.iter_mut().for_each(|p| p[c] = -p[c]);
        }
    }
    let s1 = std(&y, 1);
    let scale = START_STD / s0;
    y.iter_mut().for_each(|p| {
        p[0] *= scale;
        p[1] *= scale;
    });
    if s1.is_nan() || s1 <= 1e-9 * s0 {
        // Rank one (or one coordinate): the second axis is rounding noise; start it at random.
        for (p, r) in y.iter_mut().zip(normals(&mut rng, n)) {
            p[1] = r * START_STD;
        }
    }
    y
}

/// The two leading eigenvectors of the covariance matrix (unit length; the second is zero for
/// one-dimensional points).
fn principal_axes(points: &[f32], dim: usize, mean: &[f64], rng: &mut ChaCha8Rng) -> [Vec<f64>; 2] {
    if dim == 1 {
        return [vec![1.0], vec![0.0]];
    }
    let partial: Vec<Vec<f64>> = points
        .par_chunks(ROWS_PER_BLOCK * dim)
        .map(|block| {
            let mut c = vec![0.0; dim * dim];
            let mut centred = vec![0.0; dim];
            for row in block.chunks_exact(dim) {
                for ((x, &v), m) in centred.iter_mut().zip(row).zip(mean) {
                    *x = f64::from(v) - m;
                }
                for a in 0..dim {
                    let xa = centred[a];
                    for (cab, xb) in c[a * dim + a..(a + 1) * dim].iter_mut().zip(&centred[a..]) {
                        *cab += xa * xb;
                    }
                }
            }
            c
        })
        .collect();
    let mut c = vec![0.0; dim * dim];
    for part in &partial {
        for (t, v) in c.iter_mut().zip(part) {
            *t += v;
        }
    }
    for a in 0..dim {
        for b in 0..a {
            c[a * dim + b] = c[b * dim + a];
        }
    }
    let times = |v: &[f64]| -> Vec<f64> {
        (0..dim)
            .map(|a| {
                c[a * dim..(a + 1) * dim]
                    .iter()
                    .zip(v)
                    .map(|(x, y)| x * y)
                    .sum()
            })
            .collect()
    };
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let normalise = |v: &mut Vec<f64>| {
        let norm = dot(v, v).sqrt();
        if norm > 0.0 {
            v.iter_mut().for_each(|x| *x /= norm);
        }
    };
    let mut v = [normals(rng, dim), normals(rng, dim)];
    for _ in 0..2000 {
        let mut w = [times(&v[0]), times(&v[1])];
        normalise(&mut w[0]);
        let proj = dot(&w[1], &w[0]);
        let w0 = w[0].clone();
        w[1].iter_mut().zip(&w0).for_each(|(x, y)| *x -= proj * y);
        normalise(&mut w[1]);
        let change = (1.0 - dot(&w[0], &v[0]).abs()).max(1.0 - dot(&w[1], &v[1]).abs());
        v = w;
        if change < 1e-14 {
            break;
        }
    }
    // Rayleigh–Ritz on the 2-D subspace: order (and separate) the two directions.
    let (cv0, cv1) = (times(&v[0]), times(&v[1]));
    let (a, b, d) = (dot(&v[0], &cv0), dot(&v[0], &cv1), dot(&v[1], &cv1));
    let angle = 0.5 * (2.0 * b).atan2(a - d);
    let (cos, sin) = (angle.cos(), angle.sin());
    let first: Vec<f64> = v[0]
        .iter()
        .zip(&v[1])
        .map(|(x, y)| cos * x + sin * y)
        .collect();
    let second: Vec<f64> = v[0]
        .iter()
        .zip(&v[1])
        .map(|(x, y)| -sin * x + cos * y)
        .collect();
    [first, second]
}
