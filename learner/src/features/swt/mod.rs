//! Stroke widths (Garces et al. 2014, §5.3 "Strokes") by the Stroke Width Transform of
//! Epshtein, Ofek & Wexler, "Detecting Text in Natural Scenes with Stroke Width Transform"
//! (CVPR 2010, §2.1).
//!
//! For each of four scales (1x, 0.5x, 0.25x, 0.125x of the 400x400 canvas) and each edge kind
//! (outer = the silhouette contour, inner = every other edge) we report the mean and standard
//! deviation of the stroke width: 2 kinds × 2 statistics × 4 scales = 16 features.
//!
//! The transform, and the choices made where the papers leave room:
//! - **Edges and gradients.** At 1x the shared Canny edges and the Sobel gradients of the
//!   Canny-smoothed grey plane of [`Prepared`]. At the lower scales the grey plane is halved
//!   repeatedly ([`Plane::half`](crate::plane::Plane::half), 2x2 box average) and Canny rerun
//!   with [`CannyParams::default`]; Ω and the silhouette are halved with
//!   [`Mask::half`](crate::mask::Mask::half).
//! - **Polarity.** Clip art is ink on white paper, so strokes are darker than their surroundings:
//!   rays run along −∇I (towards darker). The opposite polarity (light strokes on dark) is not
//!   run: on a white page it would measure the gaps between shapes and the paper around them.
//!   White details inside dark shapes are still seen, through the dark bands between them.
//! - **Rays.** From every edge pixel `p` (pixel centres at integer coordinates) a ray is walked
//!   cell by cell (Amanatides & Woo's grid DDA: every pixel the ray passes through is visited,
//!   so an 8-connected Canny curve cannot be slipped through diagonally; at an exact corner the
//!   vertical neighbour is entered first). The walk stops at the first edge pixel `q` not
//!   8-adjacent to `p` (adjacent edge pixels are `p`'s own curve: Canny staircases would
//!   otherwise end every diagonal ray at once). The ray is accepted when `q`'s gradient is
//!   opposite to `p`'s within π/6 (Epshtein: `d_q = −d_p ± π/6`) and every pixel walked lies
//!   inside the image and inside Ω. Leaving either discards the ray, so a ray is at most
//!   `width + height` cells long; there is no other length cap (a filled shape is one wide
//!   stroke, as in Epshtein).
//! - **Width.** `‖p − q‖`, with `p` and `q` each moved to the sub-pixel maximum of the gradient
//!   magnitude along its own gradient (parabola through the bilinearly sampled magnitude at ±1
//!   px, offset clamped to ±½). Canny's non-maximum suppression keeps whichever pixel is on its
//!   side of a tie, so raw pixel centres are biased by up to 1 px; refined, a bar of `w` pixels
//!   measures `w`. Widths below about 2 px at a scale (2σ of Canny's smoothing) are
//!   overestimated; the coarser scales exist to see the wide strokes.
//! - **Two passes.** First every pixel of an accepted ray takes the minimum width of the rays
//!   through it; then, ray by ray in raster order of `p`, values above the ray's median (upper
//!   median of the current values) are lowered to it (Epshtein's corner fix). Updates are in
//!   place, so later rays see earlier medians; the order is fixed, so results are
//!   deterministic.
//! - **Outer and inner.** A ray is *outer* when `p` or `q` lies within 2 px (at that scale) of the
//!   silhouette contour, i.e. the disk of radius 2 around it holds both silhouette and
//!   non-silhouette pixels (off-image counts as non-silhouette). Either end, not only `p`: the
//!   rays cast inward from the far side of an outline belong to the outline. Every other
//!   accepted ray is *inner*. Each kind has its own SWT map (both passes run per kind), so a
//!   pixel crossed by both kinds of ray counts in both.
//! - **Statistics.** Mean and population standard deviation over the pixels of that kind's SWT
//!   map (Epshtein's transform is a per-pixel map; per-ray statistics would let the few long
//!   rays along a bar's length dominate). No accepted ray gives 0 and 0, never NaN.
//! - **Unit.** Widths are converted to canvas (400x400) pixels, i.e. multiplied by 2, 4 and 8 at
//!   the lower scales, so the four scales are comparable and a 12 px stroke reads ≈ 12 at each
//!   scale that resolves it.
//!
//! Cost: rays start only at edge pixels; the walk, the two passes and the statistics reuse
//! buffers across the four scales and allocate nothing per pixel or per ray.

use super::{Family, FeatureInfo, Prepared};
use crate::edges::{self, CannyParams};

#[cfg(test)]
mod tests;

/// Number of features in this family.
pub const COUNT: usize = 16;

/// Number of scales (1x, 0.5x, 0.25x, 0.125x).
const SCALES: usize = 4;

/// `cos(π/6)`: `q`'s gradient must be within π/6 of the opposite of `p`'s.
const OPPOSITE_COS: f32 = 0.866_025_4;

/// Radius in pixels (at each scale) within which a ray end counts as on the silhouette contour.
const CONTOUR_RADIUS: isize = 2;

macro_rules! feature {
    ($kind:literal, $stat:literal, $scale:literal, $kind_doc:literal, $stat_doc:literal) => {
        FeatureInfo {
            name: concat!("stroke_", $kind, "_width_", $stat, "_", $scale),
            family: Family::Stroke,
            doc: concat!(
                $stat_doc,
                " stroke width (canvas px) over SWT pixels of rays touching ",
                $kind_doc,
                ", at ",
                $scale,
                " scale (§5.3 Strokes; Epshtein et al. 2010)."
            ),
        }
    };
}

const FEATURES: [FeatureInfo; COUNT] = [
    feature!("outer", "mean", "1x", "the silhouette contour", "Mean"),
    feature!("outer", "mean", "0_5x", "the silhouette contour", "Mean"),
    feature!("outer", "mean", "0_25x", "the silhouette contour", "Mean"),
    feature!("outer", "mean", "0_125x", "the silhouette contour", "Mean"),
    feature!(
        "outer",
        "std",
        "1x",
        "the silhouette contour",
        "Std. dev. of"
    ),
    feature!(
        "outer",
        "std",
        "0_5x",
        "the silhouette contour",
        "Std. dev. of"
    ),
    feature!(
        "outer",
        "std",
        "0_25x",
        "the silhouette contour",
        "Std. dev. of"
    ),
    feature!(
        "outer",
        "std",
        "0_125x",
        "the silhouette contour",
        "Std. dev. of"
    ),
    feature!("inner", "mean", "1x", "only inner edges", "Mean"),
    feature!("inner", "mean", "0_5x", "only inner edges", "Mean"),
    feature!("inner", "mean", "0_25x", "only inner edges", "Mean"),
    feature!("inner", "mean", "0_125x", "only inner edges", "Mean"),
    feature!("inner", "std", "1x", "only inner edges", "Std. dev. of"),
    feature!("inner", "std", "0_5x", "only inner edges", "Std. dev. of"),
    feature!("inner", "std", "0_25x", "only inner edges", "Std. dev. of"),
    feature!("inner", "std", "0_125x", "only inner edges", "Std. dev. of"),
];

/// Names and docs, in output order: outer mean, outer std, inner mean, inner std, each at
/// 1x, 0.5x, 0.25x, 0.125x.
pub fn catalogue() -> Vec<FeatureInfo> {
    FEATURES.to_vec()
}

/// Writes this family's features of `p` into `out` (length [`COUNT`]).
pub fn compute(p: &Prepared, out: &mut [f64]) {
    debug_assert_eq!(out.len(), COUNT);
    let mut ws = Workspace::default();
    let mut stats = [[WidthStats::default(); 2]; SCALES];
    for_each_scale(p, |s, input| stats[s] = ws.measure(input));
    let mut values = [0.0; COUNT];
    for (s, per_kind) in stats.iter().enumerate() {
        for (k, st) in per_kind.iter().enumerate() {
            values[k * 2 * SCALES + s] = st.mean;
            values[k * 2 * SCALES + SCALES + s] = st.std;
        }
    }
    for (o, v) in out.iter_mut().zip(values) {
        *o = v;
    }
}

/// One scale's inputs, borrowed.
#[derive(Debug, Clone, Copy)]
struct ScaleInput<'a> {
    width: usize,
    height: usize,
    /// Canny edges at this scale.
    edges: &'a [bool],
    /// Gradients of the Canny-smoothed grey plane at this scale.
    dx: &'a [f32],
    dy: &'a [f32],
    /// `√(dx² + dy²)` per pixel, computed once per scale: refining each ray end samples it at
    /// nine points.
    magnitudes: &'a [f32],
    /// Ω at this scale.
    region: &'a [bool],
    /// The silhouette at this scale.
    silhouette: &'a [bool],
    /// Canvas pixels per pixel at this scale (1, 2, 4, 8).
    unit: f64,
}

impl ScaleInput<'_> {
    /// The gradient magnitude at pixel index `i`.
    #[inline]
    fn magnitude(&self, i: usize) -> f32 {
        self.magnitudes[i]
    }

    /// The gradient magnitude bilinearly interpolated at `(x, y)`, coordinates clamped.
    #[inline(always)]
    fn magnitude_at(&self, x: f32, y: f32) -> f32 {
        let x = x.clamp(0.0, (self.width - 1) as f32);
        let y = y.clamp(0.0, (self.height - 1) as f32);
        // Clamped to ≥ 0 (or NaN, which both `floor` and this cast send to 0), so the truncating
        // cast is `floor` without its libm call.
        let (x0, y0) = (x as usize, y as usize);
        let (x1, y1) = ((x0 + 1).min(self.width - 1), (y0 + 1).min(self.height - 1));
        let (fx, fy) = (x - x0 as f32, y - y0 as f32);
        let w = self.width;
        let top = self.magnitude(y0 * w + x0) * (1.0 - fx) + self.magnitude(y0 * w + x1) * fx;
        let bottom = self.magnitude(y1 * w + x0) * (1.0 - fx) + self.magnitude(y1 * w + x1) * fx;
        top * (1.0 - fy) + bottom * fy
    }

    /// The sub-pixel edge position of pixel `i`: its centre moved along its gradient to the
    /// vertex of the parabola through the magnitude at −1, 0, +1 px (offset clamped to ±½).
    #[inline(always)]
    fn refined(&self, i: usize) -> (f32, f32) {
        let (x, y) = ((i % self.width) as f32, (i / self.width) as f32);
        let m0 = self.magnitude(i);
        if !(m0 > 0.0 && m0.is_finite()) {
            return (x, y);
        }
        let (nx, ny) = (self.dx[i] / m0, self.dy[i] / m0);
        let behind = self.magnitude_at(x - nx, y - ny);
        let ahead = self.magnitude_at(x + nx, y + ny);
        let curvature = behind - 2.0 * m0 + ahead;
        let offset = if curvature < 0.0 {
            (0.5 * (behind - ahead) / curvature).clamp(-0.5, 0.5)
        } else {
            0.0
        };
        (x + offset * nx, y + offset * ny)
    }

    /// Whether the disk of radius [`CONTOUR_RADIUS`] around `i` holds both silhouette and
    /// non-silhouette pixels (off-image counts as non-silhouette).
    fn near_contour(&self, i: usize) -> bool {
        const _: () = assert!(
            CONTOUR_RADIUS == 2,
            "the interior path below spells out r = 2"
        );
        let (w, h) = (self.width, self.height);
        let (xu, yu) = (i % w, i / w);
        if (2..w.saturating_sub(2)).contains(&xu) && (2..h.saturating_sub(2)).contains(&yu) {
            // The whole disk is inside the image: its 13 pixels (dx² + dy² ≤ 4: rows of 1, 3,
            // 5, 3 and 1) by fixed offsets, without bounds tests. Mixed iff the count of
            // silhouette pixels is neither 0 nor 13.
            let s = self.silhouette;
            let row = |dy: isize, reach: isize| -> usize {
                let centre = (i as isize + dy * w as isize) as usize;
                (centre - reach as usize..=centre + reach as usize)
                    .map(|j| s[j] as usize)
                    .sum()
            };
            let inside = row(-2, 0) + row(-1, 1) + row(0, 2) + row(1, 1) + row(2, 0);
            return inside != 0 && inside != 13;
        }
        let (x, y) = (xu as isize, yu as isize);
        let (mut inside, mut outside) = (false, false);
        for oy in -CONTOUR_RADIUS..=CONTOUR_RADIUS {
            for ox in -CONTOUR_RADIUS..=CONTOUR_RADIUS {
                if ox * ox + oy * oy > CONTOUR_RADIUS * CONTOUR_RADIUS {
                    continue;
                }
                let (nx, ny) = (x + ox, y + oy);
                let set = nx >= 0
                    && ny >= 0
                    && (nx as usize) < self.width
                    && (ny as usize) < self.height
                    && self.silhouette[ny as usize * self.width + nx as usize];
                inside |= set;
                outside |= !set;
                if inside && outside {
                    return true;
                }
            }
        }
        false
    }
}

/// Builds the four scales and calls `f(scale_index, input)` on each, finest first. Stops early
/// (leaving the rest unvisited) if a scale would be under 3x3 pixels.
fn for_each_scale(p: &Prepared, mut f: impl FnMut(usize, &ScaleInput)) {
    let (dx, dy) = (&p.smoothed_gradients.dx.data, &p.smoothed_gradients.dy.data);
    f(
        0,
        &ScaleInput {
            width: p.grey.width,
            height: p.grey.height,
            edges: &p.edges.data,
            dx,
            dy,
            magnitudes: &magnitudes(dx, dy),
            region: &p.region.data,
            silhouette: &p.silhouette.data,
            unit: 1.0,
        },
    );
    let mut grey = p.grey.half();
    let mut region = p.region.half();
    let mut silhouette = p.silhouette.half();
    for s in 1..SCALES {
        if grey.width < 3 || grey.height < 3 {
            return;
        }
        let (edges, grad) = edges::canny(&grey, &CannyParams::default());
        f(
            s,
            &ScaleInput {
                width: grey.width,
                height: grey.height,
                edges: &edges.data,
                dx: &grad.dx.data,
                dy: &grad.dy.data,
                magnitudes: &magnitudes(&grad.dx.data, &grad.dy.data),
                region: &region.data,
                silhouette: &silhouette.data,
                unit: (1u32 << s) as f64,
            },
        );
        if s + 1 < SCALES {
            grey = grey.half();
            region = region.half();
            silhouette = silhouette.half();
        }
    }
}

crate::simd::vectorised_fn! {
/// The gradient magnitude `√(dx² + dy²)` of every pixel.
fn magnitudes<'a>(dx: &'a [f32], dy: &'a [f32]) -> Vec<f32> {
    dx.iter()
        .zip(dy)
        .map(|(&x, &y)| (x * x + y * y).sqrt())
        .collect()
}
}

/// Edge kind index: outer (silhouette contour) rays.
const OUTER: usize = 0;
/// Edge kind index: inner rays.
const INNER: usize = 1;

/// Mean and standard deviation of one kind's SWT map, in canvas pixels.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct WidthStats {
    mean: f64,
    std: f64,
    /// Number of SWT pixels.
    pixels: usize,
    /// Number of accepted rays.
    rays: usize,
}

/// An accepted ray: its pixels are `Workspace::pixels[start..end]`.
#[derive(Debug, Clone, Copy)]
struct Ray {
    start: u32,
    end: u32,
    kind: u8,
}

/// Buffers reused across scales.
#[derive(Debug, Default)]
struct Workspace {
    /// One SWT map per kind; `INFINITY` = no ray. All `INFINITY` between calls of `measure`.
    maps: [Vec<f32>; 2],
    /// Accepted rays, in raster order of their start pixel.
    rays: Vec<Ray>,
    /// Pixel indices of the accepted rays, concatenated (each ray from `p` to `q` inclusive).
    pixels: Vec<u32>,
    /// [`cell_flags`] of the current scale.
    flags: Vec<u8>,
    /// Median scratch: one ray's map values as bits (non-negative floats order as their bits).
    scratch: Vec<u32>,
}

impl Workspace {
    /// The SWT of one scale, summarised per kind ([`OUTER`], [`INNER`]).
    fn measure(&mut self, input: &ScaleInput) -> [WidthStats; 2] {
        let n = input.width * input.height;
        for map in &mut self.maps {
            if map.len() < n {
                map.resize(n, f32::INFINITY);
            }
        }
        self.rays.clear();
        cell_flags(input, &mut self.flags);
        // `pixels[..used]` holds the accepted rays; the walk writes past `used` and a rejected
        // ray is forgotten by not advancing it. The buffer only ever grows, so a walk of up to
        // `w + h + 1` cells always has room without a capacity check per cell.
        let longest = input.width + input.height + 1;
        let mut used = 0;
        // Pass 1: cast, keep accepted rays, minimum width per pixel. Edge pixels are a few
        // percent of the image: blocks without one are passed over by one vectorised test.
        const BLOCK: usize = 32;
        let edge_pixels = input.edges[..n]
            .chunks(BLOCK)
            .enumerate()
            .filter(|(_, block)| block.iter().fold(false, |any, &e| any | e))
            .flat_map(|(b, block)| {
                let first = b * BLOCK;
                block
                    .iter()
                    .enumerate()
                    .filter_map(move |(k, &e)| e.then_some(first + k))
            });
        for i in edge_pixels {
            if self.pixels.len() < used + longest {
                self.pixels.resize(used + longest, 0);
            }
            let walk = cast_ray(input, &self.flags, i, &mut self.pixels[used..]);
            let Some(q) = walk.end else {
                continue;
            };
            let (start, end) = (used, used + walk.cells);
            used = end;
            let (px, py) = input.refined(i);
            let (qx, qy) = input.refined(q);
            let width = (px - qx).hypot(py - qy);
            let kind = if input.near_contour(i) || input.near_contour(q) {
                OUTER
            } else {
                INNER
            };
            let map = &mut self.maps[kind];
            for &j in &self.pixels[start..end] {
                lower_to(&mut map[j as usize], width);
            }
            self.rays.push(Ray {
                start: start as u32,
                end: end as u32,
                kind: kind as u8,
            });
        }
        // Pass 2: cap each ray at its median.
        for ray in &self.rays {
            let map = &mut self.maps[ray.kind as usize];
            let ray_pixels = &self.pixels[ray.start as usize..ray.end as usize];
            self.scratch.clear();
            self.scratch
                .extend(ray_pixels.iter().map(|&j| map[j as usize].to_bits()));
            // Every value is a width (finite, ≥ +0), so the bits order like the values. When
            // the top `len - mid` values all equal the ray's maximum, the median is that
            // maximum and capping changes nothing (this includes a ray no shorter ray crossed).
            let mid = self.scratch.len() / 2;
            let top = self.scratch.iter().copied().fold(0, u32::max);
            let at_top = self.scratch.iter().filter(|&&v| v == top).count();
            if at_top >= self.scratch.len() - mid {
                continue;
            }
            let (_, &mut median, _) = self.scratch.select_nth_unstable(mid);
            let median = f32::from_bits(median);
            for &j in ray_pixels {
                lower_to(&mut map[j as usize], median);
            }
        }
        // Statistics over each map's pixels, resetting them to INFINITY for the next scale.
        [OUTER, INNER].map(|kind| {
            let (pixels, mean, variance) = summarise(&mut self.maps[kind][..n], input.unit);
            WidthStats {
                mean,
                std: variance.sqrt(),
                pixels,
                rays: self
                    .rays
                    .iter()
                    .filter(|r| usize::from(r.kind) == kind)
                    .count(),
            }
        })
    }
}

crate::simd::vectorised_fn! {
/// Count, mean and population variance of the finite values of an SWT map, each times `unit`,
/// resetting every value to `INFINITY` for the next scale.
///
/// A raster scan rather than a walk along the rays: each pixel is read once (rays share
/// pixels), blocks without a value are skipped by one vectorised test, and the sums run in
/// [`LANES`] interleaved partial sums so they vectorise. Two passes, the mean first and then
/// the squared deviations from it: the one-pass `E[x²] − E[x]²` left rounding noise of up to
/// 2·10⁻⁴ px as the deviation of strokes of one exact width.
fn summarise<'a>(map: &'a mut [f32], unit: f64) -> (usize, f64, f64) {
    let mut count = [0usize; LANES];
    let mut sum = [0.0f64; LANES];
    let mut blocks = map.chunks_exact(LANES);
    for block in &mut blocks {
        if block.iter().fold(true, |empty, v| empty & v.is_infinite()) {
            continue;
        }
        for (lane, &v) in block.iter().enumerate() {
            let finite = v.is_finite();
            count[lane] += usize::from(finite);
            sum[lane] += if finite { f64::from(v) * unit } else { 0.0 };
        }
    }
    for &v in blocks.remainder().iter().filter(|v| v.is_finite()) {
        count[0] += 1;
        sum[0] += f64::from(v) * unit;
    }
    let count: usize = count.iter().sum();
    if count == 0 {
        return (0, 0.0, 0.0);
    }
    let mean = sum.iter().sum::<f64>() / count as f64;
    let mut squares = [0.0f64; LANES];
    let mut blocks = map.chunks_exact_mut(LANES);
    for block in &mut blocks {
        if block.iter().fold(true, |empty, v| empty & v.is_infinite()) {
            continue;
        }
        for (lane, v) in block.iter_mut().enumerate() {
            let deviation = if v.is_finite() { f64::from(*v) * unit - mean } else { 0.0 };
            squares[lane] += deviation * deviation;
            *v = f32::INFINITY;
        }
    }
    for v in blocks.into_remainder().iter_mut().filter(|v| v.is_finite()) {
        let deviation = f64::from(*v) * unit - mean;
        squares[0] += deviation * deviation;
        *v = f32::INFINITY;
    }
    (count, mean, squares.iter().sum::<f64>() / count as f64)
}
}

/// Interleaved partial sums in [`summarise`].
const LANES: usize = 8;

/// `*v = v.min(x)` for the values met here: widths, finite and ≥ +0, or `INFINITY`. Such floats
/// order like their bit patterns, so this is an integer minimum, without a branch (whether a
/// crossing ray is shorter is a coin toss for the branch predictor) and without `min`'s NaN
/// handling.
#[inline]
fn lower_to(v: &mut f32, x: f32) {
    debug_assert!(x >= 0.0 && *v >= 0.0, "{x} {v}");
    *v = f32::from_bits(v.to_bits().min(x.to_bits()));
}

/// [`cell_flags`] bit: the pixel is in Ω at this scale.
const IN_REGION: u8 = 1;
/// [`cell_flags`] bit: the pixel is a Canny edge at this scale.
const ON_EDGE: u8 = 2;

/// Ω and the edges of one scale as one byte per pixel ([`IN_REGION`] | [`ON_EDGE`]), on a grid
/// padded by one empty pixel on every side (`(width + 2) × (height + 2)`): a ray leaving the
/// image steps onto the padding, which is outside Ω, so the walk needs no bounds test of its
/// own and each step costs one load.
fn cell_flags(input: &ScaleInput, flags: &mut Vec<u8>) {
    let (w, h) = (input.width, input.height);
    let padded_w = w + 2;
    flags.clear();
    flags.resize(padded_w * (h + 2), 0);
    for ((out, region), edges) in flags
        .chunks_exact_mut(padded_w)
        .skip(1)
        .zip(input.region.chunks_exact(w))
        .zip(input.edges.chunks_exact(w))
    {
        for ((o, &r), &e) in out[1..=w].iter_mut().zip(region).zip(edges) {
            *o = (r as u8 * IN_REGION) | (e as u8 * ON_EDGE);
        }
    }
}

/// Where a ray walk ended.
struct Walk {
    /// `q`, when the ray is accepted.
    end: Option<usize>,
    /// How many pixels at the start of the buffer are the ray's (`p` to `q` inclusive) when
    /// the walk reached an edge pixel `q`; 0 when it left Ω or the image first.
    cells: usize,
}

/// All ones when `condition` holds, else zero: for the branch-free selects of [`cast_ray`].
#[inline]
fn all_ones_if(condition: bool) -> isize {
    -(condition as isize)
}

/// Walks the ray from edge pixel `i` along −∇I, writing every pixel it passes through (from `i`
/// to `q` inclusive) to `pixels` (at least `width + height + 1` long). `flags` is [`cell_flags`]
/// of `input`.
fn cast_ray(input: &ScaleInput, flags: &[u8], i: usize, pixels: &mut [u32]) -> Walk {
    let rejected = Walk {
        end: None,
        cells: 0,
    };
    let (w, h) = (input.width, input.height);
    let (gx, gy) = (input.dx[i], input.dy[i]);
    let g = (gx * gx + gy * gy).sqrt();
    if !(g > 0.0 && g.is_finite()) {
        return rejected;
    }
    let (ux, uy) = (-gx / g, -gy / g);
    let (x0, y0) = ((i % w) as isize, (i / w) as isize);
    let (mut x, mut y) = (x0, y0);
    let step_x: isize = if ux > 0.0 { 1 } else { -1 };
    let step_y: isize = if uy > 0.0 { 1 } else { -1 };
    let delta_x = 1.0f32 / ux.abs(); // INFINITY when ux == 0
    let delta_y = 1.0f32 / uy.abs();
    let (mut next_x, mut next_y) = (0.5 * delta_x, 0.5 * delta_y);
    // The same pixel in the image and in the padded flag grid.
    let padded_w = (w + 2) as isize;
    let (mut j, mut padded_j) = (i as isize, (y0 + 1) * padded_w + x0 + 1);
    let (step_j_y, step_padded_y) = (step_y * w as isize, step_y * padded_w);
    pixels[0] = i as u32;
    // A 4-connected walk inside the image visits at most w + h cells.
    // Indexing by the step count, not `iter_mut().enumerate()`: that form ran the SWT 30%
    // slower (LLVM no longer kept the walk's state in registers).
    #[allow(clippy::needless_range_loop)]
    for cells in 1..=w + h {
        // Branch-free selects (masks, not `if`s, which the compiler turns back into a branch):
        // along a diagonal the axis alternates unpredictably, and a mispredicted branch per
        // cell cost more than the rest of the step. Adding +0.0 leaves the other distance as
        // it was, bit for bit.
        let along_x = all_ones_if(next_x < next_y);
        x += step_x & along_x;
        y += step_y & !along_x;
        j += step_x & along_x | step_j_y & !along_x;
        padded_j += step_x & along_x | step_padded_y & !along_x;
        let float_mask = along_x as u32;
        next_x += f32::from_bits(delta_x.to_bits() & float_mask);
        next_y += f32::from_bits(delta_y.to_bits() & !float_mask);
        let cell = flags[padded_j as usize];
        if cell & IN_REGION == 0 {
            // Outside Ω, or off the image onto the padding.
            return rejected;
        }
        pixels[cells] = j as u32;
        if cell & ON_EDGE != 0 && ((x - x0).abs() > 1 || (y - y0).abs() > 1) {
            let j = j as usize;
            let (qx, qy) = (input.dx[j], input.dy[j]);
            let gq = (qx * qx + qy * qy).sqrt();
            let accepted = gx * qx + gy * qy < -OPPOSITE_COS * g * gq;
            return Walk {
                end: accepted.then_some(j),
                cells: cells + 1,
            };
        }
    }
    rejected
}
