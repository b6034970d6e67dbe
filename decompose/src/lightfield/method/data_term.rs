//! The per-ray weight and target of step 3's data term (not in the thesis; on by default).
//!
//! The thesis' data term `μ (s − i)²` (eq. 4.4's weak term) ties every ray's log shading to its
//! log intensity with one weight. That is a prior of uniform reflectance. Inside a region bounded
//! by reflectance changes the gradient terms leave only the region's level free. The level is
//! then a balance between the border's pairs, which ask for continuous shading, and the data
//! term summed over the area. On a large dark surface (a black wall, a dark floor) the area wins
//! and pulls the surface's shading down to its intensity: a grey reflectance under a dark shading.
//!
//! Dark rays say little about the shading: a ray is dark because of its reflectance or its
//! light, and only the gradient cues can tell which. A bright ray cannot be dark reflectance. So
//! the data term's weight follows the ray's brightness ([`ray_weights`]):
//!
//! `μ_p = μ · min(1, I_p / I_ref)^γ`, with `I_ref` the 99th percentile of `‖L̂‖₂` over all lit
//! rays (one reference for the whole light field, so every view gets the same weights).
//!
//! A dark region's level is then set by its border, so it depends on which border pairs each
//! view's cues keep; that costs angular coherence. [`tie_to_centre`] gives it back. It adds a
//! second weak term towards the centre view's solution, carried through the disparity
//! (`prior::carry_from_centre`). The term weighs `κ_c μ (1 − w_p)`, so it acts on dark rays only,
//! and only on the rays the centre view sees.
//!
//! On by default at γ = 2, κ_c = 0.1, `μ` = 3e-2 since the ninth session, with the bounded
//! crease pairs ([`super::DEFAULT_DATA_GAMMA`]: chosen by cross-validation on the goal
//! count over 24 rendered scenes and confirmed on 8 fresh ones; the pairs' weight and bound
//! were chosen again in the eleventh session, `CueParams::crease_weight`); before, γ = 1 at
//! `μ` = 1e-2 ([`super::LightFieldParams::previous_defaults`]). [`DataTermParams::THESIS`] is the thesis.
//! The measurements are at [`super::DEFAULT_DATA_GAMMA`], [`super::DATA_GAMMA`] and in
//! docs/intrinsic-lightfields.md.

use rayon::prelude::*;

use crate::error::{Error, Result};

/// Parameters of the data term's weights (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DataTermParams {
    /// `γ`: the weight of a ray is `min(1, I / I_ref)^γ` times `μ`. 0 is the thesis (one weight).
    pub gamma: f32,
    /// `κ_c`: weight, relative to `μ (1 − w_p)`, of the term that ties a dark ray the centre view
    /// sees to the centre view's solution. 0 turns it off. It needs a disparity.
    pub centre_weight: f32,
}

/// Smallest relative weight of a lit ray. Lit rays have `I / I_ref ≥ SHADING_FLOOR` = 1e-4, so at
/// γ ≤ 3 this never binds; it keeps a large user γ from underflowing to a zero weight.
const MIN_WEIGHT: f32 = 1e-12;

/// Quantile of the lit rays' intensity taken as `I_ref`.
pub const REFERENCE_QUANTILE: f64 = 0.99;

impl DataTermParams {
    /// The thesis: one weight `μ` for every ray, no tie to the centre view.
    pub const THESIS: Self = Self {
        gamma: 0.0,
        centre_weight: 0.0,
    };

    /// Checks that both weights are finite and non-negative.
    pub fn validate(&self) -> Result<()> {
        for (name, v) in [("gamma", self.gamma), ("centre_weight", self.centre_weight)] {
            if !v.is_finite() || v < 0.0 {
                return Err(Error::param(name, v, "must be finite and non-negative"));
            }
        }
        Ok(())
    }
}

/// Every ray's relative data weight `min(1, I / I_ref)^γ` from the log intensities `log_i`
/// (`ln ‖L̂‖₂`, views-major). Rays at or below `log_floor` (no light) are left out of `I_ref` and
/// keep the weight 1: they are missing data, cut from the solve by their damped pairs, and their
/// shading equal to their intensity is the start from which step 4 fills their reflectance in.
/// `None` when `γ` = 0: every weight is 1.
pub fn ray_weights(log_i: &[f32], log_floor: f32, gamma: f32) -> Option<Vec<f32>> {
    if gamma <= 0.0 {
        return None;
    }
    let mut lit: Vec<f32> = log_i.iter().copied().filter(|&v| v > log_floor).collect();
    let reference = if lit.is_empty() {
        0.0
    } else {
        let k = ((lit.len() - 1) as f64 * REFERENCE_QUANTILE).round() as usize;
        *lit.select_nth_unstable_by(k, f32::total_cmp).1
    };
    Some(
        log_i
            .par_iter()
            .map(|&v| {
                if v <= log_floor {
                    1.0
                } else {
                    // Floored so that the solve's matrix stays strictly positive definite.
                    (gamma * (v - reference).min(0.0)).exp().max(MIN_WEIGHT)
                }
            })
            .collect(),
    )
}

/// Adds to the data term of every ray the centre view sees (`seen`) a second term
/// `κ_c (1 − w) (s − c)²` towards `carried`, the centre view's log shading at the same point.
/// Two quadratics in `s` are one: the weights add up and the target is their weighted mean,
/// which is what is written back into `weights` and `targets`.
pub fn tie_to_centre(
    weights: &mut [f32],
    targets: &mut [f32],
    carried: &[f32],
    seen: &[bool],
    centre_weight: f32,
) {
    weights
        .par_iter_mut()
        .zip(targets.par_iter_mut())
        .zip(carried.par_iter().zip(seen.par_iter()))
        .for_each(|((w, t), (&c, &seen))| {
            if seen {
                let extra = centre_weight * (1.0 - *w).max(0.0);
                let total = *w + extra;
                if total > 0.0 {
                    *t = (*w * *t + extra * c) / total;
                }
                *w = total;
            }
        });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_follow_the_intensity_below_the_reference_and_are_one_above() {
        // 100 lit rays at ln 1 … ln 100 and one unlit ray far below.
        let mut log_i: Vec<f32> = (1..=100).map(|k| (k as f32).ln()).collect();
        log_i.push(-30.0);
        assert!(ray_weights(&log_i, -20.0, 0.0).is_none());
        let w = ray_weights(&log_i, -20.0, 2.0).unwrap();
        // I_ref is the 99th percentile of the lit rays: 99 (index round(99 · 0.99) = 98).
        let reference = 99.0f32;
        for (k, &wk) in w.iter().take(100).enumerate() {
            let i = (k + 1) as f32;
            let want = (i / reference).min(1.0).powi(2);
            assert!((wk - want).abs() < 1e-5, "ray {k}: {wk} vs {want}");
        }
        // The unlit ray is not part of the reference and keeps the weight 1.
        assert_eq!(w[100], 1.0);
        // γ = 1 halves the weight of a ray at half the reference.
        let w1 = ray_weights(&[0.0, 2f32.ln()], -20.0, 1.0).unwrap();
        assert!(
            (w1[0] - 0.5).abs() < 1e-6 && (w1[1] - 1.0).abs() < 1e-6,
            "{w1:?}"
        );
        // No lit ray at all: no panic.
        assert_eq!(ray_weights(&[-30.0], -20.0, 2.0).unwrap(), vec![1.0]);
    }

    /// The merged term has the same minimiser and curvature as the two terms it replaces.
    #[test]
    fn the_tie_merges_two_quadratics_into_one_on_seen_dark_rays_only() {
        let mut weights = vec![1.0, 0.2, 0.2, 0.0];
        let mut targets = vec![-1.0, -3.0, -3.0, -4.0];
        let carried = vec![5.0, -1.0, -1.0, -2.0];
        let seen = vec![true, true, false, true];
        let (w0, t0) = (weights.clone(), targets.clone());
        let kappa = 0.5;
        tie_to_centre(&mut weights, &mut targets, &carried, &seen, kappa);
        // A bright ray (weight 1) and an unseen ray are unchanged.
        assert_eq!((weights[0], targets[0]), (1.0, -1.0));
        assert_eq!((weights[2], targets[2]), (0.2, -3.0));
        // Seen dark rays: E(s) = w (s − t)² + κ(1 − w)(s − c)², compared at three values of s
        // up to the constant the merge drops.
        for k in [1usize, 3] {
            let extra = kappa * (1.0 - w0[k]);
            let two = |s: f32| w0[k] * (s - t0[k]).powi(2) + extra * (s - carried[k]).powi(2);
            let one = |s: f32| weights[k] * (s - targets[k]).powi(2);
            let (d1, d2) = (two(1.0) - two(0.0), one(1.0) - one(0.0));
            let (e1, e2) = (two(-2.0) - two(0.0), one(-2.0) - one(0.0));
            assert!((d1 - d2).abs() < 1e-5 && (e1 - e2).abs() < 1e-5, "ray {k}");
        }
        // A ray with no weight of its own takes the carried value.
        assert!((targets[3] + 2.0).abs() < 1e-6 && (weights[3] - 0.5).abs() < 1e-6);
    }

    #[test]
    fn negative_or_non_finite_weights_are_refused() {
        assert!(DataTermParams::THESIS.validate().is_ok());
        for bad in [
            DataTermParams {
                gamma: -1.0,
                centre_weight: 0.0,
            },
            DataTermParams {
                gamma: 1.0,
                centre_weight: f32::NAN,
            },
        ] {
            assert!(bad.validate().is_err(), "{bad:?}");
        }
    }
}
