//! The merge tree of an agglomerative clustering in scipy's linkage-matrix convention, so trees
//! can be compared with `scipy.cluster.hierarchy` row for row and stored as JSON.

use serde::{Deserialize, Serialize};

use crate::{Error, Result};

/// One merge: clusters `a` and `b` joined at `height` into a cluster of `size` points.
///
/// Numbering as in scipy: the `n` points are clusters `0..n`; merge `i` (0-based) creates
/// cluster `n + i`. Within a merge `a < b`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Merge {
    /// The smaller cluster id.
    pub a: usize,
    /// The larger cluster id.
    pub b: usize,
    /// The merge height (for Ward: scipy's distance, see [`crate::explore::ward()`]).
    pub height: f64,
    /// Points in the new cluster.
    pub size: usize,
}

/// The `n − 1` merges of `n` points, in non-decreasing height: a row-for-row equivalent of
/// scipy's linkage matrix `Z` (`[a, b, height, size]`).
///
/// Deserialising checks that the tree is one (see [`Linkage::new`]), so [`Linkage::cut`] never
/// meets an inconsistent tree.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawLinkage")]
pub struct Linkage {
    n: usize,
    merges: Vec<Merge>,
}

#[derive(Deserialize)]
struct RawLinkage {
    n: usize,
    merges: Vec<Merge>,
}

impl TryFrom<RawLinkage> for Linkage {
    type Error = Error;
    fn try_from(raw: RawLinkage) -> Result<Self> {
        Linkage::new(raw.n, raw.merges)
    }
}

impl Linkage {
    /// A linkage of `n ≥ 2` points from its merges, checked: `n − 1` merges, each joining two
    /// existing, not yet merged clusters with `a < b`, sizes adding up, finite non-negative
    /// heights in non-decreasing order (the order scipy sorts its rows in).
    pub fn new(n: usize, merges: Vec<Merge>) -> Result<Self> {
        let bad = |message: String| Err(Error::InvalidLinkage(message));
        if n < 2 {
            return bad(format!("{n} points; a tree needs at least 2"));
        }
        if merges.len() != n - 1 {
            return bad(format!(
                "{} merges for {n} points, expected {}",
                merges.len(),
                n - 1
            ));
        }
        let mut size = vec![1usize; n];
        size.resize(2 * n - 1, 0);
        let mut used = vec![false; 2 * n - 1];
        let mut previous = 0.0f64;
        for (i, m) in merges.iter().enumerate() {
            if m.a >= m.b || m.b >= n + i {
                return bad(format!(
                    "merge {i} joins {} and {}: need a < b < {}",
                    m.a,
                    m.b,
                    n + i
                ));
            }
            if used[m.a] || used[m.b] {
                return bad(format!("merge {i} reuses an already merged cluster"));
            }
            if !(m.height.is_finite() && m.height >= previous) {
                return bad(format!(
                    "merge {i} has height {}, after {previous}: heights must be finite, \
                     non-negative and non-decreasing",
                    m.height
                ));
            }
            if m.size != size[m.a] + size[m.b] {
                return bad(format!(
                    "merge {i} has size {}, but its clusters hold {} points",
                    m.size,
                    size[m.a] + size[m.b]
                ));
            }
            used[m.a] = true;
            used[m.b] = true;
            size[n + i] = m.size;
            previous = m.height;
        }
        Ok(Self { n, merges })
    }

    /// Number of points (leaves).
    pub fn n(&self) -> usize {
        self.n
    }

    /// The merges, lowest first.
    pub fn merges(&self) -> &[Merge] {
        &self.merges
    }

    /// Flat clusters: the label (`0..k`) of each point after the first `n − k` merges, i.e. the
    /// tree cut below its top `k − 1` merges. Labels are numbered in order of each cluster's
    /// first point, so point 0 is in cluster 0.
    ///
    /// This is `fcluster(Z, k, 'maxclust')` up to relabelling whenever the heights around the
    /// cut differ; when merges `n − k − 1` and `n − k` have equal heights, scipy cuts at a
    /// height and returns fewer than `k` clusters, while this always returns exactly `k`.
    pub fn cut(&self, k: usize) -> Result<Vec<usize>> {
        if k == 0 || k > self.n {
            return Err(Error::InvalidParameter {
                name: "k",
                value: k.to_string(),
                reason: "the number of clusters must be between 1 and the number of points",
            });
        }
        let n = self.n;
        // Union-find over cluster ids: each merged cluster points at the cluster it joined.
        let mut parent: Vec<usize> = (0..2 * n - 1).collect();
        for (i, m) in self.merges[..n - k].iter().enumerate() {
            parent[m.a] = n + i;
            parent[m.b] = n + i;
        }
        let mut label = vec![usize::MAX; 2 * n - 1];
        let mut next = 0;
        let mut out = Vec::with_capacity(n);
        for leaf in 0..n {
            let mut root = leaf;
            while parent[root] != root {
                root = parent[root];
            }
            if label[root] == usize::MAX {
                label[root] = next;
                next += 1;
            }
            out.push(label[root]);
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn m(a: usize, b: usize, height: f64, size: usize) -> Merge {
        Merge { a, b, height, size }
    }

    #[test]
    fn explore_linkage_cut_and_json_round_trip() {
        // ((0, 2), (1, 3)) joined last.
        let tree =
            Linkage::new(4, vec![m(0, 2, 1.0, 2), m(1, 3, 2.0, 2), m(4, 5, 5.0, 4)]).unwrap();
        assert_eq!(tree.cut(1).unwrap(), vec![0, 0, 0, 0]);
        assert_eq!(tree.cut(2).unwrap(), vec![0, 1, 0, 1]);
        assert_eq!(tree.cut(3).unwrap(), vec![0, 1, 0, 2]);
        assert_eq!(tree.cut(4).unwrap(), vec![0, 1, 2, 3]);
        for k in [0, 5] {
            assert!(matches!(
                tree.cut(k),
                Err(Error::InvalidParameter { name: "k", .. })
            ));
        }
        let json = serde_json::to_string(&tree).unwrap();
        let back: Linkage = serde_json::from_str(&json).unwrap();
        assert_eq!(back, tree);
    }

    #[test]
    fn explore_linkage_rejects_inconsistent_trees() {
        let cases = [
            (1, vec![]),
            (3, vec![m(0, 1, 1.0, 2)]),
            (3, vec![m(1, 0, 1.0, 2), m(2, 3, 2.0, 3)]),
            (3, vec![m(0, 1, 1.0, 2), m(0, 3, 2.0, 3)]),
            (3, vec![m(0, 1, 1.0, 2), m(2, 4, 2.0, 3)]),
            (3, vec![m(0, 1, 1.0, 2), m(2, 3, 0.5, 3)]),
            (3, vec![m(0, 1, f64::NAN, 2), m(2, 3, 2.0, 3)]),
            (3, vec![m(0, 1, 1.0, 2), m(2, 3, 2.0, 4)]),
        ];
        for (n, merges) in cases {
            let text = format!("{merges:?}");
            assert!(
                matches!(Linkage::new(n, merges), Err(Error::InvalidLinkage(_))),
                "accepted n = {n}, {text}"
            );
        }
        let json = r#"{"n":3,"merges":[{"a":0,"b":1,"height":1.0,"size":2},{"a":0,"b":3,"height":2.0,"size":3}]}"#;
        assert!(serde_json::from_str::<Linkage>(json).is_err());
    }
}
