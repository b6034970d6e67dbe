use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;

fn random_lf(rows: usize, cols: usize, w: u32, h: u32, c: usize, seed: u64) -> LightField {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = rows * cols * w as usize * h as usize * c;
    // Piecewise structure plus noise, so that the minimiser is neither f nor a constant.
    let data = (0..n)
        .map(|i| {
            let x = (i / c) % w as usize;
            let base = if x < w as usize / 2 { 0.2 } else { 0.7 };
            base + 0.3 * rng.random::<f32>()
        })
        .collect();
    LightField::from_vec(rows, cols, w, h, c, data).unwrap()
}

/// Eq. 4.3 minimised by the linearised ADMM (run long, in `f32`) and by the exact-ADMM
/// reference (`f64`, duality gap below 1e-9 relative) agree to 1e-6 relative. ρ is the one
/// that converges fastest for each case (measured), which matters only for the test's time.
fn check_against_reference(c: usize, beta: f32, rho: f32, iterations: usize, seed: u64) {
    check_shape_against_reference([3, 3, 4, 5], c, beta, rho, iterations, seed);
}

fn check_shape_against_reference(
    shape: [usize; 4],
    c: usize,
    beta: f32,
    rho: f32,
    iterations: usize,
    seed: u64,
) {
    let [rows, cols, h, w] = shape;
    let lf = random_lf(rows, cols, w as u32, h as u32, c, seed);
    let params = TvL1Params {
        beta,
        rho,
        iterations,
        tolerance: 0.0,
    };
    let (u, info) = tv_l1(&lf, &params).unwrap();
    let f64s: Vec<f64> = lf.data().iter().map(|&v| f64::from(v)).collect();
    let r = reference::solve(shape, c, &f64s, f64::from(beta), 1e-9, 200_000);
    let gap = (r.primal - r.dual) / r.primal;
    assert!(
        gap <= 1e-9,
        "reference not certified: gap {gap:e} after {} iterations",
        r.iterations
    );
    let ours = objective(&u, &lf, &params);
    assert_eq!(ours, info.objective);
    let rel = (ours - r.primal) / r.primal;
    assert!(
        rel.abs() <= 1e-6,
        "c={c} β={beta}: ours {ours} vs reference {} (rel {rel:e}, {} iterations, change {})",
        r.primal,
        info.iterations,
        info.max_change
    );
    // Ours never beats the certified lower bound by more than f32 rounding.
    assert!(ours >= r.dual * (1.0 - 1e-7));
    // At the paper's β = 0.05 a field this small is flattened to a constant (2/β ≫ 5 px).
    if beta == 0.05 {
        let first = &u.data()[..c];
        assert!(
            u.data()
                .chunks(c)
                .all(|p| p.iter().zip(first).all(|(a, b)| (a - b).abs() < 1e-4))
        );
    }
}

#[test]
fn matches_reference_one_channel_paper_beta() {
    check_against_reference(1, 0.05, 0.1, 3000, 1);
}

#[test]
fn matches_reference_one_channel() {
    check_against_reference(1, 0.5, 1.0, 3000, 2);
    check_against_reference(1, 1.5, 3.0, 3000, 3);
}

/// Degenerate grids: one view (a plain image), one row of views, one column of views.
#[test]
fn matches_reference_on_degenerate_grids() {
    check_shape_against_reference([1, 1, 6, 7], 3, 0.7, 3.0, 3000, 7);
    check_shape_against_reference([1, 4, 5, 3], 1, 0.7, 3.0, 3000, 8);
    check_shape_against_reference([4, 1, 3, 5], 1, 0.7, 3.0, 3000, 9);
}

#[test]
fn matches_reference_three_channels_paper_beta() {
    check_against_reference(3, 0.05, 0.1, 3000, 4);
}

#[test]
fn matches_reference_three_channels() {
    check_against_reference(3, 0.5, 3.0, 3000, 5);
    check_against_reference(3, 1.5, 3.0, 1000, 6);
}

#[test]
fn commutes_bit_identically_with_angular_transpose() {
    let lf = random_lf(3, 2, 6, 5, 3, 7);
    let params = TvL1Params {
        beta: 0.4,
        iterations: 200,
        ..TvL1Params::default()
    };
    let (a, info_a) = tv_l1(&lf, &params).unwrap();
    let (b, info_b) = tv_l1(&lf.angular_transpose(), &params).unwrap();
    assert_eq!(a.angular_transpose(), b);
    assert_eq!(info_a.iterations, info_b.iterations);
    assert_eq!(info_a.max_change, info_b.max_change);
    assert!((info_a.objective - info_b.objective).abs() <= 1e-12 * info_a.objective);
}

#[test]
fn constant_light_field_is_a_fixed_point() {
    for c in [1, 3] {
        let n = 2 * 3 * 4 * 5 * c;
        let lf = LightField::from_vec(2, 3, 5, 4, c, vec![0.375; n]).unwrap();
        let (u, info) = tv_l1(&lf, &TvL1Params::default()).unwrap();
        assert_eq!(u, lf);
        assert_eq!(info.objective, 0.0);
        assert_eq!(info.max_change, 0.0);
        assert!(info.converged);
        assert_eq!(info.iterations, 1);
    }
}

/// TV-L1's scale property: at β = 1 a structure constant over the views is flattened when its
/// radius is below about 2/β = 2 px and kept when well above.
#[test]
fn small_speck_removed_large_disc_kept() {
    let (w, h, c) = (24u32, 24u32, 3usize);
    let mut lf = LightField::new(2, 2, w, h, c);
    let [_, sc, sy, sx] = lf.strides();
    let (bg, disc, speck) = ([0.2, 0.3, 0.4], [0.8, 0.6, 0.5], [1.0, 1.0, 1.0]);
    for v in 0..4 {
        for y in 0..h as usize {
            for x in 0..w as usize {
                let (dx, dy) = (x as f32 - 8.0, y as f32 - 12.0);
                let value = if (x, y) == (20, 4) {
                    speck
                } else if dx * dx + dy * dy <= 49.0 {
                    disc
                } else {
                    bg
                };
                let p = v * sc + y * sy + x * sx;
                lf.data_mut()[p..p + c].copy_from_slice(&value);
            }
        }
    }
    let params = TvL1Params {
        beta: 1.0,
        iterations: 3000,
        tolerance: 1e-6,
        ..TvL1Params::default()
    };
    let (u, _) = tv_l1(&lf, &params).unwrap();
    for v in 0..4 {
        let at = |x: usize, y: usize| {
            let p = v * sc + y * sy + x * sx;
            u.data()[p..p + c].to_vec()
        };
        for k in 0..c {
            assert!(
                (at(20, 4)[k] - bg[k]).abs() < 1e-3,
                "speck kept: {:?}",
                at(20, 4)
            );
            assert!(
                (at(8, 12)[k] - disc[k]).abs() < 1e-3,
                "disc lost: {:?}",
                at(8, 12)
            );
            assert!((at(2, 20)[k] - bg[k]).abs() < 1e-3);
        }
    }
}

#[test]
fn result_does_not_depend_on_the_thread_count() {
    let lf = random_lf(3, 3, 7, 6, 3, 9);
    let params = TvL1Params {
        beta: 0.3,
        iterations: 150,
        ..TvL1Params::default()
    };
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| tv_l1(&lf, &params).unwrap());
    let global = tv_l1(&lf, &params).unwrap();
    assert_eq!(one.0, global.0);
    assert_eq!(one.1, global.1);
}

/// The sweep's chunking (which follows the thread count) does not change a single bit.
#[test]
fn result_does_not_depend_on_the_chunking() {
    // Lines of 11·6·3 = 198 values: one full block of the dual kernel (192) and a short one
    // (6) in which the angular and x neighbours leave the line.
    let lf = random_lf(2, 3, 11, 7, 3, 11);
    let g = grid(&lf);
    let run = |chunk_lines: usize| {
        let mut s = admm::State::with_chunk_lines(g, lf.data(), chunk_lines);
        let changes: Vec<f32> = (0..60).map(|_| s.iterate(1.3, 0.04, 0.02)).collect();
        (s.into_u(), changes)
    };
    let one = run(1);
    for chunk_lines in [2, 3, 7, 100] {
        assert_eq!(run(chunk_lines), one, "chunk_lines = {chunk_lines}");
    }
}

#[test]
fn objective_of_the_data_is_its_total_variation() {
    // 1×2 views of 2×1 pixels, one channel: u = [[0, 1], [3, 3]].
    let f = LightField::from_vec(1, 2, 2, 1, 1, vec![0.0, 1.0, 3.0, 3.0]).unwrap();
    let p = TvL1Params::default();
    // Ray (0,0,0,0): col diff 3, x diff 1 → √10; ray (0,0,0,1): col diff 2 → 2; view 2: x 0.
    let expected = 10f64.sqrt() + 2.0;
    assert!((objective(&f, &f, &p) - expected).abs() < 1e-12);
    let zero = LightField::new(1, 2, 2, 1, 1);
    assert!((objective(&zero, &f, &p) - f64::from(p.beta) * 7.0).abs() < 1e-12);
}

#[test]
fn bad_params_and_empty_input_are_refused() {
    let lf = random_lf(2, 2, 3, 3, 1, 10);
    let bad = [
        TvL1Params {
            beta: 0.0,
            ..TvL1Params::default()
        },
        TvL1Params {
            rho: f32::NAN,
            ..TvL1Params::default()
        },
        TvL1Params {
            iterations: 0,
            ..TvL1Params::default()
        },
        TvL1Params {
            tolerance: -1.0,
            ..TvL1Params::default()
        },
    ];
    for p in bad {
        assert!(matches!(tv_l1(&lf, &p), Err(Error::InvalidParam { .. })));
    }
    let empty = LightField::new(0, 0, 0, 0, 1);
    assert!(tv_l1(&empty, &TvL1Params::default()).is_err());
}

/// Unknown samples have no fidelity term: a hole of wrong values in a smooth ramp is filled
/// from its neighbours (in the views and across them), the known samples hardly move, and the
/// reported objective leaves the hole's fidelity out.
#[test]
fn unknown_samples_are_filled_in() {
    let (rows, cols, w, h) = (3usize, 3usize, 12u32, 10u32);
    let n = rows * cols * (w * h) as usize;
    let ramp = |i: usize| 0.2 + 0.05 * (i % w as usize) as f32;
    let mut data: Vec<f32> = (0..n).map(ramp).collect();
    let mut unknown = vec![false; n];
    for v in 0..rows * cols {
        for y in 4..6 {
            for x in 5..7 {
                let i = v * (w * h) as usize + y * w as usize + x;
                data[i] = 5.0;
                unknown[i] = true;
            }
        }
    }
    let lf = LightField::from_vec(rows, cols, w, h, 1, data).unwrap();
    let params = TvL1Params {
        beta: 3.0,
        rho: 3.0,
        iterations: 2000,
        tolerance: 0.0,
    };
    let (u, info) = tv_l1_with_unknown(&lf, &unknown, &params).unwrap();
    for (i, (&v, &hole)) in u.data().iter().zip(&unknown).enumerate() {
        let want = ramp(i);
        let tol = if hole { 0.06 } else { 0.02 };
        assert!(
            (v - want).abs() <= tol,
            "sample {i} (hole {hole}): {v} vs {want}"
        );
    }
    assert_eq!(info.objective, objective_known(&u, &lf, &params, &unknown));
    assert!(info.objective < objective(&u, &lf, &params));
    // Without the flags the wrong values stay: at β = 3 removing the 2×2 patch from the 9
    // views costs more fidelity (3·4·9) than its total variation (8·9) per unit of height.
    let (kept, _) = tv_l1(&lf, &params).unwrap();
    let hole = unknown.iter().position(|&h| h).unwrap();
    assert!(kept.data()[hole] > 1.0);
    assert!(tv_l1_with_unknown(&lf, &unknown[1..], &params).is_err());
}
