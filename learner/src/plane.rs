//! Single-channel float images ([`Plane`]) and the few whole-image operations the feature
//! families share: grey conversion, 2x box downscaling and Gaussian blur.

use image::RgbImage;

/// A row-major single-channel `f32` image.
#[derive(Debug, Clone, PartialEq)]
pub struct Plane {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `width * height` values, row-major.
    pub data: Vec<f32>,
}

impl Plane {
    /// A plane filled with `value`.
    pub fn filled(width: usize, height: usize, value: f32) -> Self {
        Self {
            width,
            height,
            data: vec![value; width * height],
        }
    }

    /// The value at `(x, y)`.
    #[inline]
    pub fn at(&self, x: usize, y: usize) -> f32 {
        self.data[y * self.width + x]
    }

    /// The value at `(x, y)` with coordinates clamped to the border (replicate padding).
    #[inline]
    pub fn at_clamped(&self, x: isize, y: isize) -> f32 {
        let x = x.clamp(0, self.width as isize - 1) as usize;
        let y = y.clamp(0, self.height as isize - 1) as usize;
        self.data[y * self.width + x]
    }

    /// Halves both dimensions by averaging 2x2 blocks (an odd last row/column is dropped).
    pub fn half(&self) -> Plane {
        half_plane(self)
    }

    /// Separable Gaussian blur with standard deviation `sigma` (kernel radius ⌈3σ⌉, replicate
    /// border). `sigma <= 0` returns a copy.
    pub fn gaussian_blur(&self, sigma: f32) -> Plane {
        gaussian_blur(self, sigma)
    }
}

crate::simd::vectorised_fn! {
/// [`Plane::half`].
fn half_plane<'a>(plane: &'a Plane) -> Plane {
    let (w, h) = (plane.width / 2, plane.height / 2);
    let mut data = Vec::with_capacity(w * h);
    for y in 0..h {
        let r0 = &plane.data[(2 * y) * plane.width..][..2 * w];
        let r1 = &plane.data[(2 * y + 1) * plane.width..][..2 * w];
        data.extend(
            r0.chunks_exact(2)
                .zip(r1.chunks_exact(2))
                .map(|(a, b)| 0.25 * (a[0] + a[1] + b[0] + b[1])),
        );
    }
    Plane {
        width: w,
        height: h,
        data,
    }
}
}

crate::simd::vectorised_fn! {
/// [`Plane::gaussian_blur`].
fn gaussian_blur<'a>(plane: &'a Plane, sigma: f32) -> Plane {
    if sigma <= 0.0 || plane.data.is_empty() {
        return plane.clone();
    }
    let radius = (3.0 * sigma).ceil() as usize;
    let mut kernel: Vec<f32> = (0..=2 * radius)
        .map(|i| {
            let d = i as f32 - radius as f32;
            (-(d * d) / (2.0 * sigma * sigma)).exp()
        })
        .collect();
    let sum: f32 = kernel.iter().sum();
    kernel.iter_mut().for_each(|k| *k /= sum);
    let (w, h) = (plane.width, plane.height);
    // Each output row starts as `0.0 + k₀·s` (the first tap added to zero, as an accumulator
    // would) and grows by `extend`, so no plane is zeroed before being written.
    // Rows: pad each row by replication once, then one vectorisable sweep per tap.
    let mut tmp = Vec::with_capacity(w * h);
    let mut padded = vec![0.0f32; w + 2 * radius];
    for y in 0..h {
        let row = &plane.data[y * w..(y + 1) * w];
        padded[..radius].fill(row[0]);
        padded[radius..radius + w].copy_from_slice(row);
        padded[radius + w..].fill(row[w - 1]);
        tmp.extend(padded[..w].iter().map(|s| 0.0 + kernel[0] * s));
        let dst = &mut tmp[y * w..(y + 1) * w];
        for (k, &kv) in kernel.iter().enumerate().skip(1) {
            for (d, s) in dst.iter_mut().zip(&padded[k..k + w]) {
                *d += kv * s;
            }
        }
    }
    // Columns: accumulate whole rows so the inner loop runs along memory.
    let mut out = Vec::with_capacity(w * h);
    let source_row = |y: usize, k: usize| {
        let sy = (y as isize + k as isize - radius as isize).clamp(0, h as isize - 1) as usize;
        &tmp[sy * w..(sy + 1) * w]
    };
    for y in 0..h {
        out.extend(source_row(y, 0).iter().map(|s| 0.0 + kernel[0] * s));
        let dst = &mut out[y * w..(y + 1) * w];
        for (k, &kv) in kernel.iter().enumerate().skip(1) {
            for (d, s) in dst.iter_mut().zip(source_row(y, k)) {
                *d += kv * s;
            }
        }
    }
    Plane {
        width: w,
        height: h,
        data: out,
    }
}
}

crate::simd::vectorised_fn! {
/// Luma in `[0, 1]` with the Rec. 601 weights (0.299, 0.587, 0.114) on gamma-encoded sRGB, the
/// convention of MATLAB's `rgb2gray` and scikit-image's `rgb2gray` predecessor used by the paper's
/// era of tools.
pub fn luma<'a>(image: &'a RgbImage) -> Plane {
    let data = image.as_raw().chunks_exact(3).map(luma_of).collect();
    Plane {
        width: image.width() as usize,
        height: image.height() as usize,
        data,
    }
}
}

/// The [`luma`] of one RGB pixel (`rgb` holds at least 3 channels).
#[inline(always)]
pub fn luma_of(rgb: &[u8]) -> f32 {
    (0.299 * rgb[0] as f32 + 0.587 * rgb[1] as f32 + 0.114 * rgb[2] as f32) / 255.0
}

crate::simd::vectorised_fn! {
/// Halves an RGB image by averaging 2x2 blocks (rounding to nearest).
pub fn half_rgb<'a>(image: &'a RgbImage) -> RgbImage {
    let (w, h) = (image.width() as usize / 2, image.height() as usize / 2);
    let stride = 3 * image.width() as usize;
    let raw = image.as_raw();
    let mut data = vec![0u8; 3 * w * h];
    if w > 0 {
        for (y, out) in data.chunks_exact_mut(3 * w).enumerate() {
            let top = &raw[2 * y * stride..][..6 * w];
            let bottom = &raw[(2 * y + 1) * stride..][..6 * w];
            let blocks = top.chunks_exact(6).zip(bottom.chunks_exact(6));
            for (o, (t, b)) in out.chunks_exact_mut(3).zip(blocks) {
                for c in 0..3 {
                    let sum = t[c] as u32 + t[c + 3] as u32 + b[c] as u32 + b[c + 3] as u32;
                    o[c] = ((sum + 2) / 4) as u8;
                }
            }
        }
    }
    RgbImage::from_raw(w as u32, h as u32, data).expect("3 bytes per pixel of a w x h image")
}
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_averages_blocks() {
        let p = Plane {
            width: 4,
            height: 2,
            data: vec![0., 1., 2., 2., 1., 2., 4., 4.],
        };
        assert_eq!(p.half().data, vec![1.0, 3.0]);
    }

    #[test]
    fn half_rgb_rounds_block_means() {
        for (w, h) in [(7u32, 5u32), (1, 1), (2, 3), (10, 4)] {
            let img = RgbImage::from_fn(w, h, |x, y| {
                image::Rgb([
                    (x * 37 + y * 11) as u8,
                    (x * y * 13) as u8,
                    255 - (x + y) as u8,
                ])
            });
            let half = half_rgb(&img);
            assert_eq!(half.dimensions(), (w / 2, h / 2));
            for (x, y, p) in half.enumerate_pixels() {
                for c in 0..3 {
                    let sum: u32 = [(0, 0), (1, 0), (0, 1), (1, 1)]
                        .iter()
                        .map(|&(dx, dy)| img.get_pixel(2 * x + dx, 2 * y + dy)[c] as u32)
                        .sum();
                    assert_eq!(p[c] as u32, (sum + 2) / 4);
                }
            }
        }
    }

    #[test]
    fn blur_preserves_constant_and_mass() {
        let p = Plane::filled(9, 7, 0.5);
        assert!(
            p.gaussian_blur(1.5)
                .data
                .iter()
                .all(|&v| (v - 0.5).abs() < 1e-6)
        );
        let mut d = Plane::filled(21, 21, 0.0);
        d.data[10 * 21 + 10] = 1.0;
        let b = d.gaussian_blur(1.0);
        assert!((b.data.iter().sum::<f32>() - 1.0).abs() < 1e-5);
        assert!(b.at(10, 10) > b.at(11, 10) && b.at(11, 10) > b.at(12, 10));
    }

    #[test]
    fn luma_of_white_and_black() {
        let img = RgbImage::from_fn(2, 1, |x, _| {
            image::Rgb(if x == 0 { [255; 3] } else { [0; 3] })
        });
        let l = luma(&img);
        assert!((l.data[0] - 1.0).abs() < 1e-6 && l.data[1] == 0.0);
    }
}
