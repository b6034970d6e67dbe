//! Tests of the per-view solve: against the crate's sparse direct solver, between the two
//! preconditioners, and of the multigrid pieces (Galerkin operator, symmetry, coarsest solve).

use super::multigrid::Cycle;
use super::*;
use crate::solver::{LinearSystem, SolverParams};

fn pseudo_random(n: usize, seed: u64) -> Vec<f32> {
    let mut s = seed;
    (0..n)
        .map(|_| {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (s >> 40) as f32 / (1u64 << 24) as f32
        })
        .collect()
}

/// The minimiser of the module docs' energy from the crate's sparse Cholesky solver, with the
/// energy written as weighted least-squares equations (an independent assembly of the system).
fn direct_solution(i: &[f32], albedo: &PairWeights, occlusion: &PairWeights, mu: f64) -> Vec<f64> {
    let ones = vec![1.0; i.len()];
    direct_solution_weighted(i, i, &ones, albedo, occlusion, mu)
}

/// [`direct_solution`] with the data term `μ Σ w_p (s_p − t_p)²`.
fn direct_solution_weighted(
    i: &[f32],
    target: &[f32],
    weight: &[f32],
    albedo: &PairWeights,
    occlusion: &PairWeights,
    mu: f64,
) -> Vec<f64> {
    let (w, h) = (occlusion.width, occlusion.height);
    let mut sys = LinearSystem::new(w * h);
    let mut pair = |p: usize, q: usize, o: f32, a: f32| {
        let d = (i[p] - i[q]) as f64;
        sys.add(&[(p, 1.0), (q, -1.0)], d, (o * (1.0 - a)) as f64);
        sys.add(&[(p, 1.0), (q, -1.0)], 0.0, (o * a) as f64);
    };
    for y in 0..h {
        for x in 0..w {
            let p = y * w + x;
            if x + 1 < w {
                pair(p, p + 1, occlusion.horizontal[p], albedo.horizontal[p]);
            }
            if y + 1 < h {
                pair(p, p + w, occlusion.vertical[p], albedo.vertical[p]);
            }
        }
    }
    for (p, (&tp, &wp)) in target.iter().zip(weight).enumerate() {
        sys.add(&[(p, 1.0)], tp as f64, mu * wp as f64);
    }
    let params = SolverParams {
        damping: 0.0,
        tolerance: 1e-12,
        ..Default::default()
    };
    sys.solve(&params).unwrap().0
}

/// Random intensities, albedo cue and occlusion weights 1 or 0.01 on a `w × h` view.
fn random_view(w: usize, h: usize, seed: u64) -> (Vec<f32>, PairWeights, PairWeights) {
    let n = w * h;
    let i = pseudo_random(n, seed);
    let a_raw = pseudo_random(n, seed + 1);
    let albedo = PairWeights::from_pairs(w, h, |p, _| (a_raw[p] > 0.6) as u8 as f32);
    let o_raw = pseudo_random(n, seed + 2);
    let occlusion = PairWeights::from_pairs(w, h, |p, _| if o_raw[p] > 0.8 { 0.01 } else { 1.0 });
    (i, albedo, occlusion)
}

/// Multigrid with a tiny coarsest level, so that even small grids get several (odd) levels.
fn deep_multigrid() -> Preconditioner {
    Preconditioner::Multigrid(MultigridParams {
        coarsest_size: 4,
        ..Default::default()
    })
}

/// Solves with both preconditioners to a tight tolerance and compares with `direct`.
fn assert_both_preconditioners_match(
    i: &[f32],
    data: (&[f32], Option<&[f32]>),
    cues: (&PairWeights, &PairWeights),
    mu: f64,
    direct: &[f64],
) {
    let (w, h) = (cues.1.width, cues.1.height);
    for preconditioner in [Preconditioner::Jacobi, deep_multigrid()] {
        let params = ViewSolveParams {
            mu,
            tolerance: 1e-12,
            preconditioner: preconditioner.clone(),
            ..Default::default()
        };
        let (s, info) = solve_view_with_target(i, data.0, data.1, cues.0, cues.1, i, &params);
        assert!(info.converged, "{w}×{h} {preconditioner:?}: {info:?}");
        for (a, b) in s.iter().zip(direct) {
            assert!((*a as f64 - b).abs() < 1e-5, "{w}×{h}: {a} vs {b}");
        }
    }
}

#[test]
fn both_preconditioners_match_the_sparse_direct_least_squares_solution() {
    for (w, h, mu) in [(7, 5, 0.05), (13, 11, 1e-3), (6, 17, 1e-3), (33, 9, 1e-3)] {
        let (i, albedo, occlusion) = random_view(w, h, w as u64 * 31 + h as u64);
        let direct = direct_solution(&i, &albedo, &occlusion, mu);
        assert_both_preconditioners_match(&i, (&i, None), (&albedo, &occlusion), mu, &direct);
    }
}

#[test]
fn per_pixel_weights_and_targets_match_the_sparse_direct_solution() {
    let (w, h) = (21, 13);
    let (i, albedo, occlusion) = random_view(w, h, 77);
    // Weights over four orders of magnitude, targets away from the intensity.
    let weight: Vec<f32> = pseudo_random(w * h, 78)
        .iter()
        .map(|r| 10f32.powf(-4.0 * r))
        .collect();
    let target: Vec<f32> = i
        .iter()
        .zip(pseudo_random(w * h, 79))
        .map(|(a, b)| a - b)
        .collect();
    let mu = 0.05;
    let direct = direct_solution_weighted(&i, &target, &weight, &albedo, &occlusion, mu);
    assert_both_preconditioners_match(
        &i,
        (&target, Some(&weight)),
        (&albedo, &occlusion),
        mu,
        &direct,
    );
    // And the weights matter: the uniform solution is elsewhere.
    let uniform = direct_solution_weighted(&i, &target, &vec![1.0; w * h], &albedo, &occlusion, mu);
    let apart = uniform
        .iter()
        .zip(&direct)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(apart > 1e-2, "{apart}");
}

#[test]
fn multigrid_and_jacobi_agree_at_a_tight_tolerance_from_a_warm_start() {
    // The solution differs from the exact one by at most ‖A⁻¹‖·tolerance·‖b‖; both solvers
    // must land within that of each other from the same (imperfect) start.
    let (w, h) = (40, 27);
    let (i, albedo, occlusion) = random_view(w, h, 5);
    let start: Vec<f32> = i.iter().map(|v| 0.9 * v).collect();
    let solve = |preconditioner| {
        let params = ViewSolveParams {
            mu: 1e-3,
            tolerance: 1e-5,
            preconditioner,
            ..Default::default()
        };
        solve_view(&i, &albedo, &occlusion, &start, &params)
    };
    let (jacobi, ji) = solve(Preconditioner::Jacobi);
    let (mg, mi) = solve(deep_multigrid());
    assert!(ji.converged && mi.converged, "{ji:?} {mi:?}");
    assert!(mi.levels > 3 && ji.levels == 1, "{mi:?}");
    let direct = direct_solution(&i, &albedo, &occlusion, 1e-3);
    let tolerance = 1e-5;
    let bound = tolerance / 1e-3 * 1.0f64.max(direct.iter().map(|v| v.abs()).fold(0.0, f64::max));
    for ((j, m), d) in jacobi.iter().zip(&mg).zip(&direct) {
        assert!((*j as f64 - d).abs() < bound && (*m as f64 - d).abs() < bound);
    }
}

/// A grid level with random pair weights (some 0.01) and screening.
fn random_level(w: usize, h: usize, seed: u64) -> Level {
    let n = w * h;
    Level::new(
        w,
        h,
        pseudo_random(n, seed).iter().map(|v| v + 0.01).collect(),
        pseudo_random(n, seed + 1)
            .iter()
            .map(|v| if *v > 0.3 { 1.0 } else { 0.01 })
            .collect(),
        pseudo_random(n, seed + 2)
            .iter()
            .map(|&v| v as f64 * 1e-2)
            .collect(),
    )
}

/// `PᵀAP` with `P` the 0/1 matrix of `aggregate`, from dense matrices.
fn galerkin(a: &[Vec<f64>], aggregate: &[u32], coarse: usize) -> Vec<Vec<f64>> {
    let mut out = vec![vec![0.0; coarse]; coarse];
    for (p, row) in a.iter().enumerate() {
        for (q, v) in row.iter().enumerate() {
            out[aggregate[p] as usize][aggregate[q] as usize] += v;
        }
    }
    out
}

#[test]
fn coarse_operators_equal_pt_a_p() {
    for (w, h) in [(5, 3), (4, 4), (3, 6), (7, 7)] {
        let level = random_level(w, h, 1);
        let (coarse, aggregate) = graph::coarsen(&level, 0.1);
        let expected = galerkin(&level.dense(), &aggregate, coarse.len());
        for (x, y) in coarse
            .dense()
            .iter()
            .flatten()
            .zip(expected.iter().flatten())
        {
            assert!((x - y).abs() < 1e-6, "{w}×{h}: {x} vs {y}");
        }
        // And one level further, from a graph.
        let (coarser, aggregate) = graph::coarsen(&coarse, 0.1);
        let expected = galerkin(&coarse.dense(), &aggregate, coarser.len());
        for (x, y) in coarser
            .dense()
            .iter()
            .flatten()
            .zip(expected.iter().flatten())
        {
            assert!((x - y).abs() < 1e-6, "{w}×{h} level 2: {x} vs {y}");
        }
    }
}

#[test]
fn an_empty_view_and_a_single_pixel_are_solved() {
    let none = PairWeights::constant(0, 0, 1.0);
    let (s, info) = solve_view(&[], &none, &none, &[], &ViewSolveParams::default());
    assert!(s.is_empty() && info.converged);
    // One pixel: only the data term, s = i.
    let one = PairWeights::constant(1, 1, 1.0);
    let (s, info) = solve_view(&[0.7], &one, &one, &[0.0], &ViewSolveParams::default());
    assert!(
        info.converged && (s[0] - 0.7).abs() < 1e-5,
        "{s:?} {info:?}"
    );
}

#[test]
fn the_grid_aggregation_is_the_general_one() {
    for (w, h, seed) in [(8, 6, 1), (7, 5, 2), (1, 5, 3), (6, 1, 4), (13, 9, 5)] {
        let level = random_level(w, h, seed);
        let (fast, fast_aggregate) = grid::coarsen_grid(&level, 0.1);
        let (general, aggregate) = graph::coarsen(&level, 0.1);
        assert_eq!(fast_aggregate, aggregate, "{w}×{h}");
        assert_eq!(fast.dense(), general.dense(), "{w}×{h}");
    }
}

#[test]
fn aggregates_do_not_cross_occlusions() {
    // An occlusion outline (0.01 pairs) between columns 2 and 3, not on a 2×2 block boundary:
    // the blocks of columns 2–3 split in two, the others are whole 2×2 blocks.
    let (w, h) = (6, 4);
    let occlusion =
        PairWeights::from_pairs(
            w,
            h,
            |p, q| {
                if (p % w, q % w) == (2, 3) { 0.01 } else { 1.0 }
            },
        );
    let level = Level::new(
        w,
        h,
        occlusion.horizontal.clone(),
        occlusion.vertical.clone(),
        vec![1e-3; w * h],
    );
    let (coarse, aggregate) = graph::coarsen(&level, 0.1);
    assert_eq!(coarse.len(), 3 * 2 + 2);
    for y in 0..h {
        let a = |x: usize| aggregate[y * w + x];
        assert_ne!(a(2), a(3));
        assert_eq!((a(0), a(2), a(4)), (a(1), a(2), a(5)));
    }
    // Without the cue the same grid is 3×2 whole blocks.
    let open = Level::new(w, h, vec![1.0; w * h], vec![1.0; w * h], vec![1e-3; w * h]);
    assert_eq!(graph::coarsen(&open, 0.1).0.len(), 6);
}

#[test]
fn the_v_cycle_is_symmetric_positive_definite() {
    let (w, h) = (11, 7);
    let level = random_level(w, h, 9);
    let params = MultigridParams {
        coarsest_size: 2,
        cycle: Cycle::V,
        ..Default::default()
    };
    let hierarchy = Hierarchy::new(level, &params);
    assert!(hierarchy.levels() >= 4, "{}", hierarchy.levels());
    let mut work = hierarchy.work();
    let dot = |u: &[f64], v: &[f64]| u.iter().zip(v).map(|(a, b)| a * b).sum::<f64>();
    let vectors: Vec<Vec<f64>> = (0..4)
        .map(|k| {
            pseudo_random(w * h, 20 + k)
                .iter()
                .map(|&v| v as f64 - 0.5)
                .collect()
        })
        .collect();
    let mut images = vec![vec![0.0; w * h]; vectors.len()];
    for (u, bu) in vectors.iter().zip(&mut images) {
        hierarchy.precondition(u, bu, &mut work);
        assert!(dot(u, bu) > 0.0);
    }
    for j in 0..vectors.len() {
        for k in 0..j {
            let (a, b) = (dot(&images[j], &vectors[k]), dot(&vectors[j], &images[k]));
            assert!((a - b).abs() < 1e-9 * a.abs().max(1.0), "{a} vs {b}");
        }
    }
}

#[test]
fn a_single_level_is_solved_exactly_in_one_iteration() {
    // The coarsest level alone: the banded Cholesky is an exact inverse, in either numbering.
    for (w, h) in [(9, 4), (4, 9)] {
        let (i, albedo, occlusion) = random_view(w, h, 3);
        let params = ViewSolveParams {
            tolerance: 1e-10,
            preconditioner: Preconditioner::Multigrid(MultigridParams {
                coarsest_size: w * h,
                ..Default::default()
            }),
            ..Default::default()
        };
        let (_, info) = solve_view(&i, &albedo, &occlusion, &vec![0.0; w * h], &params);
        assert_eq!((info.iterations, info.levels), (1, 1), "{info:?}");
        assert!(info.converged);
    }
}

#[test]
fn multigrid_needs_far_fewer_iterations_than_jacobi_on_a_128_view() {
    // A smooth image with noise, albedo edges at random and an occluding square (0.01 pairs
    // along its outline), μ = 1e-3 (weaker than the default 1e-2, so harder); cold start.
    let (w, h) = (128, 128);
    let noise = pseudo_random(w * h, 4);
    let i: Vec<f32> = (0..w * h)
        .map(|p| ((p % w) as f32 / 20.0).sin() + (p / w) as f32 / 64.0 + 0.2 * noise[p])
        .collect();
    let albedo = PairWeights::from_pairs(w, h, |p, _| (noise[p] > 0.9) as u8 as f32);
    let inside = |p: usize| (30..90).contains(&(p % w)) && (40..100).contains(&(p / w));
    let occlusion =
        PairWeights::from_pairs(w, h, |p, q| if inside(p) != inside(q) { 0.01 } else { 1.0 });
    let start = vec![0.0; w * h];
    let iterations = |preconditioner| {
        let params = ViewSolveParams {
            mu: 1e-3,
            preconditioner,
            ..Default::default()
        };
        let (_, info) = solve_view(&i, &albedo, &occlusion, &start, &params);
        assert!(info.converged, "{info:?}");
        info.iterations
    };
    let jacobi = iterations(Preconditioner::Jacobi);
    let multigrid = iterations(Preconditioner::default());
    assert!(
        5 * multigrid < jacobi,
        "multigrid {multigrid}, Jacobi {jacobi}"
    );
}

#[test]
fn no_albedo_edges_give_all_of_the_image_to_the_shading() {
    let (w, h) = (6, 4);
    let i = pseudo_random(w * h, 7);
    let none = PairWeights::constant(w, h, 0.0);
    let open = PairWeights::constant(w, h, 1.0);
    let start = vec![0.0; w * h];
    let params = ViewSolveParams {
        tolerance: 1e-10,
        ..Default::default()
    };
    let (s, _) = solve_view(&i, &none, &open, &start, &params);
    for (a, b) in s.iter().zip(&i) {
        assert!((a - b).abs() < 1e-4, "{a} vs {b}");
    }
}

#[test]
fn the_mean_log_shading_is_the_mean_log_intensity_for_any_cues() {
    // Summing the normal equations: the Laplacian and the antisymmetric gradient terms
    // cancel, leaving μ Σ (s − i) = 0.
    let (w, h) = (9, 6);
    let i = pseudo_random(w * h, 11);
    let a = pseudo_random(w * h, 12);
    let albedo = PairWeights::from_pairs(w, h, |p, q| (a[p] + a[q]) / 2.0);
    let occlusion = PairWeights::from_pairs(w, h, |p, _| if a[p] > 0.7 { 0.01 } else { 1.0 });
    let params = ViewSolveParams {
        mu: 1e-2,
        tolerance: 1e-12,
        ..Default::default()
    };
    let (s, _) = solve_view(&i, &albedo, &occlusion, &i, &params);
    let mean = |v: &[f32]| v.iter().map(|&x| x as f64).sum::<f64>() / v.len() as f64;
    assert!((mean(&s) - mean(&i)).abs() < 1e-6);
    // And with albedo edges everywhere the shading is smoother than the intensity.
    let all = PairWeights::constant(w, h, 1.0);
    let (flat, _) = solve_view(&i, &all, &PairWeights::constant(w, h, 1.0), &i, &params);
    let spread = |v: &[f32]| {
        let m = mean(v);
        v.iter().map(|&x| (x as f64 - m).powi(2)).sum::<f64>()
    };
    assert!(spread(&flat) < 0.05 * spread(&i));
}
