//! Colour statistics of Garces et al., "A Similarity Measure for Illustration Style" (SIGGRAPH
//! 2014), §5.3 "Color", eqs. 5.1–5.2, with the hue/colour counts of Ke, Tang and Jing, "The
//! Design of High-Level Features for Photo Quality Assessment" (CVPR 2006) and the
//! colourfulness of Hasler and Süsstrunk, "Measuring Colourfulness in Natural Images" (2003).
//!
//! Every statistic is taken over the pixels of the drawing region Ω ([`Prepared::region`]),
//! which includes the 10 px white margin around the drawing; "fraction" always means a fraction
//! of |Ω|. Choices made where the paper is silent:
//!
//! - **Hue and saturation** are HSV (hexcone) hue and saturation of the gamma-encoded sRGB
//!   values, as scikit-image's `rgb2hsv`: `S = (max − min) / max` (0 for black), hue in turns
//!   `[0, 1)`. Hue is only meaningful for chromatic pixels, so every hue statistic uses the
//!   pixels with `S ≥` [`HUE_MIN_SATURATION`] (0.1, tested exactly in integers as
//!   `10·(max − min) ≥ max`).
//! - **Hue std** is the circular standard deviation `sqrt(−2 ln R̄)` of Mardia (scipy's
//!   `circstd`), expressed in turns (divided by 2π), where `R̄` is the mean resultant length.
//!   `R̄` is floored at `e^{−π²/2}` so the value is capped at half a turn instead of diverging
//!   for perfectly balanced hues. 0 when no pixel is chromatic.
//! - **Luminance** is the Rec. 601 luma of [`Prepared::grey`] for the mean and std; its
//!   256-bin histogram bins the 8-bit luma `⌊(299R + 587G + 114B + 500) / 1000⌋` (computed in
//!   integers, so bin edges are exact).
//! - Standard deviations are population ones (divide by |Ω|).
//! - **Entropies** are Shannon entropies in bits of the normalised histograms.
//! - **RGB histogram**: 8 levels per channel (top 3 bits), 512 bins.
//! - **Hasler–Süsstrunk** colourfulness `sqrt(σ_rg² + σ_yb²) + 0.3·sqrt(μ_rg² + μ_yb²)` with
//!   `rg = R − G`, `yb = (R + G)/2 − B` and channels in `[0, 1]` (multiply by 255 for the
//!   scale of the original paper). Sums are accumulated exactly in integers.
//! - **Eq. 5.1** colourfulness is the mean over Ω of `|R−G| + |G−B| + |B−R|` with channels in
//!   `[0, 1]` (range `[0, 2]`); it equals `2·(max − min)`.
//! - **Black** is HSV value ≤ 0.2, i.e. every channel ≤ [`BLACK_MAX_CHANNEL`] (51); see
//!   [`is_black`]. The shading family uses the same test.
//! - **Dominant colour fraction** (item 11 of the list) uses a finer 4096-bin histogram (16
//!   levels per channel): on the 512-bin histogram it would be the very same number as the
//!   most-common-colour frequency of eq. 5.2 (item 14), a duplicated column.
//! - **Eq. 5.2** (Ke et al.): a bin of the 20-bin hue histogram (or of the 512-bin RGB
//!   histogram) is *dominant* when its count exceeds [`DOMINANT_FRACTION`] (c = 0.05, Ke et
//!   al.'s α) times the largest bin; the mode frequency is the largest bin as a fraction of
//!   |Ω| (not of the chromatic pixels, so a single red dot in a grey drawing scores near 0).
//!
//! The whole family is one pass over Ω with fixed-size histograms; runs of identical pixels
//! (flat fills) are accumulated once with their length as weight, and hue cosines and sines
//! come from a table built once per process, so no trigonometry runs per pixel.

use std::f64::consts::{PI, TAU};
use std::sync::OnceLock;

use super::{Family, FeatureInfo, Prepared};

/// Number of features in this family.
pub const COUNT: usize = 15;

/// Largest channel value of a black pixel (HSV value ≤ 0.2 on 0–255).
pub const BLACK_MAX_CHANNEL: u8 = 51;
/// Minimum HSV saturation for a pixel to have a meaningful hue.
pub const HUE_MIN_SATURATION: f64 = 0.1;
/// Eq. 5.2: a histogram bin is dominant when its count exceeds this fraction of the largest.
pub const DOMINANT_FRACTION: f64 = 0.05;
/// Number of bins of the hue histogram of eq. 5.2.
pub const HUE_BINS: usize = 20;

const RGB_BINS: usize = 512;
const FINE_RGB_BINS: usize = 4096;
const LUMA_BINS: usize = 256;

const fn info(name: &'static str, doc: &'static str) -> FeatureInfo {
    FeatureInfo {
        name,
        family: Family::Colour,
        doc,
    }
}

const FEATURES: [FeatureInfo; COUNT] = [
    info(
        "colour_hue_std",
        "§5.3 Color: circular std of HSV hue (turns) over pixels with S ≥ 0.1",
    ),
    info(
        "colour_saturation_mean",
        "§5.3 Color: mean HSV saturation over Ω",
    ),
    info(
        "colour_saturation_std",
        "§5.3 Color: std of HSV saturation over Ω",
    ),
    info(
        "colour_luminance_mean",
        "§5.3 Color: mean Rec. 601 luma over Ω",
    ),
    info(
        "colour_luminance_std",
        "§5.3 Color: std of Rec. 601 luma over Ω",
    ),
    info(
        "colour_luminance_entropy",
        "§5.3 Color: entropy (bits) of the 256-bin luma histogram over Ω",
    ),
    info(
        "colour_rgb_entropy",
        "§5.3 Color: entropy (bits) of the 512-bin RGB histogram over Ω",
    ),
    info(
        "colour_colourfulness_hasler",
        "§5.3 Color: Hasler–Süsstrunk colourfulness over Ω (channels in [0,1])",
    ),
    info(
        "colour_colourfulness_channel_diff",
        "§5.3 Color, eq. 5.1: mean of |R−G|+|G−B|+|B−R| over Ω (channels in [0,1])",
    ),
    info(
        "colour_black_fraction",
        "§5.3 Color: fraction of Ω that is black (HSV value ≤ 0.2)",
    ),
    info(
        "colour_dominant_colour_fraction",
        "§5.3 Color: fraction of Ω in the most frequent bin of a 4096-bin RGB histogram",
    ),
    info(
        "colour_hue_mode_frequency",
        "§5.3 Color, eq. 5.2: largest bin of the 20-bin hue histogram (S ≥ 0.1), fraction of Ω",
    ),
    info(
        "colour_dominant_hue_count",
        "§5.3 Color, eq. 5.2: number of hue bins above 0.05 of the largest (Ke et al. 2006)",
    ),
    info(
        "colour_rgb_mode_frequency",
        "§5.3 Color, eq. 5.2: largest bin of the 512-bin RGB histogram, fraction of Ω",
    ),
    info(
        "colour_dominant_rgb_count",
        "§5.3 Color, eq. 5.2: number of RGB bins above 0.05 of the largest (Ke et al. 2006)",
    ),
];

/// Names and docs, in output order.
pub fn catalogue() -> Vec<FeatureInfo> {
    FEATURES.to_vec()
}

/// Whether a pixel is black: HSV value ≤ 0.2, i.e. every channel ≤ [`BLACK_MAX_CHANNEL`].
#[inline]
pub fn is_black(rgb: [u8; 3]) -> bool {
    rgb[0] <= BLACK_MAX_CHANNEL && rgb[1] <= BLACK_MAX_CHANNEL && rgb[2] <= BLACK_MAX_CHANNEL
}

/// Index into [`hue_table`] of the offset `a` (`0 ≤ a ≤ d`) within a hue sector of chroma `d`
/// (`1 ≤ d ≤ 255`).
#[inline]
fn hue_table_index(d: u32, a: u32) -> usize {
    (d * (d + 1) / 2 + a - 1) as usize
}

/// `(cos, sin)` of the hue angle `60° · a / d` for every chroma `d ∈ 1..=255` and offset
/// `a ∈ 0..=d`. Every HSV hue of an 8-bit pixel is such an angle, signed, plus 0°, 120° or
/// 240°, so the circular hue statistics need no trigonometry per pixel. Built once (≈33k
/// entries, 0.5 MB).
fn hue_table() -> &'static [(f64, f64)] {
    static TABLE: OnceLock<Vec<(f64, f64)>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let mut t = vec![(0.0, 0.0); hue_table_index(255, 255) + 1];
        for d in 1..=255u32 {
            for a in 0..=d {
                // a/d first: equal hues from different chroma get bit-identical table entries.
                let angle = (PI / 3.0) * (a as f64 / d as f64);
                let (s, c) = angle.sin_cos();
                t[hue_table_index(d, a)] = (c, s);
            }
        }
        t
    })
}

/// The bin of the 20-bin hue histogram of a pixel in hue `sector` (0, 1, 2 for R, G, B max)
/// with signed offset `x ∈ [−d, d]` and chroma `d ≥ 1`, in exact integer arithmetic: the hue is
/// `hn / 6d` turns with `hn = 2·sector·d + x` wrapped into `[0, 6d)`.
#[inline]
fn hue_bin(sector: usize, x: i32, d: u32) -> usize {
    let six_d = 6 * d as i32;
    let mut hn = 2 * sector as i32 * d as i32 + x;
    if hn < 0 {
        hn += six_d;
    }
    let bin = (HUE_BINS as i32 * hn) / six_d;
    (bin.max(0) as usize).min(HUE_BINS - 1)
}

/// Shannon entropy in bits of a histogram with `total` samples (0 for an empty histogram).
fn entropy_bits(hist: &[u32], total: u64) -> f64 {
    if total == 0 {
        return 0.0;
    }
    let n = total as f64;
    hist.iter()
        .filter(|&&c| c > 0)
        .map(|&c| {
            let p = c as f64 / n;
            -p * p.log2()
        })
        .sum()
}

/// The largest bin and the number of dominant bins (eq. 5.2: count > c·max; none when empty).
fn mode_and_dominant_count(hist: &[u32]) -> (u32, usize) {
    let max = hist.iter().copied().max().unwrap_or(0);
    if max == 0 {
        return (0, 0);
    }
    let threshold = DOMINANT_FRACTION * max as f64;
    (max, hist.iter().filter(|&&c| c as f64 > threshold).count())
}

/// Population std from exact integer sums: `sqrt(n·Σx² − (Σx)²) / n`, scaled by `scale`.
fn integer_std(n: u64, sum: i64, sum_sq: u64, scale: f64) -> f64 {
    let num = n as i128 * sum_sq as i128 - (sum as i128) * (sum as i128);
    // num ≥ 0 by Cauchy–Schwarz and is exact; max(0) is only belt and braces.
    (num.max(0) as f64).sqrt() / n as f64 * scale
}

/// Population std from floating sums, clamped against cancellation below zero.
fn float_std(n: f64, sum: f64, sum_sq: f64) -> f64 {
    let mean = sum / n;
    (sum_sq / n - mean * mean).max(0.0).sqrt()
}

/// A mean resultant length within this of 1 is taken as exactly 1 (a single hue): the
/// floating error of the sums is ~1e-13, and the square root of the circular std would turn it
/// into a spurious ~1e-7 turn. The smallest genuine effect lost is a hue difference of < 1e-6
/// rad on one pixel in 160k.
const SINGLE_HUE_TOLERANCE: f64 = 1e-12;

/// Floating-point sums of one row (then of the image).
#[derive(Debug, Default, Clone, Copy)]
struct FloatSums {
    sat: f64,
    sat_sq: f64,
    lum: f64,
    lum_sq: f64,
    /// Unit hue vectors summed per hue sector (R, G, B max) in the sector's own frame.
    hue_cos: [f64; 3],
    hue_sin: [f64; 3],
}

impl FloatSums {
    fn add(&mut self, o: &FloatSums) {
        self.sat += o.sat;
        self.sat_sq += o.sat_sq;
        self.lum += o.lum;
        self.lum_sq += o.lum_sq;
        for k in 0..3 {
            self.hue_cos[k] += o.hue_cos[k];
            self.hue_sin[k] += o.hue_sin[k];
        }
    }
}

/// Integer statistics of the pixels of Ω, accumulated exactly.
#[derive(Debug, Clone)]
struct Accumulator {
    /// The (cos, sin) table of [`hue_table`].
    table: &'static [(f64, f64)],
    /// |Ω|.
    n: u64,
    luma_hist: [u32; LUMA_BINS],
    rgb_hist: [u32; RGB_BINS],
    fine_hist: [u32; FINE_RGB_BINS],
    hue_hist: [u32; HUE_BINS],
    /// Pixels with S ≥ 0.1 (their hue vectors are summed in [`FloatSums`]).
    n_chromatic: u64,
    /// Hasler–Süsstrunk sums of rg = R − G and 2·yb = R + G − 2B on 0–255.
    rg_sum: i64,
    rg_sq: u64,
    yb2_sum: i64,
    yb2_sq: u64,
    /// Σ (max − min), for eq. 5.1.
    chroma_sum: u64,
    black: u64,
}

impl Default for Accumulator {
    fn default() -> Self {
        Self {
            table: &[],
            n: 0,
            luma_hist: [0; LUMA_BINS],
            rgb_hist: [0; RGB_BINS],
            fine_hist: [0; FINE_RGB_BINS],
            hue_hist: [0; HUE_BINS],
            n_chromatic: 0,
            rg_sum: 0,
            rg_sq: 0,
            yb2_sum: 0,
            yb2_sq: 0,
            chroma_sum: 0,
            black: 0,
        }
    }
}

impl Accumulator {
    /// Adds `k` pixels of colour `px` and luma `lum`; float sums go to the row's `row`.
    #[inline]
    fn add(&mut self, row: &mut FloatSums, px: [u8; 3], lum: f32, k: u32) {
        let (r, g, b) = (px[0] as u32, px[1] as u32, px[2] as u32);
        let max = r.max(g).max(b);
        let min = r.min(g).min(b);
        let d = max - min;
        let (k64, kf) = (k as u64, k as f64);
        self.n += k64;

        let l = lum as f64;
        row.lum += kf * l;
        row.lum_sq += kf * l * l;
        self.luma_hist[((299 * r + 587 * g + 114 * b + 500) / 1000) as usize] += k;
        self.rgb_hist[((r >> 5) << 6 | (g >> 5) << 3 | (b >> 5)) as usize] += k;
        self.fine_hist[((r >> 4) << 8 | (g >> 4) << 4 | (b >> 4)) as usize] += k;

        let rg = r as i64 - g as i64;
        let yb2 = r as i64 + g as i64 - 2 * b as i64;
        self.rg_sum += k as i64 * rg;
        self.rg_sq += k64 * (rg * rg) as u64;
        self.yb2_sum += k as i64 * yb2;
        self.yb2_sq += k64 * (yb2 * yb2) as u64;
        self.chroma_sum += k64 * d as u64;
        if max <= BLACK_MAX_CHANNEL as u32 {
            self.black += k64;
        }

        if d == 0 {
            return; // grey: saturation 0, no hue
        }
        let s = d as f64 / max as f64;
        row.sat += kf * s;
        row.sat_sq += kf * s * s;
        if 10 * d < max {
            return; // S < 0.1: hue unreliable
        }
        // HSV hue = (2·sector + x/d) / 6 turns, x ∈ [−d, d]; same sector rules as rgb2hsv
        // (ties give the same hue from either sector).
        let (sector, x) = if max == r {
            (0usize, g as i32 - b as i32)
        } else if max == g {
            (1, b as i32 - r as i32)
        } else {
            (2, r as i32 - g as i32)
        };
        let (c, sn) = self
            .table
            .get(hue_table_index(d, x.unsigned_abs()))
            .copied()
            .unwrap_or((1.0, 0.0)); // unreachable: d ≤ 255 and |x| ≤ d
        row.hue_cos[sector] += kf * c;
        row.hue_sin[sector] += kf * if x < 0 { -sn } else { sn };
        self.n_chromatic += k64;
        self.hue_hist[hue_bin(sector, x, d)] += k;
    }
}

/// Writes this family's features of `p` into `out` (length [`COUNT`]), in [`catalogue`] order.
pub fn compute(p: &Prepared, out: &mut [f64]) {
    out.fill(0.0);
    let raw = p.image.as_raw();
    let region = &p.region.data;
    let grey = &p.grey.data;
    if raw.len() != region.len() * 3 || grey.len() != region.len() || out.len() < COUNT {
        // Inconsistent input (not produced by `Prepared::new`): zeros rather than a panic.
        return;
    }
    let mut acc = Accumulator {
        table: hue_table(),
        ..Accumulator::default()
    };
    let mut sums = FloatSums::default();

    let w = p.region.width.max(1);
    for ((row_px, row_in), row_grey) in raw
        .chunks_exact(3 * w)
        .zip(region.chunks_exact(w))
        .zip(grey.chunks_exact(w))
    {
        if !row_in.iter().any(|&b| b) {
            continue;
        }
        // Float sums are accumulated per row and then added up (two-level summation): the
        // rounding error of 160k naive additions would otherwise be amplified by the square
        // root of the circular std into ~1e-7 turns for a single flat hue.
        let mut row = FloatSums::default();
        // Clip art is mostly flat fills, so identical pixels are counted as runs and each run
        // is accumulated once with its length as weight. The statistics are order-free, so a
        // run may continue across pixels outside Ω (which are skipped).
        let mut run_px = [0u8; 3];
        let mut run_lum = 0.0f32;
        let mut run_len = 0u32;
        for ((px, &inside), &lum) in row_px.chunks_exact(3).zip(row_in).zip(row_grey) {
            if !inside {
                continue;
            }
            let px = [px[0], px[1], px[2]];
            if run_len > 0 && px == run_px {
                run_len += 1;
                continue;
            }
            if run_len > 0 {
                acc.add(&mut row, run_px, run_lum, run_len);
            }
            (run_px, run_lum, run_len) = (px, lum, 1);
        }
        if run_len > 0 {
            acc.add(&mut row, run_px, run_lum, run_len);
        }
        sums.add(&row);
    }
    let Accumulator {
        n,
        luma_hist,
        rgb_hist,
        fine_hist,
        hue_hist,
        n_chromatic,
        rg_sum,
        rg_sq,
        yb2_sum,
        yb2_sq,
        chroma_sum,
        black,
        ..
    } = acc;

    if n == 0 {
        return;
    }
    let nf = n as f64;

    let hue_std = if n_chromatic == 0 {
        0.0
    } else {
        let (mut c, mut s) = (0.0, 0.0);
        for k in 0..3 {
            let (sin_b, cos_b) = (TAU * k as f64 / 3.0).sin_cos();
            c += sums.hue_cos[k] * cos_b - sums.hue_sin[k] * sin_b;
            s += sums.hue_cos[k] * sin_b + sums.hue_sin[k] * cos_b;
        }
        let mut r_bar = (c.hypot(s) / n_chromatic as f64).clamp((-PI * PI / 2.0).exp(), 1.0);
        if r_bar > 1.0 - SINGLE_HUE_TOLERANCE {
            r_bar = 1.0; // a single hue up to summation error
        }
        (-2.0 * r_bar.ln()).max(0.0).sqrt() / TAU
    };

    const SCALE: f64 = 1.0 / 255.0;
    let mu_rg = rg_sum as f64 / nf * SCALE;
    let mu_yb = yb2_sum as f64 / nf * SCALE * 0.5;
    let sd_rg = integer_std(n, rg_sum, rg_sq, SCALE);
    let sd_yb = integer_std(n, yb2_sum, yb2_sq, SCALE * 0.5);
    let hasler = sd_rg.hypot(sd_yb) + 0.3 * mu_rg.hypot(mu_yb);

    let (hue_mode, hue_dominant) = mode_and_dominant_count(&hue_hist);
    let (rgb_mode, rgb_dominant) = mode_and_dominant_count(&rgb_hist);
    let fine_mode = fine_hist.iter().copied().max().unwrap_or(0);

    let values: [f64; COUNT] = [
        hue_std,
        sums.sat / nf,
        float_std(nf, sums.sat, sums.sat_sq),
        sums.lum / nf,
        float_std(nf, sums.lum, sums.lum_sq),
        entropy_bits(&luma_hist, n),
        entropy_bits(&rgb_hist, n),
        hasler,
        2.0 * chroma_sum as f64 / nf * SCALE,
        black as f64 / nf,
        fine_mode as f64 / nf,
        hue_mode as f64 / nf,
        hue_dominant as f64,
        rgb_mode as f64 / nf,
        rgb_dominant as f64,
    ];
    out[..COUNT].copy_from_slice(&values);
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::{Rgb, RgbImage};
    use std::collections::HashSet;

    const HUE_STD: usize = 0;
    const SAT_MEAN: usize = 1;
    const SAT_STD: usize = 2;
    const LUM_MEAN: usize = 3;
    const LUM_STD: usize = 4;
    const LUM_ENTROPY: usize = 5;
    const RGB_ENTROPY: usize = 6;
    const HASLER: usize = 7;
    const CHANNEL_DIFF: usize = 8;
    const BLACK: usize = 9;
    const DOMINANT_FRACTION_4096: usize = 10;
    const HUE_MODE: usize = 11;
    const HUE_COUNT: usize = 12;
    const RGB_MODE: usize = 13;
    const RGB_COUNT: usize = 14;

    fn prepared(f: impl Fn(u32, u32) -> [u8; 3]) -> Prepared {
        let img = RgbImage::from_fn(400, 400, |x, y| Rgb(f(x, y)));
        Prepared::new(img).expect("valid synthetic image")
    }

    fn features(p: &Prepared) -> [f64; COUNT] {
        let mut out = [f64::NAN; COUNT];
        compute(p, &mut out);
        assert!(out.iter().all(|v| v.is_finite()), "{out:?}");
        out
    }

    fn in_disk(x: u32, y: u32, r: f64) -> bool {
        let (dx, dy) = (x as f64 - 199.5, y as f64 - 199.5);
        dx * dx + dy * dy <= r * r
    }

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * (1.0 + b.abs())
    }

    /// Binary entropy in bits.
    fn h2(p: f64) -> f64 {
        -(p * p.log2() + (1.0 - p) * (1.0 - p).log2())
    }

    /// Float HSV hue in turns (scikit-image's formula), for checking the integer paths.
    fn float_hue(rgb: [u8; 3]) -> f64 {
        let [r, g, b] = rgb.map(|c| c as f64 / 255.0);
        let (max, min) = (r.max(g).max(b), r.min(g).min(b));
        let d = max - min;
        let h = if b == max {
            4.0 + (r - g) / d
        } else if g == max {
            2.0 + (b - r) / d
        } else {
            (g - b) / d
        };
        (h / 6.0).rem_euclid(1.0)
    }

    #[test]
    fn catalogue_names_are_unique_prefixed_and_documented() {
        let cat = catalogue();
        assert_eq!(cat.len(), COUNT);
        let names: HashSet<_> = cat.iter().map(|f| f.name).collect();
        assert_eq!(names.len(), COUNT);
        for f in &cat {
            assert!(f.name.starts_with("colour_"), "{}", f.name);
            assert!(f.doc.contains("§5.3"), "{}", f.name);
            assert_eq!(f.family, Family::Colour);
        }
    }

    #[test]
    fn flat_canvas_has_one_colour_and_no_spread() {
        let p = prepared(|_, _| [200, 60, 60]);
        assert_eq!(p.region.count(), 400 * 400);
        let f = features(&p);
        assert!(f[HUE_STD] < 1e-7, "{}", f[HUE_STD]);
        assert!(close(f[SAT_MEAN], 140.0 / 200.0, 1e-9));
        assert!(f[SAT_STD] < 1e-7 && f[LUM_STD] < 1e-6, "{f:?}");
        let l = (0.299 * 200.0 + 0.587 * 60.0 + 0.114 * 60.0) / 255.0;
        assert!(close(f[LUM_MEAN], l, 1e-6));
        assert_eq!(f[LUM_ENTROPY], 0.0);
        assert_eq!(f[RGB_ENTROPY], 0.0);
        // Hasler–Süsstrunk of a constant image: only the mean term, rg = 140,
        // yb = (200 + 60)/2 − 60 = 70.
        assert!(close(f[HASLER], 0.3 * 140f64.hypot(70.0) / 255.0, 1e-12));
        assert!(close(f[CHANNEL_DIFF], 280.0 / 255.0, 1e-12));
        assert_eq!(f[BLACK], 0.0);
        assert_eq!(f[DOMINANT_FRACTION_4096], 1.0);
        assert_eq!(f[RGB_MODE], 1.0);
        assert_eq!(f[RGB_COUNT], 1.0);
        assert_eq!(f[HUE_MODE], 1.0);
        assert_eq!(f[HUE_COUNT], 1.0);
    }

    #[test]
    fn flat_disk_on_white_is_a_two_colour_mixture() {
        // Ω holds the disk and the white 10 px margin: every statistic is that of a two-colour
        // mixture with disk share q, computed here by hand.
        let c = [30u8, 120, 200];
        let p = prepared(|x, y| if in_disk(x, y, 100.0) { c } else { [255; 3] });
        let n_disk = (0..400 * 400)
            .filter(|i| in_disk(i % 400, i / 400, 100.0))
            .count() as f64;
        let n_omega = p.region.count() as f64;
        let q = n_disk / n_omega;
        assert!(q > 0.5 && q < 0.95, "{q}");
        let f = features(&p);
        let l_disk = (0.299 * 30.0 + 0.587 * 120.0 + 0.114 * 200.0) / 255.0;
        assert!(f[HUE_STD] < 1e-7);
        assert!(close(f[SAT_MEAN], q * 170.0 / 200.0, 1e-9));
        assert!(close(
            f[SAT_STD],
            (q * (1.0 - q)).sqrt() * 170.0 / 200.0,
            1e-9
        ));
        assert!(close(
            f[LUM_STD],
            (q * (1.0 - q)).sqrt() * (1.0 - l_disk),
            1e-6
        ));
        assert!(close(f[LUM_ENTROPY], h2(q), 1e-12));
        assert!(close(f[RGB_ENTROPY], h2(q), 1e-12));
        assert!(close(f[CHANNEL_DIFF], q * 340.0 / 255.0, 1e-12));
        assert!(close(f[DOMINANT_FRACTION_4096], q, 1e-12));
        assert!(close(f[RGB_MODE], q, 1e-12));
        assert_eq!(f[RGB_COUNT], 2.0);
        assert!(close(f[HUE_MODE], q, 1e-12));
        assert_eq!(f[HUE_COUNT], 1.0);
        assert_eq!(f[BLACK], 0.0);
    }

    #[test]
    fn black_and_white_art_has_no_colour() {
        // Black ring, mid-grey fill, white paper: achromatic everywhere.
        let p = prepared(|x, y| {
            if in_disk(x, y, 120.0) && !in_disk(x, y, 110.0) {
                [0; 3]
            } else if in_disk(x, y, 110.0) {
                [128; 3]
            } else {
                [255; 3]
            }
        });
        let f = features(&p);
        for i in [
            HUE_STD,
            SAT_MEAN,
            SAT_STD,
            HASLER,
            CHANNEL_DIFF,
            HUE_MODE,
            HUE_COUNT,
        ] {
            assert_eq!(f[i], 0.0, "feature {i}");
        }
        assert_eq!(f[RGB_COUNT], 3.0);
        assert!(f[BLACK] > 0.0);
    }

    #[test]
    fn half_red_half_blue() {
        let p = prepared(|x, _| if x < 200 { [255, 0, 0] } else { [0, 0, 255] });
        let f = features(&p);
        assert_eq!(f[HUE_COUNT], 2.0);
        assert_eq!(f[HUE_MODE], 0.5);
        assert!(close(f[RGB_ENTROPY], 1.0, 1e-12));
        assert_eq!(f[RGB_COUNT], 2.0);
        assert!(close(f[LUM_ENTROPY], 1.0, 1e-12));
        // Hues 0 and 2/3 turn: resultant length |1 + e^{i·4π/3}| / 2 = 1/2.
        let expected = (-2.0 * 0.5f64.ln()).sqrt() / TAU;
        assert!(close(f[HUE_STD], expected, 1e-9), "{}", f[HUE_STD]);
        // Hasler–Süsstrunk by hand: red (rg, yb) = (1, 1/2), blue = (0, −1), half each:
        // μ = (1/2, −1/4), σ = (1/2, 3/4).
        let hs = (0.25f64 + 0.5625).sqrt() + 0.3 * (0.25f64 + 0.0625).sqrt();
        assert!(close(f[HASLER], hs, 1e-12), "{} vs {hs}", f[HASLER]);
        assert!(close(f[CHANNEL_DIFF], 2.0, 1e-12));
        assert_eq!(f[SAT_MEAN], 1.0);
        assert_eq!(f[SAT_STD], 0.0);
    }

    #[test]
    fn balanced_hues_cap_the_hue_std_at_half_a_turn() {
        // Red, green, blue thirds: resultant length 0 → capped circular std of 1/2 turn.
        let p = prepared(|x, y| match (x + 400 * y) % 3 {
            0 => [255, 0, 0],
            1 => [0, 255, 0],
            _ => [0, 0, 255],
        });
        let f = features(&p);
        assert!(close(f[HUE_STD], 0.5, 1e-9), "{}", f[HUE_STD]);
        assert_eq!(f[HUE_COUNT], 3.0);
    }

    #[test]
    fn black_fraction_of_a_known_image() {
        assert!(is_black([51, 51, 51]) && is_black([0, 51, 10]));
        assert!(!is_black([52, 0, 0]) && !is_black([0, 0, 200]));
        // Left quarter black, a (51, 20, 0) stripe (black: V = 0.2), the rest dark red
        // (52, 0, 0, not black); no white, so Ω is the canvas.
        let p = prepared(|x, _| match x {
            0..100 => [0, 0, 0],
            100..140 => [51, 20, 0],
            _ => [52, 0, 0],
        });
        let f = features(&p);
        assert!(close(f[BLACK], 140.0 / 400.0, 1e-12));
    }

    #[test]
    fn saturation_below_threshold_has_no_hue() {
        // S = 10/110 < 0.1 on the left, exactly 0.1 (10/100) on the right.
        let p = prepared(|x, _| {
            if x < 200 {
                [110, 100, 100]
            } else {
                [100, 90, 90]
            }
        });
        let f = features(&p);
        assert_eq!(f[HUE_MODE], 0.5);
        assert_eq!(f[HUE_COUNT], 1.0);
        assert!(f[SAT_MEAN] > 0.0);
    }

    #[test]
    fn single_pixel_drawing_is_finite() {
        let p = prepared(|x, y| {
            if (x, y) == (0, 399) {
                [3, 200, 90]
            } else {
                [255; 3]
            }
        });
        let f = features(&p);
        assert!(f[SAT_MEAN] > 0.0 && f[SAT_MEAN] < 0.1);
        assert_eq!(f[HUE_COUNT], 1.0);
    }

    #[test]
    fn hue_bins_match_float_hue() {
        // The integer bin must equal ⌊20·h⌋ of the float hue away from bin edges, and the
        // edge hue 0.05 turn (250, 75, 0) must land in bin 1.
        assert_eq!(hue_bin(0, 75, 250), 1);
        assert_eq!(hue_bin(0, -1, 255), HUE_BINS - 1);
        let mut state = 12345u64;
        let mut rnd = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 33) as u8
        };
        for _ in 0..20_000 {
            let px = [rnd(), rnd(), rnd()];
            let (r, g, b) = (px[0] as i32, px[1] as i32, px[2] as i32);
            let (max, min) = (r.max(g).max(b), r.min(g).min(b));
            if max == min {
                continue;
            }
            let (sector, x) = if max == r {
                (0, g - b)
            } else if max == g {
                (1, b - r)
            } else {
                (2, r - g)
            };
            let h = float_hue(px) * HUE_BINS as f64;
            if (h - h.round()).abs() < 1e-9 {
                continue;
            }
            assert_eq!(
                hue_bin(sector, x, (max - min) as u32),
                h.floor() as usize,
                "{px:?}"
            );
        }
    }

    #[test]
    fn hue_std_matches_direct_trigonometry() {
        // A pseudo-random image exercises every hue sector and sign of the table path.
        let p = prepared(|x, y| {
            let v = x.wrapping_mul(2654435761) ^ y.wrapping_mul(40503);
            [(v >> 3) as u8, (v >> 11) as u8, (v >> 19) as u8 & 0x7f]
        });
        let (mut c, mut s, mut n) = (0.0f64, 0.0f64, 0.0f64);
        for (px, &inside) in p.image.pixels().zip(&p.region.data) {
            let [r, g, b] = px.0.map(|v| v as f64);
            let (max, min) = (r.max(g).max(b), r.min(g).min(b));
            if inside && max > 0.0 && (max - min) / max >= HUE_MIN_SATURATION {
                let (sn, cs) = (TAU * float_hue(px.0)).sin_cos();
                c += cs;
                s += sn;
                n += 1.0;
            }
        }
        let expected = (-2.0 * (c.hypot(s) / n).ln()).sqrt() / TAU;
        let f = features(&p);
        assert!(
            close(f[HUE_STD], expected, 1e-9),
            "{} vs {expected}",
            f[HUE_STD]
        );
    }

    #[test]
    fn dominant_bins_use_a_strict_fraction_of_the_maximum() {
        assert_eq!(mode_and_dominant_count(&[100, 5, 6, 0]), (100, 2));
        assert_eq!(mode_and_dominant_count(&[0, 0]), (0, 0));
        assert_eq!(entropy_bits(&[3, 3, 3, 3], 12), 2.0);
        assert_eq!(entropy_bits(&[0, 0], 0), 0.0);
    }

    /// Renderings checked against `tests/data/colour/reference.py` (style, concept).
    const REFERENCE_ICONS: [(&str, &str); 3] = [
        ("fluent-emoji", "fire"),
        ("twemoji", "banana"),
        ("emojione-monotone", "cat-face"),
    ];

    fn data_dir() -> std::path::PathBuf {
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/colour")
    }

    /// The committed renderings must be what our renderer makes of the fixtures today, or the
    /// Python reference values describe stale pictures. `REGENERATE=1` rewrites them (then rerun
    /// reference.py).
    #[test]
    fn reference_renderings_are_current() {
        let fixtures = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/style");
        let regenerate = std::env::var("REGENERATE").as_deref() == Ok("1");
        for (style, concept) in REFERENCE_ICONS {
            let svg = std::fs::read(fixtures.join(style).join(format!("{concept}.svg")))
                .expect("fixture exists");
            let img = crate::render::render_svg(&svg).expect("fixture renders");
            let path = data_dir().join(format!("{style}__{concept}.png"));
            if regenerate {
                img.save(&path).expect("PNG written");
            }
            let stored = image::open(&path).expect("stored PNG").to_rgb8();
            assert!(
                stored == img,
                "{} is stale: rerun with REGENERATE=1 and reference.py",
                path.display()
            );
        }
    }

    #[test]
    fn matches_independent_python_reference() {
        // Values computed by reference.py with scikit-image/scipy/numpy from the committed
        // renderings (provenance in the JSON); no Python needed here.
        let text = std::fs::read_to_string(data_dir().join("reference.json")).expect("JSON");
        let json: serde_json::Value = serde_json::from_str(&text).expect("valid JSON");
        let icons = json["icons"].as_array().expect("icons array");
        assert_eq!(icons.len(), REFERENCE_ICONS.len());
        for icon in icons {
            let file = icon["file"].as_str().expect("file");
            let img = image::open(data_dir().join(file)).expect("PNG").to_rgb8();
            let p = Prepared::new(img).expect("400x400 drawing");
            assert_eq!(
                p.region.count() as u64,
                icon["omega_count"].as_u64().expect("omega_count"),
                "{file}: Ω differs from the reference's own Ω"
            );
            let f = features(&p);
            for (key, index) in [
                ("saturation_mean", SAT_MEAN),
                ("saturation_std", SAT_STD),
                ("luminance_entropy", LUM_ENTROPY),
                ("hasler_colourfulness", HASLER),
                ("hue_std", HUE_STD),
            ] {
                let expected = icon[key].as_f64().expect("number");
                let rel = (f[index] - expected).abs() / expected.abs().max(1e-12);
                assert!(rel < 1e-6, "{file} {key}: {} vs {expected}", f[index]);
            }
        }
    }

    #[test]
    fn integer_std_is_exact() {
        // Values 1, 3 → population std 1.
        assert_eq!(integer_std(2, 4, 10, 1.0), 1.0);
        assert_eq!(integer_std(3, 21, 147, 1.0), 0.0);
    }
}
