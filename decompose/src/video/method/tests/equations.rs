//! Completion (eqs. 3.8, 3.9) against exact references, and the completed region.

use super::*;

/// A tiny Gaussian elimination with partial pivoting (the dense reference).
fn dense_solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
    let n = b.len();
    for c in 0..n {
        let p = (c..n)
            .max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))
            .unwrap();
        a.swap(c, p);
        b.swap(c, p);
        let (top, bottom) = a.split_at_mut(c + 1);
        let pivot = &top[c];
        for (r, row) in bottom.iter_mut().enumerate() {
            let f = row[c] / pivot[c];
            for (v, pv) in row[c..].iter_mut().zip(&pivot[c..]) {
                *v -= f * pv;
            }
            b[c + 1 + r] -= f * b[c];
        }
    }
    let mut x = vec![0.0; n];
    for r in (0..n).rev() {
        let s: f64 = (r + 1..n).map(|k| a[r][k] * x[k]).sum();
        x[r] = (b[r] - s) / a[r][r];
    }
    x
}

#[test]
fn completion_equation_matches_a_dense_solve() {
    // 6×4: two albedos (a chroma edge at x = 3) under a ramp; the right column is known.
    let (w, h) = (6usize, 4usize);
    let input = Image::from_fn(w as u32, h as u32, |x, y| {
        let a = if x < 3 {
            [0.7, 0.3, 0.2]
        } else {
            [0.2, 0.4, 0.7]
        };
        let s = 0.3 + 0.1 * x as f32 + 0.05 * y as f32;
        a.map(|v| v * s)
    });
    let region = Mask::full(w as u32, h as u32);
    let known: Vec<f64> = (0..w * h)
        .map(|p| {
            if p % w == w - 1 {
                -0.5 + 0.1 * (p / w) as f64
            } else {
                f64::NAN
            }
        })
        .collect();
    let params = RetinexParams::default();
    let lambda_c = 1000.0;
    let s = local_decomposition(&input, &region, &known, &params, lambda_c).unwrap();

    // Dense normal equations of eq. 3.8, written out independently.
    let n = w * h;
    let logy = |p: usize| f64::from(luminance(input.rgb(p))).ln();
    let unit = |p: usize| {
        let c = input.rgb(p).map(f64::from);
        let m = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        c.map(|v| v / m)
    };
    let mut a = vec![vec![0.0; n]; n];
    let mut b = vec![0.0; n];
    let mut add = |terms: &[(usize, f64)], rhs: f64, wt: f64| {
        for &(i, ci) in terms {
            b[i] += wt * ci * rhs;
            for &(j, cj) in terms {
                a[i][j] += wt * ci * cj;
            }
        }
    };
    for (p, &known_p) in known.iter().enumerate() {
        for q in [
            (p % w + 1 < w).then_some(p + 1),
            (p + w < n).then_some(p + w),
        ]
        .into_iter()
        .flatten()
        {
            add(&[(p, 1.0), (q, -1.0)], 0.0, params.lambda_l);
            let (u, v) = (unit(p), unit(q));
            let d2: f64 = (0..3).map(|c| (u[c] - v[c]).powi(2)).sum();
            if d2 < params.t {
                add(
                    &[(p, 1.0), (q, -1.0)],
                    logy(p) - logy(q),
                    params.lambda_l * params.omega,
                );
            }
        }
        if known_p.is_finite() {
            add(&[(p, 1.0)], known_p, lambda_c);
        }
    }
    let x = dense_solve(a, b);
    for p in 0..n {
        assert!(
            (s[p] - x[p]).abs() < 1e-6,
            "pixel {p}: {} vs {}",
            s[p],
            x[p]
        );
    }
    // The known column is held (λ_c = 1000 against unit smoothness weights).
    for p in (0..n).filter(|p| known[*p].is_finite()) {
        assert!(
            (s[p] - known[p]).abs() < 0.01,
            "pixel {p}: {} vs {}",
            s[p],
            known[p]
        );
    }
}

#[test]
fn poisson_blend_holds_the_dirichlet_boundary_exactly() {
    let (w, h) = (9usize, 7usize);
    // A hole inside and one on the image border.
    let hole: Vec<bool> = (0..w * h)
        .map(|p| {
            let (x, y) = (p % w, p / w);
            ((2..6).contains(&x) && (2..5).contains(&y)) || (x == 8 && y < 3)
        })
        .collect();
    let field = |p: usize| ((p % w) as f64 * 0.37).sin() + ((p / w) as f64 * 0.21).cos();
    let guidance: Vec<f64> = (0..w * h)
        .map(|p| field(p) + 5.0 + 0.1 * ((p * 7919) % 13) as f64)
        .collect();
    let boundary: Vec<f64> = (0..w * h)
        .map(|p| if hole[p] { f64::NAN } else { field(p) })
        .collect();
    let solver = crate::solver::SolverParams::default();
    let s = poisson_blend(w, h, &hole, &guidance, &boundary, &solver).unwrap();
    for p in 0..w * h {
        if !hole[p] {
            assert_eq!(
                s[p].to_bits(),
                boundary[p].to_bits(),
                "boundary pixel {p} moved"
            );
        }
    }
    // Inside: the discrete Poisson equation Σ_q (s_p − s_q) = Σ_q (g_p − g_q).
    for p in (0..w * h).filter(|&p| hole[p]) {
        let (x, y) = (p % w, p / w);
        let nb = [
            (x > 0).then(|| p - 1),
            (x + 1 < w).then(|| p + 1),
            (y > 0).then(|| p - w),
            (y + 1 < h).then(|| p + w),
        ];
        let res: f64 = nb
            .into_iter()
            .flatten()
            .map(|q| (s[p] - s[q]) - (guidance[p] - guidance[q]))
            .sum();
        assert!(res.abs() < 1e-7, "pixel {p}: Poisson residual {res}");
    }
    // A guidance that is the boundary's own field up to a constant is reproduced exactly.
    let shifted: Vec<f64> = (0..w * h).map(|p| field(p) + 3.0).collect();
    let s = poisson_blend(w, h, &hole, &shifted, &boundary, &solver).unwrap();
    for p in (0..w * h).filter(|&p| hole[p]) {
        assert!((s[p] - field(p)).abs() < 1e-7, "pixel {p}");
    }
}

#[test]
fn the_completed_region_is_the_unassigned_part_of_the_tripping_windows() {
    use super::passes::stop_region;
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    for trial in 0..30 {
        let (w, h) = (rng.random_range(3..20usize), rng.random_range(3..16usize));
        let m = rng.random_range(1..8u32);
        let alpha = rng.random_range(0.3..0.95);
        // Assigned everywhere but a few random rectangles.
        let mut data = vec![true; w * h];
        for _ in 0..rng.random_range(0..4) {
            let (x0, y0) = (rng.random_range(0..w), rng.random_range(0..h));
            let (x1, y1) = (rng.random_range(x0..w), rng.random_range(y0..h));
            for y in y0..=y1 {
                for x in x0..=x1 {
                    data[y * w + x] = rng.random_bool(0.05);
                }
            }
        }
        let mask = Mask::from_vec(w as u32, h as u32, data.clone()).unwrap();
        let got = stop_region(&mask, m, alpha).unwrap();
        // Brute force: every window inside the frame (clipped to it when smaller).
        let (mw, mh) = ((m as usize).min(w), (m as usize).min(h));
        let mut expect = vec![false; w * h];
        let mut any = false;
        for y0 in 0..=h - mh {
            for x0 in 0..=w - mw {
                let cells = || (y0..y0 + mh).flat_map(|y| (x0..x0 + mw).map(move |x| y * w + x));
                let unassigned = cells().filter(|&i| !data[i]).count();
                if unassigned as f64 > alpha * (mw * mh) as f64 {
                    any = true;
                    for i in cells().filter(|&i| !data[i]) {
                        expect[i] = true;
                    }
                }
            }
        }
        assert_eq!(got.is_some(), any, "trial {trial}");
        if let Some(got) = got {
            assert_eq!(
                got, expect,
                "trial {trial}: {w}x{h}, m = {m}, alpha = {alpha}"
            );
        }
    }
}
