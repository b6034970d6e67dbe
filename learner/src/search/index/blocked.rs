//! The rows again, for the scan of a whole library: blocks of [`BLOCK_ROWS`] rows stored
//! dimension by dimension (block `b`, dimension `j`, row `r` at `(b·dims + j)·BLOCK_ROWS + r`).
//!
//! A vector register then holds one dimension of 8 (AVX2) or 4 rows, and each row's squared
//! distance is summed in its own lane: no horizontal sum per row, the cost that kept the
//! row-major scan at a third of the speed of numpy's BLAS GEMV and faiss `IndexFlatL2`
//! (docs/search.md), and only the stored dimensions are read, not the padding to
//! [`LANES`](super::kernel::LANES). The row-major copy stays for what reads single rows: a
//! keyword search's scattered hits, k-means, the exact `f64` distances.
//!
//! A row's key is summed in dimension order on every vector width, so both compiled paths give
//! the same bits; the order differs from the row-major kernel's, so a key can differ from that
//! kernel's in its last bits (results are ranked by the exact `f64` distances in the end).

use rayon::prelude::*;

/// Rows per block: two AVX2 registers per dimension, two independent sums.
pub(crate) const BLOCK_ROWS: usize = 16;

/// Rows in blocks of [`BLOCK_ROWS`], dimension-major within a block; the last block is padded
/// with zero rows.
#[derive(Debug, Clone, PartialEq, Default)]
pub(crate) struct RowBlocks {
    /// Stored dimensions per row.
    dims: usize,
    /// `block count × dims × BLOCK_ROWS`.
    data: Vec<f32>,
}

impl RowBlocks {
    /// The first `dims` floats of each row of `rows` (row-major, `stride` floats per row).
    pub(crate) fn from_rows(rows: &[f32], stride: usize, dims: usize) -> Self {
        let len = rows.len().checked_div(stride).unwrap_or(0);
        let per_block = dims * BLOCK_ROWS;
        let mut data = vec![0.0f32; len.div_ceil(BLOCK_ROWS) * per_block];
        if per_block > 0 {
            data.par_chunks_mut(per_block)
                .enumerate()
                .for_each(|(b, block)| {
                    let first = b * BLOCK_ROWS;
                    for r in 0..BLOCK_ROWS.min(len - first) {
                        let at = (first + r) * stride;
                        for (j, &v) in rows[at..at + dims].iter().enumerate() {
                            block[j * BLOCK_ROWS + r] = v;
                        }
                    }
                });
        }
        Self { dims, data }
    }

    /// Heap bytes held.
    pub(crate) fn memory_bytes(&self) -> usize {
        self.data.len() * 4
    }

    /// The ranking keys (see [`block_keys`]) of rows `first..first + keys.len()`; `first` is a
    /// multiple of [`BLOCK_ROWS`], and keys of the padding rows past the end are left out.
    pub(crate) fn keys(&self, references: &[Vec<f32>], first: usize, keys: &mut [f32]) {
        debug_assert!(first.is_multiple_of(BLOCK_ROWS));
        let per_block = self.dims * BLOCK_ROWS;
        let blocks = keys.len().div_ceil(BLOCK_ROWS);
        let start = first / BLOCK_ROWS * per_block;
        let data = &self.data[start..start + blocks * per_block];
        let whole = keys.len() / BLOCK_ROWS * BLOCK_ROWS;
        let (head, tail) = keys.split_at_mut(whole);
        block_keys(&data[..head.len() * self.dims], self.dims, references, head);
        if !tail.is_empty() {
            let mut last = [0.0f32; BLOCK_ROWS];
            block_keys(
                &data[head.len() * self.dims..],
                self.dims,
                references,
                &mut last,
            );
            tail.copy_from_slice(&last[..tail.len()]);
        }
    }
}

crate::simd::vectorised_fn! {
    /// The value rows are ranked by, for whole blocks (`keys.len()` a multiple of
    /// [`BLOCK_ROWS`]): the squared distance for one reference, the mean distance for several
    /// (each block is compared with every reference while it is in the L1 cache).
    fn block_keys<'a>(
        blocks: &'a [f32],
        dims: usize,
        references: &'a [Vec<f32>],
        keys: &'a mut [f32],
    ) -> () {
        let single = references.len() == 1;
        let (keys, _) = keys.as_chunks_mut::<BLOCK_ROWS>();
        for (block, keys) in blocks.chunks_exact(dims * BLOCK_ROWS).zip(keys) {
            for (j, q) in references.iter().enumerate() {
                let sums = squared_distances(block, q);
                if single {
                    *keys = sums;
                } else if j == 0 {
                    for (k, s) in keys.iter_mut().zip(sums) {
                        *k = s.sqrt();
                    }
                } else {
                    for (k, s) in keys.iter_mut().zip(sums) {
                        *k += s.sqrt();
                    }
                }
            }
            if !single {
                let m = references.len() as f32;
                for k in keys.iter_mut() {
                    *k /= m;
                }
            }
        }
    }
}

/// `‖row − q‖²` of each row of one block, summed in dimension order.
#[inline(always)]
fn squared_distances(block: &[f32], q: &[f32]) -> [f32; BLOCK_ROWS] {
    let mut sums = [0.0f32; BLOCK_ROWS];
    let (columns, _) = block.as_chunks::<BLOCK_ROWS>();
    for (column, &qj) in columns.iter().zip(q) {
        for r in 0..BLOCK_ROWS {
            let d = column[r] - qj;
            sums[r] += d * d;
        }
    }
    sums
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Keys of a run of rows equal the row-by-row `f64` distances (to `f32` precision), for one
    /// and several references, at any block-aligned start and a length that ends mid-block;
    /// the dispatched and the baseline paths give the same bits.
    #[test]
    fn keys_are_the_distances_on_every_path() {
        let (stride, dims, n) = (16, 11, 70);
        let rows: Vec<f32> = (0..n * stride)
            .map(|i| {
                if i % stride < dims {
                    ((i * 7919) % 1000) as f32 / 100.0 - 5.0
                } else {
                    0.0
                }
            })
            .collect();
        let row = |r: usize| rows[r * stride..(r + 1) * stride].to_vec();
        let blocks = RowBlocks::from_rows(&rows, stride, dims);
        assert_eq!(blocks.memory_bytes(), 5 * BLOCK_ROWS * dims * 4);
        let exact = |r: usize, q: &[f32]| {
            row(r)
                .iter()
                .zip(q)
                .map(|(&a, &b)| (f64::from(a) - f64::from(b)).powi(2))
                .sum::<f64>()
        };
        for references in [vec![row(3)], vec![row(3), row(40), row(69)]] {
            let (first, len) = (16, 54);
            let mut keys = vec![0.0f32; len];
            blocks.keys(&references, first, &mut keys);
            for (i, &key) in keys.iter().enumerate() {
                let want = if references.len() == 1 {
                    exact(first + i, &references[0])
                } else {
                    references
                        .iter()
                        .map(|q| exact(first + i, q).sqrt())
                        .sum::<f64>()
                        / references.len() as f64
                };
                assert!(
                    (f64::from(key) - want).abs() <= 1e-5 * want.max(1.0),
                    "row {} key {key} want {want}",
                    first + i
                );
            }
            let mut slow = vec![0.0f32; len];
            crate::simd::tests::baseline_only(|| blocks.keys(&references, first, &mut slow));
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&keys), bits(&slow));
        }
    }
}
