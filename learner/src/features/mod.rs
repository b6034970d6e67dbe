//! The 169 clip-art style features of Garces et al. 2014, §5.3, in the paper's order:
//! colour (15), shading (32), texture (84 LBP + 22 Haralick), strokes (16).
//!
//! Every feature is computed on a 400x400 rendering composited on white ([`crate::render`]),
//! inside the drawing region Ω ([`crate::mask::drawing_region`]). The per-image work is
//! single-threaded and deterministic; parallelism is across images (see [`extract_all`]).

pub mod colour;
pub mod glcm;
pub mod lbp;
pub mod shading;
pub mod swt;

use image::RgbImage;
use rayon::prelude::*;

use crate::edges::{self, CannyParams, Gradients};
use crate::mask::{self, Mask};
use crate::plane::{self, Plane};
use crate::render::CANVAS_SIZE;
use crate::{Error, Result};

/// The feature families of §5.3.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Family {
    /// Colour statistics (§5.3, "Color").
    Colour,
    /// Gradient-magnitude histograms (§5.3, "Shading").
    Shading,
    /// LBP histograms and Haralick statistics (§5.3, "Texture").
    Texture,
    /// Stroke widths (§5.3, "Strokes").
    Stroke,
}

/// A feature's stable name, family and one-line documentation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FeatureInfo {
    /// Stable snake_case name (the CSV column).
    pub name: &'static str,
    /// The family it belongs to.
    pub family: Family,
    /// One line: what it measures, with the section/equation.
    pub doc: &'static str,
}

/// Number of features.
pub const FEATURE_COUNT: usize =
    colour::COUNT + shading::COUNT + lbp::COUNT + glcm::COUNT + swt::COUNT;

/// One image's features, in [`catalogue`] order.
pub type FeatureVector = [f64; FEATURE_COUNT];

/// Every feature's name and doc, in output order.
pub fn catalogue() -> Vec<FeatureInfo> {
    let mut all = Vec::with_capacity(FEATURE_COUNT);
    all.extend(colour::catalogue());
    all.extend(shading::catalogue());
    all.extend(lbp::catalogue());
    all.extend(glcm::catalogue());
    all.extend(swt::catalogue());
    all
}

/// Everything the families share, computed once per image.
#[derive(Debug, Clone)]
pub struct Prepared {
    /// The 400x400 RGB rendering on white.
    pub image: RgbImage,
    /// Ω: non-white pixels dilated by 10 px, holes filled.
    pub region: Mask,
    /// Non-white pixels with holes filled; its boundary is the external contour.
    pub silhouette: Mask,
    /// Luma in `[0,1]` ([`plane::luma`]).
    pub grey: Plane,
    /// `grey` in 8 bits ([`lbp::grey_u8`]), which LBP samples and GLCM quantises.
    pub grey8: Vec<u8>,
    /// Canny edges of `grey` with [`CannyParams::default`].
    pub edges: Mask,
    /// Gradients of the Canny-smoothed grey plane.
    pub smoothed_gradients: Gradients,
}

impl Prepared {
    /// Prepares a 400x400 rendering. Fails on other sizes and on blank (all-white) images,
    /// which have no drawing to describe.
    pub fn new(image: RgbImage) -> Result<Self> {
        if image.width() != CANVAS_SIZE || image.height() != CANVAS_SIZE {
            return Err(Error::WrongCanvasSize {
                expected: CANVAS_SIZE,
                width: image.width(),
                height: image.height(),
            });
        }
        let (grey, grey8, non_white) = per_pixel_planes(&image);
        if non_white.count() == 0 {
            return Err(Error::BlankImage);
        }
        let region = non_white.dilate(mask::REGION_DILATION).fill_holes();
        let silhouette = non_white.fill_holes();
        let (edges, smoothed_gradients) = edges::canny(&grey, &CannyParams::default());
        Ok(Self {
            image,
            region,
            silhouette,
            grey,
            grey8,
            edges,
            smoothed_gradients,
        })
    }
}

crate::simd::vectorised_fn! {
/// [`plane::luma`], [`lbp::grey_u8`] of it and [`mask::non_white`], in one pass over the pixels
/// (the same values as the three functions).
fn per_pixel_planes<'a>(image: &'a RgbImage) -> (Plane, Vec<u8>, Mask) {
    let (w, h) = (image.width() as usize, image.height() as usize);
    let mut grey = vec![0.0f32; w * h];
    let mut grey8 = vec![0u8; w * h];
    let mut non_white = vec![false; w * h];
    let pixels = image.as_raw().chunks_exact(3);
    for (((rgb, g), g8), nw) in pixels.zip(&mut grey).zip(&mut grey8).zip(&mut non_white) {
        *g = plane::luma_of(rgb);
        *g8 = lbp::round_u8(*g * 255.0);
        *nw = !mask::is_white([rgb[0], rgb[1], rgb[2]]);
    }
    let grey = Plane {
        width: w,
        height: h,
        data: grey,
    };
    let non_white = Mask {
        width: w,
        height: h,
        data: non_white,
    };
    (grey, grey8, non_white)
}
}

/// All 169 features of one 400x400 rendering.
pub fn extract(image: RgbImage) -> Result<FeatureVector> {
    let prepared = Prepared::new(image)?;
    Ok(extract_prepared(&prepared))
}

/// All 169 features from a [`Prepared`] image.
pub fn extract_prepared(p: &Prepared) -> FeatureVector {
    let mut out = [0.0; FEATURE_COUNT];
    let (c, rest) = out.split_at_mut(colour::COUNT);
    colour::compute(p, c);
    let (s, rest) = rest.split_at_mut(shading::COUNT);
    shading::compute(p, s);
    let (l, rest) = rest.split_at_mut(lbp::COUNT);
    lbp::compute(p, l);
    let (g, rest) = rest.split_at_mut(glcm::COUNT);
    glcm::compute(p, g);
    swt::compute(p, rest);
    debug_assert!(out.iter().all(|v| v.is_finite()), "non-finite feature");
    out
}

/// Features of many renderings in parallel (rayon), results in input order. `on_done` is called
/// once per finished image (from worker threads) for progress reporting.
pub fn extract_all<F>(images: Vec<RgbImage>, on_done: F) -> Vec<Result<FeatureVector>>
where
    F: Fn() + Sync,
{
    images
        .into_par_iter()
        .map(|img| {
            let r = extract(img);
            on_done();
            r
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;

    #[test]
    fn catalogue_has_169_unique_snake_case_names() {
        let cat = catalogue();
        assert_eq!(cat.len(), 169);
        assert_eq!(FEATURE_COUNT, 169);
        let names: HashSet<_> = cat.iter().map(|f| f.name).collect();
        assert_eq!(names.len(), 169);
        for f in &cat {
            assert!(
                f.name
                    .chars()
                    .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_'),
                "{} is not snake_case",
                f.name
            );
            assert!(!f.doc.is_empty(), "{} has no doc", f.name);
        }
    }

    #[test]
    fn wrong_size_and_blank_are_errors() {
        assert!(matches!(
            extract(RgbImage::new(10, 10)),
            Err(Error::WrongCanvasSize { .. })
        ));
        let white = RgbImage::from_pixel(400, 400, image::Rgb([255; 3]));
        assert!(matches!(extract(white), Err(Error::BlankImage)));
    }
}
