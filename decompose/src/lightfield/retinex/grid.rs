//! The finest level of the multigrid: the view's pixel grid, a weighted 5-point graph
//! Laplacian plus the screening `μI`, with row-wise loops (no per-pixel index arithmetic) since
//! most of the work of a cycle is spent here.

use super::graph::{Adjacency, Graph};

/// One level: `A x = diagonal ∘ x − Σ_pairs w (x_neighbour)` on a `width × height` grid.
#[derive(Clone, Debug)]
pub(super) struct Level {
    pub width: usize,
    pub height: usize,
    /// Weight of the pair `(p, p + 1)`; 0 in the last column, so the loops need no bounds test
    /// on the weight (only on the index).
    pub horizontal: Vec<f32>,
    /// Weight of the pair `(p, p + width)`; 0 in the last row.
    pub vertical: Vec<f32>,
    /// The screening diagonal (`μ` on the finest level).
    pub screening: Vec<f64>,
    /// `screening + Σ incident pair weights`.
    pub diagonal: Vec<f64>,
    /// `1 / diagonal`: Gauss–Seidel multiplies by it, keeping a division out of its dependency
    /// chain.
    inverse_diagonal: Vec<f64>,
}

impl Level {
    /// The level of the given pair weights (entries past the last column or row are ignored) and
    /// screening.
    pub fn new(
        width: usize,
        height: usize,
        mut horizontal: Vec<f32>,
        mut vertical: Vec<f32>,
        screening: Vec<f64>,
    ) -> Self {
        let n = width * height;
        debug_assert!(horizontal.len() == n && vertical.len() == n && screening.len() == n);
        for y in 0..height {
            horizontal[y * width + width - 1] = 0.0;
        }
        vertical[n - width..].fill(0.0);
        let mut diagonal = screening.clone();
        for p in 0..n {
            let (h, v) = (horizontal[p] as f64, vertical[p] as f64);
            diagonal[p] += h + v;
            if h != 0.0 {
                diagonal[p + 1] += h;
            }
            if v != 0.0 {
                diagonal[p + width] += v;
            }
        }
        let inverse_diagonal = diagonal.iter().map(|d| 1.0 / d).collect();
        Self {
            width,
            height,
            horizontal,
            vertical,
            screening,
            diagonal,
            inverse_diagonal,
        }
    }

    /// `out = A x`.
    pub fn apply(&self, x: &[f64], out: &mut [f64]) {
        for (y, row) in out.chunks_exact_mut(self.width).enumerate() {
            self.apply_row(x, y, row);
        }
    }

    /// Row `y` of `A x`. Rows are processed as whole slices (no per-pixel index arithmetic or
    /// bounds branches) so that the compiler vectorises them.
    #[inline]
    fn apply_row(&self, x: &[f64], y: usize, out: &mut [f64]) {
        let w = self.width;
        let r = y * w;
        let (xr, hw, d) = (
            &x[r..r + w],
            &self.horizontal[r..r + w],
            &self.diagonal[r..r + w],
        );
        for i in 0..w {
            out[i] = d[i] * xr[i];
        }
        // Two loops, not one: a single loop would carry `out[i + 1]` into the next iteration
        // and stop vectorisation.
        for ((o, h), x) in out[..w - 1].iter_mut().zip(&hw[..w - 1]).zip(&xr[1..]) {
            *o -= *h as f64 * x;
        }
        for ((o, h), x) in out[1..].iter_mut().zip(&hw[..w - 1]).zip(&xr[..w - 1]) {
            *o -= *h as f64 * x;
        }
        if y > 0 {
            let (up, vw) = (&x[r - w..r], &self.vertical[r - w..r]);
            for i in 0..w {
                out[i] -= vw[i] as f64 * up[i];
            }
        }
        if y + 1 < self.height {
            let (down, vw) = (&x[r + w..r + 2 * w], &self.vertical[r..r + w]);
            for i in 0..w {
                out[i] -= vw[i] as f64 * down[i];
            }
        }
    }

    /// `t = b + Σ vertical-neighbour terms` of row `y`: the part of a Gauss–Seidel update that
    /// does not depend on the row itself, computed vectorised before the sequential part.
    #[inline]
    fn vertical_terms(&self, b: &[f64], x: &[f64], y: usize, t: &mut [f64]) {
        let w = self.width;
        let r = y * w;
        t.copy_from_slice(&b[r..r + w]);
        if y > 0 {
            let (up, vw) = (&x[r - w..r], &self.vertical[r - w..r]);
            for i in 0..w {
                t[i] += vw[i] as f64 * up[i];
            }
        }
        if y + 1 < self.height {
            let (down, vw) = (&x[r + w..r + 2 * w], &self.vertical[r..r + w]);
            for i in 0..w {
                t[i] += vw[i] as f64 * down[i];
            }
        }
    }

    /// One forward Gauss–Seidel sweep (rows top to bottom, pixels left to right). With
    /// `from_zero` the sweep assumes `x = 0` on entry (the pre-smoothing of a preconditioner,
    /// whose start is always 0) and never reads what it has not yet written.
    pub fn forward(&self, b: &[f64], x: &mut [f64], from_zero: bool, t: &mut [f64]) {
        let w = self.width;
        for y in 0..self.height {
            if from_zero {
                // Only the row above is known; the one below is still 0.
                let r = y * w;
                t.copy_from_slice(&b[r..r + w]);
                if y > 0 {
                    for i in 0..w {
                        t[i] += self.vertical[r - w + i] as f64 * x[r - w + i];
                    }
                }
            } else {
                self.vertical_terms(b, x, y, t);
            }
            let r = y * w;
            let (hw, inv) = (&self.horizontal[r..r + w], &self.inverse_diagonal[r..r + w]);
            let row = &mut x[r..r + w];
            let mut left = 0.0;
            for i in 0..w {
                let right = if from_zero || i + 1 == w {
                    0.0
                } else {
                    hw[i] as f64 * row[i + 1]
                };
                let left_w = if i == 0 { 0.0 } else { hw[i - 1] as f64 };
                let v = (t[i] + left_w * left + right) * inv[i];
                row[i] = v;
                left = v;
            }
        }
    }

    /// One backward Gauss–Seidel sweep: the adjoint of [`Self::forward`], which makes the
    /// V-cycle symmetric.
    pub fn backward(&self, b: &[f64], x: &mut [f64], t: &mut [f64]) {
        let w = self.width;
        for y in (0..self.height).rev() {
            self.vertical_terms(b, x, y, t);
            let r = y * w;
            let (hw, inv) = (&self.horizontal[r..r + w], &self.inverse_diagonal[r..r + w]);
            let row = &mut x[r..r + w];
            let mut right = 0.0;
            for i in (0..w).rev() {
                let left = if i == 0 {
                    0.0
                } else {
                    hw[i - 1] as f64 * row[i - 1]
                };
                let v = (t[i] + hw[i] as f64 * right + left) * inv[i];
                row[i] = v;
                right = v;
            }
        }
    }

    /// `coarse_b += Pᵀ (b − A x)` for the aggregates `aggregate`, one row at a time (`t` holds
    /// a row).
    pub fn restrict_residual(
        &self,
        b: &[f64],
        x: &[f64],
        aggregate: &[u32],
        coarse_b: &mut [f64],
        t: &mut [f64],
    ) {
        let w = self.width;
        for y in 0..self.height {
            self.apply_row(x, y, t);
            let r = y * w..(y + 1) * w;
            for ((ax, bi), &c) in t.iter().zip(&b[r.clone()]).zip(&aggregate[r]) {
                coarse_b[c as usize] += bi - ax;
            }
        }
    }

    /// The operator as a dense matrix (tests only).
    #[cfg(test)]
    pub fn dense(&self) -> Vec<Vec<f64>> {
        let n = self.width * self.height;
        let mut e = vec![0.0; n];
        let mut out = vec![vec![0.0; n]; n];
        for j in 0..n {
            e.fill(0.0);
            e[j] = 1.0;
            let mut col = vec![0.0; n];
            self.apply(&e, &mut col);
            for i in 0..n {
                out[i][j] = col[i];
            }
        }
        out
    }
}

/// The aggregation of [`super::graph::coarsen`] for the pixel grid, block by block without its
/// generic bookkeeping (sorting by block, union-find arrays): the finest level is the largest,
/// and its set-up is part of every view's solve. Gives the same aggregates, numbering and coarse
/// operator, bit for bit (tested).
pub(super) fn coarsen_grid(level: &Level, strength: f64) -> (Graph, Vec<u32>) {
    let (w, h) = (level.width, level.height);
    let (cw, ch) = (w.div_ceil(2), h.div_ceil(2));
    let (hw, vw) = (&level.horizontal, &level.vertical);
    let mut strongest = vec![0.0f32; w * h];
    for y in 0..h {
        for x in 0..w {
            let p = y * w + x;
            // The last column's and row's weights are 0, so they can be read unconditionally.
            let mut m = hw[p].max(vw[p]);
            if x > 0 {
                m = m.max(hw[p - 1]);
            }
            if y > 0 {
                m = m.max(vw[p - w]);
            }
            strongest[p] = m;
        }
    }
    let strong = |p: usize, q: usize, weight: f32| {
        weight as f64 >= strength * strongest[p].max(strongest[q]) as f64
    };
    let mut aggregate = vec![0u32; w * h];
    let mut cell = Vec::with_capacity(cw * ch);
    let mut screening = Vec::with_capacity(cw * ch);
    // Labels of the four slots (top left, top right, bottom left, bottom right) of every block:
    // the smallest slot of each slot's component.
    let mut labels = vec![[0u8; 4]; cw * ch];
    for by in 0..ch {
        for bx in 0..cw {
            let (right, down) = (2 * bx + 1 < w, 2 * by + 1 < h);
            let a = 2 * by * w + 2 * bx;
            let mut label = [0u8, 1, 2, 3];
            let mut join = |i: usize, j: usize| {
                let (lo, hi) = (label[i].min(label[j]), label[i].max(label[j]));
                label.iter_mut().filter(|l| **l == hi).for_each(|l| *l = lo);
            };
            if right && strong(a, a + 1, hw[a]) {
                join(0, 1);
            }
            if down && strong(a, a + w, vw[a]) {
                join(0, 2);
            }
            if right && down && strong(a + 1, a + w + 1, vw[a + 1]) {
                join(1, 3);
            }
            if right && down && strong(a + w, a + w + 1, hw[a + w]) {
                join(2, 3);
            }
            let mut id = [u32::MAX; 4];
            for (slot, p, present) in block_slots(a, w, right, down) {
                if !present {
                    continue;
                }
                let root = label[slot] as usize;
                if id[root] == u32::MAX {
                    id[root] = cell.len() as u32;
                    cell.push([bx as u32, by as u32]);
                    screening.push(0.0);
                }
                aggregate[p] = id[root];
                screening[id[root] as usize] += level.screening[p];
            }
            labels[by * cw + bx] = label;
        }
    }
    // Coarse rows in numbering order: each aggregate's members in pixel order, their pairs (up,
    // left, right, down) accumulated per neighbouring aggregate with a marker array.
    let nc = cell.len();
    let mut adjacency = Adjacency::default();
    let mut marker = vec![u32::MAX; nc];
    let mut slot_of = vec![0usize; nc];
    for by in 0..ch {
        for bx in 0..cw {
            let (right, down) = (2 * bx + 1 < w, 2 * by + 1 < h);
            let a = 2 * by * w + 2 * bx;
            let label = labels[by * cw + bx];
            for root in 0..4u8 {
                let members = block_slots(a, w, right, down)
                    .filter(|&(slot, _, present)| present && label[slot] == root);
                let mut any = false;
                for (slot, p, _) in members {
                    any = true;
                    let c = aggregate[p];
                    let (x, y) = (2 * bx + (slot & 1), 2 * by + (slot >> 1));
                    let mut visit = |q: usize, weight: f32| {
                        let d = aggregate[q] as usize;
                        if d as u32 == c {
                            return;
                        }
                        if marker[d] != c {
                            marker[d] = c;
                            slot_of[d] = adjacency.column.len();
                            adjacency.push(d as u32, weight);
                        } else {
                            adjacency.weight[slot_of[d]] += weight;
                        }
                    };
                    if y > 0 {
                        visit(p - w, vw[p - w]);
                    }
                    if x > 0 {
                        visit(p - 1, hw[p - 1]);
                    }
                    if x + 1 < w {
                        visit(p + 1, hw[p]);
                    }
                    if y + 1 < h {
                        visit(p + w, vw[p]);
                    }
                }
                if any {
                    adjacency.end_row();
                }
            }
        }
    }
    let coarse = Graph::new(adjacency, screening, cell, (cw, ch));
    (coarse, aggregate)
}

/// `(slot, pixel, present)` of the four slots of the block whose top-left pixel is `a`.
fn block_slots(
    a: usize,
    w: usize,
    right: bool,
    down: bool,
) -> impl Iterator<Item = (usize, usize, bool)> {
    [
        (0, a, true),
        (1, a + 1, right),
        (2, a + w, down),
        (3, a + w + 1, right && down),
    ]
    .into_iter()
}
