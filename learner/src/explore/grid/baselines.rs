//! The layouts the balanced grid is compared with: a seeded random layout, and an IsoMatch-style
//! layout (Fried et al. 2015, "IsoMatch: Creating Informative Grid Layouts"): Isomap to two
//! dimensions, scaled onto the grid, then the optimal assignment of items to cells.

use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::isomap::{IsomapParams, isomap_2d};
use super::lap::linear_assignment;
use super::types::{Grid, NodeState, sq_dist, validate_points, validate_shape};
use crate::{Error, Result};

/// The largest assignment matrix IsoMatch builds (items × cells): 25,000,000 `f64` (200 MB),
/// e.g. 5,000 items on 5,000 cells. The exact solver is O(n³) besides.
pub const MAX_ASSIGNMENT_ENTRIES: usize = 25_000_000;

/// `n` items on an `rows × cols` grid in a seeded random order: the first `min(n, M·N)` are shown
/// on distinct random cells, the others hidden at random nodes.
///
/// Errors: a bad grid shape.
pub fn random_layout(n: usize, rows: usize, cols: usize, seed: u64) -> Result<Grid> {
    validate_shape(rows, cols)?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut grid = Grid::empty(rows, cols);
    let cells = rows * cols;
    let mut items: Vec<usize> = (0..n).collect();
    items.shuffle(&mut rng);
    let mut order: Vec<usize> = (0..cells).collect();
    order.shuffle(&mut rng);
    for (k, &i) in items.iter().enumerate() {
        if k < cells {
            let node = &mut grid.nodes[order[k]];
            node.shown = Some(i);
            node.state = NodeState::Single;
        } else {
            grid.nodes[order[rng.random_range(0..cells.min(n))]]
                .hidden
                .push(i);
        }
    }
    Ok(grid)
}

/// Parameters of [`isomatch`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct IsoMatchParams {
    /// Grid rows.
    pub rows: usize,
    /// Grid columns.
    pub cols: usize,
    /// The embedding.
    pub isomap: IsomapParams,
    /// Seed choosing the shown items when there are more items than cells.
    pub seed: u64,
}

impl IsoMatchParams {
    /// Defaults for an `rows × cols` grid.
    pub fn new(rows: usize, cols: usize) -> IsoMatchParams {
        IsoMatchParams {
            rows,
            cols,
            isomap: IsomapParams::default(),
            seed: 0,
        }
    }
}

/// IsoMatch's assignment problem: the items placed (all, or a seeded sample of `M·N`) and the
/// row-major `placed × cells` matrix of squared distances between each item's scaled Isomap
/// position and each cell (see [`isomatch`]).
///
/// Errors: as [`isomatch`].
pub fn isomatch_cost(
    points: &[f32],
    dim: usize,
    params: &IsoMatchParams,
) -> Result<(Vec<usize>, Vec<f64>)> {
    let (rows, cols) = (params.rows, params.cols);
    validate_shape(rows, cols)?;
    let n = validate_points(points, dim, None)?;
    let cells = rows * cols;
    let placed: Vec<usize> = if n <= cells {
        (0..n).collect()
    } else {
        let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
        let mut p = rand::seq::index::sample(&mut rng, n, cells).into_vec();
        p.sort_unstable();
        p
    };
    let m = placed.len();
    if m.saturating_mul(cells) > MAX_ASSIGNMENT_ENTRIES {
        return Err(Error::BadGridShape {
            rows,
            cols,
            reason: "IsoMatch's assignment matrix (placed items × cells) would exceed 25,000,000 entries",
        });
    }
    let sub: Vec<f32> = placed
        .iter()
        .flat_map(|&i| points[i * dim..(i + 1) * dim].iter().copied())
        .collect();
    let (coords, _) = isomap_2d(&sub, dim, &params.isomap)?;
    // Leading axis along the longer side of the grid.
    let (ax_row, ax_col) = if rows > cols { (0, 1) } else { (1, 0) };
    let scale = |axis: usize, len: usize| -> Vec<f64> {
        let (lo, hi) = coords
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), c| {
                (l.min(c[axis]), h.max(c[axis]))
            });
        let span = hi - lo;
        coords
            .iter()
            .map(|c| {
                if span > 0.0 {
                    (c[axis] - lo) / span * (len - 1) as f64
                } else {
                    (len - 1) as f64 / 2.0
                }
            })
            .collect()
    };
    let (y, x) = (scale(ax_row, rows), scale(ax_col, cols));
    let mut cost = vec![0.0f64; m * cells];
    for i in 0..m {
        for cell in 0..cells {
            let (r, c) = ((cell / cols) as f64, (cell % cols) as f64);
            cost[i * cells + cell] = (y[i] - r).powi(2) + (x[i] - c).powi(2);
        }
    }
    Ok((placed, cost))
}

/// IsoMatch: Isomap coordinates of the items, each axis scaled by min–max onto the grid (the
/// leading axis along the longer side), then the assignment of items to cells minimising the
/// total squared distance between an item's scaled position and its cell
/// ([`linear_assignment`]). With more items than cells, a seeded random choice of `M·N` items is
/// placed and every other item is hidden at the node of its nearest placed item (in the style
/// space); this choice is ours, IsoMatch itself shows every item.
///
/// Errors: bad points or shape, fewer than 3 items, an assignment matrix over
/// [`MAX_ASSIGNMENT_ENTRIES`].
pub fn isomatch(points: &[f32], dim: usize, params: &IsoMatchParams) -> Result<Grid> {
    let (placed, cost) = isomatch_cost(points, dim, params)?;
    let (rows, cols) = (params.rows, params.cols);
    let (n, cells, m) = (points.len() / dim, rows * cols, placed.len());
    let assignment = linear_assignment(&cost, m, cells)?;
    let mut grid = Grid::empty(rows, cols);
    let mut node_of = vec![usize::MAX; n];
    for (k, &cell) in assignment.col.iter().enumerate() {
        grid.nodes[cell].shown = Some(placed[k]);
        grid.nodes[cell].state = NodeState::Single;
        node_of[placed[k]] = cell;
    }
    for i in 0..n {
        if node_of[i] != usize::MAX {
            continue;
        }
        let xi = &points[i * dim..(i + 1) * dim];
        let nearest = placed
            .iter()
            .copied()
            .min_by(|&a, &b| {
                sq_dist(xi, &points[a * dim..(a + 1) * dim])
                    .total_cmp(&sq_dist(xi, &points[b * dim..(b + 1) * dim]))
                    .then(a.cmp(&b))
            })
            .expect("at least one placed item");
        grid.nodes[node_of[nearest]].hidden.push(i);
    }
    Ok(grid)
}
