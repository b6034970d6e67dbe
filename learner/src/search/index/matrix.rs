//! Items as rows of `√w ⊙ x̂` (eq. 5.5) over the dimensions with `w > 0`, in `f32`, and the
//! projection of a raw feature vector into the same space.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::blocked::RowBlocks;
use super::kernel::LANES;
use super::weighting::Weighting;
use crate::table::FeatureTable;
use crate::{Error, Result};

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
    pub(super) data: Vec<f32>,
    /// The same rows in blocks, for scans of the whole library (derived from `data`).
    pub(super) blocks: RowBlocks,
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
            blocks: RowBlocks::default(),
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
        matrix.blocks = RowBlocks::from_rows(&matrix.data, stride, matrix.dims.len());
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
            blocks: RowBlocks::from_rows(&data, stride, d),
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

    /// Heap bytes held (both copies of the rows).
    pub fn memory_bytes(&self) -> usize {
        self.data.len() * 4 + self.blocks.memory_bytes() + self.dims.len() * 32
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
