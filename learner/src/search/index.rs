//! The style index: the learned distance of §5.5 (eq. 5.5) as a plain Euclidean one, and the
//! exact nearest-neighbour scan that orders search results by style (§5.7.3).
//!
//! Eq. 5.5 is `d(x, y) = sqrt(Σ_k w_k (x̂_k − ŷ_k)²)` on standardised features
//! `x̂ = (x − mean) / scale`. Storing every item as `z = √w ⊙ x̂` makes it `‖z_x − z_y‖₂`, and
//! the dimensions with `w_k = 0` (most of them: the metric is L1-sparse) drop out entirely. The
//! kept dimensions are stored as `f32` rows, ordered by decreasing weight and padded with zeros
//! to a multiple of [`LANES`] so the scan is one vectorised loop per row.
//!
//! The scan is exact (recall 1.0): every candidate's distance is computed and the `k` smallest
//! are kept in a bounded heap. Equal distances are ordered by item order, so the result does not
//! depend on how the rows are split across threads.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::metric::Model;
use crate::metric::model::fit_scaling;
use crate::table::FeatureTable;
use crate::{Error, Result};

/// Row padding: the scan's inner loop works on this many `f32` lanes at a time (two AVX2
/// registers, so two independent accumulator chains).
pub const LANES: usize = 16;

/// Rows per parallel task in a full scan.
const BLOCK: usize = 4096;

/// Where the weights and the standardisation come from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Weighting {
    /// Feature names, in the table's column order.
    pub feature_names: Vec<String>,
    /// Per-feature mean of the standardisation.
    pub mean: Vec<f64>,
    /// Per-feature scale of the standardisation.
    pub scale: Vec<f64>,
    /// The weights `w` of eq. 5.5.
    pub weights: Vec<f64>,
    /// True when there was no model: `w = 1` on features standardised over the library.
    pub uniform: bool,
}

impl Weighting {
    /// The model's standardisation and weights, after checking that `table` has exactly the
    /// model's feature columns.
    pub fn from_model(model: &Model, table: &FeatureTable) -> Result<Self> {
        model.check_columns(table.names())?;
        Ok(Self {
            feature_names: model.feature_names.clone(),
            mean: model.mean.clone(),
            scale: model.scale.clone(),
            weights: model.weights.clone(),
            uniform: false,
        })
    }

    /// No model: every feature weighs 1 after standardising with the library's own mean and
    /// standard deviation (the "uniform" baseline of §5.6).
    pub fn uniform(table: &FeatureTable) -> Self {
        let (mean, scale) = fit_scaling(table, &[]);
        Self {
            feature_names: table.names().to_vec(),
            mean,
            scale,
            weights: vec![1.0; table.dim()],
            uniform: true,
        }
    }
}

/// Items as rows of `√w ⊙ x̂` over the dimensions with `w > 0`, in `f32`.
#[derive(Debug, Clone, PartialEq)]
pub struct StyleMatrix {
    /// Original column of each stored dimension (by decreasing weight, then column).
    dims: Vec<usize>,
    /// Mean, scale and `√w` of each stored dimension.
    mean: Vec<f64>,
    scale: Vec<f64>,
    sqrt_w: Vec<f64>,
    /// Number of features of a raw vector.
    feature_count: usize,
    /// Floats per row (`dims.len()` rounded up to [`LANES`]; at least `LANES`).
    stride: usize,
    /// Row-major, `len × stride`.
    data: Vec<f32>,
}

impl StyleMatrix {
    /// Projects every row of `table`. Fails when the weighting does not fit the table or has no
    /// positive weight.
    pub fn build(table: &FeatureTable, weighting: &Weighting) -> Result<Self> {
        let p = table.dim();
        if weighting.feature_names.as_slice() != table.names()
            || [
                weighting.mean.len(),
                weighting.scale.len(),
                weighting.weights.len(),
            ] != [p, p, p]
        {
            return Err(Error::FeatureMismatch {
                message: format!(
                    "the weighting has {} features, the table {p} (or other names)",
                    weighting.weights.len()
                ),
            });
        }
        if table.is_empty() {
            return Err(Error::EmptyLibrary);
        }
        let mut dims: Vec<usize> = (0..p).filter(|&k| weighting.weights[k] > 0.0).collect();
        if dims.is_empty() {
            return Err(Error::InvalidParameter {
                name: "weights",
                value: "all zero".into(),
                reason: "a metric with no positive weight ranks every item the same",
            });
        }
        dims.sort_by(|&a, &b| {
            weighting.weights[b]
                .total_cmp(&weighting.weights[a])
                .then(a.cmp(&b))
        });
        let stride = dims.len().div_ceil(LANES).max(1) * LANES;
        let mut matrix = Self {
            mean: dims.iter().map(|&k| weighting.mean[k]).collect(),
            scale: dims.iter().map(|&k| weighting.scale[k]).collect(),
            sqrt_w: dims.iter().map(|&k| weighting.weights[k].sqrt()).collect(),
            dims,
            feature_count: p,
            stride,
            data: vec![0.0; table.len() * stride],
        };
        let (dims, stride) = (&matrix.dims, matrix.stride);
        let (mean, scale, sqrt_w) = (&matrix.mean, &matrix.scale, &matrix.sqrt_w);
        matrix
            .data
            .par_chunks_mut(stride)
            .enumerate()
            .for_each(|(i, row)| {
                let raw = table.row(i);
                for (j, &k) in dims.iter().enumerate() {
                    row[j] = ((raw[k] - mean[j]) / scale[j] * sqrt_w[j]) as f32;
                }
            });
        Ok(matrix)
    }

    /// Reassembles a matrix from its parts (see [`StyleMatrix::parts`]).
    pub(crate) fn from_parts(parts: MatrixParts, data: Vec<f32>) -> Result<Self> {
        let d = parts.dims.len();
        let stride = d.div_ceil(LANES).max(1) * LANES;
        if [parts.mean.len(), parts.scale.len(), parts.sqrt_w.len()] != [d, d, d]
            || parts.dims.iter().any(|&k| k >= parts.feature_count)
            || !data.len().is_multiple_of(stride)
        {
            return Err(Error::InvalidParameter {
                name: "matrix parts",
                value: format!("{d} dims, {} floats", data.len()),
                reason: "inconsistent lengths",
            });
        }
        Ok(Self {
            dims: parts.dims,
            mean: parts.mean,
            scale: parts.scale,
            sqrt_w: parts.sqrt_w,
            feature_count: parts.feature_count,
            stride,
            data,
        })
    }

    /// Everything but the rows, for saving.
    pub(crate) fn parts(&self) -> MatrixParts {
        MatrixParts {
            dims: self.dims.clone(),
            mean: self.mean.clone(),
            scale: self.scale.clone(),
            sqrt_w: self.sqrt_w.clone(),
            feature_count: self.feature_count,
        }
    }

    /// Number of items.
    pub fn len(&self) -> usize {
        self.data.len() / self.stride
    }

    /// True without items.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// Dimensions kept (features with a positive weight).
    pub fn active_dims(&self) -> usize {
        self.dims.len()
    }

    /// Floats per stored row.
    pub fn stride(&self) -> usize {
        self.stride
    }

    /// The stored rows, row-major (`len × stride`).
    pub fn data(&self) -> &[f32] {
        &self.data
    }

    /// Stored row `i`.
    ///
    /// # Panics
    /// If `i >= self.len()`.
    pub fn row(&self, i: usize) -> &[f32] {
        &self.data[i * self.stride..(i + 1) * self.stride]
    }

    /// Heap bytes held.
    pub fn memory_bytes(&self) -> usize {
        self.data.len() * 4 + self.dims.len() * 32
    }

    /// Projects a raw feature vector (all features, table column order) like the stored rows.
    pub fn project(&self, raw: &[f64]) -> Result<Vec<f32>> {
        if raw.len() != self.feature_count {
            return Err(Error::QueryDimension {
                expected: self.feature_count,
                got: raw.len(),
            });
        }
        if let Some(v) = raw.iter().find(|v| !v.is_finite()) {
            return Err(Error::InvalidParameter {
                name: "query vector",
                value: v.to_string(),
                reason: "features must be finite",
            });
        }
        let mut row = vec![0.0; self.stride];
        for (j, &k) in self.dims.iter().enumerate() {
            row[j] = ((raw[k] - self.mean[j]) / self.scale[j] * self.sqrt_w[j]) as f32;
        }
        Ok(row)
    }

    /// The distance `d` (eq. 5.5) between stored row `i` and a projected vector, in `f64`.
    pub fn distance_to(&self, i: usize, q: &[f32]) -> f64 {
        self.row(i)
            .iter()
            .zip(q)
            .map(|(&a, &b)| (f64::from(a) - f64::from(b)).powi(2))
            .sum::<f64>()
            .sqrt()
    }

    /// The `k` candidates nearest to the references, by the mean of their distances `d` to
    /// each reference (one reference: plain nearest neighbours), nearest first, ties by row.
    ///
    /// `candidates` are rows in increasing order, or `None` for every row; rows in `exclude`
    /// are skipped. Returns `(row, mean distance)`, the distance recomputed in `f64` from the
    /// stored `f32` rows.
    pub fn nearest(
        &self,
        references: &[Vec<f32>],
        candidates: Option<&[u32]>,
        exclude: &[u32],
        k: usize,
    ) -> Vec<(u32, f64)> {
        if references.is_empty() || k == 0 {
            return Vec::new();
        }
        let top = match candidates {
            None => (0..self.len())
                .into_par_iter()
                .step_by(BLOCK)
                .map(|start| {
                    let end = (start + BLOCK).min(self.len());
                    let mut top = TopK::new(k);
                    self.scan_block(references, start, end, exclude, &mut top);
                    top
                })
                .reduce(|| TopK::new(k), TopK::merge),
            Some(rows) => rows
                .par_chunks(BLOCK)
                .map(|rows| {
                    let mut top = TopK::new(k);
                    self.scan_rows(references, rows, exclude, &mut top);
                    top
                })
                .reduce(|| TopK::new(k), TopK::merge),
        };
        let mut out: Vec<(u32, f64)> = top
            .into_sorted()
            .into_iter()
            .map(|(_, row)| {
                let mean = references
                    .iter()
                    .map(|q| self.distance_to(row as usize, q))
                    .sum::<f64>()
                    / references.len() as f64;
                (row, mean)
            })
            .collect();
        // The f64 recomputation can swap near-ties the f32 scan ordered the other way.
        out.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
        out
    }

    fn scan_block(
        &self,
        references: &[Vec<f32>],
        start: usize,
        end: usize,
        exclude: &[u32],
        top: &mut TopK,
    ) {
        let rows = &self.data[start * self.stride..end * self.stride];
        let mut keys = vec![0.0f32; end - start];
        ranking_keys(rows, references, &mut keys);
        for (i, &key) in keys.iter().enumerate() {
            let row = (start + i) as u32;
            // Most rows stop at this one comparison; `push` settles ties by row.
            if key <= top.threshold() && !exclude.contains(&row) {
                top.push(key, row);
            }
        }
    }

    fn scan_rows(&self, references: &[Vec<f32>], rows: &[u32], exclude: &[u32], top: &mut TopK) {
        let mut gathered = Vec::with_capacity(rows.len() * self.stride);
        for &r in rows {
            gathered.extend_from_slice(self.row(r as usize));
        }
        let mut keys = vec![0.0f32; rows.len()];
        ranking_keys(&gathered, references, &mut keys);
        for (&row, &key) in rows.iter().zip(&keys) {
            if !exclude.contains(&row) {
                top.push(key, row);
            }
        }
    }
}

/// What [`StyleMatrix::parts`] returns: the projection without the rows.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct MatrixParts {
    pub dims: Vec<usize>,
    pub mean: Vec<f64>,
    pub scale: Vec<f64>,
    pub sqrt_w: Vec<f64>,
    pub feature_count: usize,
}

/// The value rows are ranked by: the squared distance for one reference (same order as the
/// distance, one square root less per row), the mean distance for several.
fn ranking_keys(rows: &[f32], references: &[Vec<f32>], keys: &mut [f32]) {
    if let [q] = references {
        squared_distances(rows, q, keys);
        return;
    }
    let mut d = vec![0.0f32; keys.len()];
    keys.fill(0.0);
    for q in references {
        squared_distances(rows, q, &mut d);
        for (k, d) in keys.iter_mut().zip(&d) {
            *k += d.sqrt();
        }
    }
    let m = references.len() as f32;
    for k in keys.iter_mut() {
        *k /= m;
    }
}

crate::simd::vectorised_fn! {
    /// Squared Euclidean distance from `q` to each row of `rows` (rows of `q.len()` floats, a
    /// multiple of [`LANES`]), into `out`.
    pub(crate) fn squared_distances<'a>(rows: &'a [f32], q: &'a [f32], out: &'a mut [f32]) -> () {
        // Two passes over groups of rows: the lane sums of each row are stored, then reduced.
        // Reducing each row's sums right away made LLVM's SLP vectoriser grow its tree from the
        // reduction's 2-wide last step up into the loop, which then ran on `xmm` pairs of
        // lanes; spilling them with a barrier instead stalled on store-to-load forwarding.
        // Either cost ~3x the scan (perf on `learner bench search`). The arithmetic, hence
        // every bit of the result, is the same.
        let stride = q.len();
        let mut sums = [[0.0f32; LANES]; GROUP];
        for (rows, out) in rows.chunks(stride * GROUP).zip(out.chunks_mut(GROUP)) {
            for (row, s) in rows.chunks_exact(stride).zip(sums.iter_mut()) {
                *s = lane_sums(row, q);
            }
            for (s, o) in sums.iter().zip(out.iter_mut()) {
                *o = reduce_lanes(s);
            }
        }
    }
}

/// Rows per group of [`squared_distances`].
const GROUP: usize = 64;

/// The [`LANES`] partial sums of `(a − b)²` over rows padded to [`LANES`], lane `l` over
/// elements `l`, `l + LANES`, …; with [`reduce_lanes`], `‖a − b‖²` in an order that does not
/// depend on the vector width, so every path gives the same bits.
#[inline(always)]
fn lane_sums(a: &[f32], b: &[f32]) -> [f32; LANES] {
    let mut acc = [0.0f32; LANES];
    let (a, _) = a.as_chunks::<LANES>();
    let (b, _) = b.as_chunks::<LANES>();
    for (x, y) in a.iter().zip(b) {
        for l in 0..LANES {
            let d = x[l] - y[l];
            acc[l] += d * d;
        }
    }
    acc
}

/// The partial sums added up in a fixed tree order.
#[inline(always)]
fn reduce_lanes(acc: &[f32; LANES]) -> f32 {
    let mut half = [0.0f32; LANES / 2];
    for l in 0..LANES / 2 {
        half[l] = acc[l] + acc[l + LANES / 2];
    }
    let q = [
        half[0] + half[4],
        half[1] + half[5],
        half[2] + half[6],
        half[3] + half[7],
    ];
    (q[0] + q[2]) + (q[1] + q[3])
}

/// A heap entry: ordered by key, then row (so ties go to the earlier item).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Entry {
    key: f32,
    row: u32,
}

impl Eq for Entry {}

impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        self.key
            .total_cmp(&other.key)
            .then(self.row.cmp(&other.row))
    }
}

/// The `k` smallest `(key, row)` pairs seen, in a max-heap.
#[derive(Debug, Clone)]
pub(crate) struct TopK {
    k: usize,
    heap: BinaryHeap<Entry>,
}

impl TopK {
    pub(crate) fn new(k: usize) -> Self {
        Self {
            k,
            heap: BinaryHeap::with_capacity(k + 1),
        }
    }

    fn is_full(&self) -> bool {
        self.heap.len() >= self.k
    }

    /// Keys above this cannot enter.
    #[inline]
    fn threshold(&self) -> f32 {
        if self.is_full() {
            self.heap.peek().map_or(f32::INFINITY, |e| e.key)
        } else {
            f32::INFINITY
        }
    }

    #[inline]
    pub(crate) fn push(&mut self, key: f32, row: u32) {
        let e = Entry { key, row };
        if !self.is_full() {
            self.heap.push(e);
        } else if self.heap.peek().is_some_and(|top| e < *top) {
            self.heap.pop();
            self.heap.push(e);
        }
    }

    pub(crate) fn merge(mut self, other: Self) -> Self {
        for e in other.heap {
            self.push(e.key, e.row);
        }
        self
    }

    /// `(key, row)`, smallest first.
    pub(crate) fn into_sorted(self) -> Vec<(f32, u32)> {
        self.heap
            .into_sorted_vec()
            .into_iter()
            .map(|e| (e.key, e.row))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(rows: &[&[f64]]) -> FeatureTable {
        let p = rows[0].len();
        FeatureTable::new(
            (0..p).map(|k| format!("f{k}")).collect(),
            (0..rows.len()).map(|i| format!("i{i}")).collect(),
            rows.concat(),
        )
        .unwrap()
    }

    fn weighting(t: &FeatureTable, weights: Vec<f64>) -> Weighting {
        Weighting {
            feature_names: t.names().to_vec(),
            mean: vec![0.0; t.dim()],
            scale: vec![1.0; t.dim()],
            weights,
            uniform: false,
        }
    }

    #[test]
    fn zero_weights_drop_out_and_distances_are_eq_5_5() {
        let t = table(&[&[0.0, 5.0, 0.0], &[3.0, -7.0, 4.0], &[1.0, 1.0, 1.0]]);
        let m = StyleMatrix::build(&t, &weighting(&t, vec![1.0, 0.0, 4.0])).unwrap();
        assert_eq!(m.active_dims(), 2);
        assert_eq!(m.stride(), LANES);
        // d(row 0, row 1) = sqrt(1·3² + 4·4²) = sqrt(73).
        let q = m.project(t.row(0)).unwrap();
        assert!((m.distance_to(1, &q) - 73f64.sqrt()).abs() < 1e-6);
        let near = m.nearest(&[q], None, &[0], 5);
        assert_eq!(near.iter().map(|n| n.0).collect::<Vec<_>>(), [2, 1]);
        assert!((near[0].1 - 5f64.sqrt()).abs() < 1e-6);
    }

    #[test]
    fn ties_go_to_the_earlier_item_in_any_split() {
        let rows: Vec<Vec<f64>> = (0..10_000).map(|i| vec![(i % 3) as f64]).collect();
        let refs: Vec<&[f64]> = rows.iter().map(Vec::as_slice).collect();
        let t = table(&refs);
        let m = StyleMatrix::build(&t, &weighting(&t, vec![1.0])).unwrap();
        let q = m.project(&[1.0]).unwrap();
        let near = m.nearest(std::slice::from_ref(&q), None, &[], 4);
        assert_eq!(near.iter().map(|n| n.0).collect::<Vec<_>>(), [1, 4, 7, 10]);
        let subset: Vec<u32> = (0..10_000).step_by(2).collect();
        let near = m.nearest(&[q], Some(&subset), &[4], 3);
        assert_eq!(near.iter().map(|n| n.0).collect::<Vec<_>>(), [10, 16, 22]);
    }

    #[test]
    fn bad_shapes_are_errors() {
        let t = table(&[&[0.0, 1.0]]);
        let m = StyleMatrix::build(&t, &weighting(&t, vec![1.0, 1.0])).unwrap();
        assert!(matches!(
            m.project(&[1.0]),
            Err(Error::QueryDimension {
                expected: 2,
                got: 1
            })
        ));
        assert!(matches!(
            StyleMatrix::build(&t, &weighting(&t, vec![0.0, 0.0])),
            Err(Error::InvalidParameter { .. })
        ));
        let mut w = weighting(&t, vec![1.0, 1.0]);
        w.feature_names[1] = "other".into();
        assert!(matches!(
            StyleMatrix::build(&t, &w),
            Err(Error::FeatureMismatch { .. })
        ));
    }
}
