//! Single-channel float planes and the resampling the coarse-to-fine scheme needs: Gaussian
//! smoothing, bicubic and bilinear sampling with Neumann (replicated-border) boundaries,
//! centred gradients and the pyramid's zoom-out / flow zoom-in (IPOL 2013, §3 "Multiscale").

use rayon::prelude::*;

/// A row-major single-channel plane.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Plane {
    pub w: usize,
    pub h: usize,
    pub data: Vec<f32>,
}

/// Rows per parallel chunk so that a chunk holds about 8k samples: the partition depends only
/// on the plane's size, never on the number of threads, so sums over chunks are reproducible.
pub(crate) fn rows_per_chunk(w: usize) -> usize {
    (8192 / w.max(1)).max(1)
}

/// Catmull–Rom weights (Keys' cubic convolution with a = −0.5, the IPOL implementation's
/// bicubic) for the samples at offsets −1, 0, 1, 2 of a fraction `t` in [0, 1).
#[inline]
fn cubic_weights(t: f32) -> [f32; 4] {
    let t2 = t * t;
    let t3 = t2 * t;
    [
        -0.5 * t3 + t2 - 0.5 * t,
        1.5 * t3 - 2.5 * t2 + 1.0,
        -1.5 * t3 + 2.0 * t2 + 0.5 * t,
        0.5 * t3 - 0.5 * t2,
    ]
}

/// Index `i` reflected into `0..n` with half-sample symmetry (…, 1, 0 | 0, 1, …, n−1 | n−1, …),
/// valid for any `i` (periodic extension of the mirrored signal).
#[inline]
fn reflect(i: isize, n: usize) -> usize {
    let n = n as isize;
    let m = i.rem_euclid(2 * n);
    (if m >= n { 2 * n - 1 - m } else { m }) as usize
}

/// The 4×4 samples and Catmull–Rom weights of a bicubic interpolation at one point, with
/// replicated borders; computed once and applied to several planes sampled at the same point.
pub(crate) struct Taps {
    xs: [usize; 4],
    ys: [usize; 4],
    wx: [f32; 4],
    wy: [f32; 4],
}

impl Taps {
    #[inline]
    pub fn new(x: f32, y: f32, w: usize, h: usize) -> Self {
        // NaN clamps to NaN and `as usize` maps it to 0: no panic on a broken flow.
        let x = x.clamp(0.0, (w - 1) as f32);
        let y = y.clamp(0.0, (h - 1) as f32);
        // Non-negative after the clamp, so truncation is the floor.
        let (x0, y0) = (x as usize, y as usize);
        let (wx, wy) = (cubic_weights(x - x0 as f32), cubic_weights(y - y0 as f32));
        let idx = |i0: usize, n: usize| {
            [
                i0.saturating_sub(1),
                i0,
                (i0 + 1).min(n - 1),
                (i0 + 2).min(n - 1),
            ]
        };
        Self {
            xs: idx(x0, w),
            ys: idx(y0, h),
            wx,
            wy,
        }
    }

    /// The interpolated value of `get(sample)` over a row-major buffer of width `w`.
    #[inline]
    pub fn apply<T>(&self, data: &[T], w: usize, get: impl Fn(&T) -> f32) -> f32 {
        let mut acc = 0.0;
        for (&yk, &wyk) in self.ys.iter().zip(&self.wy) {
            let r = &data[yk * w..yk * w + w];
            let mut row = 0.0;
            for (&xk, &wxk) in self.xs.iter().zip(&self.wx) {
                row += wxk * get(&r[xk]);
            }
            acc += wyk * row;
        }
        acc
    }

    /// [`Taps::apply`] on three interleaved planes at once.
    #[inline]
    pub fn apply3(&self, data: &[[f32; 3]], w: usize) -> [f32; 3] {
        let mut acc = [0.0f32; 3];
        for (&yk, &wyk) in self.ys.iter().zip(&self.wy) {
            let r = &data[yk * w..yk * w + w];
            let mut row = [0.0f32; 3];
            for (&xk, &wxk) in self.xs.iter().zip(&self.wx) {
                let v = r[xk];
                row[0] += wxk * v[0];
                row[1] += wxk * v[1];
                row[2] += wxk * v[2];
            }
            acc[0] += wyk * row[0];
            acc[1] += wyk * row[1];
            acc[2] += wyk * row[2];
        }
        acc
    }
}

impl Plane {
    pub fn new(w: usize, h: usize) -> Self {
        Self {
            w,
            h,
            data: vec![0.0; w * h],
        }
    }

    /// Bicubic value at real coordinates `(x, y)` (pixel centres at integers); the plane is
    /// extended by replicating its border (Neumann), as IPOL's warping does.
    #[inline]
    pub fn bicubic(&self, x: f32, y: f32) -> f32 {
        let t = Taps::new(x, y, self.w, self.h);
        t.apply(&self.data, self.w, |v| *v)
    }

    /// Centred differences `(∂x, ∂y)` with Neumann boundaries (the difference across the border
    /// uses the replicated sample, so it is a half difference there), IPOL's `centered_gradient`.
    pub fn centred_gradient(&self) -> (Plane, Plane) {
        let (w, h) = (self.w, self.h);
        let mut gx = Plane::new(w, h);
        let mut gy = Plane::new(w, h);
        gx.data
            .par_chunks_mut(w)
            .zip(gy.data.par_chunks_mut(w))
            .enumerate()
            .for_each(|(y, (rx, ry))| {
                let up = &self.data[y.saturating_sub(1) * w..][..w];
                let down = &self.data[(y + 1).min(h - 1) * w..][..w];
                let row = &self.data[y * w..][..w];
                for x in 0..w {
                    rx[x] = 0.5 * (row[(x + 1).min(w - 1)] - row[x.saturating_sub(1)]);
                    ry[x] = 0.5 * (down[x] - up[x]);
                }
            });
        (gx, gy)
    }

    /// Separable Gaussian smoothing of standard deviation `sigma` (pixels), truncated at 4σ,
    /// with symmetric boundaries. `sigma ≤ 0` returns a copy.
    pub fn gaussian(&self, sigma: f32) -> Plane {
        if sigma <= 0.0 {
            return self.clone();
        }
        let r = (4.0 * sigma).ceil() as isize;
        let mut k: Vec<f32> = (-r..=r)
            .map(|i| (-(i * i) as f32 / (2.0 * sigma * sigma)).exp())
            .collect();
        let s: f32 = k.iter().sum();
        k.iter_mut().for_each(|v| *v /= s);
        let (w, h) = (self.w, self.h);
        // Horizontal pass, on a copy of the row padded by reflection.
        let mut tmp = Plane::new(w, h);
        tmp.data
            .par_chunks_mut(w)
            .enumerate()
            .for_each_init(Vec::new, |padded, (y, out)| {
                let row = &self.data[y * w..][..w];
                padded.clear();
                padded.extend((-r..w as isize + r).map(|i| row[reflect(i, w)]));
                for (x, o) in out.iter_mut().enumerate() {
                    *o = k.iter().zip(&padded[x..]).map(|(kj, v)| kj * v).sum();
                }
            });
        // Vertical pass.
        let mut out = Plane::new(w, h);
        out.data.par_chunks_mut(w).enumerate().for_each(|(y, o)| {
            o.fill(0.0);
            for (j, kj) in k.iter().enumerate() {
                let src = &tmp.data[reflect(y as isize + j as isize - r, h) * w..][..w];
                for (ov, sv) in o.iter_mut().zip(src) {
                    *ov += kj * sv;
                }
            }
        });
        out
    }

    /// The next, coarser pyramid level of size `(w, h)`: Gaussian anti-aliasing with
    /// σ = 0.6·√(η⁻² − 1) (IPOL's `zoom_out`, η the ratio of the sizes) and bicubic sampling at
    /// the coarse pixel centres (centres aligned).
    pub fn zoom_out(&self, w: usize, h: usize) -> Plane {
        let eta = (w as f32 / self.w as f32).min(h as f32 / self.h as f32);
        let sigma = 0.6 * (1.0 / (eta * eta) - 1.0).max(0.0).sqrt();
        // The same centre-aligned bicubic resampling as `zoom_in`, of the smoothed plane
        // (× 1 is exact).
        self.gaussian(sigma).zoom_in(w, h, 1.0)
    }

    /// Bicubic resampling to `(w, h)` with centres aligned and every value multiplied by
    /// `scale`: a flow component brought to a finer level (IPOL's `zoom_in`, times 1/η).
    pub fn zoom_in(&self, w: usize, h: usize, scale: f32) -> Plane {
        let (sx, sy) = (self.w as f32 / w as f32, self.h as f32 / h as f32);
        let mut out = Plane::new(w, h);
        out.data.par_chunks_mut(w).enumerate().for_each(|(y, o)| {
            let fy = (y as f32 + 0.5) * sy - 0.5;
            for (x, v) in o.iter_mut().enumerate() {
                *v = scale * self.bicubic((x as f32 + 0.5) * sx - 0.5, fy);
            }
        });
        out
    }
}

/// Bilinear value of the interleaved image `data` (`w × h × c`, channel `ch`) at `(x, y)` with
/// replicated borders.
#[inline]
pub(crate) fn bilinear(
    data: &[f32],
    w: usize,
    h: usize,
    c: usize,
    x: f32,
    y: f32,
    out: &mut [f32],
) {
    let x = x.clamp(0.0, (w - 1) as f32);
    let y = y.clamp(0.0, (h - 1) as f32);
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (tx, ty) = (x - x0 as f32, y - y0 as f32);
    let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
    let at = |xx: usize, yy: usize, ch: usize| data[(yy * w + xx) * c + ch];
    for (ch, o) in out.iter_mut().enumerate().take(c) {
        let a = at(x0, y0, ch) * (1.0 - tx) + at(x1, y0, ch) * tx;
        let b = at(x0, y1, ch) * (1.0 - tx) + at(x1, y1, ch) * tx;
        *o = a * (1.0 - ty) + b * ty;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(w: usize, h: usize) -> Plane {
        Plane {
            w,
            h,
            data: (0..w * h)
                .map(|i| (i % w) as f32 * 2.0 + (i / w) as f32)
                .collect(),
        }
    }

    #[test]
    fn bicubic_is_exact_on_a_linear_ramp_inside_and_interpolates_samples() {
        let p = ramp(9, 7);
        // Keys' cubic reproduces linear functions exactly away from the border.
        for &(x, y) in &[(3.25f32, 2.5f32), (4.9, 3.1), (1.0, 1.0), (6.5, 4.75)] {
            assert!(
                (p.bicubic(x, y) - (2.0 * x + y)).abs() < 1e-4,
                "at ({x}, {y})"
            );
        }
        // At integer positions it returns the samples, including the corners.
        assert_eq!(p.bicubic(0.0, 0.0), 0.0);
        assert_eq!(p.bicubic(8.0, 6.0), 22.0);
        // Outside, the border is replicated.
        assert_eq!(p.bicubic(-5.0, 0.0), 0.0);
    }

    #[test]
    fn gaussian_preserves_constants_and_the_mean_of_a_symmetric_signal() {
        let c = Plane {
            w: 5,
            h: 3,
            data: vec![0.7; 15],
        };
        assert!(c.gaussian(2.0).data.iter().all(|v| (v - 0.7).abs() < 1e-6));
        // Symmetric boundaries conserve the sum on any signal.
        let p = ramp(6, 4);
        let s0: f32 = p.data.iter().sum();
        let s1: f32 = p.gaussian(0.8).data.iter().sum();
        assert!((s0 - s1).abs() < 1e-3 * s0, "{s0} vs {s1}");
    }

    #[test]
    fn centred_gradient_of_a_ramp() {
        let (gx, gy) = ramp(5, 4).centred_gradient();
        assert_eq!(gx.data[2 * 5 + 2], 2.0);
        assert_eq!(gy.data[2 * 5 + 2], 1.0);
        // Half differences at the border.
        assert_eq!(gx.data[0], 1.0);
        assert_eq!(gy.data[3 * 5 + 1], 0.5);
    }

    #[test]
    fn zoom_in_of_a_constant_flow_scales_it() {
        let c = Plane {
            w: 4,
            h: 3,
            data: vec![1.5; 12],
        };
        let z = c.zoom_in(8, 6, 2.0);
        assert!(z.data.iter().all(|v| (v - 3.0).abs() < 1e-6));
    }

    #[test]
    fn reflect_covers_every_offset() {
        assert_eq!(reflect(-1, 3), 0);
        assert_eq!(reflect(-3, 3), 2);
        assert_eq!(reflect(3, 3), 2);
        assert_eq!(reflect(-7, 1), 0);
        assert_eq!(reflect(10, 4), 2);
        assert_eq!(reflect(5, 4), 2);
    }
}
