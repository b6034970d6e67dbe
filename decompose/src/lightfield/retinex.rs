//! The per-view Retinex solve of the light-field method (thesis §4.3, eqs. 4.4–4.9), in the
//! gradient domain with the albedo and occlusion cues ([`super::cues`]).
//!
//! Unknown: the log shading `s` of every pixel of one view (grey shading). Known: `i`, the log
//! intensity `ln ‖L̂‖₂` of the 4D-filtered light field. For every 4-neighbour pair `p, q`:
//!
//! `E(s) = Σ_pq ω^occ_pq [ (1 − ω^a_pq)·((s_p − s_q) − (i_p − i_q))² + ω^a_pq·(s_p − s_q)² ]
//!        + μ Σ_p (s_p − i_p)²`
//!
//! Where the pair is no reflectance change the image gradient is shading's; where it is one, the
//! shading stays smooth and the gradient goes to the reflectance; across an occlusion both terms
//! are damped by `ω^occ`. The weak data term `μ` fixes the otherwise free constant and ties the
//! shading's lowest frequencies to the intensity, with one scale for every view.
//!
//! The normal equations are a screened Poisson system whose matrix is the graph Laplacian of the
//! weights `ω^occ` plus `μI` (the cue `ω^a` only enters the right-hand side). It is symmetric
//! positive definite and solved matrix-free by Jacobi-preconditioned conjugate gradients, warm
//! started (neighbouring views of a light field are nearly the same image, so a solved
//! neighbour is an excellent start; see [`super::decompose`]).

use super::cues::PairWeights;

/// Parameters of [`solve_view`].
#[derive(Clone, Debug, PartialEq)]
pub struct ViewSolveParams {
    /// `μ`: weight of the data term `(s − i)²`. Default 1e-3.
    pub mu: f64,
    /// Relative residual `‖b − As‖ / ‖b‖` at which conjugate gradients stop. Default 1e-5.
    pub tolerance: f64,
    /// Iteration cap of conjugate gradients. Default 2000.
    pub max_iterations: usize,
}

impl Default for ViewSolveParams {
    fn default() -> Self {
        Self {
            mu: 1e-3,
            tolerance: 1e-5,
            max_iterations: 2000,
        }
    }
}

/// What one view's solve did.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct ViewSolveInfo {
    /// Conjugate-gradient iterations.
    pub iterations: usize,
    /// Final relative residual.
    pub residual: f64,
    /// Whether the tolerance was reached.
    pub converged: bool,
}

/// The system `A s = b` of one view.
struct System<'a> {
    width: usize,
    height: usize,
    occlusion: &'a PairWeights,
    diagonal: Vec<f64>,
}

impl System<'_> {
    /// `out = A x` with `A = L(ω^occ) + μI`.
    fn apply(&self, x: &[f64], out: &mut [f64]) {
        let (w, h) = (self.width, self.height);
        let (hw, vw) = (&self.occlusion.horizontal, &self.occlusion.vertical);
        for y in 0..h {
            for xi in 0..w {
                let p = y * w + xi;
                let mut acc = self.diagonal[p] * x[p];
                if xi + 1 < w {
                    acc -= hw[p] as f64 * x[p + 1];
                }
                if xi > 0 {
                    acc -= hw[p - 1] as f64 * x[p - 1];
                }
                if y + 1 < h {
                    acc -= vw[p] as f64 * x[p + w];
                }
                if y > 0 {
                    acc -= vw[p - w] as f64 * x[p - w];
                }
                out[p] = acc;
            }
        }
    }
}

/// Solves one view (see the module docs). `log_intensity` is `i` (length `width·height`),
/// `initial` the warm start (`i` itself when nothing better is known). Returns `s`.
pub fn solve_view(
    log_intensity: &[f32],
    albedo: &PairWeights,
    occlusion: &PairWeights,
    initial: &[f32],
    params: &ViewSolveParams,
) -> (Vec<f32>, ViewSolveInfo) {
    let (w, h) = (occlusion.width, occlusion.height);
    let n = w * h;
    debug_assert_eq!(log_intensity.len(), n);
    debug_assert_eq!(initial.len(), n);
    let i = |p: usize| log_intensity[p] as f64;
    // Right-hand side and diagonal of the normal equations.
    let mut b: Vec<f64> = (0..n).map(|p| params.mu * i(p)).collect();
    let mut diagonal = vec![params.mu; n];
    let mut pair = |p: usize, q: usize, occ: f32, alb: f32| {
        let (o, a) = (occ as f64, alb as f64);
        diagonal[p] += o;
        diagonal[q] += o;
        let g = o * (1.0 - a) * (i(p) - i(q));
        b[p] += g;
        b[q] -= g;
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
    let system = System {
        width: w,
        height: h,
        occlusion,
        diagonal,
    };
    let mut x: Vec<f64> = initial.iter().map(|&v| v as f64).collect();
    let info = conjugate_gradients(&system, &b, &mut x, params);
    (x.into_iter().map(|v| v as f32).collect(), info)
}

/// Jacobi-preconditioned conjugate gradients from the warm start in `x`.
fn conjugate_gradients(
    a: &System,
    b: &[f64],
    x: &mut [f64],
    params: &ViewSolveParams,
) -> ViewSolveInfo {
    let n = b.len();
    let dot = |u: &[f64], v: &[f64]| u.iter().zip(v).map(|(a, b)| a * b).sum::<f64>();
    let b_norm = dot(b, b).sqrt().max(f64::MIN_POSITIVE);
    let mut r = vec![0.0; n];
    a.apply(x, &mut r);
    for (ri, bi) in r.iter_mut().zip(b) {
        *ri = bi - *ri;
    }
    let mut z: Vec<f64> = r.iter().zip(&a.diagonal).map(|(r, d)| r / d).collect();
    let mut p = z.clone();
    let mut rz = dot(&r, &z);
    let mut ap = vec![0.0; n];
    let mut info = ViewSolveInfo {
        residual: dot(&r, &r).sqrt() / b_norm,
        ..Default::default()
    };
    while info.residual > params.tolerance && info.iterations < params.max_iterations {
        a.apply(&p, &mut ap);
        let alpha = rz / dot(&p, &ap).max(f64::MIN_POSITIVE);
        for k in 0..n {
            x[k] += alpha * p[k];
            r[k] -= alpha * ap[k];
        }
        for k in 0..n {
            z[k] = r[k] / a.diagonal[k];
        }
        let rz_next = dot(&r, &z);
        let beta = rz_next / rz.max(f64::MIN_POSITIVE);
        rz = rz_next;
        for k in 0..n {
            p[k] = z[k] + beta * p[k];
        }
        info.iterations += 1;
        info.residual = dot(&r, &r).sqrt() / b_norm;
    }
    info.converged = info.residual <= params.tolerance;
    info
}

#[cfg(test)]
mod tests {
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

    #[test]
    fn matches_the_sparse_direct_least_squares_solution() {
        // The same energy written as weighted equations for the crate's Cholesky solver.
        let (w, h) = (7, 5);
        let n = w * h;
        let i = pseudo_random(n, 1);
        let a_raw = pseudo_random(n, 2);
        let albedo = PairWeights::from_pairs(w, h, |p, _| (a_raw[p] > 0.6) as u8 as f32);
        let o_raw = pseudo_random(n, 3);
        let occlusion =
            PairWeights::from_pairs(w, h, |p, _| if o_raw[p] > 0.8 { 0.01 } else { 1.0 });
        let params = ViewSolveParams {
            mu: 0.05,
            tolerance: 1e-12,
            ..Default::default()
        };
        let (s, info) = solve_view(&i, &albedo, &occlusion, &i, &params);
        assert!(info.converged, "{info:?}");

        let mut sys = LinearSystem::new(n);
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
        for (p, &ip) in i.iter().enumerate() {
            sys.add(&[(p, 1.0)], ip as f64, params.mu);
        }
        let (direct, _) = sys
            .solve(&SolverParams {
                damping: 0.0,
                ..Default::default()
            })
            .unwrap();
        for (a, b) in s.iter().zip(&direct) {
            assert!((*a as f64 - b).abs() < 1e-5, "{a} vs {b}");
        }
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
}
