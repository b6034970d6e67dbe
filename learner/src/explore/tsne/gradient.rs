//! The gradient of `KL(P‖Q)` (van der Maaten & Hinton 2008, eq. 5), split as in van der Maaten
//! 2014 (eq. 11) into an attractive part over the nonzero `p_ij` and a repulsive part over all
//! pairs:
//!
//! `∂C/∂y_i = 4 (α Σ_j p_ij w_ij (y_i − y_j) − (1/Z) Σ_j w_ij² (y_i − y_j))`,
//! `w_ij = 1/(1 + ‖y_i − y_j‖²)`, `Z = Σ_{k≠l} w_kl`,
//!
//! with `α` the exaggeration. The repulsive sums are exact (every pair), Barnes–Hut
//! ([`QuadTree`]) or interpolated on a grid with FFTs ([`interpolation`], FIt-SNE). Each point's sums run in a fixed order on whichever thread takes it, and `Z`
//! is summed over the points in index order afterwards, so the gradient does not depend on the
//! thread count.

use rayon::prelude::*;

use super::affinity::Affinities;
use super::interpolation::{self, Interpolation};
use super::quadtree::{QuadTree, Repulsion};

/// How the repulsive sums are computed.
#[derive(Clone, Copy, Debug)]
pub(super) enum Repulsive {
    /// Every pair.
    Exact,
    /// Barnes–Hut with this `θ`.
    BarnesHut(f64),
    /// FFT-accelerated interpolation (FIt-SNE).
    Fft(Interpolation),
}

fn exact_repulsion(i: usize, y: &[[f64; 2]]) -> Repulsion {
    let yi = y[i];
    let (mut fx, mut fy, mut z) = (0.0, 0.0, 0.0);
    for (j, yj) in y.iter().enumerate() {
        if j == i {
            continue;
        }
        let (dx, dy) = (yi[0] - yj[0], yi[1] - yj[1]);
        let w = 1.0 / (1.0 + dx * dx + dy * dy);
        z += w;
        fx += w * w * dx;
        fy += w * w * dy;
    }
    Repulsion { force: [fx, fy], z }
}

/// The repulsion on every point and `Z`.
fn repulsion(y: &[[f64; 2]], method: Repulsive) -> (Vec<Repulsion>, f64) {
    let forces: Vec<Repulsion> = match method {
        Repulsive::Exact => (0..y.len())
            .into_par_iter()
            .map(|i| exact_repulsion(i, y))
            .collect(),
        Repulsive::BarnesHut(theta) => {
            let tree = QuadTree::new(y);
            (0..y.len())
                .into_par_iter()
                .map(|i| tree.repulsion(i, y, theta))
                .collect()
        }
        Repulsive::Fft(params) => interpolation::repulsion(y, &params),
    };
    let z = forces.iter().map(|r| r.z).sum();
    (forces, z)
}

/// `Σ_j p_ij w_ij (y_i − y_j)` for point `i`.
fn attraction(p: &Affinities, i: usize, y: &[[f64; 2]]) -> [f64; 2] {
    let (columns, values) = p.row(i);
    let yi = y[i];
    let (mut fx, mut fy) = (0.0, 0.0);
    for (&j, &pij) in columns.iter().zip(values) {
        let yj = y[j as usize];
        let (dx, dy) = (yi[0] - yj[0], yi[1] - yj[1]);
        let w = pij / (1.0 + dx * dx + dy * dy);
        fx += w * dx;
        fy += w * dy;
    }
    [fx, fy]
}

/// Writes `∂C/∂y` (with exaggeration `alpha`) into `grad`.
pub(super) fn gradient(
    p: &Affinities,
    y: &[[f64; 2]],
    alpha: f64,
    method: Repulsive,
    grad: &mut [[f64; 2]],
) {
    let (forces, z) = repulsion(y, method);
    grad.par_iter_mut()
        .zip(forces.par_iter())
        .enumerate()
        .for_each(|(i, (g, r))| {
            let a = attraction(p, i, y);
            g[0] = 4.0 * (alpha * a[0] - r.force[0] / z);
            g[1] = 4.0 * (alpha * a[1] - r.force[1] / z);
        });
}

/// `KL(P‖Q) = Σ p ln p − Σ p ln w + ln Z` (Σ p = 1), with `Z` exact or from the tree; `q` is
/// clamped at machine epsilon as scikit-learn does.
pub(super) fn kl_divergence(p: &Affinities, y: &[[f64; 2]], method: Repulsive) -> f64 {
    let (_, z) = repulsion(y, method);
    kl_with_z(p, y, z)
}

/// `KL(P‖Q)` given `Z`.
pub(super) fn kl_with_z(p: &Affinities, y: &[[f64; 2]], z: f64) -> f64 {
    let rows: Vec<f64> = (0..p.n())
        .into_par_iter()
        .map(|i| {
            let (columns, values) = p.row(i);
            let yi = y[i];
            columns
                .iter()
                .zip(values)
                .filter(|e| *e.1 > 0.0)
                .map(|(&j, &pij)| {
                    let yj = y[j as usize];
                    let (dx, dy) = (yi[0] - yj[0], yi[1] - yj[1]);
                    let q = (1.0 / (1.0 + dx * dx + dy * dy) / z).max(f64::EPSILON);
                    pij * (pij / q).ln()
                })
                .sum()
        })
        .collect();
    rows.iter().sum()
}

/// `Z` over every pair, exactly.
pub(super) fn exact_z(y: &[[f64; 2]]) -> f64 {
    repulsion(y, Repulsive::Exact).1
}
