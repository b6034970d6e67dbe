//! The balanced grid of Garces et al. 2016, "Style-Based Exploration of Illustration Datasets"
//! (thesis §6.5.2): the items of a style branch laid out on an `M × N` grid so that neighbouring
//! cells hold similar styles, every cell shows one item, the semantic labels are shown in fair
//! proportions, and every item not shown stays reachable as a hidden item of its node.
//!
//! * [`som()`]: the self-organising map that initialises the grid;
//! * [`balance()`]: Algorithm 3 (multi → single, balancing labels) and Algorithm 4 (empty →
//!   single from 5×5 neighbourhoods), lowering [`cost()`], eq. 6.1;
//! * baselines on the same inputs: [`som_grid`] (the raw SOM), [`isomatch()`] (Isomap + an exact
//!   [`linear_assignment`], after Fried et al. 2015) and [`random_layout`];
//! * [`layout_spearman`] and [`dpq`] (Barthel et al. 2023) measure how a layout keeps the style
//!   distances.
//!
//! ```
//! use learner::explore::grid::{balance, cost, som, BalanceParams, SomParams};
//!
//! // Nine items on a 3×3 lattice of styles, two labels.
//! let points: Vec<f32> = (0..9).flat_map(|i| [(i / 3) as f32, (i % 3) as f32]).collect();
//! let labels = [0, 1, 0, 1, 0, 1, 0, 1, 0];
//! let map = som(&points, 2, &SomParams::new(3, 3))?;
//! let (grid, _) = balance(&points, 2, &labels, &map, &BalanceParams::default())?;
//! assert!(grid.holds_each_item_once(9));
//! assert_eq!(cost(&grid, &labels)?.empty, 0);
//! # Ok::<(), learner::Error>(())
//! ```

mod balance;
mod baselines;
mod cost;
mod eigen;
mod isomap;
mod lap;
mod quality;
mod som;
mod types;

pub use balance::{BalanceInfo, BalanceParams, balance, som_grid};
pub use baselines::{
    IsoMatchParams, MAX_ASSIGNMENT_ENTRIES, isomatch, isomatch_cost, random_layout,
};
pub use cost::{Cost, cost};
pub use isomap::{IsomapParams, isomap_2d};
pub use lap::{Assignment, linear_assignment};
pub use quality::{QualityParams, dpq, layout_spearman, spearman};
pub use som::{Som, SomInit, SomParams, som};
pub use types::{
    ExportNode, Grid, GridExport, MAX_COORDINATE, MAX_NODES, Node, NodeState, validate_points,
    validate_shape,
};

/// The SOM then [`balance`]: the balanced grid from points and labels in one call.
///
/// Errors: as [`som`] and [`balance`].
pub fn balanced_grid(
    points: &[f32],
    dim: usize,
    labels: &[u32],
    som_params: &SomParams,
    params: &BalanceParams,
) -> crate::Result<(Grid, BalanceInfo)> {
    validate_points(points, dim, Some(labels))?;
    let map = som(points, dim, som_params)?;
    balance(points, dim, labels, &map, params)
}

#[cfg(test)]
mod tests;

/// LAP, Spearman and classical MDS against scipy/numpy (reference values of
/// `scripts/reference/grid_reference.py`).
#[cfg(test)]
mod scipy_reference;
