//! Style exploration of a library: the first brick of the style taxonomy of Garces et al. 2016,
//! "Style-Based Exploration of Illustration Datasets" (§6.5.1), which groups the items of a
//! dataset into a hierarchy of styles by agglomerative clustering with Ward's criterion.
//!
//! * [`ward()`]: exact Ward clustering of points (nearest-neighbour chain, Lance–Williams
//!   update), the same tree as `scipy.cluster.hierarchy.linkage(X, 'ward')`.
//! * [`Linkage`]: the merge tree in scipy's numbering, serialisable, and [`Linkage::cut`] into
//!   `k` flat clusters.
//!
//! * [`tsne()`]: the t-SNE map of the points in the plane (Barnes–Hut for large inputs) and
//!   [`tsne::quality`] to measure one (§5.7.1, ch. 6 of the same paper).
//!
//! The points are whatever the caller chooses (standardised features, or rows of the learned
//! style space `√w ⊙ x`); this module only clusters.
//!
//! ```
//! use learner::explore::ward;
//!
//! // Four points on a line: 0, 1 and 10, 11 pair up first.
//! let tree = ward(&[0.0f64, 1.0, 10.0, 11.0], 1)?;
//! assert_eq!(tree.merges()[0].a, 0);
//! assert_eq!(tree.merges()[0].b, 1);
//! assert_eq!(tree.cut(2)?, vec![0, 0, 1, 1]);
//! # Ok::<(), learner::Error>(())
//! ```

pub mod grid;
pub mod library;
mod linkage;
pub mod map;
pub mod taxonomy;
pub mod tsne;
pub mod ward;

pub use grid::{
    BalanceParams, Cost, Grid, IsoMatchParams, Node, NodeState, QualityParams, SomParams, balance,
    balanced_grid, cost, dpq, isomatch, layout_spearman, random_layout, som,
};
pub use library::{StyleLibrary, read_item_labels};
pub use linkage::{Linkage, Merge};
pub use taxonomy::{Taxonomy, TaxonomyParams, taxonomy};
pub use tsne::{Affinities, TsneInfo, TsneInit, TsneMethod, TsneParams, tsne};
pub use ward::{MAX_COORDINATE, MAX_POINTS, ward, ward_weighted};

/// The tree against scipy's `linkage(X, 'ward')` (reference values of
/// `scripts/reference/ward_reference.py`); a unit-test module so the crate keeps one
/// integration-test binary.
#[cfg(test)]
mod scipy_reference;
