//! The grid every layout returns, its validation, and its JSON form for the command line.

use serde::{Deserialize, Serialize};

use crate::{Error, Result};

/// The most nodes a grid may have (`M·N`): 250,000 (a 500×500 grid) keeps the SOM's weights and
/// the layouts' bookkeeping well under a gigabyte for any style dimension we use.
pub const MAX_NODES: usize = 250_000;

/// The largest coordinate magnitude accepted in a point (squared distances stay finite in `f32`).
pub const MAX_COORDINATE: f32 = 1e15;

/// What a node holds after a layout (Garces et al. 2016, §6.5.2, eq. 6.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum NodeState {
    /// No item: a hole in the displayed grid.
    Empty,
    /// One item chosen to be shown (others, if any, are hidden behind it).
    Single,
    /// Several items landed here and the layout did not choose one (the raw SOM); `shown` is then
    /// only a stand-in (the item nearest the node's weight vector) so the layout can be measured.
    Multi,
}

/// One cell of the grid.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Node {
    /// 0-based row.
    pub row: usize,
    /// 0-based column.
    pub col: usize,
    /// The item shown (index into the input), if any.
    pub shown: Option<usize>,
    /// Items reachable from this node but not shown (opening the node lists them).
    pub hidden: Vec<usize>,
    /// Empty, single or multi.
    pub state: NodeState,
}

/// An `rows × cols` grid of nodes, row-major (`nodes[row·cols + col]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Grid {
    /// Rows `M`.
    pub rows: usize,
    /// Columns `N`.
    pub cols: usize,
    /// `rows·cols` nodes, row-major.
    pub nodes: Vec<Node>,
}

impl Grid {
    /// An all-empty grid (shape not validated: callers validate first).
    pub(crate) fn empty(rows: usize, cols: usize) -> Grid {
        let nodes = (0..rows * cols)
            .map(|k| Node {
                row: k / cols,
                col: k % cols,
                shown: None,
                hidden: Vec::new(),
                state: NodeState::Empty,
            })
            .collect();
        Grid { rows, cols, nodes }
    }

    /// Whether every item `0..n` appears exactly once, shown or hidden, and nothing else does.
    pub fn holds_each_item_once(&self, n: usize) -> bool {
        let mut seen = vec![false; n];
        for node in &self.nodes {
            for &i in node.shown.iter().chain(&node.hidden) {
                if i >= n || seen[i] {
                    return false;
                }
                seen[i] = true;
            }
        }
        seen.into_iter().all(|s| s)
    }

    /// The items shown, with their node's `(row, col)`.
    pub fn shown(&self) -> Vec<(usize, usize, usize)> {
        self.nodes
            .iter()
            .filter_map(|n| n.shown.map(|i| (i, n.row, n.col)))
            .collect()
    }

    /// The JSON form for the command line: items as ids, with the shown item's label.
    ///
    /// Errors: `ids` or `labels` not one entry per item of the grid (`n` = their length).
    pub fn export(&self, ids: &[String], labels: &[String]) -> Result<GridExport> {
        if ids.len() != labels.len() {
            return Err(Error::LengthMismatch {
                what: "labels of the ids",
                expected: ids.len(),
                got: labels.len(),
            });
        }
        if !self.holds_each_item_once(ids.len()) {
            return Err(Error::LengthMismatch {
                what: "ids (the grid does not hold each of them exactly once)",
                expected: ids.len(),
                got: self
                    .nodes
                    .iter()
                    .map(|n| n.hidden.len() + n.shown.is_some() as usize)
                    .sum(),
            });
        }
        let nodes = self
            .nodes
            .iter()
            .map(|n| ExportNode {
                row: n.row,
                col: n.col,
                id: n.shown.map(|i| ids[i].clone()),
                label: n.shown.map(|i| labels[i].clone()),
                state: n.state,
                hidden: n.hidden.iter().map(|&i| ids[i].clone()).collect(),
            })
            .collect();
        Ok(GridExport {
            rows: self.rows,
            cols: self.cols,
            nodes,
        })
    }
}

/// [`Grid`] with item ids: `{"rows","cols","nodes":[{"row","col","id","label","state","hidden"}]}`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GridExport {
    /// Rows.
    pub rows: usize,
    /// Columns.
    pub cols: usize,
    /// Row-major nodes.
    pub nodes: Vec<ExportNode>,
}

/// A node of [`GridExport`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ExportNode {
    /// Row.
    pub row: usize,
    /// Column.
    pub col: usize,
    /// The shown item's id.
    pub id: Option<String>,
    /// The shown item's label.
    pub label: Option<String>,
    /// Empty, single or multi.
    pub state: NodeState,
    /// Ids of the hidden items.
    pub hidden: Vec<String>,
}

/// Checks `rows × cols`: both at least 1, at most [`MAX_NODES`] nodes.
pub fn validate_shape(rows: usize, cols: usize) -> Result<()> {
    if rows == 0 || cols == 0 {
        return Err(Error::BadGridShape {
            rows,
            cols,
            reason: "both sides must be at least 1",
        });
    }
    if rows.checked_mul(cols).is_none_or(|c| c > MAX_NODES) {
        return Err(Error::BadGridShape {
            rows,
            cols,
            reason: "at most 250,000 nodes (MAX_NODES)",
        });
    }
    Ok(())
}

/// Checks points (row-major, `dim` per row, at least one row, finite, at most
/// [`MAX_COORDINATE`]) and, when given, one label per point. Returns the number of points.
pub fn validate_points(points: &[f32], dim: usize, labels: Option<&[u32]>) -> Result<usize> {
    if dim == 0 {
        return Err(Error::InvalidParameter {
            name: "dim",
            value: "0".into(),
            reason: "points need at least one coordinate",
        });
    }
    if !points.len().is_multiple_of(dim) {
        return Err(Error::NotAMatrix {
            len: points.len(),
            dim,
        });
    }
    let n = points.len() / dim;
    if n == 0 {
        return Err(Error::NotEnoughData {
            what: "a grid layout (points)",
            needed: 1,
            got: 0,
        });
    }
    if let Some(i) = points
        .iter()
        .position(|v| !v.is_finite() || v.abs() > MAX_COORDINATE)
    {
        return Err(Error::BadCoordinate {
            row: i / dim,
            column: i % dim,
            value: points[i] as f64,
            limit: MAX_COORDINATE as f64,
        });
    }
    if let Some(l) = labels
        && l.len() != n
    {
        return Err(Error::LengthMismatch {
            what: "labels",
            expected: n,
            got: l.len(),
        });
    }
    Ok(n)
}

/// Squared Euclidean distance in `f32` with eight accumulators (vectorises).
#[inline]
pub(crate) fn sq_dist(a: &[f32], b: &[f32]) -> f32 {
    let mut acc = [0f32; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..8 {
            let d = x[k] - y[k];
            acc[k] += d * d;
        }
    }
    let mut s: f32 = acc.iter().sum();
    for (x, y) in ra.iter().zip(rb) {
        s += (x - y) * (x - y);
    }
    s
}

/// Dot product in `f32` with eight accumulators.
#[inline]
pub(crate) fn dot(a: &[f32], b: &[f32]) -> f32 {
    let mut acc = [0f32; 8];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for k in 0..8 {
            acc[k] += x[k] * y[k];
        }
    }
    let mut s: f32 = acc.iter().sum();
    for (x, y) in ra.iter().zip(rb) {
        s += x * y;
    }
    s
}
