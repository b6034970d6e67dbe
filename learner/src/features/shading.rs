//! Gradient-magnitude histograms of Garces et al., "A Similarity Measure for Illustration
//! Style" (SIGGRAPH 2014), §5.3 "Shading", eq. 5.3.
//!
//! Four 8-bin histograms, in this output order:
//!
//! 1. colour gradients at 1x, 2. black-pixel gradients at 1x,
//! 3. colour gradients at 0.5x, 4. black-pixel gradients at 0.5x.
//!
//! Choices made where the paper is silent:
//!
//! - **Colour gradient** at a pixel is the Euclidean norm of the six per-channel Sobel
//!   derivatives of the RGB image with channels in `[0, 1]`, normalised by 1/8 like
//!   [`crate::edges::sobel`] (a unit step gives 0.5 per channel), with replicate borders:
//!   `|∇I| = sqrt(Σ_c (∂x I_c)² + (∂y I_c)²)`. Its maximum is `sqrt(3 · 2 · 0.5²) = sqrt(1.5)
//!   ≈ 1.2247`. It is computed in exact integer arithmetic on the 8-bit values and only at
//!   pixels of Ω.
//! - **Colour histogram** (eq. 5.3): over Φ = Ω minus black pixels minus zero-gradient pixels,
//!   magnitudes clamped at 1.1, 8 equal bins on `[0, 1.1]` (the top bin holds everything from
//!   0.9625 up).
//! - **Black histogram**: the same gradient at every black pixel of Ω (black as in
//!   [`super::colour::is_black`]), unclamped, 8 equal bins on `[0, sqrt(1.5)]`, the full range
//!   of the gradient. Zero-gradient black pixels are kept (in bin 0), so this histogram sums to
//!   the black fraction of Ω: flat black fills and thin black lines are told apart by how
//!   that mass is spread over the bins.
//! - **0.5x** is [`crate::plane::half_rgb`] of the rendering with Ω halved by
//!   [`crate::mask::Mask::half`]; black is re-evaluated on the halved pixels.
//! - Each histogram is normalised by |Ω| at its scale, so bins are fractions of the drawing.

use image::RgbImage;

use super::colour::BLACK_MAX_CHANNEL;
use super::{Family, FeatureInfo, Prepared};
use crate::mask::Mask;
use crate::plane;

/// Number of features in this family.
pub const COUNT: usize = 32;
/// Bins per histogram.
pub const BINS: usize = 8;
/// Eq. 5.3: colour-gradient magnitudes are clamped here, and binned on `[0, COLOUR_CLAMP]`.
pub const COLOUR_CLAMP: f32 = 1.1;
/// Upper end of the black-gradient bins: the largest possible gradient, `sqrt(1.5)`.
pub const BLACK_RANGE: f32 = 1.224_744_9;

/// Integer Sobel sums (`Σ` of the 1-2-1 weighted differences) are per-pixel derivatives
/// scaled by `8 · 255`.
const INTEGER_SCALE: f32 = 1.0 / (8.0 * 255.0);

macro_rules! histogram {
    ($kind:literal, $scale:literal, $doc:literal) => {
        [
            histogram!(@bin $kind, $scale, $doc, "0"),
            histogram!(@bin $kind, $scale, $doc, "1"),
            histogram!(@bin $kind, $scale, $doc, "2"),
            histogram!(@bin $kind, $scale, $doc, "3"),
            histogram!(@bin $kind, $scale, $doc, "4"),
            histogram!(@bin $kind, $scale, $doc, "5"),
            histogram!(@bin $kind, $scale, $doc, "6"),
            histogram!(@bin $kind, $scale, $doc, "7"),
        ]
    };
    (@bin $kind:literal, $scale:literal, $doc:literal, $bin:literal) => {
        FeatureInfo {
            name: concat!("shading_", $kind, "_grad_", $scale, "_bin", $bin),
            family: Family::Shading,
            doc: concat!($doc, ", bin ", $bin, " of 8 (fraction of Ω)"),
        }
    };
}

const COLOUR_1X: [FeatureInfo; BINS] = histogram!(
    "colour",
    "1x",
    "§5.3 Shading, eq. 5.3: colour-gradient magnitude (clamped 1.1) on Φ at 1x"
);
const BLACK_1X: [FeatureInfo; BINS] = histogram!(
    "black",
    "1x",
    "§5.3 Shading: colour-gradient magnitude at black pixels of Ω at 1x, bins on [0, √1.5]"
);
const COLOUR_HALF: [FeatureInfo; BINS] = histogram!(
    "colour",
    "half",
    "§5.3 Shading, eq. 5.3: colour-gradient magnitude (clamped 1.1) on Φ at 0.5x"
);
const BLACK_HALF: [FeatureInfo; BINS] = histogram!(
    "black",
    "half",
    "§5.3 Shading: colour-gradient magnitude at black pixels of Ω at 0.5x, bins on [0, √1.5]"
);

/// Names and docs, in output order.
pub fn catalogue() -> Vec<FeatureInfo> {
    [COLOUR_1X, BLACK_1X, COLOUR_HALF, BLACK_HALF].concat()
}

/// Writes this family's features of `p` into `out` (length [`COUNT`]), in [`catalogue`] order.
pub fn compute(p: &Prepared, out: &mut [f64]) {
    out.fill(0.0);
    if out.len() < COUNT {
        return;
    }
    let (full, half) = out[..COUNT].split_at_mut(2 * BINS);
    let (colour, black) = full.split_at_mut(BINS);
    gradient_histograms(&p.image, &p.region, colour, black);
    let half_image = plane::half_rgb(&p.image);
    let half_region = p.region.half();
    let (colour, black) = half.split_at_mut(BINS);
    gradient_histograms(&half_image, &half_region, colour, black);
}

/// The bin of `value ≥ 0` among [`BINS`] equal bins on `[0, top]`; values at or above `top`
/// go to the last bin.
#[inline(always)]
fn bin_of(value: f32, top: f32) -> usize {
    // `as usize` saturates (NaN → 0), so no input can index out of bounds.
    ((value * (BINS as f32 / top)) as usize).min(BINS - 1)
}

/// Squared colour-gradient magnitudes of one image row in integer Sobel units, written to
/// `m2` (length `w`). The Sobel kernel is separated: `sv` holds the vertical 1-2-1 smoothing
/// and `dv` the vertical difference of every channel sample, so the horizontal passes run over
/// contiguous, interleaved RGB samples (`±3` is one pixel) and vectorise. `q` is scratch.
#[inline(always)]
fn row_squared_gradients(
    above: &[u8],
    row: &[u8],
    below: &[u8],
    sv: &mut [i32],
    dv: &mut [i32],
    q: &mut [i32],
    m2: &mut [i32],
) {
    let len = row.len();
    // Zipped slices instead of indexing: no bounds checks, so both passes vectorise.
    for ((((s, d), &a), &c), &b) in sv
        .iter_mut()
        .zip(dv.iter_mut())
        .zip(above)
        .zip(row)
        .zip(below)
    {
        let (a, c, b) = (a as i32, c as i32, b as i32);
        *s = a + 2 * c + b;
        *d = b - a;
    }
    if len <= 3 {
        // One pixel wide: replicate borders make every derivative 0 except vertical ones.
        for (q, &d) in q.iter_mut().zip(dv.iter()) {
            *q = 16 * d * d;
        }
    } else {
        let interior = q[3..len - 3]
            .iter_mut()
            .zip(sv[6..].iter().zip(&sv[..len - 6]))
            .zip(dv[..len - 6].iter().zip(&dv[3..len - 3]).zip(&dv[6..]));
        for ((q, (&s_right, &s_left)), ((&d_left, &d_mid), &d_right)) in interior {
            let gx = s_right - s_left;
            let gy = d_left + 2 * d_mid + d_right;
            *q = gx * gx + gy * gy;
        }
        // Replicate border: the missing neighbour is the pixel itself.
        for i in (0..3).chain(len - 3..len) {
            let l = if i >= 3 { i - 3 } else { i };
            let r = if i + 3 < len { i + 3 } else { i };
            let gx = sv[r] - sv[l];
            let gy = dv[l] + 2 * dv[i] + dv[r];
            q[i] = gx * gx + gy * gy;
        }
    }
    for (m, t) in m2.iter_mut().zip(q.chunks_exact(3)) {
        *m = t[0] + t[1] + t[2];
    }
}

crate::simd::vectorised_fn! {
/// Fills the colour (eq. 5.3, on Φ) and black-pixel gradient histograms of `image` over
/// `region`, each normalised by |region|. All zeros for an empty or mismatched region.
fn gradient_histograms<'a>(
    image: &'a RgbImage,
    region: &'a Mask,
    colour: &'a mut [f64],
    black: &'a mut [f64],
) -> () {
    colour.fill(0.0);
    black.fill(0.0);
    let (w, h) = (image.width() as usize, image.height() as usize);
    if w == 0 || h == 0 || region.width != w || region.height != h {
        return;
    }
    let raw = image.as_raw();
    let stride = 3 * w;
    // Row scratch, allocated once per image.
    let mut sv = vec![0i32; stride];
    let mut dv = vec![0i32; stride];
    let mut q = vec![0i32; stride];
    let mut m2 = vec![0i32; w];
    let mut colour_hist = [0u32; BINS];
    let mut black_hist = [0u32; BINS];
    let mut n: u32 = 0;
    for y in 0..h {
        let inside = &region.data[y * w..][..w];
        if !inside.iter().any(|&b| b) {
            continue;
        }
        let (ym, yp) = (y.saturating_sub(1), (y + 1).min(h - 1));
        let row = &raw[y * stride..][..stride];
        row_squared_gradients(
            &raw[ym * stride..][..stride],
            row,
            &raw[yp * stride..][..stride],
            &mut sv,
            &mut dv,
            &mut q,
            &mut m2,
        );
        for ((&ins, &m2), px) in inside.iter().zip(&m2).zip(row.chunks_exact(3)) {
            if !ins {
                continue;
            }
            n += 1;
            let is_black = px.iter().all(|&c| c <= BLACK_MAX_CHANNEL);
            if is_black {
                let m = (m2 as f32).sqrt() * INTEGER_SCALE;
                black_hist[bin_of(m, BLACK_RANGE)] += 1;
            } else if m2 != 0 {
                let m = ((m2 as f32).sqrt() * INTEGER_SCALE).min(COLOUR_CLAMP);
                colour_hist[bin_of(m, COLOUR_CLAMP)] += 1;
            }
        }
    }
    if n == 0 {
        return;
    }
    let nf = n as f64;
    for (o, &c) in colour.iter_mut().zip(&colour_hist) {
        *o = c as f64 / nf;
    }
    for (o, &c) in black.iter_mut().zip(&black_hist) {
        *o = c as f64 / nf;
    }
}
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::edges;
    use crate::features::colour;
    use crate::plane::Plane;
    use image::Rgb;
    use std::collections::HashSet;

    fn prepared(f: impl Fn(u32, u32) -> [u8; 3]) -> Prepared {
        let img = RgbImage::from_fn(400, 400, |x, y| Rgb(f(x, y)));
        Prepared::new(img).expect("valid synthetic image")
    }

    fn features(p: &Prepared) -> [f64; COUNT] {
        let mut out = [f64::NAN; COUNT];
        compute(p, &mut out);
        assert!(out.iter().all(|v| v.is_finite() && *v >= 0.0), "{out:?}");
        out
    }

    fn in_disk(x: u32, y: u32, r: f64) -> bool {
        let (dx, dy) = (x as f64 - 199.5, y as f64 - 199.5);
        dx * dx + dy * dy <= r * r
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-12
    }

    /// Sum of one histogram: 0 colour@1x, 1 black@1x, 2 colour@0.5x, 3 black@0.5x.
    fn sum(f: &[f64], which: usize) -> f64 {
        f[which * BINS..(which + 1) * BINS].iter().sum()
    }

    /// Whether any 8-neighbour (replicate border) differs from the pixel.
    fn has_varying_neighbour(img: &RgbImage, x: u32, y: u32) -> bool {
        let c = img.get_pixel(x, y);
        let (w, h) = (img.width() as i32, img.height() as i32);
        (-1i32..=1).any(|dy| {
            (-1i32..=1).any(|dx| {
                let nx = (x as i32 + dx).clamp(0, w - 1) as u32;
                let ny = (y as i32 + dy).clamp(0, h - 1) as u32;
                img.get_pixel(nx, ny) != c
            })
        })
    }

    #[test]
    fn catalogue_order_and_names() {
        let cat = catalogue();
        assert_eq!(cat.len(), COUNT);
        let names: HashSet<_> = cat.iter().map(|f| f.name).collect();
        assert_eq!(names.len(), COUNT);
        assert!(cat.iter().all(|f| f.family == Family::Shading));
        assert_eq!(cat[0].name, "shading_colour_grad_1x_bin0");
        assert_eq!(cat[8].name, "shading_black_grad_1x_bin0");
        assert_eq!(cat[19].name, "shading_colour_grad_half_bin3");
        assert_eq!(cat[31].name, "shading_black_grad_half_bin7");
        assert!(cat[3].doc.contains("eq. 5.3") && cat[3].doc.contains("bin 3"));
    }

    #[test]
    fn bins_cover_the_range() {
        assert_eq!(bin_of(0.0, COLOUR_CLAMP), 0);
        assert_eq!(bin_of(0.1374, COLOUR_CLAMP), 0);
        assert_eq!(bin_of(0.1376, COLOUR_CLAMP), 1);
        assert_eq!(bin_of(COLOUR_CLAMP, COLOUR_CLAMP), BINS - 1);
        assert_eq!(bin_of(f32::INFINITY, BLACK_RANGE), BINS - 1);
        assert_eq!(bin_of(f32::NAN, BLACK_RANGE), 0);
        assert!((BLACK_RANGE - 1.5f32.sqrt()).abs() < 1e-6);
    }

    #[test]
    fn linear_ramp_lands_in_hand_computed_bins() {
        // Grey ramp 60, 125, 190, 245 at x = 100..=103, flat 60 to the left and 245 to the
        // right; no white or black, so Ω and Φ-candidates are the whole canvas. Per channel
        // ∂x = (v(x+1) − v(x−1)) / 2 / 255 and |∇I| = √3·∂x:
        //   x=100: 65/2/255·√3 = 0.2207 → bin ⌊0.2207·8/1.1⌋ = 1
        //   x=101: 130/2/255·√3 = 0.4415 → bin 3
        //   x=102: 120/2/255·√3 = 0.4075 → bin 2
        //   x=103: 55/2/255·√3 = 0.1868 → bin 1
        let v = |x: u32| match x {
            0..100 => 60u8,
            100 => 60,
            101 => 125,
            102 => 190,
            _ => 245,
        };
        let p = prepared(|x, _| [v(x); 3]);
        assert_eq!(p.region.count(), 160_000);
        let f = features(&p);
        let mut expected = [0.0; COUNT];
        expected[1] = 800.0 / 160_000.0;
        expected[2] = 400.0 / 160_000.0;
        expected[3] = 400.0 / 160_000.0;
        // 0.5x: columns average in pairs (rounded): …, 60, 93, 218, 245, … at X = 49..=52:
        //   X=49: 33/2/255·√3 = 0.1121 → bin 0;  X=50: 158/2/255·√3 = 0.5366 → bin 3
        //   X=51: 152/2/255·√3 = 0.5162 → bin 3; X=52: 27/2/255·√3 = 0.0917 → bin 0
        expected[16] = 400.0 / 40_000.0;
        expected[16 + 3] = 400.0 / 40_000.0;
        for (i, (a, b)) in f.iter().zip(&expected).enumerate() {
            assert!(close(*a, *b), "feature {i}: {a} vs {b}");
        }
    }

    #[test]
    fn flat_disk_has_gradients_only_at_its_boundary() {
        let p = prepared(|x, y| {
            if in_disk(x, y, 100.0) {
                [200, 40, 90]
            } else {
                [255; 3]
            }
        });
        let f = features(&p);
        let n_omega = p.region.count() as f64;
        let boundary = (0..400u32)
            .flat_map(|y| (0..400u32).map(move |x| (x, y)))
            .filter(|&(x, y)| p.region.at(x as usize, y as usize))
            .filter(|&(x, y)| has_varying_neighbour(&p.image, x, y))
            .count() as f64;
        assert!(boundary > 0.0 && boundary < 0.05 * n_omega);
        assert!(close(sum(&f, 0), boundary / n_omega));
        assert_eq!(sum(&f, 1), 0.0);
        assert_eq!(sum(&f, 3), 0.0);
        // Same at 0.5x, where the 2x2 averaging widens the boundary.
        let (img, region) = (plane::half_rgb(&p.image), p.region.half());
        let boundary = (0..200u32)
            .flat_map(|y| (0..200u32).map(move |x| (x, y)))
            .filter(|&(x, y)| region.at(x as usize, y as usize))
            .filter(|&(x, y)| has_varying_neighbour(&img, x, y))
            .count() as f64;
        assert!(boundary > 0.0);
        assert!(close(sum(&f, 2), boundary / region.count() as f64));
    }

    #[test]
    fn black_histogram_sums_to_the_black_fraction() {
        // Black disk with a thin black ring: flat black interior in bin 0, edges higher.
        let p = prepared(|x, y| {
            if in_disk(x, y, 60.0) || (in_disk(x, y, 150.0) && !in_disk(x, y, 148.0)) {
                [10, 10, 10]
            } else if in_disk(x, y, 148.0) {
                [240, 200, 0]
            } else {
                [255; 3]
            }
        });
        let f = features(&p);
        let mut c = [0.0; colour::COUNT];
        colour::compute(&p, &mut c);
        let black_fraction = c[9];
        assert!(black_fraction > 0.0);
        assert!(close(sum(&f, 1), black_fraction));
        let interior = (0..400u32)
            .flat_map(|y| (0..400u32).map(move |x| (x, y)))
            .filter(|&(x, y)| colour::is_black(p.image.get_pixel(x, y).0))
            .filter(|&(x, y)| !has_varying_neighbour(&p.image, x, y))
            .count() as f64;
        let n_omega = p.region.count() as f64;
        assert!(close(f[BINS], interior / n_omega));
        assert!(f[BINS + 1..2 * BINS].iter().sum::<f64>() > 0.0);
        // Every pixel of Ω is in at most one histogram.
        assert!(sum(&f, 0) + sum(&f, 1) <= 1.0 + 1e-12);
        assert!(sum(&f, 2) + sum(&f, 3) <= 1.0 + 1e-12);
    }

    #[test]
    fn integer_sobel_matches_edges_sobel() {
        // Includes 1- and 2-pixel-wide images for the replicate borders of the row passes.
        for (w, h) in [(37usize, 23usize), (1, 5), (2, 4), (3, 1)] {
            let img = RgbImage::from_fn(w as u32, h as u32, |x, y| {
                let v = x.wrapping_mul(2654435761) ^ y.wrapping_mul(40503).rotate_left(7);
                Rgb([(v >> 3) as u8, (v >> 11) as u8, (v >> 19) as u8])
            });
            let grads: Vec<_> = (0..3)
                .map(|c| {
                    edges::sobel(&Plane {
                        width: w,
                        height: h,
                        data: img.pixels().map(|p| p[c] as f32 / 255.0).collect(),
                    })
                })
                .collect();
            let raw = img.as_raw();
            let stride = 3 * w;
            let (mut sv, mut dv, mut q, mut m2) = (
                vec![0; stride],
                vec![0; stride],
                vec![0; stride],
                vec![0; w],
            );
            for y in 0..h {
                let (ym, yp) = (y.saturating_sub(1), (y + 1).min(h - 1));
                row_squared_gradients(
                    &raw[ym * stride..][..stride],
                    &raw[y * stride..][..stride],
                    &raw[yp * stride..][..stride],
                    &mut sv,
                    &mut dv,
                    &mut q,
                    &mut m2,
                );
                for (x, &m2) in m2.iter().enumerate() {
                    let ours = (m2 as f32).sqrt() * INTEGER_SCALE;
                    let theirs = grads
                        .iter()
                        .map(|g| g.magnitude(y * w + x).powi(2))
                        .sum::<f32>()
                        .sqrt();
                    assert!(
                        (ours - theirs).abs() < 1e-5,
                        "{w}x{h} ({x},{y}): {ours} vs {theirs}"
                    );
                }
            }
        }
    }

    #[test]
    fn single_pixel_drawing_is_finite() {
        let p = prepared(|x, y| {
            if (x, y) == (399, 0) {
                [0, 0, 0]
            } else {
                [255; 3]
            }
        });
        let f = features(&p);
        assert!(sum(&f, 0) > 0.0 && sum(&f, 1) > 0.0);
        let region = Mask::filled(400, 400, false);
        let (mut c, mut b) = ([1.0; BINS], [1.0; BINS]);
        gradient_histograms(&p.image, &region, &mut c, &mut b);
        assert!(c.iter().chain(&b).all(|&v| v == 0.0));
    }
}
