//! Unit tests of t-SNE: the calibration, the neighbour search, the gradients, determinism,
//! the start, the quality measures on hand cases, and every error.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::affinity::{ENTROPY_TOLERANCE, conditional, symmetrise};
use super::gradient::{Repulsive, gradient, kl_divergence};
use super::knn::{all_pairs, nearest};
use super::quality::{knn_preservation, trustworthiness};
use super::*;

fn random(n: usize, dim: usize, seed: u64) -> Vec<f32> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n * dim).map(|_| rng.random_range(-1.0..1.0)).collect()
}

/// Three seeded clusters of `n / 3` points in `dim` dimensions.
fn clusters(n: usize, dim: usize, seed: u64) -> Vec<f32> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .flat_map(|i| {
            let c = (i % 3) as f32 * 10.0;
            (0..dim)
                .map(|_| c + rng.random_range(-1.0f32..1.0))
                .collect::<Vec<_>>()
        })
        .collect()
}

#[test]
fn perplexity_calibration_hits_the_target_entropy() {
    let x = random(200, 6, 1);
    for (perplexity, neighbours) in [(5.0, nearest(&x, 6, 15)), (30.0, all_pairs(&x, 6))] {
        let (p, entropy) = conditional(&neighbours, perplexity);
        for (i, (row, h)) in p.chunks(neighbours.k).zip(&entropy).enumerate() {
            // The entropy of the row as stored, recomputed.
            let recomputed: f64 = -row
                .iter()
                .filter(|&&v| v > 0.0)
                .map(|v| v * v.ln())
                .sum::<f64>();
            assert!((recomputed - h).abs() < 1e-9, "row {i}");
            assert!(
                (recomputed - f64::ln(perplexity)).abs() <= ENTROPY_TOLERANCE,
                "row {i}: H = {recomputed}, target ln {perplexity}"
            );
            assert!((row.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        }
        let joint = symmetrise(&neighbours, &p);
        let mut total = 0.0;
        for i in 0..joint.n() {
            let (columns, values) = joint.row(i);
            assert!(columns.windows(2).all(|w| w[0] < w[1]) && !columns.contains(&(i as u32)));
            for (&j, &v) in columns.iter().zip(values) {
                // Symmetric.
                let (cj, vj) = joint.row(j as usize);
                let at = cj.binary_search(&(i as u32)).unwrap();
                assert_eq!(vj[at], v);
                total += v;
            }
        }
        assert!((total - 1.0).abs() < 1e-12);
    }
}

/// The blocked `f32` search finds the same neighbours as a sort of all `f64` distances.
#[test]
fn nearest_neighbours_are_the_exact_ones() {
    // 300 points: several blocks and a partial last block, queries across task boundaries.
    let (n, dim, k) = (300, 7, 12);
    let x = random(n, dim, 2);
    let found = nearest(&x, dim, k);
    let all = all_pairs(&x, dim);
    for i in 0..n {
        let mut pairs: Vec<(f64, u32)> = all.sq_dist[i * (n - 1)..(i + 1) * (n - 1)]
            .iter()
            .copied()
            .zip(all.index[i * (n - 1)..(i + 1) * (n - 1)].iter().copied())
            .collect();
        pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        let expected: Vec<u32> = pairs[..k].iter().map(|p| p.1).collect();
        assert_eq!(&found.index[i * k..(i + 1) * k], &expected[..], "point {i}");
        for (d, p) in found.sq_dist[i * k..(i + 1) * k].iter().zip(&pairs) {
            assert_eq!(*d, p.0);
        }
    }
}

fn embedding(n: usize, seed: u64) -> Vec<[f64; 2]> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| [rng.random_range(-5.0..5.0), rng.random_range(-5.0..5.0)])
        .collect()
}

/// Barnes–Hut with θ = 0 sums every pair: the exact gradient up to rounding; with θ = 0.5 it
/// stays close.
#[test]
fn barnes_hut_with_theta_zero_is_the_exact_gradient() {
    let n = 300;
    let x = random(n, 4, 3);
    let params = TsneParams {
        perplexity: 10.0,
        method: TsneMethod::BarnesHut,
        ..TsneParams::default()
    };
    let p = affinities(&x, 4, &params).unwrap();
    let y = embedding(n, 4);
    let mut exact = vec![[0.0; 2]; n];
    let mut tree = vec![[0.0; 2]; n];
    let mut approx = vec![[0.0; 2]; n];
    gradient(&p, &y, 12.0, Repulsive::Exact, &mut exact);
    gradient(&p, &y, 12.0, Repulsive::BarnesHut(0.0), &mut tree);
    gradient(&p, &y, 12.0, Repulsive::BarnesHut(0.5), &mut approx);
    let norm = |g: &[[f64; 2]]| {
        g.iter()
            .map(|v| v[0] * v[0] + v[1] * v[1])
            .sum::<f64>()
            .sqrt()
    };
    let diff = |a: &[[f64; 2]], b: &[[f64; 2]]| {
        a.iter()
            .zip(b)
            .map(|(u, v)| (u[0] - v[0]).powi(2) + (u[1] - v[1]).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    assert!(diff(&exact, &tree) <= 1e-12 * norm(&exact));
    let relative = diff(&exact, &approx) / norm(&exact);
    assert!(
        relative > 0.0 && relative < 0.05,
        "θ = 0.5: relative error {relative}"
    );
    let kl_exact = kl_divergence(&p, &y, Repulsive::Exact);
    let kl_tree = kl_divergence(&p, &y, Repulsive::BarnesHut(0.0));
    assert!((kl_exact - kl_tree).abs() <= 1e-12 * kl_exact);
}

/// The exact gradient (α = 1) is the derivative of the exact KL divergence.
#[test]
fn gradient_is_the_derivative_of_the_kl_divergence() {
    let n = 60;
    let x = random(n, 3, 5);
    let params = TsneParams {
        perplexity: 8.0,
        method: TsneMethod::Exact,
        ..TsneParams::default()
    };
    let p = affinities(&x, 3, &params).unwrap();
    let mut y = embedding(n, 6);
    let mut g = vec![[0.0; 2]; n];
    gradient(&p, &y, 1.0, Repulsive::Exact, &mut g);
    let h = 1e-6;
    for (i, d) in [(0, 0), (7, 1), (31, 0), (59, 1)] {
        let keep = y[i][d];
        y[i][d] = keep + h;
        let up = kl_divergence(&p, &y, Repulsive::Exact);
        y[i][d] = keep - h;
        let down = kl_divergence(&p, &y, Repulsive::Exact);
        y[i][d] = keep;
        let numeric = (up - down) / (2.0 * h);
        assert!(
            (numeric - g[i][d]).abs() <= 1e-6 * g[i][d].abs().max(1e-3),
            "point {i}, coordinate {d}: analytic {} numeric {numeric}",
            g[i][d]
        );
    }
}

fn run_in_pool(threads: usize, x: &[f32], dim: usize, params: &TsneParams) -> (Vec<[f32; 2]>, f64) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let (y, info) = pool
        .install(|| tsne(x, dim, params, &mut |_, _| {}))
        .unwrap();
    (y, info.kl_divergence)
}

/// The same seed gives the same bits on 1 and 2 threads, for both methods and both starts;
/// another seed gives another (random) start.
#[test]
fn same_seed_same_embedding_on_one_and_two_threads() {
    // 450 points: more than one neighbour-search task (128 queries) and quadtree levels.
    let x = clusters(450, 5, 7);
    for (method, init) in [
        (TsneMethod::Exact, TsneInit::Pca),
        (TsneMethod::BarnesHut, TsneInit::Pca),
        (TsneMethod::BarnesHut, TsneInit::Random),
    ] {
        let params = TsneParams {
            perplexity: 10.0,
            n_iter: 120,
            early_exaggeration_iter: 60,
            method,
            init,
            seed: 11,
            ..TsneParams::default()
        };
        let one = run_in_pool(1, &x, 5, &params);
        let two = run_in_pool(2, &x, 5, &params);
        assert_eq!(one.0, two.0, "{method:?} {init:?}");
        assert_eq!(one.1.to_bits(), two.1.to_bits());
        if init == TsneInit::Random {
            let other = run_in_pool(2, &x, 5, &TsneParams { seed: 12, ..params });
            assert_ne!(one.0, other.0);
        }
    }
}

/// The PCA start lies along the data's main axis with standard deviation 1e-4 there.
#[test]
fn pca_start_follows_the_main_axis() {
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    // Points along (1, 2, 2)/3 with spread 10, plus small noise.
    let x: Vec<f32> = (0..200)
        .flat_map(|_| {
            let t: f32 = rng.random_range(-10.0..10.0);
            let e: [f32; 3] = [
                rng.random_range(-0.1..0.1),
                rng.random_range(-0.1..0.1),
                rng.random_range(-0.1..0.1),
            ];
            [t / 3.0 + e[0], 2.0 * t / 3.0 + e[1], 2.0 * t / 3.0 + e[2]]
        })
        .collect();
    let y = init::initial(&x, 3, TsneInit::Pca, 0);
    let mean = y.iter().map(|p| p[0]).sum::<f64>() / 200.0;
    let std = (y.iter().map(|p| (p[0] - mean).powi(2)).sum::<f64>() / 200.0).sqrt();
    assert!((std - 1e-4).abs() < 1e-12);
    // The first coordinate is the projection on the axis (up to sign and scale): correlation
    // 1 with it; the second (the noise) is much smaller.
    let t: Vec<f64> = x
        .chunks_exact(3)
        .map(|r| f64::from(r[0] + 2.0 * r[1] + 2.0 * r[2]) / 3.0)
        .collect();
    let t_mean = t.iter().sum::<f64>() / 200.0;
    let (mut sty, mut stt, mut syy) = (0.0, 0.0, 0.0);
    for (ti, p) in t.iter().zip(&y) {
        sty += (ti - t_mean) * (p[0] - mean);
        stt += (ti - t_mean).powi(2);
        syy += (p[0] - mean).powi(2);
    }
    let correlation = sty / (stt * syy).sqrt();
    assert!(correlation.abs() > 0.9999, "{correlation}");
    let second = (y.iter().map(|p| p[1] * p[1]).sum::<f64>() / 200.0).sqrt();
    assert!(second < 0.05 * std, "{second}");
}

#[test]
fn quality_measures_on_hand_cases() {
    // Six points on a line, embedded in the same order: perfect.
    let x = [0.0f32, 1.0, 3.0, 6.0, 10.0, 15.0];
    let same: Vec<[f32; 2]> = x.iter().map(|&v| [v, 0.0]).collect();
    assert_eq!(trustworthiness(&x, 1, &same, 2).unwrap(), 1.0);
    assert_eq!(knn_preservation(&x, 1, &same, 2).unwrap(), 1.0);
    // The two ends swapped.
    let swapped: Vec<[f32; 2]> = [15.0f32, 1.0, 3.0, 6.0, 10.0, 0.0]
        .iter()
        .map(|&v| [v, 0.0])
        .collect();
    // By hand (ties in rank by lower index): penalties 3, 3, 1, 0, 3, 3 over 2/(n k (2n − 3k − 1))
    // = 1/30; nearest neighbours kept by points 2, 3, 4 only.
    let t = trustworthiness(&x, 1, &swapped, 2).unwrap();
    assert!((t - (1.0 - 13.0 / 30.0)).abs() < 1e-15, "{t}");
    assert_eq!(knn_preservation(&x, 1, &swapped, 1).unwrap(), 0.5);
}
