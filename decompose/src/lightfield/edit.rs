//! Light-field edits (thesis Fig. 4.8): one set of strokes or one curve, applied to every view
//! through the decomposition, so that the edit stays on the same surface and has the same
//! strength in every view.
//!
//! - [`recolour`]: the reflectance inside a region drawn on the centre view is turned in hue and
//!   scaled in saturation ([`crate::edit::recolour`] per view); the region is carried to every
//!   view by the disparity ([`region_to_every_view`]).
//! - [`relight`]: the shading goes through one tone curve, relative to the shading maximum of
//!   the **whole** light field (a per-view maximum would relight each view differently).

use rayon::prelude::*;

use super::LightField;
use super::disparity::corresponding;
use super::eval::VISIBILITY_TOLERANCE;
use super::method::LightFieldDecomposition;
use crate::edit::{self, Curve};
use crate::error::{Error, Result};
use crate::image::Mask;

/// A region drawn on the centre view, carried to every view: pixel `(x, y)` of view `v` is in
/// the region when the point it shows (at its own disparity, `disparity` holding every view's
/// map) lands on a region pixel of the centre view **and** is the point the centre view sees
/// there (same disparity within [`VISIBILITY_TOLERANCE`]); a surface hidden from the centre
/// view cannot have been stroked.
pub fn region_to_every_view(centre_region: &Mask, disparity: &LightField) -> Result<LightField> {
    if centre_region.dims() != disparity.dims() || disparity.channels() != 1 {
        return Err(Error::ShapeMismatch {
            expected: disparity.dims(),
            got: centre_region.dims(),
        });
    }
    let (w, h) = disparity.dims();
    let centre = (disparity.rows() / 2, disparity.cols() / 2);
    let centre_disparity = disparity.view_data(disparity.view_index(centre.0, centre.1));
    let views: Vec<Vec<f32>> = (0..disparity.views())
        .into_par_iter()
        .map(|v| {
            let from = (v / disparity.cols(), v % disparity.cols());
            let d = disparity.view_data(v);
            (0..(w * h) as usize)
                .map(|p| {
                    let (x, y) = ((p % w as usize) as f32, (p / w as usize) as f32);
                    let (cx, cy) = corresponding(x, y, d[p], from, centre);
                    let (cx, cy) = (cx.round(), cy.round());
                    let inside = cx >= 0.0 && cy >= 0.0 && cx < w as f32 && cy < h as f32;
                    let q = cy as usize * w as usize + cx as usize;
                    let hit = inside
                        && centre_region.at(q)
                        && (centre_disparity[q] - d[p]).abs() <= VISIBILITY_TOLERANCE;
                    if hit { 1.0 } else { 0.0 }
                })
                .collect()
        })
        .collect();
    LightField::from_vec(disparity.rows(), disparity.cols(), w, h, 1, views.concat())
}

/// Every view recoloured inside its region (`None`: everywhere); returns the edited light field.
pub fn recolour(
    d: &LightFieldDecomposition,
    region: Option<&LightField>,
    hue_degrees: f32,
    saturation: f32,
) -> Result<LightField> {
    let views = d.reflectance.views();
    let edited: Vec<_> = (0..views)
        .into_par_iter()
        .map(|v| {
            let mask = region
                .map(|r| {
                    Mask::from_vec(
                        r.width(),
                        r.height(),
                        r.view_data(v).iter().map(|&x| x > 0.5).collect(),
                    )
                })
                .transpose()?;
            edit::recolour(&d.view(v), mask.as_ref(), hue_degrees, saturation)
        })
        .collect::<Result<_>>()?;
    LightField::from_views(d.reflectance.rows(), d.reflectance.cols(), &edited)
}

/// Every view relit through one curve on the shading, relative to the light field's maximum.
pub fn relight(d: &LightFieldDecomposition, curve: &Curve) -> Result<LightField> {
    let max = d
        .shading
        .data()
        .iter()
        .copied()
        .fold(0.0f32, f32::max)
        .max(f32::MIN_POSITIVE);
    let mut out = d.reflectance.clone();
    out.data_mut()
        .par_chunks_exact_mut(3)
        .zip(d.shading.data().par_iter())
        .for_each(|(p, &s)| {
            let s = curve.eval(s / max).max(0.0) * max;
            p.iter_mut().for_each(|v| *v *= s);
        });
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lightfield::synthetic::card_in_front_of_a_wall;

    #[test]
    fn a_region_on_the_centre_view_follows_its_surface_into_every_view() {
        let (_, truth) = card_in_front_of_a_wall(5, 5, 30, 24, 4);
        let c = truth.disparity.view_index(2, 2);
        let card = Mask::from_vec(
            30,
            24,
            truth
                .disparity
                .view_data(c)
                .iter()
                .map(|&d| d > 0.5)
                .collect(),
        )
        .unwrap();
        let region = region_to_every_view(&card, &truth.disparity).unwrap();
        // The card region in every view is exactly where the card is (disparity 1).
        for (r, d) in region.data().iter().zip(truth.disparity.data()) {
            assert_eq!(*r, *d);
        }
    }

    #[test]
    fn relighting_uses_one_scale_for_all_views() {
        let (lf, truth) = card_in_front_of_a_wall(3, 3, 16, 12, 6);
        let d = LightFieldDecomposition {
            reflectance: truth.reflectance.clone(),
            shading: truth.shading.clone(),
        };
        // The identity curve gives the input back; halving the curve halves every view.
        let same = relight(&d, &Curve::new(&[(0.0, 0.0), (1.0, 1.0)]).unwrap()).unwrap();
        for (a, b) in same.data().iter().zip(lf.data()) {
            assert!((a - b).abs() < 1e-5);
        }
        let half = relight(&d, &Curve::new(&[(0.0, 0.0), (1.0, 0.5)]).unwrap()).unwrap();
        for (a, b) in half.data().iter().zip(lf.data()) {
            assert!((a - 0.5 * b).abs() < 1e-5);
        }
        let all = recolour(&d, None, 0.0, 1.0).unwrap();
        for (a, b) in all.data().iter().zip(lf.data()) {
            assert!((a - b).abs() < 1e-4 * b.max(1.0));
        }
    }
}
