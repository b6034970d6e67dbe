//! Image gradients (Sobel) and the Canny edge detector shared by the texture (LBP on edges) and
//! stroke (SWT) features.
//!
//! Canny follows Canny (1986) as implemented by scikit-image's `feature.canny`: Gaussian
//! smoothing with σ, Sobel gradients, non-maximum suppression with linear interpolation
//! along the gradient, and hysteresis with 8-connectivity. Thresholds are absolute gradient
//! magnitudes on grey levels in `[0, 1]` (Sobel scaled by 1/8 so a unit step gives magnitude
//! 0.5 at the edge).

use crate::mask::Mask;
use crate::plane::Plane;

/// Horizontal and vertical derivatives of a plane.
#[derive(Debug, Clone)]
pub struct Gradients {
    /// ∂/∂x (positive to the right).
    pub dx: Plane,
    /// ∂/∂y (positive downwards).
    pub dy: Plane,
}

impl Gradients {
    /// The gradient magnitude at pixel index `i`.
    #[inline]
    pub fn magnitude(&self, i: usize) -> f32 {
        (self.dx.data[i] * self.dx.data[i] + self.dy.data[i] * self.dy.data[i]).sqrt()
    }
}

/// Sobel derivatives with replicate borders, normalised by 1/8 so they estimate the
/// per-pixel derivative.
///
/// Computed separably: per row the central difference `row[x+1] − row[x−1]` and the smoothing
/// `row[x−1] + 2·row[x] + row[x+1]`, then combined across rows; every inner loop runs along
/// memory so it vectorises. The row results live in a three-row ring (rows `y−1`, `y`, `y+1`)
/// rather than two whole-image temporaries, which cost more in fresh pages than in arithmetic.
pub fn sobel(plane: &Plane) -> Gradients {
    sobel_vectorised(plane)
}

crate::simd::vectorised_fn! {
/// [`sobel`].
fn sobel_vectorised<'a>(plane: &'a Plane) -> Gradients {
    let (w, h) = (plane.width, plane.height);
    if w == 0 || h == 0 {
        return Gradients {
            dx: Plane::filled(w, h, 0.0),
            dy: Plane::filled(w, h, 0.0),
        };
    }
    // Outputs grow row by row (`extend`), so they are written once, not zeroed first.
    let (mut dx, mut dy) = (Vec::with_capacity(w * h), Vec::with_capacity(w * h));
    let mut diff = vec![0.0f32; 3 * w];
    let mut smooth = vec![0.0f32; 3 * w];
    let slot = |y: usize| (y % 3) * w..(y % 3 + 1) * w;
    sobel_row(&plane.data[..w], &mut diff[slot(0)], &mut smooth[slot(0)]);
    for y in 0..h {
        if y + 1 < h {
            let row = &plane.data[(y + 1) * w..(y + 2) * w];
            sobel_row(row, &mut diff[slot(y + 1)], &mut smooth[slot(y + 1)]);
        }
        let (ym, yp) = (y.saturating_sub(1), (y + 1).min(h - 1));
        let (dm, d0, dp) = (&diff[slot(ym)], &diff[slot(y)], &diff[slot(yp)]);
        let (sm, sp) = (&smooth[slot(ym)], &smooth[slot(yp)]);
        let row_x = dm.iter().zip(d0).zip(dp);
        dx.extend(row_x.map(|((a, b), c)| (a + 2.0 * b + c) * 0.125));
        dy.extend(sm.iter().zip(sp).map(|(a, c)| (c - a) * 0.125));
    }
    let plane = |data| Plane {
        width: w,
        height: h,
        data,
    };
    Gradients {
        dx: plane(dx),
        dy: plane(dy),
    }
}
}

/// One row's horizontal Sobel passes with replicate borders: the central difference into `d`
/// and the `1 2 1` smoothing into `s`.
#[inline(always)]
fn sobel_row(row: &[f32], d: &mut [f32], s: &mut [f32]) {
    let w = row.len();
    if w == 1 {
        d[0] = 0.0;
        s[0] = 4.0 * row[0];
        return;
    }
    d[0] = row[1] - row[0];
    s[0] = 3.0 * row[0] + row[1];
    for x in 1..w - 1 {
        d[x] = row[x + 1] - row[x - 1];
        s[x] = row[x - 1] + 2.0 * row[x] + row[x + 1];
    }
    d[w - 1] = row[w - 1] - row[w - 2];
    s[w - 1] = row[w - 2] + 3.0 * row[w - 1];
}

/// `x.floor()` for finite `|x| < 2²³`, inline: without SSE4.1 the standard one is a libm call,
/// which dominated non-maximum suppression.
#[inline(always)]
fn floor(x: f32) -> f32 {
    debug_assert!(x.abs() < 8_388_608.0, "{x}");
    let t = x as i32 as f32; // rounds towards zero
    if t > x { t - 1.0 } else { t }
}

/// Parameters of [`canny`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CannyParams {
    /// σ of the Gaussian pre-smoothing in pixels (scikit-image default 1).
    pub sigma: f32,
    /// Weak threshold on the gradient magnitude (grey levels in `[0,1]`).
    pub low: f32,
    /// Strong threshold on the gradient magnitude.
    pub high: f32,
}

impl Default for CannyParams {
    /// σ = 1; thresholds 0.05 and 0.1 of the unit-step response, which keep the anti-aliased
    /// outlines of clip art and drop the faint banding of gradients.
    fn default() -> Self {
        Self {
            sigma: 1.0,
            low: 0.025,
            high: 0.05,
        }
    }
}

/// Canny edges of `plane`, with the gradients of the smoothed plane (SWT follows them).
pub fn canny(plane: &Plane, params: &CannyParams) -> (Mask, Gradients) {
    canny_vectorised(plane, params)
}

crate::simd::vectorised_fn! {
/// [`canny`].
fn canny_vectorised<'a>(plane: &'a Plane, params: &'a CannyParams) -> (Mask, Gradients) {
    let smoothed = plane.gaussian_blur(params.sigma);
    let grad = sobel(&smoothed);
    let (w, h) = (plane.width, plane.height);
    let mag: Vec<f32> = grad
        .dx
        .data
        .iter()
        .zip(&grad.dy.data)
        .map(|(&dx, &dy)| (dx * dx + dy * dy).sqrt())
        .collect();
    // Non-maximum suppression: compare with the magnitude interpolated one pixel along ±gradient.
    const WEAK: u8 = 1;
    const STRONG: u8 = 2;
    let mut candidate = vec![0u8; w * h]; // 0, WEAK or STRONG
    // Interior pixels only and |u| ≤ 1, so x, y ∈ [0, w-1] × [0, h-1]; capping the cell's corner
    // at (w-2, h-2) keeps all four taps inside the image (fx or fy is then exactly 1).
    let sample = |x: f32, y: f32| -> f32 {
        let (x0, y0) = (floor(x).min((w - 2) as f32), floor(y).min((h - 2) as f32));
        let (xi, yi) = (x0 as usize, y0 as usize);
        let (fx, fy) = (x - x0, y - y0);
        let i = yi * w + xi;
        let top = mag[i] + (mag[i + 1] - mag[i]) * fx;
        let bottom = mag[i + w] + (mag[i + w + 1] - mag[i + w]) * fx;
        top + (bottom - top) * fy
    };
    // Most pixels of clip art are flat: blocks of SKIP pixels under the weak threshold are
    // passed over with one vectorised test instead of a branch per pixel.
    const SKIP: usize = 16;
    for y in 1..h.saturating_sub(1) {
        let row = &mag[y * w..(y + 1) * w];
        let mut block = 1;
        while block < w.saturating_sub(1) {
            let end = (block + SKIP).min(w - 1);
            let any_weak = row[block..end]
                .iter()
                .fold(false, |any, &m| any | (m >= params.low));
            if any_weak {
                for x in block..end {
                    let i = y * w + x;
                    let m = mag[i];
                    if m < params.low {
                        continue;
                    }
                    let (ux, uy) = (grad.dx.data[i] / m, grad.dy.data[i] / m);
                    let ahead = sample(x as f32 + ux, y as f32 + uy);
                    let behind = sample(x as f32 - ux, y as f32 - uy);
                    if m >= ahead && m > behind {
                        candidate[i] = if m >= params.high { STRONG } else { WEAK };
                    }
                }
            }
            block = end;
        }
    }
    // Hysteresis: weak pixels 8-connected to a strong one survive. Candidates are interior
    // pixels, so their eight neighbours are index offsets that stay inside the image.
    let mut edges = Mask::filled(w, h, false);
    let mut stack: Vec<usize> = Vec::new();
    for (i, &c) in candidate.iter().enumerate() {
        if c == STRONG {
            edges.data[i] = true;
            stack.push(i);
        }
    }
    // (Saturating only so an empty plane, which has no candidates, cannot underflow.)
    let neighbours = [w + 1, w, w.saturating_sub(1), 1];
    while let Some(i) = stack.pop() {
        for j in neighbours
            .iter()
            .flat_map(|&offset| [i - offset, i + offset])
        {
            if candidate[j] == WEAK && !edges.data[j] {
                edges.data[j] = true;
                stack.push(j);
            }
        }
    }
    (edges, grad)
}
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The textbook 3x3 stencil with clamped coordinates, as the reference for the separable path.
    fn sobel_naive(p: &Plane) -> Gradients {
        let (w, h) = (p.width, p.height);
        let mut dx = Plane::filled(w, h, 0.0);
        let mut dy = Plane::filled(w, h, 0.0);
        for y in 0..h as isize {
            for x in 0..w as isize {
                let v = |i: isize, j: isize| p.at_clamped(x + i, y + j);
                let gx = v(1, -1) - v(-1, -1) + 2.0 * (v(1, 0) - v(-1, 0)) + v(1, 1) - v(-1, 1);
                let gy = v(-1, 1) - v(-1, -1) + 2.0 * (v(0, 1) - v(0, -1)) + v(1, 1) - v(1, -1);
                dx.data[y as usize * w + x as usize] = gx * 0.125;
                dy.data[y as usize * w + x as usize] = gy * 0.125;
            }
        }
        Gradients { dx, dy }
    }

    proptest::proptest! {
        #[test]
        fn separable_sobel_equals_the_stencil(w in 1usize..9, h in 1usize..9, seed in 0u64..1000) {
            let data = (0..w * h).map(|i| ((i as u64 * 7919 + seed * 104729) % 97) as f32 / 97.0).collect();
            let p = Plane { width: w, height: h, data };
            let (fast, slow) = (sobel(&p), sobel_naive(&p));
            for i in 0..w * h {
                proptest::prop_assert!((fast.dx.data[i] - slow.dx.data[i]).abs() < 1e-5);
                proptest::prop_assert!((fast.dy.data[i] - slow.dy.data[i]).abs() < 1e-5);
            }
        }
    }

    #[test]
    fn inline_floor_is_floor() {
        let samples = [
            -2.5f32,
            -1.0,
            -0.99999994,
            -1e-7,
            -0.0,
            0.0,
            1e-7,
            0.5,
            1.0,
            398.99997,
            399.0,
        ];
        for x in samples
            .into_iter()
            .chain((0..4000).map(|k| k as f32 * 0.1 - 3.0))
        {
            assert_eq!(floor(x), x.floor(), "{x}");
        }
    }

    #[test]
    fn sobel_of_a_ramp_is_its_slope() {
        let p = Plane {
            width: 5,
            height: 5,
            data: (0..25).map(|i| (i % 5) as f32 * 0.1).collect(),
        };
        let g = sobel(&p);
        assert!((g.dx.at(2, 2) - 0.1).abs() < 1e-6 && g.dy.at(2, 2).abs() < 1e-6);
    }

    #[test]
    fn canny_finds_a_one_pixel_wide_vertical_edge() {
        let p = Plane {
            width: 40,
            height: 30,
            data: (0..1200)
                .map(|i| if i % 40 < 20 { 0.0 } else { 1.0 })
                .collect(),
        };
        let (edges, _) = canny(&p, &CannyParams::default());
        for y in 3..27 {
            let row: Vec<usize> = (0..40).filter(|&x| edges.at(x, y)).collect();
            assert_eq!(row.len(), 1, "row {y}: {row:?}");
            assert!(row[0] == 19 || row[0] == 20);
        }
    }

    #[test]
    fn canny_handles_edges_at_the_image_border_and_tiny_images() {
        for (w, h) in [(3, 3), (1, 5), (2, 2), (17, 4), (0, 0), (0, 3), (3, 0)] {
            let p = Plane {
                width: w,
                height: h,
                data: (0..w * h).map(|i| (i % 3) as f32).collect(),
            };
            let (edges, _) = canny(&p, &CannyParams::default());
            assert_eq!(edges.data.len(), w * h);
        }
        let corner = Plane {
            width: 8,
            height: 8,
            data: (0..64)
                .map(|i| if i % 8 == 7 || i >= 56 { 1.0 } else { 0.0 })
                .collect(),
        };
        let (edges, _) = canny(&corner, &CannyParams::default());
        assert!(edges.count() > 0);
    }

    #[test]
    fn canny_of_flat_plane_is_empty() {
        let (edges, _) = canny(&Plane::filled(20, 20, 0.3), &CannyParams::default());
        assert_eq!(edges.count(), 0);
    }
}
