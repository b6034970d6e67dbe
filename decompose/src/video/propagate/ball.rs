//! The mean reflectance of one cluster's colours inside a wide colour ball: the reflectance a
//! propagated pixel takes when [`super::PropagateParams::reflectance_radius`] is positive.
//!
//! `𝓘_k` keeps, per exact 8-bit colour of cluster `k`, the mean reflectance of the first
//! frame's pixels of that colour (§3.4). Under a moving light one albedo's colour changes from
//! frame to frame, and an exact bin carries the first frame's decomposition error pixel by
//! pixel; the mean over a ball of nearby colours pools it. The ball's bins are found through a
//! grid of cells of 16³ colours per cluster, so a query reads the cells that meet the ball,
//! not its volume (`(2r + 1)³` colours); a [`ReflectanceMemo`] keeps the answers while the
//! tables stay the same.

use std::collections::HashMap;

use rayon::prelude::*;

use super::tables::{ClusterTables, add3};

/// Side of a grid cell, in 8-bit colour units (a power of two).
const CELL_SHIFT: u32 = 4;
const CELLS_PER_AXIS: u32 = 256 >> CELL_SHIFT;

/// The bins of every cluster grouped by (cluster, cell), built by a counting sort of the
/// tables' bins (O(bins + clusters × cells)) once per state of the tables. It holds positions
/// in the tables' bin array, so it is valid only for the tables it was built from, unchanged.
#[derive(Debug)]
pub(super) struct BallIndex {
    /// `order[start[c]..start[c + 1]]` are the positions in `ClusterTables::entries` of the
    /// bins in cell `c % CELLS` of cluster `c / CELLS`.
    start: Vec<u32>,
    order: Vec<u32>,
}

const CELLS: usize = (CELLS_PER_AXIS * CELLS_PER_AXIS * CELLS_PER_AXIS) as usize;

fn cell_of(cluster: u32, cell: [u32; 3]) -> usize {
    cluster as usize * CELLS
        + ((cell[0] * CELLS_PER_AXIS + cell[1]) * CELLS_PER_AXIS + cell[2]) as usize
}

impl BallIndex {
    pub(super) fn new(tables: &ClusterTables) -> Self {
        let slot = |e: &super::tables::Entry| {
            cell_of(e.cluster, e.rgb.map(|v| u32::from(v) >> CELL_SHIFT))
        };
        let mut start = vec![0u32; tables.clusters.len() * CELLS + 1];
        for e in &tables.entries {
            start[slot(e) + 1] += 1;
        }
        for j in 1..start.len() {
            start[j] += start[j - 1];
        }
        // Scattered in the tables' (colour, cluster) order, so every cell's bins, and the
        // sums over them, come in a fixed order whatever the thread count.
        let mut next = start.clone();
        let mut order = vec![0u32; tables.entries.len()];
        for (pos, e) in tables.entries.iter().enumerate() {
            let j = &mut next[slot(e)];
            order[*j as usize] = pos as u32;
            *j += 1;
        }
        Self { start, order }
    }

    /// The count-weighted mean reflectance of cluster `k`'s bins within Euclidean distance
    /// `radius` (inclusive) of `colour`; `None` when the ball holds none of them (or `k` is
    /// not a cluster of the tables). `tables` must be those the index was built from.
    pub(super) fn mean(
        &self,
        tables: &ClusterTables,
        colour: [u8; 3],
        radius: f64,
        k: u32,
    ) -> Option<[f32; 3]> {
        if (k as usize + 1) * CELLS >= self.start.len() {
            return None;
        }
        let c = colour.map(i32::from);
        let reach = radius.floor().min(255.0) as i32;
        let r2 = radius * radius;
        let lo = c.map(|v| ((v - reach).max(0) as u32) >> CELL_SHIFT);
        let hi = c.map(|v| ((v + reach).min(255) as u32) >> CELL_SHIFT);
        let (mut count, mut sum) = (0u64, [0.0f64; 3]);
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                for z in lo[2]..=hi[2] {
                    let cell = [x, y, z];
                    if cell_gap2(cell, c) > r2 {
                        continue;
                    }
                    let j = cell_of(k, cell);
                    for &pos in &self.order[self.start[j] as usize..self.start[j + 1] as usize] {
                        let e = &tables.entries[pos as usize];
                        let d2: i32 = (0..3).map(|i| (i32::from(e.rgb[i]) - c[i]).pow(2)).sum();
                        if f64::from(d2) <= r2 {
                            count += e.count;
                            add3(&mut sum, e.refl_sum);
                        }
                    }
                }
            }
        }
        (count > 0).then(|| sum.map(|v| (v / count as f64) as f32))
    }
}

/// Squared distance from `c` to the nearest colour of `cell`.
fn cell_gap2(cell: [u32; 3], c: [i32; 3]) -> f64 {
    let side = 1i32 << CELL_SHIFT;
    (0..3)
        .map(|i| {
            let lo = cell[i] as i32 * side;
            let hi = lo + side - 1;
            let g = if c[i] < lo {
                lo - c[i]
            } else if c[i] > hi {
                c[i] - hi
            } else {
                0
            };
            f64::from(g * g)
        })
        .sum()
}

/// Reflectances of (colour, cluster) pairs under a colour ball
/// ([`super::PropagateParams::reflectance_radius`]), kept between calls of
/// [`super::propagate_with`] for as long as the tables do not change (they change only in
/// [`ClusterTables::update`], at completed frames). Consecutive frames share most of their
/// colours, so most pairs are read from here instead of summing the ball again.
///
/// A memo serves one [`ClusterTables`] at a time: given other tables (or the same after an
/// update, or another radius) it starts afresh, so it never returns a stale value. Memory: the
/// ball index (4 bytes per bin of `𝓘_k`, and 16 KiB per cluster) and about 30 bytes per
/// pair; once past [`ReflectanceMemo::CAPACITY`] pairs it starts afresh at the next call.
#[derive(Debug, Default)]
pub struct ReflectanceMemo {
    stamp: u64,
    radius: f64,
    index: Option<BallIndex>,
    means: HashMap<(u32, u32), [f32; 3]>,
}

impl ReflectanceMemo {
    /// Most (colour, cluster) pairs kept.
    pub const CAPACITY: usize = 1 << 20;

    /// A memo with nothing in it.
    pub fn new() -> Self {
        Self::default()
    }

    /// Pairs currently kept.
    pub fn len(&self) -> usize {
        self.means.len()
    }

    /// Whether no pair is kept.
    pub fn is_empty(&self) -> bool {
        self.means.is_empty()
    }

    /// Empties the memo unless it belongs to `tables` and `radius`.
    fn serve(&mut self, tables: &ClusterTables, radius: f64) {
        if self.stamp != tables.stamp || self.radius != radius || self.means.len() > Self::CAPACITY
        {
            self.stamp = tables.stamp;
            self.radius = radius;
            self.index = None;
            self.means.clear();
        }
    }

    /// The reflectance of each (packed 8-bit colour `0x00RRGGBB`, cluster) pair of `pairs`:
    /// the mean of the cluster's bins within `radius`, or, when that ball holds none, within
    /// the Parzen radius `d` (which holds one for every assigned pair).
    pub(super) fn means(
        &mut self,
        tables: &ClusterTables,
        radius: f64,
        d: f64,
        pairs: &[(u32, u32)],
    ) -> Vec<[f32; 3]> {
        self.serve(tables, radius);
        let fresh: Vec<(u32, u32)> = pairs
            .iter()
            .filter(|p| !self.means.contains_key(p))
            .copied()
            .collect();
        if !fresh.is_empty() {
            let index = self.index.get_or_insert_with(|| BallIndex::new(tables));
            let computed: Vec<[f32; 3]> = fresh
                .par_iter()
                .map(|&(colour, k)| {
                    let [_, r, g, b] = colour.to_be_bytes();
                    index
                        .mean(tables, [r, g, b], radius, k)
                        .or_else(|| tables.ball_mean([r, g, b], d, k))
                        .expect("an assigned cluster has a bin in the Parzen ball")
                })
                .collect();
            self.means.extend(fresh.into_iter().zip(computed));
        }
        pairs.iter().map(|p| self.means[p]).collect()
    }
}
