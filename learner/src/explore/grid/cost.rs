//! The cost of a grid layout, eq. 6.1 of Garces et al. 2016 (§6.5.2): the number of empty nodes,
//! the label imbalance of the shown items, and the number of multi nodes, summed with unit
//! weights.
//!
//! Label imbalance, precisely: with `n` items, `C = M·N` nodes and `S = min(n, C)` slots, the
//! ideal number of shown items of label `l` (which has `c_l` items) is the water-filling share
//! `ideal_l = min(c_l, t)` with `t` chosen so that `Σ_l ideal_l = S`: every label gets an equal
//! share of the grid unless it has fewer items than that. The imbalance is
//! `Σ_l |shown_l − ideal_l|`. An empty slot therefore also costs imbalance (an item is missing);
//! with all labels equal the term is 0 exactly when every slot is used.

use std::collections::BTreeMap;

use super::types::{Grid, NodeState};
use crate::{Error, Result};

/// The terms of eq. 6.1.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Cost {
    /// Nodes that show nothing.
    pub empty: usize,
    /// Nodes whose items were not resolved into one shown item.
    pub multi: usize,
    /// `Σ_l |shown_l − ideal_l|`.
    pub imbalance: f64,
    /// `empty + imbalance + multi`.
    pub total: f64,
}

/// The real-valued ideal share of each label for `slots` shown items (water-filling), and the
/// integer targets closest to it (the shares rounded down, the remainder one each to the labels
/// that still have items, lowest label first). `Σ_l |target_l − ideal_l|` is the smallest
/// imbalance any layout can reach.
pub(crate) fn ideal_shares(labels: &[u32], slots: usize) -> BTreeMap<u32, (f64, usize)> {
    let mut count: BTreeMap<u32, usize> = BTreeMap::new();
    for &l in labels {
        *count.entry(l).or_default() += 1;
    }
    let mut by_count: Vec<(usize, u32)> = count.iter().map(|(&l, &c)| (c, l)).collect();
    by_count.sort_unstable();
    let mut out = BTreeMap::new();
    let (mut left, mut rest) = (slots as f64, by_count.len());
    let mut capped = Vec::new();
    for &(c, l) in &by_count {
        let share = left / rest as f64;
        if (c as f64) <= share {
            out.insert(l, (c as f64, c));
            left -= c as f64;
            rest -= 1;
        } else {
            capped.push(l);
        }
    }
    if !capped.is_empty() {
        let t = left / capped.len() as f64;
        let floor = t.floor() as usize;
        let mut remainder = (left as usize).saturating_sub(floor * capped.len());
        capped.sort_unstable();
        for l in capped {
            let extra = usize::from(remainder > 0);
            remainder -= extra;
            out.insert(l, (t, floor + extra));
        }
    }
    out
}

/// Eq. 6.1 of a grid for items with `labels` (one per item; all equal when there are none).
///
/// Errors: the grid does not hold each of the `labels.len()` items exactly once.
pub fn cost(grid: &Grid, labels: &[u32]) -> Result<Cost> {
    let n = labels.len();
    if !grid.holds_each_item_once(n) {
        return Err(Error::LengthMismatch {
            what: "labels (the grid does not hold each item exactly once)",
            expected: grid
                .nodes
                .iter()
                .map(|x| x.hidden.len() + x.shown.is_some() as usize)
                .sum(),
            got: n,
        });
    }
    let slots = n.min(grid.nodes.len());
    let shares = ideal_shares(labels, slots);
    let mut shown: BTreeMap<u32, usize> = BTreeMap::new();
    for i in grid.nodes.iter().filter_map(|x| x.shown) {
        *shown.entry(labels[i]).or_default() += 1;
    }
    let imbalance = shares
        .iter()
        .map(|(l, (ideal, _))| (shown.get(l).copied().unwrap_or(0) as f64 - ideal).abs())
        .sum::<f64>();
    let empty = grid.nodes.iter().filter(|x| x.shown.is_none()).count();
    let multi = grid
        .nodes
        .iter()
        .filter(|x| x.state == NodeState::Multi)
        .count();
    Ok(Cost {
        empty,
        multi,
        imbalance,
        total: empty as f64 + imbalance + multi as f64,
    })
}
