//! Step 2 of the intrinsic-video method (thesis §3.4): the first frame's reflectance is cut
//! into clusters of one material by Felzenszwalb–Huttenlocher graph segmentation (σ = 0.8,
//! K = 50, min = 256), and segments of nearly the same mean reflectance are merged.
//!
//! [`felzenszwalb`] implements "Efficient Graph-Based Image Segmentation" (Felzenszwalb &
//! Huttenlocher, IJCV 59(2), 2004) on the 8-connected pixel grid:
//! 1. smooth each channel with a Gaussian of standard deviation σ;
//! 2. weight the edge between neighbours p, q by the Euclidean distance of their smoothed
//!    colours, `w(p, q) = ‖I(p) − I(q)‖₂`;
//! 3. walk the edges by increasing weight (Algorithm 1) and join the components C₁ ∋ p,
//!    C₂ ∋ q when `w < MInt(C₁, C₂) = min(Int(C₁) + τ(C₁), Int(C₂) + τ(C₂))` (eq. 4), where
//!    `Int(C)` is the largest weight of C's minimum spanning tree (eq. 1, the weight of the
//!    edge that last joined it, since edges come in order) and `τ(C) = K/|C|` (eq. 5);
//! 4. walk the edges again in the same order and join any two components of which one is
//!    smaller than `min_size` pixels (§4.1, the paper's post-processing).
//!
//! [`merge_by_mean`] then joins adjacent segments whose mean colours are closer than a
//! threshold (default 0.1, our choice: see [`MeanMergeParams::threshold`]), closest pair first,
//! into reflectance clusters.
//!
//! Conventions follow `skimage.segmentation.felzenszwalb` (scikit-image ≥ 0.14), so that the
//! two can be compared (`scripts/reference/felzenszwalb_skimage.py`, checked by
//! `tests::matches_scikit_image_on_photographs`):
//! - one segmentation on the colour distance, as in the authors' published C++ code and in
//!   scikit-image. §5 of the paper instead segments each colour plane separately and
//!   intersects the three results, which gives many more, smaller segments;
//! - `K` is in 8-bit units: samples are taken in [0, 1] and the threshold is `K/255 / |C|`,
//!   exactly scikit-image's `scale / 255` on a float image and the paper's code on 0–255
//!   values, so K = 50 means what it means in the thesis. The image is segmented as given: pass
//!   sRGB-encoded values to reproduce tools that read 8-bit files, linear values (e.g. a
//!   Retinex reflectance) otherwise;
//! - the Gaussian is SciPy's (`mode='reflect'`, truncated at 4σ), not the paper code's
//!   clamped kernel of length ⌈4σ⌉ + 1;
//! - joins need `w < MInt` strictly, as in scikit-image (the paper writes `≤`; the two differ
//!   only on exact ties), and ties between equal weights are broken by the order in which
//!   scikit-image lists its edges (right, down, down-right, up-right neighbours), with a stable
//!   sort where NumPy's default `argsort` is not stable;
//! - labels are numbered by first appearance in row-major order, as scikit-image's are.
//!
//! On the three fixture photographs the label maps agree with scikit-image's exactly
//! (adjusted Rand index 1.0, equal counts) at the setting and two others.

mod merge;
mod smooth;
#[cfg(test)]
mod tests;

pub use merge::{MeanMergeParams, merge_by_mean};

use rayon::slice::ParallelSliceMut;

use crate::decomposition::Labels;
use crate::error::{Error, Result};
use crate::image::Image;

/// Parameters of [`felzenszwalb`]; `Default` holds the thesis' values (§3.4).
#[derive(Clone, Debug, PartialEq)]
pub struct FelzenszwalbParams {
    /// `σ`: standard deviation, in pixels, of the Gaussian that smooths the image before the
    /// edge weights are taken (paper §4.1; scikit-image `sigma`). 0 disables smoothing.
    /// Thesis default 0.8.
    pub sigma: f64,
    /// `K` (scikit-image `scale`): the constant of the threshold function `τ(C) = K/|C|`
    /// (eq. 5), in 8-bit units (see the module docs). Larger K prefers larger components.
    /// Thesis default 50.
    pub k: f64,
    /// Smallest component kept, in pixels: smaller ones are joined to a neighbour in the
    /// post-processing pass (§4.1). Thesis default 256.
    pub min_size: usize,
}

impl Default for FelzenszwalbParams {
    fn default() -> Self {
        Self {
            sigma: 0.8,
            k: 50.0,
            min_size: 256,
        }
    }
}

impl FelzenszwalbParams {
    /// Errors on a negative or non-finite σ or K.
    pub fn validate(&self) -> Result<()> {
        if !(self.sigma.is_finite() && self.sigma >= 0.0) {
            return Err(Error::param("sigma", self.sigma, "must be finite and >= 0"));
        }
        if !(self.k.is_finite() && self.k >= 0.0) {
            return Err(Error::param("k", self.k, "must be finite and >= 0"));
        }
        Ok(())
    }
}

/// Disjoint sets over pixels with union by size and path halving; each root also keeps its
/// component's size and `Int(C)`.
struct Forest {
    parent: Vec<u32>,
    size: Vec<u32>,
    int: Vec<f64>,
}

impl Forest {
    fn new(n: usize) -> Self {
        Self {
            parent: (0..n as u32).collect(),
            size: vec![1; n],
            int: vec![0.0; n],
        }
    }

    fn find(&mut self, mut i: u32) -> u32 {
        while self.parent[i as usize] != i {
            let g = self.parent[self.parent[i as usize] as usize];
            self.parent[i as usize] = g;
            i = g;
        }
        i
    }

    /// Joins two roots; the new root's `Int` is `w`.
    fn join(&mut self, a: u32, b: u32, w: f64) {
        let (big, small) = if self.size[a as usize] >= self.size[b as usize] {
            (a, b)
        } else {
            (b, a)
        };
        self.parent[small as usize] = big;
        self.size[big as usize] += self.size[small as usize];
        self.int[big as usize] = w;
    }
}

/// The 8-connected grid graph: every pixel's right, down, down-right and up-right neighbour,
/// listed in scikit-image's order (all right edges row-major, then all down edges, …). An edge
/// is stored as its position in that list, from which [`Grid::ends`] recovers the pixels: 16
/// bytes an edge with the weight, 31 MB at 800×600.
struct Grid {
    w: usize,
    h: usize,
}

impl Grid {
    /// Number of edges in each of the four blocks.
    fn blocks(&self) -> [usize; 4] {
        let (w, h) = (self.w, self.h);
        let d = (w - 1) * h.saturating_sub(1);
        [(w - 1) * h, w * (h - 1), d, d]
    }

    /// The two pixels of edge `i`.
    fn ends(&self, i: u32) -> (u32, u32) {
        let w = self.w;
        let [r, d, dr, _] = self.blocks();
        let i = i as usize;
        let (p, q) = if i < r {
            let (y, x) = (i / (w - 1), i % (w - 1) + 1);
            (y * w + x, y * w + x - 1)
        } else if i < r + d {
            let j = i - r;
            (j + w, j)
        } else if i < r + d + dr {
            let j = i - r - d;
            let (y, x) = (j / (w - 1) + 1, j % (w - 1) + 1);
            (y * w + x, (y - 1) * w + x - 1)
        } else {
            let j = i - r - d - dr;
            let (y, x) = (j / (w - 1), j % (w - 1) + 1);
            (y * w + x, (y + 1) * w + x - 1)
        };
        (p as u32, q as u32)
    }

    /// Every edge as (weight, position in the list): the Euclidean distance of the colours.
    fn weighted(&self, img: &[f64], c: usize) -> Vec<(f64, u32)> {
        let n: usize = self.blocks().iter().sum();
        (0..n as u32)
            .map(|i| {
                let (p, q) = self.ends(i);
                let (a, b) = (&img[p as usize * c..][..c], &img[q as usize * c..][..c]);
                let d2: f64 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
                (d2.sqrt(), i)
            })
            .collect()
    }
}

/// Segments `img` (any number of channels, samples nominally in [0, 1]) into connected
/// components; `Labels::count` components labelled `0..count` by first appearance in
/// row-major order.
///
/// Every component has at least `min_size` pixels unless the whole image is smaller. The
/// result does not depend on the number of threads.
pub fn felzenszwalb(img: &Image, params: &FelzenszwalbParams) -> Result<Labels> {
    params.validate()?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    if img.is_empty() {
        return Err(Error::EmptyImage {
            width: img.width(),
            height: img.height(),
        });
    }
    // Edges are numbered in u32: about four per pixel.
    if 4 * w * h > u32::MAX as usize {
        return Err(Error::TooLarge {
            width: img.width(),
            height: img.height(),
            limit: u32::MAX as u64 / 4,
        });
    }
    let c = img.channels();
    let mut data: Vec<f64> = img.data().iter().map(|&v| v as f64).collect();
    if let Some(i) = data.iter().position(|v| !v.is_finite()) {
        return Err(Error::NonFinite {
            x: ((i / c) % w) as u32,
            y: ((i / c) / w) as u32,
        });
    }
    smooth::gaussian(&mut data, w, h, c, params.sigma);

    // Sorting by (weight, position in the list) is a stable sort: ties keep skimage's order.
    let grid = Grid { w, h };
    let mut order = grid.weighted(&data, c);
    drop(data);
    order.par_sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));

    let k = params.k / 255.0;
    let mut forest = Forest::new(w * h);
    for &(wt, i) in &order {
        let (p, q) = grid.ends(i);
        let (a, b) = (forest.find(p), forest.find(q));
        if a == b {
            continue;
        }
        // eq. 4–5: MInt(C₁, C₂) = min(Int(C₁) + K/|C₁|, Int(C₂) + K/|C₂|).
        let m_int = (forest.int[a as usize] + k / forest.size[a as usize] as f64)
            .min(forest.int[b as usize] + k / forest.size[b as usize] as f64);
        if wt < m_int {
            forest.join(a, b, wt);
        }
    }
    let min = params.min_size as u64;
    for &(_, i) in &order {
        let (p, q) = grid.ends(i);
        let (a, b) = (forest.find(p), forest.find(q));
        if a != b
            && ((forest.size[a as usize] as u64) < min || (forest.size[b as usize] as u64) < min)
        {
            let keep = forest.int[a as usize].max(forest.int[b as usize]);
            forest.join(a, b, keep);
        }
    }
    Ok(relabel(w, h, |i| forest.find(i as u32)))
}

/// Step 2 of the method (§3.4) in one call: [`felzenszwalb`] on `reflectance` (the first
/// frame's, linear RGB), then [`merge_by_mean`] of the segments by their mean reflectance.
pub fn reflectance_clusters(
    reflectance: &Image,
    segmentation: &FelzenszwalbParams,
    merge: &MeanMergeParams,
) -> Result<Labels> {
    merge.validate()?;
    let segments = felzenszwalb(reflectance, segmentation)?;
    merge_by_mean(&segments, reflectance, merge)
}

/// Numbers the classes of `class(i)` by first appearance in row-major order.
pub(super) fn relabel(w: usize, h: usize, mut class: impl FnMut(usize) -> u32) -> Labels {
    let n = w * h;
    let mut map = std::collections::HashMap::new();
    let mut data = Vec::with_capacity(n);
    for i in 0..n {
        let r = class(i);
        if r == Labels::NONE {
            data.push(Labels::NONE);
            continue;
        }
        let next = map.len() as u32;
        data.push(*map.entry(r).or_insert(next));
    }
    Labels {
        width: w as u32,
        height: h as u32,
        data,
        count: map.len(),
    }
}

/// The adjusted Rand index (Hubert & Arabie 1985) of two labellings of the same pixels: 1 for
/// identical partitions (whatever the label numbers), about 0 for independent ones. Pixels
/// labelled [`Labels::NONE`] in either map are left out. Used to compare segmentations with a
/// reference; it equals scikit-learn's `adjusted_rand_score`.
pub fn adjusted_rand_index(a: &Labels, b: &Labels) -> Result<f64> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(Error::ShapeMismatch {
            expected: (a.width, a.height),
            got: (b.width, b.height),
        });
    }
    let mut joint = std::collections::HashMap::<(u32, u32), u64>::new();
    let (mut ra, mut rb) = (
        std::collections::HashMap::<u32, u64>::new(),
        std::collections::HashMap::<u32, u64>::new(),
    );
    let mut n = 0u64;
    for (&x, &y) in a.data.iter().zip(&b.data) {
        if x == Labels::NONE || y == Labels::NONE {
            continue;
        }
        *joint.entry((x, y)).or_default() += 1;
        *ra.entry(x).or_default() += 1;
        *rb.entry(y).or_default() += 1;
        n += 1;
    }
    let pairs = |m: u64| (m as f64) * (m as f64 - 1.0) / 2.0;
    let index: f64 = joint.values().map(|&m| pairs(m)).sum();
    let sa: f64 = ra.values().map(|&m| pairs(m)).sum();
    let sb: f64 = rb.values().map(|&m| pairs(m)).sum();
    let expected = sa * sb / pairs(n).max(1.0);
    let max = (sa + sb) / 2.0;
    if max == expected {
        // Both partitions trivial (one class each, or all singletons): identical.
        return Ok(1.0);
    }
    Ok((index - expected) / (max - expected))
}
