//! The disparity convention of the HCI 4D light field benchmark (Honauer, Johannsen, Kondermann
//! & Goldluecke, "A dataset and evaluation methodology for depth estimation on 4D light fields",
//! ACCV 2016), which every light-field function of this crate follows.
//!
//! The views are numbered row-major (`input_Cam{row·cols + col:03}`); row 0 is the top row of
//! the camera grid and column 0 its left column. The cameras have parallel optical axes and
//! sensors shifted so that the focus plane has zero disparity (their Blender add-on,
//! `lightfield_simulator.py`: camera `(i, j)` sits at `x = (j − c₀)·b`, `y = −(i − r₀)·b`).
//! Disparity `d` is in pixels per view step, positive in front of the focus plane:
//! `d = b·f_px·(1/Z − 1/Z_focus)` (`depth2disp` in their evaluation toolkit). Hence
//!
//! > a point with disparity `d` at pixel `(x, y)` of view `(r, c)` appears at
//! > `(x − (c′ − c)·d, y − (r′ − r)·d)` in view `(r′, c′)`,
//!
//! with `x` to the right and `y` down: stepping one view to the right moves a near point
//! (`d > 0`) `d` pixels to the left, stepping one view down moves it `d` pixels up. In an
//! epipolar-plane image `S(x, s)` (a fixed image row `y` of the views of one grid row, `s` the
//! column index) the point traces the line `x + s·d = const`, so `∂x/∂s = −d`.
//! `scripts/render_lightfields.py` renders data in this convention and checks it against the
//! renderer; the tests below check it against the committed rendered fixture.

use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::image::Image;

use super::LightField;

/// Where a point with disparity `disparity` seen at `(x, y)` in view `from = (row, col)`
/// appears in view `to = (row, col)`: `(x − (c′ − c)·d, y − (r′ − r)·d)` (HCI convention, see
/// the module docs). Pixel coordinates are continuous, pixel centres at integers.
pub fn corresponding(
    x: f32,
    y: f32,
    disparity: f32,
    from: (usize, usize),
    to: (usize, usize),
) -> (f32, f32) {
    let dr = to.0 as f32 - from.0 as f32;
    let dc = to.1 as f32 - from.1 as f32;
    (x - dc * disparity, y - dr * disparity)
}

/// Bilinear sample of `img` at continuous `(x, y)` (pixel centres at integers), clamped to the
/// image; `out` receives one value per channel.
pub fn sample_bilinear(img: &Image, x: f32, y: f32, out: &mut [f32]) {
    let (w, h) = img.dims();
    let x = x.clamp(0.0, (w - 1) as f32);
    let y = y.clamp(0.0, (h - 1) as f32);
    let (x0, y0) = (x.floor() as u32, y.floor() as u32);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let (fx, fy) = (x - x0 as f32, y - y0 as f32);
    let (a, b) = (img.get(x0, y0), img.get(x1, y0));
    let (c, d) = (img.get(x0, y1), img.get(x1, y1));
    for (k, o) in out.iter_mut().enumerate() {
        let top = a[k] + (b[k] - a[k]) * fx;
        let bottom = c[k] + (d[k] - c[k]) * fx;
        *o = top + (bottom - top) * fy;
    }
}

/// View `from` of `lf` resampled onto view `to` through `to`'s disparity map: pixel `(x, y)` of
/// the result is view `from` sampled (bilinearly) at `corresponding(x, y, d(x, y), to, from)`.
/// Where the point is occluded in `from`, the result shows the occluder; compare it with the
/// disparity of `from` to find those pixels. Returns the warped image and a 1-channel mask
/// image holding 1 where the sample fell inside view `from`, 0 where it was clamped.
///
/// Errors when `disparity` is not a 1-channel image of the views' size or a view index is out
/// of the grid.
pub fn warp_to(
    lf: &LightField,
    from: (usize, usize),
    to: (usize, usize),
    disparity: &Image,
) -> Result<(Image, Image)> {
    disparity.check_dims(lf.dims())?;
    if disparity.channels() != 1 {
        return Err(Error::param(
            "disparity.channels",
            disparity.channels(),
            "a disparity map has one channel",
        ));
    }
    for (name, (r, c)) in [("from", from), ("to", to)] {
        if r >= lf.rows() || c >= lf.cols() {
            return Err(Error::param(
                name,
                format!("({r}, {c})"),
                "view index outside the camera grid",
            ));
        }
    }
    let source = lf.view(lf.view_index(from.0, from.1));
    let (w, h) = lf.dims();
    let ch = lf.channels();
    let mut out = Image::new(w, h, ch);
    let mut inside = Image::new(w, h, 1);
    out.data_mut()
        .par_chunks_mut(w as usize * ch)
        .zip(inside.data_mut().par_chunks_mut(w as usize))
        .enumerate()
        .for_each(|(y, (row, in_row))| {
            for x in 0..w as usize {
                let d = disparity.get(x as u32, y as u32)[0];
                let (sx, sy) = corresponding(x as f32, y as f32, d, to, from);
                sample_bilinear(&source, sx, sy, &mut row[x * ch..(x + 1) * ch]);
                let ok = sx >= 0.0 && sy >= 0.0 && sx <= (w - 1) as f32 && sy <= (h - 1) as f32;
                in_row[x] = if ok { 1.0 } else { 0.0 };
            }
        });
    Ok((out, inside))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn corresponding_follows_the_hci_signs_and_round_trips() {
        // One view to the right: a near point (d > 0) moves left; one view down: it moves up.
        assert_eq!(corresponding(10.0, 20.0, 1.5, (4, 4), (4, 5)), (8.5, 20.0));
        assert_eq!(corresponding(10.0, 20.0, 1.5, (4, 4), (5, 4)), (10.0, 18.5));
        assert_eq!(
            corresponding(10.0, 20.0, -0.5, (0, 0), (2, 3)),
            (11.5, 21.0)
        );
        let there = corresponding(3.25, 7.5, 0.7, (1, 2), (4, 0));
        let back = corresponding(there.0, there.1, 0.7, (4, 0), (1, 2));
        assert!((back.0 - 3.25).abs() < 1e-6 && (back.1 - 7.5).abs() < 1e-6);
    }

    #[test]
    fn warping_a_shifted_ramp_recovers_the_target_view() {
        // Views of the linear ramp v(x, y) = x + 2y on a plane of disparity 0.5: bilinear
        // sampling is exact on a ramp, so the warp reproduces the target inside the image.
        let d = 0.5f32;
        let views: Vec<Image> = (0..9)
            .map(|i| {
                let (r, c) = (i / 3, i % 3);
                Image::from_fn(12, 10, |x, y| {
                    let (cx, cy) = corresponding(x as f32, y as f32, d, (r, c), (1, 1));
                    [cx + 2.0 * cy]
                })
            })
            .collect();
        let lf = LightField::from_views(3, 3, &views).unwrap();
        let disp = Image::from_fn(12, 10, |_, _| [d]);
        let (warped, inside) = warp_to(&lf, (0, 2), (1, 1), &disp).unwrap();
        let target = lf.view(lf.view_index(1, 1));
        let mut checked = 0;
        for i in 0..warped.len() {
            if inside.px(i)[0] == 1.0 {
                assert!((warped.px(i)[0] - target.px(i)[0]).abs() < 1e-4);
                checked += 1;
            }
        }
        assert!(checked > 80, "only {checked} pixels inside");
        assert!(warp_to(&lf, (3, 0), (1, 1), &disp).is_err());
        assert!(warp_to(&lf, (0, 0), (1, 1), &Image::new(12, 10, 3)).is_err());
    }
}
