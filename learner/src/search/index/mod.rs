//! The style index: the learned distance of §5.5 (eq. 5.5) as a plain Euclidean one, and the
//! exact nearest-neighbour scan that orders search results by style (§5.7.3).
//!
//! Eq. 5.5 is `d(x, y) = sqrt(Σ_k w_k (x̂_k − ŷ_k)²)` on standardised features
//! `x̂ = (x − mean) / scale`. Storing every item as `z = √w ⊙ x̂` makes it `‖z_x − z_y‖₂`, and
//! the dimensions with `w_k = 0` (most of them: the metric is L1-sparse) drop out entirely. The
//! kept dimensions are stored as `f32` rows, ordered by decreasing weight and padded with zeros
//! to a multiple of [`LANES`] so the scan of a candidate list is one vectorised loop per row;
//! a scan of the whole library reads a second copy stored in blocks of 16 rows, dimension by
//! dimension, where a vector register holds one dimension of several rows.
//!
//! The scan is exact (recall 1.0): every candidate's distance is computed and the `k` smallest
//! are kept in a bounded heap. Equal distances are ordered by item order, so the result does not
//! depend on how the rows are split across threads.
//!
//! * [`weighting`]: where `w`, the mean and the scale come from (a model, or uniform).
//! * [`matrix`]: the projected rows.
//! * `nearest`: the exact scan over all rows or a candidate list.
//! * `kernel`: the vectorised distance loops over rows; `blocked`: the blocked copy and its
//!   loops; `topk`: the bounded heap.

mod blocked;
mod kernel;
pub mod matrix;
mod nearest;
mod topk;
pub mod weighting;

pub use kernel::LANES;
pub(crate) use kernel::squared_distances;
pub(crate) use matrix::MatrixParts;
pub use matrix::StyleMatrix;
pub use weighting::Weighting;
