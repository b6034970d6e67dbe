//! The last step of [`super::decompose`]: the layers from the filtered log reflectance,
//! `S_f = ‖L̂‖₂ / ‖R̂₁‖₂` and `R_f = L / S_f`, so that `R_f × S_f = L` on every ray, with one
//! reflectance scale for the whole light field.

use rayon::prelude::*;

use super::channel_max_quantile;
use crate::decomposition::SHADING_FLOOR;
use crate::lightfield::LightField;

/// `(R_f, S_f)` (3 and 1 values per ray) from the input `lf`, `‖L̂‖₂` per ray (`norm`) and
/// `ln ‖R̂₁‖₂` per ray (`log_r_hat`).
///
/// A ray marked in `unlit` (no light, `‖L̂‖ = 0`, e.g. a shadow that is black in an 8-bit
/// file), which says nothing about its reflectance, takes the filtered reflectance as a
/// grey (`‖R‖ = ‖R̂₁‖`) and zero shading, rather than the black reflectance of the thesis'
/// `L / S_f` that no other view of the point agrees with. Elsewhere the shading is floored at
/// `SHADING_FLOOR` of the input's maximum.
pub(super) fn compose(
    lf: &LightField,
    norm: &[f32],
    log_r_hat: &[f32],
    unlit: Option<&[bool]>,
) -> (LightField, Vec<f32>) {
    let input_max = lf.data().iter().copied().fold(0.0f32, f32::max);
    let s_floor = (input_max * SHADING_FLOOR).max(f32::MIN_POSITIVE);
    let mut shading: Vec<f32> = vec![0.0; norm.len()];
    let mut reflectance = lf.clone();
    reflectance
        .data_mut()
        .par_chunks_exact_mut(3)
        .zip(shading.par_iter_mut())
        .zip(norm.par_iter().zip(log_r_hat.par_iter()))
        .enumerate()
        .for_each(|(i, ((p, s), (&l, &r)))| {
            let r_norm = r.exp().max(f32::MIN_POSITIVE);
            if unlit.is_some_and(|u| u[i]) {
                *s = 0.0;
                let grey = if r_norm.is_finite() {
                    r_norm / 3f32.sqrt()
                } else {
                    0.0
                };
                p.fill(grey);
                return;
            }
            let mut v = l / r_norm;
            if !(v.is_finite() && v >= s_floor) {
                v = s_floor;
            }
            *s = v;
            p.iter_mut().for_each(|c| *c /= v);
        });
    // One scale for the whole light field.
    let q = channel_max_quantile(reflectance.data(), 0.995);
    if q.is_finite() && q > 0.0 {
        reflectance.data_mut().par_iter_mut().for_each(|v| *v /= q);
        shading.par_iter_mut().for_each(|s| *s *= q);
    }
    (reflectance, shading)
}
