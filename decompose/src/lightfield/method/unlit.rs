//! Unlit rays take the centre view's reflectance (not in the thesis;
//! [`super::LightFieldParams::unlit_from_centre`]).
//!
//! A ray with no light (`‖L̂‖ = 0`) says nothing about its reflectance. With
//! [`super::LightFieldParams::unlit_as_missing`] the 4D filter fills it in from the lit rays
//! around it, and in a large shadow the spatial neighbours dominate: each view fills the
//! shadow from the surface it sees around it, and the views see different surroundings, so
//! one surface point gets a different reflectance in every view. On rendered test scene81
//! (12% of its rays in an unlit shadow) that put the angular incoherence at 0.0262, against
//! 0.0073 over its lit rays (docs/intrinsic-lightfields.md, twelfth session).
//!
//! One point should have one reflectance, so each unlit ray of a view other than the centre
//! takes the centre view's filled log reflectance at the point it shows: the ray's own
//! disparity `d` gives the centre position ([`crate::lightfield::disparity::corresponding`]),
//! sampled bilinearly ([`crate::lightfield::disparity::sample_bilinear`]), where all four centre neighbours have a disparity within
//! [`SAME_SURFACE`] of `d` (the centre view sees the same surface) and are finite. Elsewhere
//! (the point is hidden from the centre view, or outside it) the ray keeps its own fill. Lit
//! rays, and the centre view, are not touched; `R × S = L` holds whatever an unlit ray's
//! reflectance (its shading is 0).

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::image::Image;
use crate::lightfield::LightField;
use crate::lightfield::disparity::{corresponding, sample_bilinear};

/// Largest disparity difference (pixels per view step) for a centre pixel to show the same
/// surface as a ray: the tolerance of the evaluation's visibility test
/// ([`crate::lightfield::eval::VISIBILITY_TOLERANCE`]).
pub const SAME_SURFACE: f32 = 0.25;

/// Replaces the log reflectance of every unlit ray outside the centre view by the centre
/// view's at the point the ray shows (see the module docs). `log_r` and `unlit` hold one value
/// per ray, view after view in `lf`'s order; `disparity` one channel per view. Errors with
/// [`Error::InvalidParam`] unless `log_r` and `unlit` hold one value per ray.
pub(super) fn share_centre_fill(
    lf: &LightField,
    disparity: &LightField,
    unlit: &[bool],
    log_r: &mut [f32],
) -> Result<()> {
    let (w, h) = (lf.width() as usize, lf.height() as usize);
    let n = w * h;
    let centre = (lf.rows() / 2, lf.cols() / 2);
    let c = lf.view_index(centre.0, centre.1);
    let rays = lf.views() * n;
    if log_r.len() != rays || unlit.len() != rays {
        return Err(Error::param(
            "log_r",
            log_r.len(),
            "share_centre_fill needs one log reflectance and one unlit flag per ray",
        ));
    }
    let centre_values = log_r[c * n..(c + 1) * n].to_vec();
    let centre_log_r = Image::from_vec(lf.width(), lf.height(), 1, centre_values)?;
    let centre_disp = disparity.view_data(c);
    log_r
        .par_chunks_mut(n)
        .enumerate()
        .filter(|&(v, _)| v != c)
        .for_each(|(v, view_log_r)| {
            let from = (v / lf.cols(), v % lf.cols());
            let disp = disparity.view_data(v);
            let unlit = &unlit[v * n..(v + 1) * n];
            for p in (0..n).filter(|&p| unlit[p]) {
                let d = disp[p];
                let (x, y) = ((p % w) as f32, (p / w) as f32);
                let (sx, sy) = corresponding(x, y, d, from, centre);
                if !(sx >= 0.0 && sy >= 0.0 && sx <= (w - 1) as f32 && sy <= (h - 1) as f32) {
                    continue;
                }
                let (x0, y0) = (sx.floor() as usize, sy.floor() as usize);
                let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
                let corners = [(x0, y0), (x1, y0), (x0, y1), (x1, y1)];
                let same = corners.iter().all(|&(xx, yy)| {
                    let q = yy * w + xx;
                    (centre_disp[q] - d).abs() <= SAME_SURFACE && centre_log_r.data()[q].is_finite()
                });
                if !same {
                    continue;
                }
                sample_bilinear(&centre_log_r, sx, sy, &mut view_log_r[p..=p]);
            }
        });
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unlit_rays_take_the_centre_value_of_the_point_they_show() {
        // 1×3 views of 8×1 pixels at disparity 1: view 0's pixel x shows the centre's x − 1,
        // view 2's the centre's x + 1.
        let (w, views) = (8usize, 3usize);
        let lf = LightField::from_vec(1, 3, w as u32, 1, 3, vec![0.5; views * w * 3]).unwrap();
        let mut disp = vec![1.0f32; views * w];
        disp[w + 6] = 3.0; // the centre's pixel 6 is another surface
        let disparity = LightField::from_vec(1, 3, w as u32, 1, 1, disp).unwrap();
        let centre: Vec<f32> = (0..w).map(|x| -0.1 * x as f32).collect();
        let mut log_r: Vec<f32> = [vec![9.0; w], centre.clone(), vec![7.0; w]].concat();
        let mut unlit = vec![false; views * w];
        for p in [2, 3, 7] {
            unlit[p] = true; // view 0
            unlit[2 * w + p] = true; // view 2
        }
        unlit[w + 4] = true; // the centre's own unlit rays keep their fill
        share_centre_fill(&lf, &disparity, &unlit, &mut log_r).unwrap();
        // View 0: x = 2, 3 show the centre's 1, 2; x = 7 shows 6, another surface: kept.
        assert_eq!(
            &log_r[..w],
            &[9.0, 9.0, centre[1], centre[2], 9.0, 9.0, 9.0, 9.0]
        );
        // The centre is untouched.
        assert_eq!(&log_r[w..2 * w], &centre[..]);
        // View 2: x = 2 shows 3, x = 3 shows 4; x = 7 shows 8, outside the view: kept.
        assert_eq!(
            &log_r[2 * w..],
            &[7.0, 7.0, centre[3], centre[4], 7.0, 7.0, 7.0, 7.0]
        );
    }
}
