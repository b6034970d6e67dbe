//! The diversity ordering of §5.7.3: with nothing on the canvas, show a spread of styles rather
//! than the first hits. Offline, the library is clustered twice by k-means under the learned
//! metric (on the index rows `√w ⊙ x̂`): all items into `k1` clusters (paper: 100), then those
//! clusters' centres into `k2` (paper: 7). Results are dealt like cards: one from each top-level
//! cluster in turn, and within a top-level cluster one from each of its first-level clusters in
//! turn, so the first `k2` results come from `k2` different top-level clusters whenever the hits
//! span that many.
//!
//! Order inside the deal (deliberate choices, the paper does not say): top-level clusters with
//! more hits go first, and so do first-level clusters within one; inside a first-level cluster,
//! better keyword matches first, then items nearer its centre (the most typical first), then item
//! order. Cluster numbers are renumbered by size, largest first, so `0` is the biggest group of
//! the library.

use serde::{Deserialize, Serialize};

use super::index::StyleMatrix;
use super::kmeans::{KMeansInfo, kmeans};
use super::params::SearchParams;

/// The two-level clustering of a library.
#[derive(Debug, Clone, PartialEq)]
pub struct Diversity {
    /// First-level cluster of each item.
    pub(crate) leaf: Vec<u16>,
    /// Top-level cluster of each first-level cluster.
    pub(crate) leaf_top: Vec<u16>,
    /// Distance of each item to its first-level centre.
    pub(crate) centre_distance: Vec<f32>,
    /// How the clustering went.
    pub(crate) info: DiversityInfo,
}

/// What the clustering did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DiversityInfo {
    /// k-means over the items.
    pub level1: KMeansInfo,
    /// k-means over the first-level centres.
    pub level2: KMeansInfo,
    /// Items per top-level cluster, by cluster number (largest first).
    pub top_sizes: Vec<usize>,
}

/// A result's place in the clustering.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct ClusterId {
    /// Top-level cluster (`0..k2`).
    pub top: u16,
    /// First-level cluster (`0..k1`).
    pub leaf: u16,
}

/// Which level a clustering progress report is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Level {
    /// Items into `k1` clusters.
    Items,
    /// Centres into `k2` clusters.
    Centres,
}

impl Diversity {
    /// Clusters the matrix's rows. `progress(level, iteration)` after each Lloyd iteration.
    pub fn build(
        matrix: &StyleMatrix,
        params: &SearchParams,
        progress: &mut dyn FnMut(Level, usize),
    ) -> Self {
        let stride = matrix.stride();
        let items = kmeans(
            matrix.data(),
            stride,
            params.k1,
            params.seed,
            params.max_iterations,
            &mut |i| progress(Level::Items, i),
        );
        let centres = kmeans(
            &items.centroids,
            stride,
            params.k2,
            params.seed.wrapping_add(1),
            params.max_iterations,
            &mut |i| progress(Level::Centres, i),
        );
        let k1 = items.info.k;
        let k2 = centres.info.k;

        // Renumber both levels by size, largest first (ties: the k-means number).
        let mut leaf_size = vec![0usize; k1];
        for &l in &items.assignment {
            leaf_size[l as usize] += 1;
        }
        let mut top_size = vec![0usize; k2];
        for (l, &t) in centres.assignment.iter().enumerate() {
            top_size[t as usize] += leaf_size[l];
        }
        let top_order = by_size(&top_size);
        let leaf_order = by_size(&leaf_size);
        let mut new_top = vec![0u16; k2];
        for (new, &old) in top_order.iter().enumerate() {
            new_top[old] = new as u16;
        }
        let mut new_leaf = vec![0u16; k1];
        for (new, &old) in leaf_order.iter().enumerate() {
            new_leaf[old] = new as u16;
        }
        let leaf_top = leaf_order
            .iter()
            .map(|&old| new_top[centres.assignment[old] as usize])
            .collect();
        Self {
            leaf: items
                .assignment
                .iter()
                .map(|&l| new_leaf[l as usize])
                .collect(),
            leaf_top,
            centre_distance: items.distance.iter().map(|d| d.sqrt()).collect(),
            info: DiversityInfo {
                level1: items.info,
                level2: centres.info,
                top_sizes: top_order.iter().map(|&t| top_size[t]).collect(),
            },
        }
    }

    /// Reassembles a clustering from saved parts.
    pub(crate) fn from_parts(
        leaf: Vec<u16>,
        leaf_top: Vec<u16>,
        centre_distance: Vec<f32>,
        info: DiversityInfo,
    ) -> Self {
        Self {
            leaf,
            leaf_top,
            centre_distance,
            info,
        }
    }

    /// How the clustering went.
    pub fn info(&self) -> &DiversityInfo {
        &self.info
    }

    /// The clusters of item `row`.
    pub fn cluster_of(&self, row: u32) -> ClusterId {
        let leaf = self.leaf[row as usize];
        ClusterId {
            top: self.leaf_top[leaf as usize],
            leaf,
        }
    }

    /// The first `limit` of `hits` (`(row, keyword score)`; scores all equal without keywords)
    /// in the diversity order.
    pub fn interleave(&self, hits: &[(u32, f32)], limit: usize) -> Vec<(u32, ClusterId)> {
        let k1 = self.leaf_top.len();
        let k2 = self
            .leaf_top
            .iter()
            .map(|&t| t as usize + 1)
            .max()
            .unwrap_or(0);
        let mut leaves: Vec<Vec<(u32, f32)>> = vec![Vec::new(); k1];
        for &(row, score) in hits {
            leaves[self.leaf[row as usize] as usize].push((row, score));
        }
        let key = |a: &(u32, f32), b: &(u32, f32)| {
            b.1.total_cmp(&a.1)
                .then(
                    self.centre_distance[a.0 as usize]
                        .total_cmp(&self.centre_distance[b.0 as usize]),
                )
                .then(a.0.cmp(&b.0))
        };
        let leaf_hits: Vec<usize> = leaves.iter().map(Vec::len).collect();
        for list in &mut leaves {
            // Only the first `limit` of a cluster can be shown.
            if list.len() > limit {
                list.select_nth_unstable_by(limit, key);
                list.truncate(limit);
            }
            list.sort_unstable_by(key);
        }
        // Per top-level cluster: its first-level clusters with hits, most hits first.
        let mut tops: Vec<Vec<usize>> = vec![Vec::new(); k2];
        let mut top_hits = vec![0usize; k2];
        for (l, list) in leaves.iter().enumerate() {
            if !list.is_empty() {
                let t = self.leaf_top[l] as usize;
                tops[t].push(l);
                top_hits[t] += leaf_hits[l];
            }
        }
        for t in &mut tops {
            t.sort_by(|&a, &b| leaf_hits[b].cmp(&leaf_hits[a]).then(a.cmp(&b)));
        }
        let top_order: Vec<usize> = by_size(&top_hits)
            .into_iter()
            .filter(|&t| top_hits[t] > 0)
            .collect();
        // Deal: round r takes the r-th item of each top-level cluster's own deal.
        let streams: Vec<Vec<u32>> = top_order
            .iter()
            .map(|&t| deal(tops[t].iter().map(|&l| leaves[l].as_slice()), limit))
            .collect();
        let mut out = Vec::with_capacity(limit.min(hits.len()));
        for round in 0.. {
            let mut any = false;
            for s in &streams {
                if let Some(&row) = s.get(round) {
                    any = true;
                    out.push((row, self.cluster_of(row)));
                    if out.len() == limit {
                        return out;
                    }
                }
            }
            if !any {
                break;
            }
        }
        out
    }
}

/// Round robin over `lists`, at most `limit` items.
fn deal<'a>(lists: impl Iterator<Item = &'a [(u32, f32)]>, limit: usize) -> Vec<u32> {
    let lists: Vec<&[(u32, f32)]> = lists.collect();
    let longest = lists.iter().map(|l| l.len()).max().unwrap_or(0);
    let mut out = Vec::new();
    for round in 0..longest {
        for l in &lists {
            if let Some(&(row, _)) = l.get(round) {
                out.push(row);
                if out.len() == limit {
                    return out;
                }
            }
        }
    }
    out
}

/// Indices by decreasing size, ties by index.
fn by_size(sizes: &[usize]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..sizes.len()).collect();
    order.sort_by(|&a, &b| sizes[b].cmp(&sizes[a]).then(a.cmp(&b)));
    order
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hand-made clustering: leaves 0,1 in top 0; leaf 2 in top 1; leaf 3 in top 2.
    fn fixture() -> Diversity {
        Diversity::from_parts(
            vec![0, 0, 0, 1, 1, 2, 2, 3],
            vec![0, 0, 1, 2],
            vec![0.3, 0.1, 0.2, 0.5, 0.4, 0.9, 0.8, 0.0],
            DiversityInfo {
                level1: KMeansInfo {
                    k: 4,
                    points: 8,
                    iterations: 1,
                    converged: true,
                    inertia: 0.0,
                    reseeded: 0,
                },
                level2: KMeansInfo {
                    k: 3,
                    points: 4,
                    iterations: 1,
                    converged: true,
                    inertia: 0.0,
                    reseeded: 0,
                },
                top_sizes: vec![5, 2, 1],
            },
        )
    }

    #[test]
    fn deals_across_top_clusters_then_their_leaves() {
        let d = fixture();
        let all: Vec<(u32, f32)> = (0..8).map(|r| (r, 0.0)).collect();
        let order: Vec<u32> = d.interleave(&all, 100).iter().map(|x| x.0).collect();
        // Tops by hits: 0 (5), 1 (2), 2 (1). Top 0 deals leaf 0 (1, 2, 0 by centre distance)
        // and leaf 1 (4, 3): 1 4 2 3 0. Top 1: 6 5. Top 2: 7.
        assert_eq!(order, [1, 6, 7, 4, 5, 2, 3, 0]);
        let top3: Vec<u16> = d.interleave(&all, 3).iter().map(|x| x.1.top).collect();
        assert_eq!(top3, [0, 1, 2]);
    }

    #[test]
    fn keyword_scores_come_first_within_a_cluster() {
        let d = fixture();
        let hits = [(0, 2.0), (1, 1.0), (2, 1.0)];
        let order: Vec<u32> = d.interleave(&hits, 10).iter().map(|x| x.0).collect();
        assert_eq!(order, [0, 1, 2]);
    }
}
