//! The balanced grid of Garces et al. 2016 (§6.5.2): from the SOM's assignment of items to nodes,
//! Algorithm 3 turns every multi node into a single node (one item shown, the rest hidden behind
//! it), choosing the shown item to balance the semantic labels, and Algorithm 4 fills each empty
//! node with a hidden item from its 5×5 neighbourhood, lowering eq. 6.1 (`|empty| + label
//! imbalance + |multi|`, see [`super::cost`]).
//!
//! The paper's text was not available to us; the steps follow the description, and two
//! steps are ours, both needed for the guarantees tested here (with `n ≥ M·N` items every node
//! ends single; the label counts reach the best the data allow):
//! * after the 5×5 pass, empty nodes that found nothing look in 7×7, 9×9, … neighbourhoods until
//!   no node is empty or no item is hidden;
//! * a last pass moves hidden items of labels below their target into the nearest node (by
//!   lattice rings) that shows a label above its target, the displaced item staying hidden there.
//!
//! Choices inside a pass: an item of a label below its target first, then the item nearest (in
//! the style space) to the node's SOM weight, then the lowest item index; nodes in row-major
//! order. No item is ever lost or duplicated: each move takes an item out of one list and puts it
//! in another.

use std::collections::BTreeMap;

use super::cost::{Cost, cost, ideal_shares};
use super::som::Som;
use super::types::{Grid, NodeState, sq_dist, validate_points};
use crate::{Error, Result};

/// Parameters of [`balance`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BalanceParams {
    /// Half-width of Algorithm 4's neighbourhood: 2 is the paper's 5×5.
    pub radius: usize,
    /// Grow the neighbourhood beyond `radius` while empty nodes and hidden items remain (ours).
    pub grow: bool,
    /// Run the final label pass (ours).
    pub relabel: bool,
}

impl Default for BalanceParams {
    fn default() -> Self {
        BalanceParams {
            radius: 2,
            grow: true,
            relabel: true,
        }
    }
}

/// What [`balance`] did.
#[derive(Clone, Debug, PartialEq)]
pub struct BalanceInfo {
    /// Eq. 6.1 of the raw SOM layout ([`som_grid`]).
    pub som: Cost,
    /// After Algorithm 3.
    pub after_alg3: Cost,
    /// After Algorithm 4 at the paper's radius.
    pub after_alg4: Cost,
    /// Final.
    pub last: Cost,
    /// Empty nodes filled at the paper's radius.
    pub filled: usize,
    /// Empty nodes filled by the grown neighbourhoods.
    pub filled_grown: usize,
    /// Items moved by the label pass.
    pub relabelled: usize,
}

/// The raw SOM layout: each node holds the items whose BMU it is; a node with several is multi,
/// showing as a stand-in the item nearest its weight.
///
/// Errors: the SOM was not trained on these points.
pub fn som_grid(points: &[f32], dim: usize, som: &Som) -> Result<Grid> {
    let n = check(points, dim, None, som)?;
    let mut grid = Grid::empty(som.rows, som.cols);
    for i in 0..n {
        grid.nodes[som.bmu[i]].hidden.push(i);
    }
    for (j, node) in grid.nodes.iter_mut().enumerate() {
        let w = &som.weights[j * dim..(j + 1) * dim];
        if let Some(k) = nearest(&node.hidden, points, dim, w, |_| false) {
            node.shown = Some(node.hidden.remove(k));
            node.state = if node.hidden.is_empty() {
                NodeState::Single
            } else {
                NodeState::Multi
            };
        }
    }
    Ok(grid)
}

/// Algorithms 3 and 4 (and our two extensions, see the module docs) from the SOM's assignment.
///
/// Errors: labels not one per point, bad points, a SOM trained on other points.
pub fn balance(
    points: &[f32],
    dim: usize,
    labels: &[u32],
    som: &Som,
    params: &BalanceParams,
) -> Result<(Grid, BalanceInfo)> {
    let n = check(points, dim, Some(labels), som)?;
    let mut grid = som_grid(points, dim, som)?;
    let som_cost = cost(&grid, labels)?;
    let cells = grid.nodes.len();
    let targets: BTreeMap<u32, usize> = ideal_shares(labels, n.min(cells))
        .into_iter()
        .map(|(l, (_, t))| (l, t))
        .collect();
    let weight = |j: usize| &som.weights[j * dim..(j + 1) * dim];

    // Algorithm 3: multi → single. Labels of single nodes count first; then each multi node
    // shows the item that best serves the labels below target.
    let mut shown: BTreeMap<u32, usize> = BTreeMap::new();
    for node in grid.nodes.iter().filter(|x| x.state == NodeState::Single) {
        *shown
            .entry(labels[node.shown.expect("single")])
            .or_default() += 1;
    }
    for j in 0..cells {
        if grid.nodes[j].state != NodeState::Multi {
            continue;
        }
        let node = &mut grid.nodes[j];
        let mut items = std::mem::take(&mut node.hidden);
        items.push(node.shown.take().expect("multi shows a stand-in"));
        items.sort_unstable();
        let below = |i: usize| shown.get(&labels[i]).copied().unwrap_or(0) < targets[&labels[i]];
        let k = nearest(&items, points, dim, weight(j), below).expect("multi has items");
        let chosen = items.remove(k);
        *shown.entry(labels[chosen]).or_default() += 1;
        node.shown = Some(chosen);
        node.hidden = items;
        node.state = NodeState::Single;
    }
    let after_alg3 = cost(&grid, labels)?;

    // Algorithm 4: empty → single from the (2r+1)×(2r+1) neighbourhood, then (ours) wider.
    let mut hidden_left: usize = grid.nodes.iter().map(|x| x.hidden.len()).sum();
    let mut filled = [0usize; 2];
    let mut after_alg4 = after_alg3;
    let mut radius = params.radius;
    loop {
        for j in 0..cells {
            if hidden_left == 0 {
                break;
            }
            if grid.nodes[j].shown.is_some() {
                continue;
            }
            let below =
                |i: usize| shown.get(&labels[i]).copied().unwrap_or(0) < targets[&labels[i]];
            let mut pool: Vec<(usize, usize)> = Vec::new();
            for k in ring_box(grid.rows, grid.cols, j, radius) {
                pool.extend(grid.nodes[k].hidden.iter().map(|&i| (i, k)));
            }
            pool.sort_unstable();
            let items: Vec<usize> = pool.iter().map(|p| p.0).collect();
            if let Some(p) = nearest(&items, points, dim, weight(j), below) {
                let (item, donor) = pool[p];
                grid.nodes[donor].hidden.retain(|&i| i != item);
                grid.nodes[j].shown = Some(item);
                grid.nodes[j].state = NodeState::Single;
                *shown.entry(labels[item]).or_default() += 1;
                hidden_left -= 1;
                filled[usize::from(radius > params.radius)] += 1;
            }
        }
        if radius == params.radius {
            after_alg4 = cost(&grid, labels)?;
        }
        let empty = grid.nodes.iter().any(|x| x.shown.is_none());
        if !params.grow || !empty || hidden_left == 0 || radius >= grid.rows.max(grid.cols) {
            break;
        }
        radius += 1;
    }

    let relabelled = if params.relabel {
        relabel(&mut grid, labels, &targets, &mut shown)
    } else {
        0
    };
    let last = cost(&grid, labels)?;
    Ok((
        grid,
        BalanceInfo {
            som: som_cost,
            after_alg3,
            after_alg4,
            last,
            filled: filled[0],
            filled_grown: filled[1],
            relabelled,
        },
    ))
}

/// Our label pass: while a label is below its target, a hidden item of it replaces, at the
/// nearest node (in lattice rings around the item's node) showing a label above its target, the
/// shown item, which becomes hidden there. Returns the number of moves.
fn relabel(
    grid: &mut Grid,
    labels: &[u32],
    targets: &BTreeMap<u32, usize>,
    shown: &mut BTreeMap<u32, usize>,
) -> usize {
    let count = |s: &BTreeMap<u32, usize>, l: u32| s.get(&l).copied().unwrap_or(0);
    let mut moves = 0;
    let (rows, cols) = (grid.rows, grid.cols);
    for (&b, &target) in targets {
        let mut candidates: Vec<(usize, usize)> = Vec::new();
        for (j, node) in grid.nodes.iter().enumerate() {
            candidates.extend(
                node.hidden
                    .iter()
                    .filter(|&&i| labels[i] == b)
                    .map(|&i| (j, i)),
            );
        }
        for (home, item) in candidates {
            if count(shown, b) >= target {
                break;
            }
            let over =
                |s: &BTreeMap<u32, usize>, i: usize| count(s, labels[i]) > targets[&labels[i]];
            let found = (0..rows.max(cols)).find_map(|r| {
                ring(rows, cols, home, r)
                    .find(|&k| grid.nodes[k].shown.is_some_and(|i| over(shown, i)))
            });
            let Some(k) = found else { break };
            grid.nodes[home].hidden.retain(|&i| i != item);
            let displaced = grid.nodes[k].shown.replace(item).expect("shows an item");
            grid.nodes[k].hidden.push(displaced);
            grid.nodes[k].hidden.sort_unstable();
            *shown.entry(labels[displaced]).or_default() -= 1;
            *shown.entry(b).or_default() += 1;
            moves += 1;
        }
    }
    moves
}

/// Position in `items` of the item that satisfies `prefer`, then is nearest to `w`, then has
/// the lowest index (`items` sorted ascending).
fn nearest(
    items: &[usize],
    points: &[f32],
    dim: usize,
    w: &[f32],
    prefer: impl Fn(usize) -> bool,
) -> Option<usize> {
    let mut best: Option<(bool, f32, usize)> = None;
    for (k, &i) in items.iter().enumerate() {
        let key = (!prefer(i), sq_dist(&points[i * dim..(i + 1) * dim], w));
        if best.is_none_or(|(p, d, _)| (key.0, key.1) < (p, d)) {
            best = Some((key.0, key.1, k));
        }
    }
    best.map(|b| b.2)
}

/// Nodes within Chebyshev distance `r` of node `j`, row-major.
fn ring_box(rows: usize, cols: usize, j: usize, r: usize) -> impl Iterator<Item = usize> {
    let (r0, c0) = (j / cols, j % cols);
    (r0.saturating_sub(r)..(r0 + r + 1).min(rows)).flat_map(move |a| {
        (c0.saturating_sub(r)..(c0 + r + 1).min(cols)).map(move |b| a * cols + b)
    })
}

/// Nodes at Chebyshev distance exactly `r` of node `j`, row-major.
fn ring(rows: usize, cols: usize, j: usize, r: usize) -> impl Iterator<Item = usize> {
    let (r0, c0) = (j / cols, j % cols);
    ring_box(rows, cols, j, r)
        .filter(move |&k| (k / cols).abs_diff(r0).max((k % cols).abs_diff(c0)) == r)
}

fn check(points: &[f32], dim: usize, labels: Option<&[u32]>, som: &Som) -> Result<usize> {
    let n = validate_points(points, dim, labels)?;
    if som.dim != dim || som.bmu.len() != n || som.weights.len() != som.rows * som.cols * dim {
        return Err(Error::LengthMismatch {
            what: "items of the SOM (it was trained on other points)",
            expected: n,
            got: som.bmu.len(),
        });
    }
    Ok(n)
}
