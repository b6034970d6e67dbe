//! The exact scan (recall 1.0): every candidate's ranking key is computed and the `k` smallest
//! kept, over the whole library or a keyword search's hits, against one reference ("more like
//! this", an example drawing) or several (the canvas, §5.7.3).

use rayon::prelude::*;

use super::blocked::BLOCK_ROWS;
use super::kernel::ranking_keys;
use super::matrix::StyleMatrix;
use super::topk::TopK;

/// Rows per parallel task (and per key buffer) in a scan; a multiple of [`BLOCK_ROWS`].
const BLOCK: usize = 4096;
const _: () = assert!(BLOCK.is_multiple_of(BLOCK_ROWS));

impl StyleMatrix {
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
            // The whole library: the blocked copy, in runs of consecutive rows.
            None => (0..self.len())
                .into_par_iter()
                .step_by(BLOCK)
                .map(|start| {
                    let mut keys = [0.0f32; BLOCK];
                    let keys = &mut keys[..BLOCK.min(self.len() - start)];
                    self.blocks.keys(references, start, keys);
                    select(keys, |i| (start + i) as u32, exclude, k)
                })
                .reduce(|| TopK::new(k), TopK::merge),
            // A candidate list: each row read where it is in the row-major copy.
            Some(rows) => rows
                .par_chunks(BLOCK)
                .map(|rows| {
                    let mut keys = [0.0f32; BLOCK];
                    let keys = &mut keys[..rows.len()];
                    ranking_keys(&self.data, rows, references, keys);
                    select(keys, |i| rows[i], exclude, k)
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
}

/// The `k` smallest keys of a run and their rows (`row(i)` of key `i`), skipping `exclude`;
/// most keys stop at one comparison with the heap's threshold.
fn select(keys: &[f32], row: impl Fn(usize) -> u32, exclude: &[u32], k: usize) -> TopK {
    let mut top = TopK::new(k);
    for (i, &key) in keys.iter().enumerate() {
        if key <= top.threshold() {
            let row = row(i);
            // `push` settles ties by row.
            if !exclude.contains(&row) {
                top.push(key, row);
            }
        }
    }
    top
}

#[cfg(test)]
mod tests {
    use crate::search::index::Weighting;
    use crate::search::index::matrix::StyleMatrix;
    use crate::table::FeatureTable;

    #[test]
    fn ties_go_to_the_earlier_item_in_any_split() {
        let values: Vec<f64> = (0..10_000).map(|i| (i % 3) as f64).collect();
        let t = FeatureTable::new(
            vec!["f0".into()],
            (0..10_000).map(|i| format!("i{i}")).collect(),
            values,
        )
        .unwrap();
        let w = Weighting {
            feature_names: t.names().to_vec(),
            mean: vec![0.0],
            scale: vec![1.0],
            weights: vec![1.0],
            uniform: false,
        };
        let m = StyleMatrix::build(&t, &w).unwrap();
        let q = m.project(&[1.0]).unwrap();
        let near = m.nearest(std::slice::from_ref(&q), None, &[], 4);
        assert_eq!(near.iter().map(|n| n.0).collect::<Vec<_>>(), [1, 4, 7, 10]);
        let subset: Vec<u32> = (0..10_000).step_by(2).collect();
        let near = m.nearest(&[q], Some(&subset), &[4], 3);
        assert_eq!(near.iter().map(|n| n.0).collect::<Vec<_>>(), [10, 16, 22]);
    }
}
