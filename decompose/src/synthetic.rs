//! Synthetic ground truth made by the project: Lambertian scenes with known reflectance and
//! shading, used by the tests (the MIT data may not be redistributed).
//!
//! - [`fig21`]: the three 1-D cases of thesis Fig. 2.1 (a reflectance edge under constant light,
//!   a smooth shading ramp over constant albedo, and both at once), drawn as a strip of
//!   identical rows.
//! - [`scene`]: piecewise-constant albedo patches, including near-black and near-white ones,
//!   on a plane with smooth shading, plus a Lambertian sphere whose silhouette is an
//!   occluding shading discontinuity.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::image::{Image, Mask};

/// A smooth random texture with values in (0, 1), as a function of real coordinates: the
/// logistic of `gain` times a sum of `waves` unit cosines. Each has a seeded direction, phase
/// and wavelength, uniform in `wavelengths` pixels. It is analytic, so a moved copy is exact
/// rather than interpolated: the optical-flow tests and the flow benchmark use it for frames
/// with a known flow.
pub fn wave_texture(
    seed: u64,
    waves: usize,
    wavelengths: std::ops::Range<f64>,
    gain: f64,
) -> impl Fn(f64, f64) -> f64 {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let waves: Vec<[f64; 3]> = (0..waves)
        .map(|_| {
            let angle = rng.random_range(0.0..std::f64::consts::PI);
            let k = std::f64::consts::TAU / rng.random_range(wavelengths.clone());
            [
                k * angle.cos(),
                k * angle.sin(),
                rng.random_range(0.0..std::f64::consts::TAU),
            ]
        })
        .collect();
    move |x, y| {
        let s: f64 = waves
            .iter()
            .map(|[kx, ky, phase]| (kx * x + ky * y + phase).cos())
            .sum();
        1.0 / (1.0 + (-gain * s).exp())
    }
}

/// An input with its true decomposition: `input = reflectance × shading`.
#[derive(Clone, Debug)]
pub struct GroundTruth {
    /// The rendered image (linear RGB).
    pub input: Image,
    /// True reflectance (RGB).
    pub reflectance: Image,
    /// True shading (grey).
    pub shading: Image,
    /// Pixels to evaluate.
    pub mask: Mask,
}

fn compose(reflectance: Image, shading: Image) -> GroundTruth {
    let mut input = reflectance.clone();
    for i in 0..input.len() {
        let s = shading.px(i)[0];
        input.px_mut(i).iter_mut().for_each(|v| *v *= s);
    }
    let mask = Mask::full(input.width(), input.height());
    GroundTruth {
        input,
        reflectance,
        shading,
        mask,
    }
}

/// The three 1-D configurations of Fig. 2.1.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fig21 {
    /// (a) a reflectance step under constant shading.
    ReflectanceEdge,
    /// (b) a smooth shading ramp over constant reflectance.
    ShadingRamp,
    /// (c) a reflectance step inside a shading ramp.
    Both,
}

/// Albedo left and right of the step in [`Fig21`] strips.
pub const FIG21_ALBEDO: [[f32; 3]; 2] = [[0.7, 0.25, 0.2], [0.2, 0.35, 0.7]];

/// A `width`×`height` strip of one Fig. 2.1 case; the step is at `width / 2`.
pub fn fig21(case: Fig21, width: u32, height: u32) -> GroundTruth {
    let refl = Image::from_fn(width, height, |x, _| match case {
        Fig21::ShadingRamp => FIG21_ALBEDO[0],
        _ => FIG21_ALBEDO[usize::from(x >= width / 2)],
    });
    let shade = Image::from_fn(width, height, |x, _| match case {
        Fig21::ReflectanceEdge => [0.8],
        _ => [0.25 + 0.7 * x as f32 / (width.max(2) - 1) as f32],
    });
    compose(refl, shade)
}

/// A seeded Lambertian scene of `width`×`height` pixels (see the module docs).
pub fn scene(width: u32, height: u32, seed: u64) -> GroundTruth {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (w, h) = (width as f32, height as f32);
    // Albedo palette: saturated colours plus near-black and near-white.
    let palette: [[f32; 3]; 6] = [
        [0.75, 0.2, 0.15],
        [0.15, 0.55, 0.2],
        [0.2, 0.3, 0.8],
        [0.8, 0.7, 0.2],
        [0.04, 0.04, 0.04],
        [0.92, 0.92, 0.92],
    ];
    let background = [0.55f32, 0.5, 0.45];
    let patches: Vec<([f32; 4], [f32; 3])> = (0..6)
        .map(|i| {
            let x0 = rng.random_range(0.0..0.7) * w;
            let y0 = rng.random_range(0.0..0.7) * h;
            let pw = rng.random_range(0.15..0.3) * w;
            let ph = rng.random_range(0.15..0.3) * h;
            ([x0, y0, x0 + pw, y0 + ph], palette[i])
        })
        .collect();
    let (cx, cy, r) = (0.68 * w, 0.62 * h, 0.22 * w.min(h));
    let sphere_albedo = [0.6f32, 0.45, 0.7];
    let light = {
        let l = [-0.5f32, -0.6, 0.62];
        let n = (l[0] * l[0] + l[1] * l[1] + l[2] * l[2]).sqrt();
        l.map(|v| v / n)
    };
    let inside = |x: f32, y: f32| (x - cx).powi(2) + (y - cy).powi(2) < r * r;
    let refl = Image::from_fn(width, height, |x, y| {
        let (fx, fy) = (x as f32 + 0.5, y as f32 + 0.5);
        if inside(fx, fy) {
            return sphere_albedo;
        }
        patches
            .iter()
            .rev()
            .find(|(b, _)| fx >= b[0] && fx < b[2] && fy >= b[1] && fy < b[3])
            .map_or(background, |p| p.1)
    });
    let shade = Image::from_fn(width, height, |x, y| {
        let (fx, fy) = (x as f32 + 0.5, y as f32 + 0.5);
        if inside(fx, fy) {
            let (nx, ny) = ((fx - cx) / r, (fy - cy) / r);
            let nz = (1.0 - nx * nx - ny * ny).max(0.0).sqrt();
            [(0.08 + 0.9 * (nx * light[0] + ny * light[1] + nz * light[2]).max(0.0))]
        } else {
            // A smooth light fall-off across the plane.
            let d = ((fx / w - 0.2).powi(2) + (fy / h - 0.1).powi(2)).sqrt();
            [0.9 - 0.55 * d.min(1.2)]
        }
    });
    compose(refl, shade)
}

/// Albedos of [`sliding_albedo`]'s five regions.
const SLIDING_PALETTE: [[f32; 3]; 5] = [
    [0.80, 0.25, 0.20],
    [0.20, 0.60, 0.30],
    [0.25, 0.30, 0.85],
    [0.85, 0.80, 0.30],
    [0.90, 0.90, 0.90],
];

/// Pixels per frame the albedo of [`sliding_albedo`] moves, (right, down).
pub const SLIDING_MOTION: (f64, f64) = (2.0, 1.0);

/// The synthetic video of `decompose bench --video`: frame `t` of `w`×`h` is a
/// piecewise-constant albedo (a smooth random texture cut into five levels) moved by
/// `t ×` [`SLIDING_MOTION`], under a smooth light fixed on the screen; `I = R × S` exactly.
pub fn sliding_albedo(w: u32, h: u32) -> impl Fn(usize) -> Image {
    let pattern = wave_texture(7, 6, 60.0..220.0, 3.0);
    let light = wave_texture(11, 3, 500.0..1200.0, 1.5);
    move |t| {
        let (dx, dy) = (SLIDING_MOTION.0 * t as f64, SLIDING_MOTION.1 * t as f64);
        let n = SLIDING_PALETTE.len();
        Image::from_fn(w, h, |x, y| {
            let level = pattern(x as f64 - dx, y as f64 - dy);
            let a = SLIDING_PALETTE[((level * n as f64) as usize).min(n - 1)];
            let s = (0.25 + 0.75 * light(x as f64, y as f64)) as f32;
            [a[0] * s, a[1] * s, a[2] * s]
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn product_holds() {
        let g = scene(32, 24, 1);
        for i in 0..g.input.len() {
            for c in 0..3 {
                let p = g.reflectance.px(i)[c] * g.shading.px(i)[0];
                assert!((p - g.input.px(i)[c]).abs() < 1e-6);
            }
        }
    }
}
