//! Tests of the disparity-sheared filter against an independent solver and the plain filter.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;

fn random_field(rows: usize, cols: usize, w: u32, h: u32, seed: u64) -> LightField {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = rows * cols * (w * h) as usize;
    let data = (0..n)
        .map(|i| {
            let x = i % w as usize;
            (if x < w as usize / 2 { 0.2 } else { 0.7 }) + 0.3 * rng.random::<f32>()
        })
        .collect();
    LightField::from_vec(rows, cols, w, h, 1, data).unwrap()
}

/// A disparity field with two depths and a few odd rays, so that edges exist, are cut at the
/// depth step, and leave the view at the borders.
fn two_depths(rows: usize, cols: usize, w: u32, h: u32) -> LightField {
    let n = rows * cols * (w * h) as usize;
    let data = (0..n)
        .map(|i| {
            let x = i % w as usize;
            if i % 17 == 5 {
                0.2
            } else if x < w as usize / 2 {
                1.1
            } else {
                -0.7
            }
        })
        .collect();
    LightField::from_vec(rows, cols, w, h, 1, data).unwrap()
}

/// The sheared energy minimised by an independent `f64` primal–dual solver on an explicit edge
/// list, stopped on a duality-gap certificate (as in `reference.rs`: with `‖y_p‖ ≤ 1` and
/// `|∇ᵀy| ≤ β`, `⟨f, ∇ᵀy⟩` bounds `min E` from below). Returns (primal, dual).
fn reference(f: &LightField, disparity: &LightField, beta: f64) -> (f64, f64) {
    let (rows, cols) = (f.rows(), f.cols());
    let (w, h) = (f.width() as i64, f.height() as i64);
    let n = (w * h) as usize;
    let shift = |i: usize| disparity.data()[i].round() as i64;
    let index = |v: usize, y: i64, x: i64| v * n + (y * w + x) as usize;
    // edges[a] = (from, to) along axis a (row, col, y, x).
    let mut edges: Vec<(usize, usize, usize)> = Vec::new();
    for v in 0..rows * cols {
        let (r, c) = (v / cols, v % cols);
        for y in 0..h {
            for x in 0..w {
                let i = index(v, y, x);
                let k = shift(i);
                // Angular edges only between rays of one rounded disparity.
                let mut angular = |a: usize, view: usize, yy: i64, xx: i64| {
                    if (0..h).contains(&yy) && (0..w).contains(&xx) {
                        let j = index(view, yy, xx);
                        if shift(j) == k {
                            edges.push((a, i, j));
                        }
                    }
                };
                if r + 1 < rows {
                    angular(0, v + cols, y - k, x);
                }
                if c + 1 < cols {
                    angular(1, v + 1, y, x - k);
                }
                if y + 1 < h {
                    edges.push((2, i, index(v, y + 1, x)));
                }
                if x + 1 < w {
                    edges.push((3, i, index(v, y, x + 1)));
                }
            }
        }
    }
    let len = f.data().len();
    let fd: Vec<f64> = f.data().iter().map(|&v| f64::from(v)).collect();
    let grad = |u: &[f64]| {
        let mut g = vec![0.0; 4 * len];
        for &(a, i, j) in &edges {
            g[4 * i + a] = u[j] - u[i];
        }
        g
    };
    let grad_t = |g: &[f64]| {
        let mut out = vec![0.0; len];
        for &(a, i, j) in &edges {
            out[j] += g[4 * i + a];
            out[i] -= g[4 * i + a];
        }
        out
    };
    let energy = |u: &[f64]| {
        let g = grad(u);
        (0..len)
            .map(|i| {
                let s: f64 = g[4 * i..4 * i + 4].iter().map(|v| v * v).sum();
                s.sqrt() + beta * (u[i] - fd[i]).abs()
            })
            .sum::<f64>()
    };
    let (sigma, tau) = (1.0, 1.0 / 16.0);
    let mut u = fd.clone();
    let mut ubar = u.clone();
    let mut y = vec![0.0; 4 * len];
    let (mut primal, mut dual) = (f64::INFINITY, f64::NEG_INFINITY);
    for it in 0..400_000 {
        let g = grad(&ubar);
        for i in 0..len {
            let t: Vec<f64> = (0..4)
                .map(|a| y[4 * i + a] + sigma * g[4 * i + a])
                .collect();
            let norm = t.iter().map(|v| v * v).sum::<f64>().sqrt().max(1.0);
            for a in 0..4 {
                y[4 * i + a] = t[a] / norm;
            }
        }
        let gt = grad_t(&y);
        for i in 0..len {
            let old = u[i];
            let d = old - tau * gt[i] - fd[i];
            let new = fd[i] + (d - d.clamp(-tau * beta, tau * beta));
            u[i] = new;
            ubar[i] = 2.0 * new - old;
        }
        if it % 1000 == 999 {
            primal = energy(&u);
            let gt = grad_t(&y);
            let scale = gt.iter().fold(1.0f64, |m, v| m.max(v.abs() / beta));
            dual = gt.iter().zip(&fd).map(|(g, f)| g / scale * f).sum();
            if (primal - dual) / primal < 1e-9 {
                break;
            }
        }
    }
    (primal, dual)
}

#[test]
fn matches_an_independent_solver_with_two_depths() {
    let (rows, cols, w, h) = (3, 3, 6, 5);
    let f = random_field(rows, cols, w, h, 11);
    let d = two_depths(rows, cols, w, h);
    for (beta, rho) in [(0.5f32, 0.3f32), (1.5, 1.0)] {
        let params = TvL1Params {
            beta,
            rho,
            iterations: 20000,
            tolerance: 0.0,
        };
        let (u, info) = tv_l1_sheared(&f, &d, None, &params).unwrap();
        let (primal, dual) = reference(&f, &d, f64::from(beta));
        assert!((primal - dual) / primal < 1e-9, "reference not certified");
        let ours = objective_sheared(&u, &f, &d, None, beta).unwrap();
        assert_eq!(ours, info.objective);
        let rel = (ours - primal) / primal;
        assert!(
            rel.abs() <= 1e-6,
            "β={beta}: ours {ours} vs reference {primal} (rel {rel:e})"
        );
    }
}

#[test]
fn zero_disparity_gives_the_plain_filter() {
    let f = random_field(3, 2, 5, 4, 12);
    let zero = LightField::new(3, 2, 5, 4, 1);
    let params = TvL1Params {
        beta: 0.5,
        rho: 1.0,
        iterations: 4000,
        tolerance: 0.0,
    };
    let (a, _) = tv_l1_sheared(&f, &zero, None, &params).unwrap();
    let (b, _) = tv_l1(&f, &params).unwrap();
    // The same energy: each solution scores the same under the other's objective.
    let ea = objective(&a, &f, &params);
    let eb = objective_sheared(&b, &f, &zero, None, params.beta).unwrap();
    assert!((ea - objective(&b, &f, &params)).abs() <= 1e-6 * ea);
    assert!((eb - objective_sheared(&a, &f, &zero, None, params.beta).unwrap()).abs() <= 1e-6 * eb);
}

/// Views of one textured plane with 1 px of disparity, each with its own noise: after the
/// method's early-stopped filter (β 0.3, ρ 3, 30 iterations), the rays of one point agree far
/// better when the angular differences follow the disparity.
#[test]
fn keeps_a_shifted_plane_coherent() {
    let (rows, cols, w, h) = (5usize, 5usize, 40u32, 32u32);
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    let texture = |x: i64, y: i64| {
        if (x.div_euclid(5) + y.div_euclid(5)) % 2 == 0 {
            0.0
        } else {
            1.0
        }
    };
    let (rc, cc) = ((rows / 2) as i64, (cols / 2) as i64);
    let mut data = Vec::new();
    for v in 0..rows * cols {
        let (r, c) = ((v / cols) as i64, (v % cols) as i64);
        for y in 0..h as i64 {
            for x in 0..w as i64 {
                // Disparity 1: the point at x in the centre column is at x − (c − cc) here.
                data.push(texture(x + (c - cc), y + (r - rc)) + 0.05 * rng.random::<f32>());
            }
        }
    }
    let f = LightField::from_vec(rows, cols, w, h, 1, data).unwrap();
    let disparity = LightField::from_vec(rows, cols, w, h, 1, vec![1.0; f.data().len()]).unwrap();
    let params = TvL1Params {
        beta: 0.3,
        rho: 3.0,
        iterations: 30,
        tolerance: 0.0,
    };
    let spread = |u: &LightField| {
        // Variance across views of each interior centre point, averaged.
        let mut total = 0.0f64;
        let mut count = 0;
        for y in 4..h as i64 - 4 {
            for x in 4..w as i64 - 4 {
                let vals: Vec<f64> = (0..rows * cols)
                    .map(|v| {
                        let (r, c) = ((v / cols) as i64, (v % cols) as i64);
                        let (xx, yy) = (x - (c - cc), y - (r - rc));
                        f64::from(u.view_data(v)[(yy * w as i64 + xx) as usize])
                    })
                    .collect();
                let m = vals.iter().sum::<f64>() / vals.len() as f64;
                total += vals.iter().map(|v| (v - m).powi(2)).sum::<f64>() / vals.len() as f64;
                count += 1;
            }
        }
        total / count as f64
    };
    let (sheared, _) = tv_l1_sheared(&f, &disparity, None, &params).unwrap();
    let (plain, _) = tv_l1(&f, &params).unwrap();
    let (s, p, input) = (spread(&sheared), spread(&plain), spread(&f));
    assert!(s < 0.5 * input, "sheared {s} vs input {input}");
    assert!(s < 0.25 * p, "sheared {s} vs plain {p} (input {input})");
}

#[test]
fn bad_inputs_are_refused() {
    let f = random_field(2, 2, 4, 3, 1);
    let params = TvL1Params::default();
    let rgb = LightField::new(2, 2, 4, 3, 3);
    let d = LightField::new(2, 2, 4, 3, 1);
    assert!(tv_l1_sheared(&rgb, &d, None, &params).is_err());
    assert!(tv_l1_sheared(&f, &LightField::new(2, 2, 3, 4, 1), None, &params).is_err());
    let mut nan = d.clone();
    nan.data_mut()[3] = f32::NAN;
    assert!(tv_l1_sheared(&f, &nan, None, &params).is_err());
    let bad = TvL1Params {
        beta: -1.0,
        ..params
    };
    assert!(tv_l1_sheared(&f, &d, None, &bad).is_err());
}

/// As for the plain filter: a hole marked unknown is filled from the surface around it.
#[test]
fn unknown_rays_are_filled_in() {
    let (rows, cols, w, h) = (3usize, 3usize, 12u32, 10u32);
    let n = rows * cols * (w * h) as usize;
    let mut data = vec![0.5f32; n];
    let mut unknown = vec![false; n];
    for v in 0..rows * cols {
        let i = v * (w * h) as usize + 5 * w as usize + 6;
        data[i] = -4.0;
        unknown[i] = true;
    }
    let f = LightField::from_vec(rows, cols, w, h, 1, data).unwrap();
    let d = LightField::from_vec(rows, cols, w, h, 1, vec![1.0; n]).unwrap();
    // β = 6: without the flags the one-ray hole of every view is held by its data (fidelity
    // 6 per view against a total variation of 4).
    let params = TvL1Params {
        beta: 6.0,
        rho: 3.0,
        iterations: 500,
        tolerance: 0.0,
    };
    let (u, info) = tv_l1_sheared(&f, &d, Some(&unknown), &params).unwrap();
    assert!(
        u.data().iter().all(|v| (v - 0.5).abs() < 1e-3),
        "{:?}",
        &u.data()[..20]
    );
    assert!(info.objective < 1e-2);
    let (kept, _) = tv_l1_sheared(&f, &d, None, &params).unwrap();
    assert!(kept.data().iter().any(|&v| v < 0.0));
    assert!(tv_l1_sheared(&f, &d, Some(&unknown[1..]), &params).is_err());
}
