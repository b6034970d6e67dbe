//! The level prior of the per-view solves: Zhao et al.'s Retinex ([`crate::retinex`]) solved
//! once, on the centre view, and carried to every view through the disparity.
//!
//! The per-view energy (eq. 4.4, [`crate::lightfield::retinex`]) ties the shading's lowest
//! frequencies to a target with the weak weight `μ`. The thesis' target is the log intensity,
//! which pulls large dark surfaces (a black wall) towards dark shading, i.e. grey reflectance:
//! the gradient cues cannot tell an achromatic reflectance edge from a shadow edge. Zhao's
//! non-local texture groups and white anchors can, so its log shading is the target here. One
//! solve, warped, is the same target for every view, so it adds no angular incoherence.
//!
//! Measured on the 8 rendered tuning scenes it is an option, not the default: it fixes the
//! black back wall of `scene06` (LMSE 0.1125 → 0.0841) but imports Zhao's own errors elsewhere
//! (mean LMSE 0.0537 against 0.0432; docs/intrinsic-lightfields.md).

use rayon::prelude::*;

use crate::decomposition::SHADING_FLOOR;
use crate::error::Result;
use crate::image::Image;
use crate::lightfield::LightField;
use crate::lightfield::disparity::{corresponding, sample_bilinear};
use crate::retinex::{self, RetinexParams, Strokes};

/// Largest difference (pixels per view step) between a ray's disparity and the centre view's at
/// the point it maps to, for the centre pixel to show the same surface.
const SAME_SURFACE: f32 = 0.5;

/// The log-shading target of every ray (views-major, one value per pixel): Zhao's centre-view
/// log shading at the corresponding centre pixel; where the centre view does not see the point,
/// the ray's log intensity `log_i` plus the centre view's median of `ln S − i`.
pub(super) fn centre_retinex_prior(
    lf: &LightField,
    disparity: &LightField,
    log_i: &[f32],
) -> Result<Vec<f32>> {
    let centre = lf.view_index(lf.rows() / 2, lf.cols() / 2);
    let (d, _) = retinex::decompose(
        &lf.view(centre),
        None,
        &Strokes::default(),
        &RetinexParams::default(),
        &mut |_| {},
    )?;
    let s_max = d.shading.data().iter().copied().fold(0.0f32, f32::max);
    let floor = (s_max * SHADING_FLOOR).max(f32::MIN_POSITIVE);
    let log_s: Vec<f32> = d.shading.data().iter().map(|v| v.max(floor).ln()).collect();
    Ok(carry_from_centre(lf, disparity, &log_s, log_i)?.0)
}

/// A centre-view log shading `centre_log_s` carried to every ray (views-major): the value at the
/// corresponding centre pixel where the centre view sees the same surface, else the
/// ray's log intensity plus the centre view's median of `ln S − i`. Also returns which rays
/// the centre view sees.
pub(super) fn carry_from_centre(
    lf: &LightField,
    disparity: &LightField,
    centre_log_s: &[f32],
    log_i: &[f32],
) -> Result<(Vec<f32>, Vec<bool>)> {
    let (w, h) = (lf.width() as usize, lf.height() as usize);
    let n = w * h;
    let centre = (lf.rows() / 2, lf.cols() / 2);
    let ci = lf.view_index(centre.0, centre.1);
    let centre_i = &log_i[ci * n..(ci + 1) * n];
    let mut gap: Vec<f32> = centre_log_s
        .iter()
        .zip(centre_i)
        .map(|(s, i)| s - i)
        .collect();
    let mid = gap.len() / 2;
    let offset = *gap.select_nth_unstable_by(mid, f32::total_cmp).1;
    let log_s = Image::from_vec(w as u32, h as u32, 1, centre_log_s.to_vec())?;
    let centre_disp = disparity.view_data(ci);
    let mut out = vec![0.0f32; lf.views() * n];
    let mut seen_mask = vec![false; lf.views() * n];
    out.par_chunks_mut(n)
        .zip(seen_mask.par_chunks_mut(n))
        .enumerate()
        .for_each(|(v, (target, seen_out))| {
            let from = (v / lf.cols(), v % lf.cols());
            let disp = disparity.view_data(v);
            let i = &log_i[v * n..(v + 1) * n];
            let mut sample = [0.0f32];
            for (p, t) in target.iter_mut().enumerate() {
                let (x, y) = ((p % w) as f32, (p / w) as f32);
                let (cx, cy) = corresponding(x, y, disp[p], from, centre);
                let (rx, ry) = (cx.round(), cy.round());
                let seen = rx >= 0.0
                    && ry >= 0.0
                    && (rx as usize) < w
                    && (ry as usize) < h
                    && (centre_disp[ry as usize * w + rx as usize] - disp[p]).abs() <= SAME_SURFACE;
                seen_out[p] = seen;
                *t = if seen {
                    sample_bilinear(&log_s, cx, cy, &mut sample);
                    sample[0]
                } else {
                    i[p] + offset
                };
            }
        });
    Ok((out, seen_mask))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lightfield::synthetic::card_in_front_of_a_wall;

    /// With whole-pixel disparities every ray the centre view sees takes exactly Zhao's centre
    /// log shading at its corresponding pixel; the others the log intensity plus one offset.
    #[test]
    fn seen_rays_take_the_centre_solution_and_hidden_ones_the_intensity() {
        let (lf, truth) = card_in_front_of_a_wall(3, 3, 40, 32, 5);
        let (w, h) = (40usize, 32usize);
        let n = w * h;
        let log_i: Vec<f32> = lf
            .data()
            .chunks_exact(3)
            .map(|p| {
                (p[0] * p[0] + p[1] * p[1] + p[2] * p[2])
                    .sqrt()
                    .max(1e-6)
                    .ln()
            })
            .collect();
        let prior = centre_retinex_prior(&lf, &truth.disparity, &log_i).unwrap();
        let (zhao, _) = retinex::decompose(
            &lf.view(4),
            None,
            &Strokes::default(),
            &RetinexParams::default(),
            &mut |_| {},
        )
        .unwrap();
        let centre_disp = truth.disparity.view_data(4);
        let (mut seen, mut hidden) = (0, 0);
        let mut offsets = Vec::new();
        for v in 0..9 {
            let disp = truth.disparity.view_data(v);
            for p in 0..n {
                let (x, y) = ((p % w) as f32, (p / w) as f32);
                let (cx, cy) = corresponding(x, y, disp[p], (v / 3, v % 3), (1, 1));
                let inside = cx >= 0.0 && cy >= 0.0 && (cx as usize) < w && (cy as usize) < h;
                let q = cy as usize * w + cx as usize;
                let got = prior[v * n + p];
                if inside && centre_disp[q] == disp[p] {
                    let want = zhao.shading.data()[q].ln();
                    assert!(
                        (got - want).abs() < 1e-5,
                        "view {v} pixel {p}: {got} vs {want}"
                    );
                    seen += 1;
                } else {
                    offsets.push(got - log_i[v * n + p]);
                    hidden += 1;
                }
            }
        }
        assert_eq!(prior[4 * n..5 * n].len(), n);
        assert!(seen > 8 * n && hidden > 100, "seen {seen}, hidden {hidden}");
        // One offset for every hidden ray.
        assert!(offsets.iter().all(|o| (o - offsets[0]).abs() < 1e-5));
    }
}
