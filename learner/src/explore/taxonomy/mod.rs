//! The style taxonomy of Garces et al. 2016, "Style-Based Exploration of Illustration
//! Datasets" (§6.5.1): Ward's agglomerative clustering of a library under the learned metric,
//! each branch represented by the item nearest its centroid, and the tree pruned to the
//! branches that hold more than κ items in all and more than τ items of every semantic label
//! the user asked for. The leaves of the pruned tree are the *representative styles*: styles
//! in which every requested label (a dog *and* a tree *and* a sun) can be found.
//!
//! Exact Ward needs the O(n²) distance matrix, so a library larger than
//! [`TaxonomyParams::max_exact`] is first reduced to k-means centres and Ward runs on the
//! centres weighted by their sizes ([`super::ward_weighted`]): the tree Ward builds on the
//! items from that partition on. The result says so ([`Taxonomy::reduction`]); no item is ever
//! dropped.

mod build;
mod tree;

#[cfg(test)]
mod tests;

use serde::{Deserialize, Serialize};

pub use build::taxonomy;

use crate::search::KMeansInfo;

/// Parameters of the taxonomy (§6.5.1).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TaxonomyParams {
    /// κ: a kept branch holds more than κ items.
    pub kappa: usize,
    /// τ: a kept branch holds more than τ items of every requested label.
    pub tau: usize,
    /// The largest library clustered exactly; above it Ward runs on k-means centres (the
    /// distance matrix of 20,000 items takes 1.6 GB; [`super::MAX_POINTS`] is the hard limit).
    pub max_exact: usize,
    /// k-means centres of a library larger than `max_exact`.
    pub centres: usize,
    /// Lloyd iterations of that k-means at most.
    pub kmeans_iterations: usize,
    /// Seed of the k-means.
    pub seed: u64,
}

impl Default for TaxonomyParams {
    fn default() -> Self {
        Self {
            kappa: 20,
            tau: 2,
            max_exact: 20_000,
            centres: 4_000,
            kmeans_iterations: 25,
            seed: 0,
        }
    }
}

/// A branch of the pruned tree.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TaxonNode {
    /// Items in the branch.
    pub count: usize,
    /// Ward height at which the branch was formed (0 for a single item).
    pub height: f64,
    /// The item nearest the branch's centroid (an index into the library).
    pub representative: usize,
    /// Items of each label in the branch, `(label index, count)`, most frequent first.
    pub label_counts: Vec<(u32, usize)>,
    /// Kept sub-branches (indices into [`Taxonomy::nodes`]); empty for a representative style.
    pub children: Vec<usize>,
    /// The items of a representative style (empty for inner branches).
    pub members: Vec<usize>,
}

/// How a large library was reduced before Ward.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Reduction {
    /// Non-empty k-means centres Ward clustered.
    pub centres: usize,
    /// The k-means run.
    pub kmeans: KMeansInfo,
}

/// The pruned style taxonomy.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Taxonomy {
    /// Items clustered.
    pub items: usize,
    /// The parameters used.
    pub params: TaxonomyParams,
    /// Labels each kept branch had to hold more than τ items of.
    pub required: Vec<u32>,
    /// Present when Ward ran on k-means centres.
    pub reduction: Option<Reduction>,
    /// The kept branches: the root first, then depth first; only the root, the branches that
    /// split into two kept branches, and the representative styles (a chain of branches each
    /// with one kept child is shown as its lowest branch).
    pub nodes: Vec<TaxonNode>,
    /// The representative styles (indices into `nodes`), largest first.
    pub representatives: Vec<usize>,
    /// Items in none of the representative styles (they sit in branches too small to keep).
    pub unassigned: usize,
}

/// A stage of a taxonomy run, for progress reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// k-means reduction: iterations done of at most this many.
    KMeans,
    /// Ward clustering (one step).
    Ward,
    /// Branch statistics and representatives: branches done of this many.
    Representatives,
}
