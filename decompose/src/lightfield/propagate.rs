//! The centre view's disparity carried to every view, for the occlusion cue when only the
//! centre view's map is known (HCI's `gt_disp_lowres.pfm`, or the EPI estimate).
//!
//! Each centre pixel is splatted to where it appears in the view
//! ([`super::disparity::corresponding`]); where two land on one pixel the nearer wins (larger
//! disparity: HCI's disparity is positive in front of the focus plane). Pixels no centre pixel
//! lands on were hidden from the centre view: they are disoccluded background, so they take the
//! smaller (farther) of the nearest filled values to their left and right.

use rayon::prelude::*;

use super::LightField;
use super::disparity::corresponding;
use crate::error::{Error, Result};
use crate::image::Image;

/// Every view's disparity (1 channel) from the centre view's map, for a `rows × cols` grid.
pub fn disparity_to_every_view(centre: &Image, rows: usize, cols: usize) -> Result<LightField> {
    if centre.channels() != 1 {
        return Err(Error::param(
            "disparity.channels",
            centre.channels(),
            "a disparity map has one channel",
        ));
    }
    let (w, h) = (centre.width() as usize, centre.height() as usize);
    let c = (rows / 2, cols / 2);
    let views: Vec<Image> = (0..rows * cols)
        .into_par_iter()
        .map(|v| {
            let to = (v / cols, v % cols);
            if to == c {
                return centre.clone();
            }
            let mut out = vec![f32::NEG_INFINITY; w * h];
            for y in 0..h {
                for x in 0..w {
                    let d = centre.data()[y * w + x];
                    let (tx, ty) = corresponding(x as f32, y as f32, d, c, to);
                    let (tx, ty) = (tx.round(), ty.round());
                    if tx < 0.0 || ty < 0.0 || tx >= w as f32 || ty >= h as f32 {
                        continue;
                    }
                    let slot = &mut out[ty as usize * w + tx as usize];
                    *slot = slot.max(d);
                }
            }
            fill_holes(&mut out, w, h);
            Image::from_vec(w as u32, h as u32, 1, out).expect("sized to the view")
        })
        .collect();
    LightField::from_views(rows, cols, &views)
}

/// Fills unset pixels (−∞) of each row with the smaller of the nearest set values on either
/// side; a row with nothing set (the card covers no whole row in practice) copies the row above,
/// or is 0 at the top.
fn fill_holes(d: &mut [f32], w: usize, h: usize) {
    for y in 0..h {
        let row = y * w;
        let mut left = vec![f32::NEG_INFINITY; w];
        let mut last = f32::NEG_INFINITY;
        for x in 0..w {
            if d[row + x].is_finite() {
                last = d[row + x];
            }
            left[x] = last;
        }
        let mut next = f32::NEG_INFINITY;
        for x in (0..w).rev() {
            if d[row + x].is_finite() {
                next = d[row + x];
                continue;
            }
            d[row + x] = match (left[x].is_finite(), next.is_finite()) {
                (true, true) => left[x].min(next),
                (true, false) => left[x],
                (false, true) => next,
                (false, false) => {
                    if y > 0 {
                        d[row - w + x]
                    } else {
                        0.0
                    }
                }
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lightfield::synthetic::card_in_front_of_a_wall;

    #[test]
    fn centre_disparity_reproduces_every_views_true_disparity() {
        // The card at disparity 1 in front of a wall at 0: the splatted maps must match the
        // true per-view maps exactly, including the wall strips the card uncovers.
        let (_, truth) = card_in_front_of_a_wall(5, 5, 30, 24, 2);
        let centre = truth.disparity.view(truth.disparity.view_index(2, 2));
        let every = disparity_to_every_view(&centre, 5, 5).unwrap();
        assert_eq!(every, truth.disparity);
    }

    #[test]
    fn a_grey_or_rgb_map_is_checked() {
        assert!(disparity_to_every_view(&Image::new(4, 4, 3), 3, 3).is_err());
    }
}
