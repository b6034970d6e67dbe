//! The exact scan (recall 1.0): every candidate's ranking key is computed and the `k` smallest
//! kept, over the whole library or a keyword search's hits, against one reference ("more like
//! this", an example drawing) or several (the canvas, §5.7.3).

use rayon::prelude::*;

use super::kernel::{Rows, ranking_keys};
use super::matrix::StyleMatrix;
use super::topk::TopK;

/// Rows per parallel task (and per key buffer) in a scan.
const BLOCK: usize = 4096;

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
        let scan = |rows: Rows<'_>, n: usize| {
            let mut top = TopK::new(k);
            self.scan(references, rows, n, exclude, &mut top);
            top
        };
        let top = match candidates {
            None => (0..self.len())
                .into_par_iter()
                .step_by(BLOCK)
                .map(|start| scan(Rows::From(start), BLOCK.min(self.len() - start)))
                .reduce(|| TopK::new(k), TopK::merge),
            Some(rows) => rows
                .par_chunks(BLOCK)
                .map(|rows| scan(Rows::List(rows), rows.len()))
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

    /// Ranks `n ≤ BLOCK` rows into `top`; most stop at one comparison with its threshold.
    fn scan(
        &self,
        references: &[Vec<f32>],
        rows: Rows<'_>,
        n: usize,
        exclude: &[u32],
        top: &mut TopK,
    ) {
        let mut keys = [0.0f32; BLOCK];
        let keys = &mut keys[..n];
        ranking_keys(&self.data, rows, references, keys);
        for (i, &key) in keys.iter().enumerate() {
            if key <= top.threshold() {
                let row = match rows {
                    Rows::From(start) => (start + i) as u32,
                    Rows::List(list) => list[i],
                };
                // `push` settles ties by row.
                if !exclude.contains(&row) {
                    top.push(key, row);
                }
            }
        }
    }
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
