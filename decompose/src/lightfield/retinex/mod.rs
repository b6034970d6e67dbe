//! The per-view Retinex solve of the light-field method (thesis §4.3, eqs. 4.4–4.9), in the
//! gradient domain with the albedo and occlusion cues ([`super::cues`]).
//!
//! Unknown: the log shading `s` of every pixel of one view (grey shading). Known: `i`, the log
//! intensity `ln ‖L̂‖₂` of the 4D-filtered light field. For every 4-neighbour pair `p, q`:
//!
//! `E(s) = Σ_pq ω^occ_pq [ (1 − ω^a_pq)·((s_p − s_q) − (i_p − i_q))² + ω^a_pq·(s_p − s_q)² ]
//!        + μ Σ_p w_p (s_p − t_p)²`
//!
//! with `t = i` and `w = 1` in the thesis; the light-field method may give every pixel its own
//! weight `w_p` and target `t_p` (`lightfield::method::data_term`).
//!
//! Where the pair is no reflectance change the image gradient is shading's; where it is one, the
//! shading stays smooth and the gradient goes to the reflectance; across an occlusion both terms
//! are damped by `ω^occ`. The weak data term `μ` fixes the otherwise free constant and ties the
//! shading's lowest frequencies to the intensity, with one scale for every view.
//!
//! The normal equations are a screened Poisson system whose matrix is the graph Laplacian of the
//! weights `ω^occ` plus `μ diag(w)` (the cue `ω^a` only enters the right-hand side). It is symmetric
//! positive definite and solved matrix-free by preconditioned conjugate gradients, warm started
//! (neighbouring views of a light field are nearly the same image, so a solved neighbour is an
//! excellent start; see [`super::decompose`]).
//!
//! The preconditioner is by default one K-cycle of an aggregation multigrid ([`multigrid`]):
//! with the weak `μ` the system is nearly as hard as a Poisson problem, and Jacobi needs
//! hundreds of iterations on a 512² view because it cannot move the smooth part of the error.
//! [`Preconditioner::Jacobi`] is kept as the reference. Both stop on the same relative residual;
//! at that residual the multigrid solution is also closer to the exact one (last column below).
//!
//! One 512² view next to the centre of a 9×9 light field, release build on a shared, loaded
//! machine (thread CPU time; `nice -n 5 cargo run --release -p decompose --example
//! retinex_multigrid -- 512 [SCENE]`); warm = started from the solved centre view, as in
//! [`super::decompose`]; `max |Δs|` against a solve to 1e-10. Measured at μ = 1e-3, the
//! default before the cross-validation that chose 1e-2 (a better-conditioned system):
//!
//! ```text
//! view                      preconditioner start iters levels CPU ms  max |Δs|
//! synthetic card (0.39% of  Jacobi         cold   487     1    605    1.9e-5
//!   pairs occluded)         Jacobi         warm   322     1    412    2.6e-5
//!                           multigrid      cold    11     6    124    1.4e-6
//!                           multigrid      warm     7     6     90    2.2e-6
//! tune/scene00 ×2 (0.81%)   Jacobi         cold   332     1    470    4.2e-4
//!                           Jacobi         warm   283     1    397    4.9e-4
//!                           multigrid      cold     8     6     97    3.8e-5
//!                           multigrid      warm     7     6     83    5.6e-5
//! ```
//!
//! So about 5× less CPU per view, of which about 20 ms is the set-up of the hierarchy (Jacobi's
//! set-up: 2–9 ms); one multigrid iteration costs about as much as 7 Jacobi iterations. The
//! choices, from `--sweep` on the synthetic view (cold / warm iterations): aggregating across
//! occlusions (θ = 0) 34 / 27; a V-cycle instead of the K-cycle 22 / 15 (α = 1) or 17 / 14
//! (α = 1.5); two smoothing steps 11 / 8 at 30% more CPU; a coarsest level of 256 or 4096
//! unknowns changes nothing measurable.

use super::cues::PairWeights;

mod cholesky;
mod graph;
mod grid;
pub mod multigrid;
#[cfg(test)]
mod tests;

use grid::Level;
pub use multigrid::Cycle;
use multigrid::Hierarchy;
pub use multigrid::MultigridParams;

/// The preconditioner of the conjugate gradients.
#[derive(Clone, Debug, PartialEq)]
pub enum Preconditioner {
    /// `diag(A)⁻¹`: cheap per iteration, but the iteration count grows with the view size.
    Jacobi,
    /// One symmetric V-cycle of the aggregation multigrid of [`multigrid`].
    Multigrid(MultigridParams),
}

impl Default for Preconditioner {
    fn default() -> Self {
        Self::Multigrid(MultigridParams::default())
    }
}

/// Parameters of [`solve_view`].
#[derive(Clone, Debug, PartialEq)]
pub struct ViewSolveParams {
    /// `μ`: weight of the data term `(s − i)²` (per pixel, times the `data_weight` given to
    /// [`solve_view_with_target`], if any). Default 1e-2, the thesis' data term's, chosen with
    /// `θ_a` by leave-one-scene-out cross-validation on the rendered tuning scenes among
    /// 1e-3 / 1e-2 / 3e-2: mean LMSE 0.0488 / 0.0460 / 0.0485 at θ_a = 0.005 (see
    /// `CueParams::theta_a`). The thesis' data term keeps it (the light-field ablation and the
    /// video's single views); the light-field method's default per-ray data term uses 3e-2
    /// since the ninth session (`lightfield::method::DATA_MU`).
    pub mu: f64,
    /// Relative residual `‖b − As‖ / ‖b‖` at which conjugate gradients stop. Default 1e-4:
    /// against 1e-5 it saves 0.4–0.6 s of the 9.7 s of `bench --lightfield 512`, and the mean
    /// scores of the tuning and test scenes agree to every printed digit (LMSE 0.0459 /
    /// incoherence 0.00892 on tune, 0.0651 / 0.02490 on test).
    pub tolerance: f64,
    /// Iteration cap of conjugate gradients. Default 2000.
    pub max_iterations: usize,
    /// Preconditioner of the conjugate gradients. Default multigrid with
    /// [`MultigridParams::default`].
    pub preconditioner: Preconditioner,
}

impl Default for ViewSolveParams {
    fn default() -> Self {
        Self {
            mu: 1e-2,
            tolerance: 1e-4,
            max_iterations: 2000,
            preconditioner: Preconditioner::default(),
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
    /// Grid levels of the preconditioner (1 for Jacobi).
    pub levels: usize,
}

/// The right-hand side `b` and the fine operator `A` of one view.
fn normal_equations(
    log_intensity: &[f32],
    target: &[f32],
    albedo: &PairWeights,
    occlusion: &PairWeights,
    mu: f64,
    data_weight: Option<&[f32]>,
) -> (Vec<f64>, Level) {
    let (w, h) = (occlusion.width, occlusion.height);
    let n = w * h;
    let i = |p: usize| log_intensity[p] as f64;
    let mu_at: Vec<f64> = match data_weight {
        Some(dw) => dw.iter().map(|&v| mu * v as f64).collect(),
        None => vec![mu; n],
    };
    let mut b: Vec<f64> = (0..n).map(|p| mu_at[p] * target[p] as f64).collect();
    let mut pair = |p: usize, q: usize, occ: f32, alb: f32| {
        let g = occ as f64 * (1.0 - alb as f64) * (i(p) - i(q));
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
    let a = Level::new(
        w,
        h,
        occlusion.horizontal.clone(),
        occlusion.vertical.clone(),
        mu_at,
    );
    (b, a)
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
    solve_view_with_target(
        log_intensity,
        log_intensity,
        None,
        albedo,
        occlusion,
        initial,
        params,
    )
}

/// [`solve_view`] with the data term `μ (s − t)²` tied to `target` (a log shading per pixel)
/// instead of the log intensity `i`, and `μ` scaled per pixel by `data_weight` when given.
pub fn solve_view_with_target(
    log_intensity: &[f32],
    target: &[f32],
    data_weight: Option<&[f32]>,
    albedo: &PairWeights,
    occlusion: &PairWeights,
    initial: &[f32],
    params: &ViewSolveParams,
) -> (Vec<f32>, ViewSolveInfo) {
    let n = occlusion.width * occlusion.height;
    debug_assert_eq!(log_intensity.len(), n);
    debug_assert_eq!(target.len(), n);
    debug_assert_eq!(initial.len(), n);
    if n == 0 {
        // Nothing to solve (and the grid levels assume at least one pixel).
        let info = ViewSolveInfo {
            converged: true,
            ..Default::default()
        };
        return (Vec::new(), info);
    }
    let (b, a) = normal_equations(
        log_intensity,
        target,
        albedo,
        occlusion,
        params.mu,
        data_weight,
    );
    let mut x: Vec<f64> = initial.iter().map(|&v| v as f64).collect();
    let info = match &params.preconditioner {
        Preconditioner::Jacobi => {
            let inverse: Vec<f64> = a.diagonal.iter().map(|d| 1.0 / d).collect();
            let jacobi = |r: &[f64], z: &mut [f64]| {
                for ((z, r), d) in z.iter_mut().zip(r).zip(&inverse) {
                    *z = r * d;
                }
            };
            let mut info = conjugate_gradients(&a, &b, &mut x, params, false, jacobi);
            info.levels = 1;
            info
        }
        Preconditioner::Multigrid(mg) => {
            let hierarchy = Hierarchy::new(a, mg);
            let mut work = hierarchy.work();
            let cycle = |r: &[f64], z: &mut [f64]| hierarchy.precondition(r, z, &mut work);
            let flexible = mg.cycle == Cycle::K;
            let fine = &hierarchy.fine;
            let mut info = conjugate_gradients(fine, &b, &mut x, params, flexible, cycle);
            info.levels = hierarchy.levels();
            info
        }
    };
    (x.into_iter().map(|v| v as f32).collect(), info)
}

/// Preconditioned conjugate gradients from the warm start in `x`; `precondition(r, z)` sets
/// `z = B r` for a symmetric positive definite `B`. `flexible` when `B` varies from call to call
/// (the K-cycle): then `β` is the Polak–Ribière form `zₖ₊₁·(rₖ₊₁ − rₖ) / zₖ·rₖ` (Notay 2000,
/// "Flexible conjugate gradients"), which equals the usual one for a fixed `B`.
fn conjugate_gradients(
    a: &Level,
    b: &[f64],
    x: &mut [f64],
    params: &ViewSolveParams,
    flexible: bool,
    mut precondition: impl FnMut(&[f64], &mut [f64]),
) -> ViewSolveInfo {
    let n = b.len();
    let dot = |u: &[f64], v: &[f64]| u.iter().zip(v).map(|(a, b)| a * b).sum::<f64>();
    let b_norm = dot(b, b).sqrt().max(f64::MIN_POSITIVE);
    let mut r = vec![0.0; n];
    a.apply(x, &mut r);
    for (ri, bi) in r.iter_mut().zip(b) {
        *ri = bi - *ri;
    }
    let mut info = ViewSolveInfo {
        residual: dot(&r, &r).sqrt() / b_norm,
        ..Default::default()
    };
    if info.residual <= params.tolerance {
        info.converged = true;
        return info;
    }
    let mut z = vec![0.0; n];
    precondition(&r, &mut z);
    let mut p = z.clone();
    let mut rz = dot(&r, &z);
    let mut ap = vec![0.0; n];
    let mut r_old = if flexible { r.clone() } else { Vec::new() };
    while info.residual > params.tolerance && info.iterations < params.max_iterations {
        a.apply(&p, &mut ap);
        let alpha = rz / dot(&p, &ap).max(f64::MIN_POSITIVE);
        // Loops fused where they share vectors: at 512² every pass over them costs as much as
        // the arithmetic.
        let mut rr = 0.0;
        for k in 0..n {
            x[k] += alpha * p[k];
            r[k] -= alpha * ap[k];
            rr += r[k] * r[k];
        }
        info.iterations += 1;
        info.residual = rr.sqrt() / b_norm;
        if info.residual <= params.tolerance {
            break;
        }
        precondition(&r, &mut z);
        let (rz_next, beta) = if flexible {
            let (mut rz_next, mut r_old_z) = (0.0, 0.0);
            for k in 0..n {
                rz_next += r[k] * z[k];
                r_old_z += r_old[k] * z[k];
                r_old[k] = r[k];
            }
            (rz_next, (rz_next - r_old_z) / rz.max(f64::MIN_POSITIVE))
        } else {
            let rz_next = dot(&r, &z);
            (rz_next, rz_next / rz.max(f64::MIN_POSITIVE))
        };
        rz = rz_next;
        for k in 0..n {
            p[k] = z[k] + beta * p[k];
        }
    }
    info.converged = info.residual <= params.tolerance;
    info
}
