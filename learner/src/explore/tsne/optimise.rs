//! Gradient descent with momentum and per-coordinate gains (van der Maaten & Hinton 2008,
//! §3.4; the delta-bar-delta rule of Jacobs 1988 as in scikit-learn's `_gradient_descent`):
//!
//! `g ← ∂C/∂y`; a gain grows by 0.2 where the gradient's sign disagrees with the last step's
//! (`update · g < 0`), else shrinks by ×0.8, never below `min_gain`;
//! `update ← momentum · update − η · gain · g`; `y ← y + update`.
//!
//! The early-exaggeration phase and the rest run as two descents, each starting with zero
//! updates and unit gains, as scikit-learn does. The embedding is re-centred after each step
//! (the cost does not change; the quadtree's box stays put).

use rayon::prelude::*;

use super::affinity::Affinities;
use super::gradient::{Repulsive, gradient};

/// One phase of the descent.
pub(super) struct Phase {
    pub iterations: usize,
    pub exaggeration: f64,
    pub momentum: f64,
}

/// Runs the phases in order on `y`; `progress(done, total)` after each iteration.
pub(super) fn descend(
    p: &Affinities,
    y: &mut [[f64; 2]],
    phases: &[Phase],
    learning_rate: f64,
    min_gain: f64,
    method: Repulsive,
    progress: &mut dyn FnMut(usize, usize),
) -> usize {
    let n = y.len();
    let total: usize = phases.iter().map(|p| p.iterations).sum();
    let mut grad = vec![[0.0; 2]; n];
    let mut done = 0;
    for phase in phases {
        let mut update = vec![[0.0f64; 2]; n];
        let mut gains = vec![[1.0f64; 2]; n];
        for _ in 0..phase.iterations {
            gradient(p, y, phase.exaggeration, method, &mut grad);
            y.par_iter_mut()
                .zip(update.par_iter_mut())
                .zip(gains.par_iter_mut())
                .zip(grad.par_iter())
                .for_each(|(((yi, ui), gi), g)| {
                    for d in 0..2 {
                        gi[d] = if ui[d] * g[d] < 0.0 {
                            gi[d] + 0.2
                        } else {
                            gi[d] * 0.8
                        }
                        .max(min_gain);
                        ui[d] = phase.momentum * ui[d] - learning_rate * gi[d] * g[d];
                        yi[d] += ui[d];
                    }
                });
            let mut mean = [0.0; 2];
            for yi in y.iter() {
                mean[0] += yi[0];
                mean[1] += yi[1];
            }
            let mean = [mean[0] / n as f64, mean[1] / n as f64];
            y.par_iter_mut().for_each(|yi| {
                yi[0] -= mean[0];
                yi[1] -= mean[1];
            });
            done += 1;
            progress(done, total);
        }
    }
    done
}
