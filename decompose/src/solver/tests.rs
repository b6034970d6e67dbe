use super::*;
use faer::linalg::solvers::SolveLstsq;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Dense reference: QR least squares of [√W A; √(εD) I] x = [√W b; 0].
fn dense_reference(sys: &LinearSystem, eps_rel: f64) -> Vec<f64> {
    let n = sys.unknowns();
    let m = sys.equations();
    let mut a = Mat::<f64>::zeros(m + n, n);
    let mut b = Mat::<f64>::zeros(m + n, 1);
    for r in 0..m {
        let sw = sys.weight[r].sqrt();
        for (c, v) in sys.row(r) {
            a[(r, c)] += sw * v;
        }
        b[(r, 0)] = sw * sys.rhs[r];
    }
    let diag: Vec<f64> = (0..n)
        .map(|c| (0..m).map(|r| a[(r, c)] * a[(r, c)]).sum())
        .collect();
    let eps = eps_rel * diag.iter().sum::<f64>() / n as f64;
    for i in 0..n {
        a[(m + i, i)] = eps.sqrt();
    }
    let x = a.qr().solve_lstsq(&b);
    (0..n).map(|i| x[(i, 0)]).collect()
}

#[test]
fn sparse_equals_dense_least_squares() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for trial in 0..20 {
        let n = rng.random_range(2..40);
        let m = rng.random_range(n..4 * n);
        let mut sys = LinearSystem::new(n);
        for _ in 0..m {
            let k = rng.random_range(1..4);
            let terms: Vec<(usize, f64)> = (0..k)
                .map(|_| (rng.random_range(0..n), rng.random_range(-2.0..2.0)))
                .collect();
            sys.add(
                &terms,
                rng.random_range(-1.0..1.0),
                rng.random_range(0.1..10.0),
            );
        }
        // Anchor every unknown so the dense problem is well posed too.
        for i in 0..n {
            sys.add(&[(i, 1.0)], rng.random_range(-1.0..1.0), 0.5);
        }
        let params = SolverParams {
            damping: 1e-6,
            ..Default::default()
        };
        let (x, info) = sys.solve(&params).unwrap();
        let reference = dense_reference(&sys, 1e-6);
        for (a, b) in x.iter().zip(&reference) {
            assert!((a - b).abs() < 1e-7, "trial {trial}: {a} vs {b}");
        }
        assert!(info.converged && info.residual < 1e-9, "{info:?}");
    }
}

#[test]
fn free_gauge_is_fixed_per_component() {
    // x0 - x1 = 1, x2 - x3 = 2: two groups, each with a free constant.
    let mut sys = LinearSystem::new(4);
    sys.add(&[(0, 1.0), (1, -1.0)], 1.0, 1.0);
    sys.add(&[(2, 1.0), (3, -1.0)], 2.0, 1.0);
    let (mut x, _) = sys.solve(&SolverParams::default()).unwrap();
    let comps = sys.components();
    assert_eq!(comps, vec![0, 0, 2, 2]);
    zero_mean_per_component(&mut x, &comps);
    let expect = [0.5, -0.5, 1.0, -1.0];
    for (a, b) in x.iter().zip(expect) {
        assert!((a - b).abs() < 1e-6, "{x:?}");
    }
}

#[test]
fn bad_equations_are_skipped() {
    let mut sys = LinearSystem::new(2);
    assert!(!sys.add(&[(0, f64::NAN)], 1.0, 1.0));
    assert!(!sys.add(&[(5, 1.0)], 1.0, 1.0));
    assert!(!sys.add(&[(0, 1.0)], f64::INFINITY, 1.0));
    assert!(sys.add(&[(0, 1.0)], 2.0, 1.0));
    let (x, _) = sys.solve(&SolverParams::default()).unwrap();
    assert!((x[0] - 2.0).abs() < 1e-6 && x[1] == 0.0);
}

#[test]
fn irls_reuses_the_symbolic_factorisation_exactly() {
    // Each pass must equal a fresh dense solve of the reweighted system.
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let n = 25;
    let mut sys = LinearSystem::new(n);
    for _ in 0..80 {
        let (a, b) = (rng.random_range(0..n), rng.random_range(0..n));
        sys.add(&[(a, 1.0), (b, -1.0)], rng.random_range(-1.0..1.0), 1.0);
    }
    for i in 0..n {
        sys.add(&[(i, 1.0)], rng.random_range(-1.0..1.0), 0.5);
    }
    let params = SolverParams {
        damping: 1e-6,
        ..Default::default()
    };
    let factor = |r: f64| 0.1 / r.abs().max(0.1);
    let (x, _) = sys.solve_irls(&params, 2, factor).unwrap();
    let mut reference = dense_reference(&sys, 1e-6);
    for _ in 0..2 {
        let f: Vec<f64> = sys.residuals(&reference).into_iter().map(factor).collect();
        reference = dense_reference(&sys.reweighted(&f), 1e-6);
    }
    for (a, b) in x.iter().zip(&reference) {
        assert!((a - b).abs() < 1e-7, "{a} vs {b}");
    }
}

#[test]
fn l1_irls_rejects_an_outlier_that_least_squares_follows() {
    // Five equations say x = 1, one says x = 10: least squares gives the mean 2.5, the L1
    // loss the median 1.
    let mut sys = LinearSystem::new(1);
    for _ in 0..5 {
        sys.add(&[(0, 1.0)], 1.0, 1.0);
    }
    sys.add(&[(0, 1.0)], 10.0, 1.0);
    let params = SolverParams::default();
    let (plain, _) = sys.solve(&params).unwrap();
    assert!((plain[0] - 2.5).abs() < 1e-6, "{plain:?}");
    let (robust, _) = sys
        .solve_irls(&params, 20, |r| 0.01 / r.abs().max(0.01))
        .unwrap();
    assert!((robust[0] - 1.0).abs() < 0.05, "{robust:?}");
    // A factor that is not a positive weight is an error, not a silent NaN.
    assert!(sys.solve_irls(&params, 1, |_| f64::NAN).is_err());
}
