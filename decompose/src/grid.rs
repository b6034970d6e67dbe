//! Per-pixel quantities shared by the pixel-level methods (retinex and color-retinex).

use crate::color::luminance;
use crate::image::{Image, Mask};

/// One unknown per masked pixel, with its log luminance and unit chromaticity.
pub(crate) struct Grid {
    pub w: usize,
    pub h: usize,
    /// Pixel → unknown index (u32::MAX outside the mask).
    pub index: Vec<u32>,
    /// Unknown → pixel.
    pub pixel: Vec<usize>,
    /// Log luminance per pixel (floored).
    pub log_y: Vec<f64>,
    /// Luminance per pixel (floored).
    pub y: Vec<f64>,
    /// Unit RGB direction per pixel; grey for pixels darker than the chroma floor.
    pub chroma: Vec<[f64; 3]>,
    /// Largest luminance inside the mask.
    pub max_y: f64,
}

/// Relative luminance below which a pixel's chromaticity is considered noise.
pub(crate) const CHROMA_FLOOR: f64 = 1e-3;

impl Grid {
    pub(crate) fn new(input: &Image, mask: &Mask) -> Self {
        let (w, h) = (input.width() as usize, input.height() as usize);
        let mut index = vec![u32::MAX; w * h];
        let mut pixel = Vec::new();
        for (p, idx) in index.iter_mut().enumerate() {
            if mask.at(p) {
                *idx = pixel.len() as u32;
                pixel.push(p);
            }
        }
        let raw_y: Vec<f64> = (0..w * h)
            .map(|p| luminance(input.rgb(p)).max(0.0) as f64)
            .collect();
        let max_y = pixel.iter().map(|&p| raw_y[p]).fold(0.0, f64::max);
        let floor = (max_y * 1e-4).max(1e-12);
        let y: Vec<f64> = raw_y.iter().map(|v| v.max(floor)).collect();
        let log_y = y.iter().map(|v| v.ln()).collect();
        let grey = [1.0 / 3f64.sqrt(); 3];
        let chroma = (0..w * h)
            .map(|p| {
                let c = input.rgb(p).map(|v| v.max(0.0) as f64);
                let n = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
                if raw_y[p] <= max_y * CHROMA_FLOOR || n <= 0.0 {
                    grey
                } else {
                    c.map(|v| v / n)
                }
            })
            .collect();
        Self {
            w,
            h,
            index,
            pixel,
            log_y,
            y,
            chroma,
            max_y,
        }
    }

    /// Squared distance between the unit chromaticities of two pixels.
    pub(crate) fn chroma_dist2(&self, p: usize, q: usize) -> f64 {
        let (a, b) = (self.chroma[p], self.chroma[q]);
        (0..3).map(|c| (a[c] - b[c]).powi(2)).sum()
    }

    /// 4-neighbour pairs (p, q) with both pixels in the mask, each pair once.
    pub(crate) fn pairs(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.pixel.iter().flat_map(move |&p| {
            let right = (p % self.w + 1 < self.w).then_some(p + 1);
            let down = (p + self.w < self.w * self.h).then_some(p + self.w);
            [right, down]
                .into_iter()
                .flatten()
                .filter(move |&q| self.index[q] != u32::MAX)
                .map(move |q| (p, q))
        })
    }
}
