//! Writing a light field's results: every view under the input's own name, a contact sheet of
//! all views, and an animation that steps through the views so that a person can see whether
//! reflectance and shading stay put from view to view.

use std::path::Path;

use image::codecs::gif::{GifEncoder, Repeat};
use image::{Delay, Frame, RgbaImage};

use crate::color::linear_to_srgb;
use crate::error::{Error, Result};
use crate::image::Image;
use crate::io::{Depth, Encoding, save};
use crate::lightfield::LightField;

/// Writes view `i` of `lf` to `dir/names[i]` with a `.png` extension (values in [0, 1] after
/// dividing by `scale`; clamped).
pub fn write_views(
    dir: &Path,
    names: &[String],
    lf: &LightField,
    scale: f32,
    enc: Encoding,
    depth: Depth,
) -> Result<()> {
    use rayon::prelude::*;
    if names.len() != lf.views() {
        return Err(Error::param(
            "names",
            names.len(),
            "one file name per view is needed",
        ));
    }
    names.par_iter().enumerate().try_for_each(|(i, name)| {
        let file = Path::new(name).with_extension("png");
        save(dir.join(file), &lf.view(i).map(|v| v / scale), enc, depth)
    })
}

/// 8-bit sRGB RGBA of a 1- or 3-channel linear image divided by `scale`.
fn to_rgba(img: &Image, scale: f32) -> RgbaImage {
    let c = img.channels();
    let mut out = RgbaImage::new(img.width(), img.height());
    for (i, px) in out.pixels_mut().enumerate() {
        let p = img.px(i);
        let rgb = [p[0], p[(1).min(c - 1)], p[(2).min(c - 1)]];
        let b = rgb.map(|v| (linear_to_srgb((v / scale).clamp(0.0, 1.0)) * 255.0).round() as u8);
        px.0 = [b[0], b[1], b[2], 255];
    }
    out
}

/// Tile size so that `cols` tiles of the view's aspect fit in `max_width` pixels: at least 8
/// pixels wide, at most the view's width (a view narrower than 8 pixels keeps its width).
fn tile_size(lf: &LightField, cols: usize, max_width: u32) -> (u32, u32) {
    let tw = (max_width / cols.max(1) as u32)
        .max(8)
        .min(lf.width())
        .max(1);
    let th = ((tw as f32 * lf.height() as f32 / lf.width() as f32).round() as u32).max(1);
    (tw, th)
}

/// All views on one sheet, laid out as the camera grid, each divided by `scale`, at most
/// `max_width` pixels wide (views are shrunk, never enlarged). 2-pixel black gutters.
pub fn contact_sheet(lf: &LightField, scale: f32, max_width: u32) -> RgbaImage {
    let gap = 2;
    let (tw, th) = tile_size(lf, lf.cols(), max_width);
    let mut sheet = RgbaImage::from_pixel(
        lf.cols() as u32 * (tw + gap) - gap,
        lf.rows() as u32 * (th + gap) - gap,
        image::Rgba([0, 0, 0, 255]),
    );
    for r in 0..lf.rows() {
        for c in 0..lf.cols() {
            let tile = to_rgba(&lf.view(lf.view_index(r, c)).resize(tw, th), scale);
            image::imageops::replace(
                &mut sheet,
                &tile,
                (c as u32 * (tw + gap)) as i64,
                (r as u32 * (th + gap)) as i64,
            );
        }
    }
    sheet
}

/// Views in a serpentine order (left to right on even rows, back on odd ones), so that every
/// step of the animation moves to a neighbouring view.
pub fn serpentine(rows: usize, cols: usize) -> Vec<usize> {
    (0..rows)
        .flat_map(|r| {
            let row: Vec<usize> = if r % 2 == 0 {
                (0..cols).collect()
            } else {
                (0..cols).rev().collect()
            };
            row.into_iter().map(move |c| r * cols + c)
        })
        .collect()
}

/// A looping GIF stepping through the views in [`serpentine`] order; each frame shows the given
/// light fields side by side (for instance input, reflectance, shading), each divided by its
/// scale, every panel at most `panel_width` pixels wide. `delay_ms` per frame.
pub fn write_animation(
    path: &Path,
    panels: &[(&LightField, f32)],
    panel_width: u32,
    delay_ms: u32,
) -> Result<()> {
    let Some((first, _)) = panels.first() else {
        return Err(Error::param(
            "panels",
            0,
            "at least one light field to animate",
        ));
    };
    let (tw, th) = tile_size(first, 1, panel_width);
    let file = std::fs::File::create(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let codec = |e: image::ImageError| Error::Codec {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let mut encoder = GifEncoder::new_with_speed(std::io::BufWriter::new(file), 30);
    encoder.set_repeat(Repeat::Infinite).map_err(codec)?;
    for v in serpentine(first.rows(), first.cols()) {
        let mut frame = RgbaImage::new(tw * panels.len() as u32, th);
        for (k, (lf, scale)) in panels.iter().enumerate() {
            let tile = to_rgba(&lf.view(v).resize(tw, th), *scale);
            image::imageops::replace(&mut frame, &tile, (k as u32 * tw) as i64, 0);
        }
        let delay = Delay::from_numer_denom_ms(delay_ms, 1);
        encoder
            .encode_frame(Frame::from_parts(frame, 0, 0, delay))
            .map_err(codec)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn serpentine_steps_between_neighbouring_views() {
        let order = serpentine(3, 4);
        assert_eq!(order, [0, 1, 2, 3, 7, 6, 5, 4, 8, 9, 10, 11]);
        for pair in order.windows(2) {
            let (a, b) = (pair[0], pair[1]);
            assert_eq!((a / 4).abs_diff(b / 4) + (a % 4).abs_diff(b % 4), 1);
        }
    }

    #[test]
    fn sheet_places_each_view_at_its_grid_position_and_gif_has_a_frame_per_view() {
        // View (r, c) is uniformly (r, c, 0)/2 in linear values.
        let views: Vec<Image> = (0..6)
            .map(|i| {
                let (r, c) = ((i / 3) as f32, (i % 3) as f32);
                Image::from_fn::<3>(10, 8, move |_, _| [r / 2.0, c / 2.0, 0.0])
            })
            .collect();
        let lf = LightField::from_views(2, 3, &views).unwrap();
        let sheet = contact_sheet(&lf, 1.0, 60);
        // 3 tiles of 10 px (60/3 = 20, but views are never enlarged) plus 2-px gutters.
        assert_eq!(sheet.dimensions(), (3 * 10 + 4, 2 * 8 + 2));
        let at = |x, y| sheet.get_pixel(x, y).0;
        let srgb = |v: f32| (linear_to_srgb(v) * 255.0).round() as u8;
        assert_eq!(at(2 * 12 + 5, 10 + 4), [srgb(0.5), srgb(1.0), 0, 255]);
        assert_eq!(at(10, 0), [0, 0, 0, 255]);

        let dir = tempfile::tempdir().unwrap();
        let gif = dir.path().join("views.gif");
        write_animation(&gif, &[(&lf, 1.0), (&lf, 2.0)], 10, 80).unwrap();
        let decoder = image::codecs::gif::GifDecoder::new(std::io::BufReader::new(
            std::fs::File::open(&gif).unwrap(),
        ))
        .unwrap();
        use image::AnimationDecoder;
        let frames = decoder.into_frames().collect_frames().unwrap();
        assert_eq!(frames.len(), 6);
        assert_eq!(frames[0].buffer().dimensions(), (20, 8));
    }

    #[test]
    fn views_narrower_than_a_tile_keep_their_size_on_the_sheet_and_in_the_gif() {
        // 1×1 and 5×3 views: the sheet's smallest tile is 8 pixels, but views are never
        // enlarged (this used to panic: a clamp to [8, width] with width < 8).
        for (w, h) in [(1u32, 1u32), (5, 3)] {
            let views: Vec<Image> = (0..4)
                .map(|_| Image::from_fn::<3>(w, h, |_, _| [0.5, 0.5, 0.5]))
                .collect();
            let lf = LightField::from_views(2, 2, &views).unwrap();
            let sheet = contact_sheet(&lf, 1.0, 1800);
            assert_eq!(sheet.dimensions(), (2 * w + 2, 2 * h + 2));
            let dir = tempfile::tempdir().unwrap();
            write_animation(&dir.path().join("views.gif"), &[(&lf, 1.0)], 400, 80).unwrap();
        }
    }
}
