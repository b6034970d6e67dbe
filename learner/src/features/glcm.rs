//! The 22 Haralick/GLCM statistics (§5.3 "Texture").
//!
//! Garces et al. 2014, §5.3, describe texture by "Haralick features" of the grey-level
//! co-occurrence matrix (GLCM). We compute the 22 statistics collected in the widely used
//! MATLAB `GLCM_Features` (Uppuluri), which gathers Haralick, Shanmugam and Dinstein, "Textural
//! features for image classification", IEEE TSMC 3(6), 1973; Soh and Tsatsoulis, "Texture
//! analysis of SAR sea ice imagery using gray level co-occurrence matrices", IEEE TGRS 37(2),
//! 1999; and Clausi, "An analysis of co-occurrence texture statistics as a function of grey level
//! quantization", Can. J. Remote Sensing 28(1), 2002 — in that code's order.
//!
//! Notation: `p(i, j)` is the normalised symmetric GLCM with **0-based** levels
//! `i, j ∈ 0..N`; `px`, `py` its marginals with means `μx`, `μy` and standard deviations
//! `σx`, `σy`; `p₊(k) = Σ_{i+j=k} p`, `k ∈ 0..=2N−2`; `p₋(k) = Σ_{|i−j|=k} p`, `k ∈ 0..N`;
//! `H(·) = −Σ q ln q` over `q > 0`.
//!
//! | # | name | definition |
//! |---|------|------------|
//! | 0 | autocorrelation | `Σ i·j·p` |
//! | 1 | contrast | `Σ (i−j)²·p` |
//! | 2 | correlation_matlab | `Σ (i−μx)(j−μy)·p / (σx·σy)` (MATLAB `graycoprops`) |
//! | 3 | correlation_haralick | `(Σ i·j·p − μx·μy) / (σx·σy)` (Haralick f3) |
//! | 4 | cluster_prominence | `Σ (i+j−μx−μy)⁴·p` |
//! | 5 | cluster_shade | `Σ (i+j−μx−μy)³·p` |
//! | 6 | dissimilarity | `Σ abs(i−j)·p` |
//! | 7 | energy | `Σ p²` (angular second moment; MATLAB's "Energy", not its square root) |
//! | 8 | entropy | `H(p)` |
//! | 9 | homogeneity_matlab | `Σ p / (1 + abs(i−j))` (MATLAB `graycoprops`) |
//! | 10 | homogeneity_haralick | `Σ p / (1 + (i−j)²)` (inverse difference moment, f5) |
//! | 11 | max_probability | `max p` |
//! | 12 | sum_of_squares_variance | `Σ (i−μx)²·p` (f4) |
//! | 13 | sum_average | `Σ k·p₊(k)` (f6) |
//! | 14 | sum_variance | `Σ (k − sum_average)²·p₊(k)` (f7) |
//! | 15 | sum_entropy | `H(p₊)` (f8) |
//! | 16 | difference_variance | `Σ (k − μ₋)²·p₋(k)`, `μ₋ = Σ k·p₋(k)` (f10) |
//! | 17 | difference_entropy | `H(p₋)` (f11) |
//! | 18 | imc1 | `(H(p) − HXY1) / max(H(px), H(py))`, `HXY1 = −Σ p·ln(px·py)` (f12) |
//! | 19 | imc2 | `√(1 − exp(−2·(HXY2 − H(p))))`, `HXY2 = H(px ⊗ py)` (f13) |
//! | 20 | inverse_difference_normalised | `Σ p / (1 + abs(i−j)/N)` (Clausi's INN) |
//! | 21 | inverse_difference_moment_normalised | `Σ p / (1 + (i−j)²/N²)` (Clausi's IDN) |
//!
//! Choices made where the paper and the sources are silent or differ:
//! - **Grey levels**: `N = 8`, by uniform quantisation of the 8-bit grey
//!   ([`super::lbp::grey_u8`]): level `= g >> 5` (bins of 32 grey values, MATLAB
//!   `graycomatrix`'s default `NumLevels = 8` over `[0, 255]`).
//! - **Offsets**: distance 1 at 0°, 45°, 90° and 135° (`(dy, dx) = (0,1), (1,1), (1,0), (1,−1)`),
//!   each counted symmetrically (pair `(a, b)` adds to `(a, b)` and `(b, a)`); the 22
//!   statistics are computed per direction and averaged over the four (as mahotas'
//!   `return_mean=True`).
//! - **Region**: a pair counts only when both pixels lie in Ω ([`Prepared::region`]).
//! - **Levels are 0-based**, as in scikit-image and mahotas; MATLAB's 1-based indexing would
//!   shift autocorrelation, sum average and cluster statistics.
//! - **Entropies use the natural logarithm** (as `GLCM_Features`, and as the `exp` in IMC2
//!   requires). mahotas uses `log₂`: its entropies are ours divided by `ln 2`, and its IMC2 is
//!   `√(1 − exp(−2·ΔH/ln 2))`; IMC1 is base-independent.
//! - **Sum variance** uses the sum *average* (the variance of `p₊`), not Haralick's printed sum
//!   entropy (a known typo; mahotas' default; `GLCM_Features` keeps the typo).
//! - **Difference variance** is the variance of the distribution `p₋` (of `abs(i−j)`), as mahotas
//!   with `use_x_minus_y_variance=True`; `GLCM_Features` and mahotas' default instead take the
//!   variance of the `N` numbers `p₋(0..N)`, which depends on `N` and is not a texture variance.
//! - **Sum of squares variance** is centred on `μx` (Haralick's `μ`, equal to mahotas' `vx`).
//! - **Correlation** variants are mathematically equal for a normalised GLCM; both are kept for
//!   the 22-feature layout. When `σx` or `σy` is below 10⁻¹⁵ (a single grey level) both are 1,
//!   as in scikit-image and mahotas.
//! - **IMC1** is 0 when `max(H(px), H(py)) = 0`; **IMC2** clamps the radicand at 0.
//! - **Empty GLCM** (no pair inside Ω in any direction): all 22 values are 0. A direction with no
//!   pairs is left out of the average.
//!
//! The four directed count matrices are fixed-size stack arrays (`MAX_LEVELS²` each), filled in
//! one pass over the image with a sentinel-padded copy of the levels (one allocation per image,
//! none per pixel); `C + Cᵀ` gives the symmetric GLCM.

use super::{Family, FeatureInfo, Prepared};
use crate::mask::Mask;

/// Number of features in this family.
pub const COUNT: usize = 22;

/// Grey levels of the GLCM computed by [`compute`].
pub const LEVELS: usize = 8;

/// The largest number of grey levels [`haralick_from_levels`] accepts.
pub const MAX_LEVELS: usize = 32;

/// The four symmetric offsets `(dy, dx)` at distance 1: 0°, 45°, 90°, 135°.
pub const OFFSETS: [(isize, isize); 4] = [(0, 1), (1, 1), (1, 0), (1, -1)];

const fn feature(name: &'static str, doc: &'static str) -> FeatureInfo {
    FeatureInfo {
        name,
        family: Family::Texture,
        doc,
    }
}

const FEATURES: [FeatureInfo; COUNT] = [
    feature(
        "texture_glcm_autocorrelation",
        "GLCM autocorrelation Σ i·j·p (Soh & Tsatsoulis 1999; §5.3 Texture)",
    ),
    feature(
        "texture_glcm_contrast",
        "GLCM contrast Σ (i−j)²·p (Haralick 1973 f2; §5.3 Texture)",
    ),
    feature(
        "texture_glcm_correlation_matlab",
        "GLCM correlation Σ (i−μx)(j−μy)·p/(σx·σy), MATLAB graycoprops form (§5.3 Texture)",
    ),
    feature(
        "texture_glcm_correlation_haralick",
        "GLCM correlation (Σ i·j·p − μx·μy)/(σx·σy) (Haralick 1973 f3; §5.3 Texture)",
    ),
    feature(
        "texture_glcm_cluster_prominence",
        "GLCM cluster prominence Σ (i+j−μx−μy)⁴·p (Soh & Tsatsoulis 1999; §5.3 Texture)",
    ),
    feature(
        "texture_glcm_cluster_shade",
        "GLCM cluster shade Σ (i+j−μx−μy)³·p (Soh & Tsatsoulis 1999; §5.3 Texture)",
    ),
    feature(
        "texture_glcm_dissimilarity",
        "GLCM dissimilarity Σ |i−j|·p (Soh & Tsatsoulis 1999; §5.3 Texture)",
    ),
    feature(
        "texture_glcm_energy",
        "GLCM energy = angular second moment Σ p² (Haralick 1973 f1; §5.3 Texture)",
    ),
    feature(
        "texture_glcm_entropy",
        "GLCM entropy −Σ p·ln p (Haralick 1973 f9; §5.3 Texture)",
    ),
    feature(
        "texture_glcm_homogeneity_matlab",
        "GLCM homogeneity Σ p/(1+|i−j|), MATLAB graycoprops form (§5.3 Texture)",
    ),
    feature(
        "texture_glcm_homogeneity_haralick",
        "GLCM inverse difference moment Σ p/(1+(i−j)²) (Haralick 1973 f5; §5.3 Texture)",
    ),
    feature(
        "texture_glcm_max_probability",
        "GLCM maximum probability max p (Soh & Tsatsoulis 1999; §5.3 Texture)",
    ),
    feature(
        "texture_glcm_sum_of_squares_variance",
        "GLCM sum of squares: variance Σ (i−μx)²·p (Haralick 1973 f4; §5.3 Texture)",
    ),
    feature(
        "texture_glcm_sum_average",
        "GLCM sum average Σ k·p_{x+y}(k), 0-based levels (Haralick 1973 f6; §5.3 Texture)",
    ),
    feature(
        "texture_glcm_sum_variance",
        "GLCM sum variance Σ (k−sum average)²·p_{x+y}(k) (Haralick 1973 f7; §5.3 Texture)",
    ),
    feature(
        "texture_glcm_sum_entropy",
        "GLCM sum entropy −Σ p_{x+y}·ln p_{x+y} (Haralick 1973 f8; §5.3 Texture)",
    ),
    feature(
        "texture_glcm_difference_variance",
        "GLCM difference variance: variance of |i−j| under p_{x−y} (Haralick 1973 f10; §5.3 Texture)",
    ),
    feature(
        "texture_glcm_difference_entropy",
        "GLCM difference entropy −Σ p_{x−y}·ln p_{x−y} (Haralick 1973 f11; §5.3 Texture)",
    ),
    feature(
        "texture_glcm_imc1",
        "GLCM information measure of correlation 1 (Haralick 1973 f12; §5.3 Texture)",
    ),
    feature(
        "texture_glcm_imc2",
        "GLCM information measure of correlation 2 (Haralick 1973 f13; §5.3 Texture)",
    ),
    feature(
        "texture_glcm_inverse_difference_normalised",
        "GLCM inverse difference normalised Σ p/(1+|i−j|/N) (Clausi 2002 INN; §5.3 Texture)",
    ),
    feature(
        "texture_glcm_inverse_difference_moment_normalised",
        "GLCM inverse difference moment normalised Σ p/(1+(i−j)²/N²) (Clausi 2002 IDN; §5.3 Texture)",
    ),
];

/// Names and docs, in output order.
pub fn catalogue() -> Vec<FeatureInfo> {
    FEATURES.to_vec()
}

/// Writes this family's features of `p` into `out` (length [`COUNT`]).
pub fn compute(p: &Prepared, out: &mut [f64]) {
    out.fill(0.0);
    if out.len() != COUNT {
        return;
    }
    let levels: Vec<u8> = p.grey8.iter().map(|&g| quantise(g)).collect();
    if let Some(f) = haralick_from_levels(
        &levels,
        p.grey.width,
        p.grey.height,
        LEVELS,
        Some(&p.region),
    ) {
        out.copy_from_slice(&f);
    }
}

/// The GLCM level `0..8` of an 8-bit grey value (`g >> 5`).
#[inline]
pub fn quantise(grey: u8) -> u8 {
    grey >> 5
}

/// The 22 statistics (module order) averaged over the four [`OFFSETS`], from a row-major image
/// of grey levels in `0..n_levels`. Pixels with a level `≥ n_levels` are skipped; with `mask`,
/// a pair counts only when both pixels are set. `None` when `n_levels` is not in
/// `1..=MAX_LEVELS`, `levels.len() != width * height`, or the mask has another size.
/// All zeros when no pair is counted.
pub fn haralick_from_levels(
    levels: &[u8],
    width: usize,
    height: usize,
    n_levels: usize,
    mask: Option<&Mask>,
) -> Option<[f64; COUNT]> {
    if !(1..=MAX_LEVELS).contains(&n_levels) || width.checked_mul(height) != Some(levels.len()) {
        return None;
    }
    if mask.is_some_and(|m| m.width != width || m.height != height || m.data.len() != levels.len())
    {
        return None;
    }
    if width == 0 || height == 0 {
        return Some([0.0; COUNT]);
    }
    let counts = co_occurrences(levels, width, height, n_levels, mask);
    let mut sum = [0.0; COUNT];
    let mut directions = 0u32;
    for directed in &counts {
        let pairs: u64 = directed.iter().map(|&c| u64::from(c)).sum();
        if pairs == 0 {
            continue;
        }
        let f = statistics(directed, n_levels, 2.0 * pairs as f64);
        for (s, v) in sum.iter_mut().zip(f) {
            *s += v;
        }
        directions += 1;
    }
    if directions > 0 {
        for s in &mut sum {
            *s /= f64::from(directions);
        }
    }
    Some(sum)
}

crate::simd::vectorised_fn! {
/// The directed pair counts per offset of [`haralick_from_levels`] (arguments checked there):
/// `counts[d][a * MAX_LEVELS + b]` pairs with level `a` at a pixel and `b` at its neighbour.
fn co_occurrences<'a>(
    levels: &'a [u8],
    width: usize,
    height: usize,
    n_levels: usize,
    mask: Option<&'a Mask>,
) -> [[u32; MAX_LEVELS * MAX_LEVELS]; 4] {
    // One pass over a copy padded with a sentinel level (≥ any `n_levels`) on the left, right
    // and bottom, so that every pixel has its four forward neighbours; pixels outside the
    // mask or out of range become the sentinel and never pair.
    const SENTINEL: u8 = u8::MAX;
    let stride = width + 2;
    let mut cells = vec![SENTINEL; stride * (height + 1)];
    for y in 0..height {
        let row = y * width..(y + 1) * width;
        let dst = &mut cells[y * stride + 1..y * stride + 1 + width];
        let keep = |level: u8, inside: bool| {
            if inside && usize::from(level) < n_levels {
                level
            } else {
                SENTINEL
            }
        };
        match mask {
            Some(m) => {
                for ((d, &level), &inside) in dst.iter_mut().zip(&levels[row.clone()]).zip(&m.data[row]) {
                    *d = keep(level, inside);
                }
            }
            None => {
                for (d, &level) in dst.iter_mut().zip(&levels[row]) {
                    *d = keep(level, true);
                }
            }
        }
    }
    let mut counts = [[0u32; MAX_LEVELS * MAX_LEVELS]; 4];
    let steps = OFFSETS.map(|(dy, dx)| (dy * stride as isize + dx) as usize);
    debug_assert_eq!(OFFSETS, [(0, 1), (1, 1), (1, 0), (1, -1)], "the flat-block test below");
    for y in 0..height {
        let row_start = y * stride + 1;
        let row_end = row_start + width;
        let mut block = row_start;
        while block < row_end {
            let end = (block + FLAT_BLOCK).min(row_end);
            // A block of one level whose right, lower-left, lower and lower-right neighbours
            // all have that level too (a flat area, most of clip art) adds one pair per pixel
            // and direction to the diagonal: counted at once instead of pixel by pixel.
            let level = cells[block];
            let flat = usize::from(level) < n_levels
                && all_equal(&cells[block..=end], level)
                && all_equal(&cells[block + stride - 1..=end + stride], level);
            if flat {
                let a = usize::from(level);
                for directed in &mut counts {
                    directed[a * MAX_LEVELS + a] += (end - block) as u32;
                }
                block = end;
                continue;
            }
            for i in block..end {
                let a = usize::from(cells[i]);
                if a >= n_levels {
                    continue;
                }
                for (d, &step) in steps.iter().enumerate() {
                    let b = usize::from(cells[i.wrapping_add(step)]);
                    if b < n_levels {
                        counts[d][a * MAX_LEVELS + b] += 1;
                    }
                }
            }
            block = end;
        }
    }
    counts
}
}

/// Pixels per block of the flat-area shortcut in [`haralick_from_levels`].
const FLAT_BLOCK: usize = 16;

/// Whether every byte of `cells` is `level` (a fold rather than `all`, so it vectorises).
#[inline(always)]
fn all_equal(cells: &[u8], level: u8) -> bool {
    cells.iter().fold(true, |same, &c| same & (c == level))
}

/// `−q·ln q`, 0 for `q ≤ 0`.
#[inline]
fn plogp(q: f64) -> f64 {
    if q > 0.0 { -q * q.ln() } else { 0.0 }
}

/// The 22 statistics of the symmetric GLCM `C + Cᵀ` of a directed count matrix `C`
/// (`C[a * MAX_LEVELS + b]`), whose total is `total` (> 0).
fn statistics(counts: &[u32; MAX_LEVELS * MAX_LEVELS], n: usize, total: f64) -> [f64; COUNT] {
    let mut p = [[0.0f64; MAX_LEVELS]; MAX_LEVELS];
    let mut px = [0.0f64; MAX_LEVELS];
    let mut py = [0.0f64; MAX_LEVELS];
    let mut p_sum = [0.0f64; 2 * MAX_LEVELS];
    let mut p_diff = [0.0f64; MAX_LEVELS];
    for i in 0..n {
        for j in 0..n {
            let v = f64::from(counts[i * MAX_LEVELS + j] + counts[j * MAX_LEVELS + i]) / total;
            p[i][j] = v;
            px[i] += v;
            py[j] += v;
            p_sum[i + j] += v;
            p_diff[i.abs_diff(j)] += v;
        }
    }
    let (mut mu_x, mut mu_y) = (0.0, 0.0);
    for k in 0..n {
        mu_x += k as f64 * px[k];
        mu_y += k as f64 * py[k];
    }
    let (mut var_x, mut var_y) = (0.0, 0.0);
    for k in 0..n {
        var_x += (k as f64 - mu_x).powi(2) * px[k];
        var_y += (k as f64 - mu_y).powi(2) * py[k];
    }
    let (sigma_x, sigma_y) = (var_x.sqrt(), var_y.sqrt());
    let degenerate = sigma_x < 1e-15 || sigma_y < 1e-15;
    let nf = n as f64;

    let mut autocorrelation = 0.0;
    let mut contrast = 0.0;
    let mut cov = 0.0;
    let mut prominence = 0.0;
    let mut shade = 0.0;
    let mut dissimilarity = 0.0;
    let mut energy = 0.0;
    let mut entropy = 0.0;
    let mut homogeneity_abs = 0.0;
    let mut homogeneity_sq = 0.0;
    let mut max_probability = 0.0f64;
    let mut inn = 0.0;
    let mut idn = 0.0;
    let mut hxy1 = 0.0;
    let mut hxy2 = 0.0;
    for i in 0..n {
        for j in 0..n {
            let v = p[i][j];
            let (fi, fj) = (i as f64, j as f64);
            let d = fi - fj;
            let ad = d.abs();
            let c = fi + fj - mu_x - mu_y;
            autocorrelation += fi * fj * v;
            contrast += d * d * v;
            cov += (fi - mu_x) * (fj - mu_y) * v;
            prominence += c.powi(4) * v;
            shade += c.powi(3) * v;
            dissimilarity += ad * v;
            energy += v * v;
            entropy += plogp(v);
            homogeneity_abs += v / (1.0 + ad);
            homogeneity_sq += v / (1.0 + d * d);
            max_probability = max_probability.max(v);
            inn += v / (1.0 + ad / nf);
            idn += v / (1.0 + d * d / (nf * nf));
            let q = px[i] * py[j];
            if q > 0.0 {
                hxy1 -= v * q.ln();
                hxy2 += plogp(q);
            }
        }
    }
    let (correlation_matlab, correlation_haralick) = if degenerate {
        (1.0, 1.0)
    } else {
        (
            cov / (sigma_x * sigma_y),
            (autocorrelation - mu_x * mu_y) / (sigma_x * sigma_y),
        )
    };

    let mut sum_average = 0.0;
    let mut sum_entropy = 0.0;
    for (k, &q) in p_sum.iter().enumerate().take(2 * n - 1) {
        sum_average += k as f64 * q;
        sum_entropy += plogp(q);
    }
    let mut sum_variance = 0.0;
    for (k, &q) in p_sum.iter().enumerate().take(2 * n - 1) {
        sum_variance += (k as f64 - sum_average).powi(2) * q;
    }
    let mut diff_mean = 0.0;
    let mut difference_entropy = 0.0;
    for (k, &q) in p_diff.iter().enumerate().take(n) {
        diff_mean += k as f64 * q;
        difference_entropy += plogp(q);
    }
    let mut difference_variance = 0.0;
    for (k, &q) in p_diff.iter().enumerate().take(n) {
        difference_variance += (k as f64 - diff_mean).powi(2) * q;
    }
    let (mut hx, mut hy) = (0.0, 0.0);
    for k in 0..n {
        hx += plogp(px[k]);
        hy += plogp(py[k]);
    }
    let h_max = hx.max(hy);
    let imc1 = if h_max > 0.0 {
        (entropy - hxy1) / h_max
    } else {
        0.0
    };
    let imc2 = (1.0 - (-2.0 * (hxy2 - entropy)).exp()).max(0.0).sqrt();

    [
        autocorrelation,
        contrast,
        correlation_matlab,
        correlation_haralick,
        prominence,
        shade,
        dissimilarity,
        energy,
        entropy,
        homogeneity_abs,
        homogeneity_sq,
        max_probability,
        var_x,
        sum_average,
        sum_variance,
        sum_entropy,
        difference_variance,
        difference_entropy,
        imc1,
        imc2,
        inn,
        idn,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    const CONTRAST: usize = 1;
    const CORRELATION_MATLAB: usize = 2;
    const CORRELATION_HARALICK: usize = 3;
    const ENERGY: usize = 7;
    const ENTROPY: usize = 8;

    #[test]
    fn catalogue_is_complete_and_ordered() {
        let cat = catalogue();
        assert_eq!(cat.len(), COUNT);
        assert_eq!(cat[0].name, "texture_glcm_autocorrelation");
        assert_eq!(cat[CONTRAST].name, "texture_glcm_contrast");
        assert_eq!(cat[ENERGY].name, "texture_glcm_energy");
        assert_eq!(cat[ENTROPY].name, "texture_glcm_entropy");
        assert_eq!(
            cat[21].name,
            "texture_glcm_inverse_difference_moment_normalised"
        );
    }

    #[test]
    fn constant_image() {
        for level in 0..8u8 {
            let f = haralick_from_levels(&[level; 12 * 10], 12, 10, 8, None).unwrap();
            assert_eq!(f[CONTRAST], 0.0);
            assert_eq!(f[ENERGY], 1.0);
            assert_eq!(f[ENTROPY], 0.0);
            assert_eq!(f[CORRELATION_MATLAB], 1.0);
            assert_eq!(f[CORRELATION_HARALICK], 1.0);
            assert_eq!(f[11], 1.0, "max probability");
            assert_eq!(f[18], 0.0, "imc1");
            assert_eq!(f[19], 0.0, "imc2");
            let l = f64::from(level);
            assert_eq!(f[0], l * l, "autocorrelation");
            assert_eq!(f[13], 2.0 * l, "sum average");
            assert!(f.iter().all(|v| v.is_finite()));
        }
    }

    #[test]
    fn checkerboard_contrast() {
        // Levels 0 and 7 alternating: horizontal and vertical pairs always differ by 7
        // (contrast 49, dissimilarity 7), diagonal pairs never (contrast 0). Average: 24.5.
        let (w, h) = (17, 17);
        let levels: Vec<u8> = (0..w * h)
            .map(|i| if (i % w + i / w) % 2 == 0 { 0 } else { 7 })
            .collect();
        let f = haralick_from_levels(&levels, w, h, 8, None).unwrap();
        assert!((f[CONTRAST] - 24.5).abs() < 1e-12, "{}", f[CONTRAST]);
        assert!((f[6] - 3.5).abs() < 1e-12, "dissimilarity {}", f[6]);
        // Axis directions: anti-correlated (−1); diagonals: correlated (+1).
        assert!(f[CORRELATION_MATLAB].abs() < 1e-12);
        // Each direction: two equally likely cells → energy 1/2, entropy ln 2.
        assert!((f[ENERGY] - 0.5).abs() < 1e-12);
        assert!((f[ENTROPY] - std::f64::consts::LN_2).abs() < 1e-12);
    }

    #[test]
    fn mask_restricts_pairs_and_empty_gives_zeros() {
        let (w, h) = (10, 10);
        let levels: Vec<u8> = (0..w * h).map(|i| (i % 8) as u8).collect();
        // A mask holding a single pixel: no pair → zeros.
        let mut mask = Mask::filled(w, h, false);
        mask.data[55] = true;
        let f = haralick_from_levels(&levels, w, h, 8, Some(&mask)).unwrap();
        assert!(f.iter().all(|&v| v == 0.0));
        // A mask over a constant block makes the texture constant.
        let levels: Vec<u8> = (0..w * h)
            .map(|i| if i % w < 5 { 3 } else { (i % 7) as u8 })
            .collect();
        let mask = Mask {
            width: w,
            height: h,
            data: (0..w * h).map(|i| i % w < 5).collect(),
        };
        let f = haralick_from_levels(&levels, w, h, 8, Some(&mask)).unwrap();
        assert_eq!(f[CONTRAST], 0.0);
        assert_eq!(f[ENERGY], 1.0);
    }

    #[test]
    fn invalid_inputs_are_refused_not_panics() {
        assert!(haralick_from_levels(&[0; 10], 3, 3, 8, None).is_none());
        assert!(haralick_from_levels(&[0; 9], 3, 3, 0, None).is_none());
        assert!(haralick_from_levels(&[0; 9], 3, 3, MAX_LEVELS + 1, None).is_none());
        let m = Mask::filled(2, 2, true);
        assert!(haralick_from_levels(&[0; 9], 3, 3, 8, Some(&m)).is_none());
        // Out-of-range levels are skipped; tiny and empty images give zeros.
        let f = haralick_from_levels(&[200; 9], 3, 3, 8, None).unwrap();
        assert!(f.iter().all(|&v| v == 0.0));
        let f = haralick_from_levels(&[], 0, 0, 8, None).unwrap();
        assert!(f.iter().all(|&v| v == 0.0));
        let f = haralick_from_levels(&[1], 1, 1, 8, None).unwrap();
        assert!(f.iter().all(|&v| v == 0.0));
        compute_on_blank_region_is_finite();
    }

    fn compute_on_blank_region_is_finite() {
        let mut image = image::RgbImage::from_pixel(400, 400, image::Rgb([255; 3]));
        image.put_pixel(200, 200, image::Rgb([0; 3]));
        let mut p = Prepared::new(image).unwrap();
        let mut out = [f64::NAN; COUNT];
        compute(&p, &mut out);
        assert!(out.iter().all(|v| v.is_finite()));
        p.region = Mask::filled(400, 400, false);
        compute(&p, &mut out);
        assert!(out.iter().all(|&v| v == 0.0));
        compute(&p, &mut [0.0; 2]);
    }

    fn data_dir() -> PathBuf {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/texture")
    }

    /// Our index of a feature named in `reference.json`.
    fn index_of(name: &str) -> usize {
        catalogue()
            .iter()
            .position(|f| f.name == format!("texture_glcm_{name}"))
            .unwrap_or_else(|| panic!("unknown feature {name}"))
    }

    #[test]
    fn features_match_scikit_image_and_mahotas() {
        let reference: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(data_dir().join("reference.json")).unwrap(),
        )
        .unwrap();
        let tolerance = reference["glcm_relative_tolerance"].as_f64().unwrap();
        let mut compared = 0;
        let (mut max_abs, mut max_rel) = (0.0f64, 0.0f64);
        for entry in reference["images"].as_array().unwrap() {
            let img = image::open(data_dir().join(entry["grey_png"].as_str().unwrap()))
                .unwrap()
                .into_luma8();
            let (w, h) = (img.width() as usize, img.height() as usize);
            let levels: Vec<u8> = img.as_raw().iter().map(|&g| quantise(g)).collect();
            let ours = haralick_from_levels(&levels, w, h, LEVELS, None).unwrap();
            for library in ["skimage", "mahotas"] {
                let values = entry["glcm"][library].as_object().unwrap();
                for (name, expected) in values {
                    let expected = expected.as_f64().unwrap();
                    let got = ours[index_of(name)];
                    let rel = (got - expected).abs() / expected.abs().max(1e-300);
                    max_abs = max_abs.max((got - expected).abs());
                    max_rel = max_rel.max(rel);
                    assert!(
                        rel <= tolerance || (got - expected).abs() <= 1e-12,
                        "{} {library} {name}: ours {got}, reference {expected} (rel {rel:e})",
                        entry["name"]
                    );
                    compared += 1;
                }
            }
        }
        assert!(compared >= 3 * 15, "only {compared} values compared");
        eprintln!("{compared} GLCM values compared: max abs diff {max_abs:e}, max rel {max_rel:e}");
    }
}
