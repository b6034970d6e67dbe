//! Coarse levels of the multigrid: a weighted graph Laplacian plus a screening diagonal on an
//! arbitrary graph (compressed rows), and its aggregation.
//!
//! Aggregation follows the pixel grid (2×2 blocks of the previous level's cells) but never
//! across a weak pair: within a block, the nodes are split into the connected components of its
//! strong pairs, each component one coarse node. This matters for the occlusion cue: an outline
//! of `ω^occ = 0.01` pairs at an odd position would otherwise put both sides of an occlusion in
//! one aggregate, the coarse space could not represent the jump of the shading there, and the
//! iteration count tripled (measured on the synthetic card, see the parent module).
//!
//! With the piecewise-constant prolongation `P` of the aggregates the Galerkin operator `PᵀAP`
//! is again a graph Laplacian plus screening: the coarse pair weight is the sum of the fine pair
//! weights between the two aggregates, pairs inside an aggregate cancel (a constant has no
//! gradient), and the coarse screening is the aggregate's sum.

use super::grid::Level;

/// `A x = diagonal ∘ x − Σ_q w_pq x_q` on a graph.
#[derive(Clone, Debug, Default)]
pub(super) struct Graph {
    /// Row `p`'s neighbours are `column[start[p]..start[p + 1]]`.
    start: Vec<u32>,
    column: Vec<u32>,
    weight: Vec<f32>,
    screening: Vec<f64>,
    diagonal: Vec<f64>,
    inverse_diagonal: Vec<f64>,
    /// The grid cell `[x, y]` of every node and the cell grid's size: nodes in one cell came
    /// from one block of the level above.
    cell: Vec<[u32; 2]>,
    grid: (usize, usize),
}

impl Graph {
    pub(super) fn new(
        adjacency: Adjacency,
        screening: Vec<f64>,
        cell: Vec<[u32; 2]>,
        grid: (usize, usize),
    ) -> Self {
        let mut diagonal = screening.clone();
        for (p, d) in diagonal.iter_mut().enumerate() {
            let (a, b) = (adjacency.start[p] as usize, adjacency.start[p + 1] as usize);
            *d += adjacency.weight[a..b]
                .iter()
                .map(|&w| w as f64)
                .sum::<f64>();
        }
        let inverse_diagonal = diagonal.iter().map(|d| 1.0 / d).collect();
        Self {
            start: adjacency.start,
            column: adjacency.column,
            weight: adjacency.weight,
            screening,
            diagonal,
            inverse_diagonal,
            cell,
            grid,
        }
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.diagonal.len()
    }

    /// The neighbours of `p` and their weights.
    pub fn row(&self, p: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let (a, b) = (self.start[p] as usize, self.start[p + 1] as usize);
        self.column[a..b]
            .iter()
            .zip(&self.weight[a..b])
            .map(|(&q, &w)| (q as usize, w as f64))
    }

    /// The diagonal of `A`.
    pub fn diagonal(&self) -> &[f64] {
        &self.diagonal
    }

    #[inline]
    fn neighbours(&self, x: &[f64], p: usize) -> f64 {
        let (a, b) = (self.start[p] as usize, self.start[p + 1] as usize);
        let mut s = 0.0;
        for k in a..b {
            s += self.weight[k] as f64 * x[self.column[k] as usize];
        }
        s
    }

    /// `out = A x`.
    pub fn apply(&self, x: &[f64], out: &mut [f64]) {
        for (p, o) in out.iter_mut().enumerate() {
            *o = self.diagonal[p] * x[p] - self.neighbours(x, p);
        }
    }

    /// One forward Gauss–Seidel sweep; `from_zero` skips the read of `x` (it is 0 on entry,
    /// and the not yet updated neighbours contribute 0).
    pub fn forward(&self, b: &[f64], x: &mut [f64], from_zero: bool) {
        if from_zero {
            x.fill(0.0);
        }
        for p in 0..b.len() {
            x[p] = (b[p] + self.neighbours(x, p)) * self.inverse_diagonal[p];
        }
    }

    /// One backward Gauss–Seidel sweep, the adjoint of [`Self::forward`].
    pub fn backward(&self, b: &[f64], x: &mut [f64]) {
        for p in (0..b.len()).rev() {
            x[p] = (b[p] + self.neighbours(x, p)) * self.inverse_diagonal[p];
        }
    }

    /// The operator as a dense matrix (tests only).
    #[cfg(test)]
    pub fn dense(&self) -> Vec<Vec<f64>> {
        let n = self.len();
        let mut out = vec![vec![0.0; n]; n];
        for (p, row) in out.iter_mut().enumerate() {
            row[p] = self.diagonal[p];
            for (q, w) in self.row(p) {
                row[q] -= w;
            }
        }
        out
    }
}

/// What aggregation needs of a level: its pairs, screening and grid cells.
pub(super) trait Pairs {
    /// Number of nodes.
    fn len(&self) -> usize;
    /// Calls `f(q, w_pq)` for every neighbour `q` of `p`, whose cell is `cell`.
    fn for_each_pair(&self, p: usize, cell: [u32; 2], f: impl FnMut(usize, f64));
    /// The screening of `p`.
    fn screening(&self, p: usize) -> f64;
    /// The grid cell `[x, y]` of every node.
    fn cells(&self) -> Vec<[u32; 2]>;
    /// The size of the cell grid.
    fn grid(&self) -> (usize, usize);
}

impl Pairs for Graph {
    fn len(&self) -> usize {
        self.diagonal.len()
    }

    fn for_each_pair(&self, p: usize, _: [u32; 2], mut f: impl FnMut(usize, f64)) {
        for (q, w) in self.row(p) {
            f(q, w);
        }
    }

    fn screening(&self, p: usize) -> f64 {
        self.screening[p]
    }

    fn cells(&self) -> Vec<[u32; 2]> {
        self.cell.clone()
    }

    fn grid(&self) -> (usize, usize) {
        self.grid
    }
}

/// The pixel grid: one cell per pixel.
impl Pairs for Level {
    fn len(&self) -> usize {
        self.width * self.height
    }

    fn for_each_pair(&self, p: usize, [x, y]: [u32; 2], mut f: impl FnMut(usize, f64)) {
        let (w, h) = (self.width, self.height);
        let (x, y) = (x as usize, y as usize);
        if y > 0 {
            f(p - w, self.vertical[p - w] as f64);
        }
        if x > 0 {
            f(p - 1, self.horizontal[p - 1] as f64);
        }
        if x + 1 < w {
            f(p + 1, self.horizontal[p] as f64);
        }
        if y + 1 < h {
            f(p + w, self.vertical[p] as f64);
        }
    }

    fn screening(&self, p: usize) -> f64 {
        self.screening[p]
    }

    fn cells(&self) -> Vec<[u32; 2]> {
        let (w, h) = (self.width as u32, self.height as u32);
        (0..h).flat_map(|y| (0..w).map(move |x| [x, y])).collect()
    }

    fn grid(&self) -> (usize, usize) {
        (self.width, self.height)
    }
}

/// The graph of a pixel grid level (the coarsest level when the view is too small to coarsen).
pub(super) fn from_level(level: &Level) -> Graph {
    let mut adjacency = Adjacency::default();
    let cell = level.cells();
    for (p, &c) in cell.iter().enumerate() {
        level.for_each_pair(p, c, |q, w| adjacency.push(q as u32, w as f32));
        adjacency.end_row();
    }
    Graph::new(adjacency, level.screening.clone(), cell, level.grid())
}

/// The aggregates of the next level (see the module docs) and its Galerkin operator:
/// `(coarse, aggregate)` with `aggregate[p]` the coarse node of node `p`.
pub(super) fn coarsen(level: &impl Pairs, strength: f64) -> (Graph, Vec<u32>) {
    let n = level.len();
    let (gw, gh) = level.grid();
    let coarse_grid = (gw.div_ceil(2), gh.div_ceil(2));
    // The block of every node, once: the pair loops below would otherwise divide per pair.
    let cells = level.cells();
    let blocks_of: Vec<u32> = cells
        .iter()
        .map(|&[x, y]| (y / 2) * coarse_grid.0 as u32 + x / 2)
        .collect();
    let block = |p: usize| blocks_of[p] as usize;
    // A pair is strong when it is at least `strength` times the stronger of the two nodes'
    // strongest pairs.
    let strongest: Vec<f64> = (0..n)
        .map(|p| {
            let mut m = 0.0f64;
            level.for_each_pair(p, cells[p], |_, w| m = m.max(w));
            m
        })
        .collect();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    for p in 0..n {
        level.for_each_pair(p, cells[p], |q, w| {
            if q < p && block(p) == block(q) && w >= strength * strongest[p].max(strongest[q]) {
                union(&mut parent, p, q);
            }
        });
    }
    // Number the aggregates block by block in row-major block order, so that the coarse
    // numbering is again row-major and the coarsest level's band stays narrow.
    let blocks = coarse_grid.0 * coarse_grid.1;
    let mut count = vec![0u32; blocks + 1];
    for p in 0..n {
        count[block(p) + 1] += 1;
    }
    for k in 0..blocks {
        count[k + 1] += count[k];
    }
    let mut order = vec![0u32; n];
    let mut next = count.clone();
    for p in 0..n {
        let k = block(p);
        order[next[k] as usize] = p as u32;
        next[k] += 1;
    }
    let mut aggregate = vec![u32::MAX; n];
    let mut coarse_cell = Vec::new();
    for &p in &order {
        let root = find(&mut parent, p as usize);
        if aggregate[root] == u32::MAX {
            aggregate[root] = coarse_cell.len() as u32;
            let [x, y] = cells[root];
            coarse_cell.push([x / 2, y / 2]);
        }
        aggregate[p as usize] = aggregate[root];
    }
    let nc = coarse_cell.len();
    let mut screening = vec![0.0; nc];
    let mut first = vec![0u32; nc + 1];
    for p in 0..n {
        screening[aggregate[p] as usize] += level.screening(p);
        first[aggregate[p] as usize + 1] += 1;
    }
    for c in 0..nc {
        first[c + 1] += first[c];
    }
    let mut members = vec![0u32; n];
    let mut next = first.clone();
    for (p, &c) in aggregate.iter().enumerate() {
        members[next[c as usize] as usize] = p as u32;
        next[c as usize] += 1;
    }
    // Coarse rows: the pairs of each aggregate's members accumulated per neighbouring
    // aggregate with a marker array (the sparse product PᵀAP in O(pairs)).
    let mut adjacency = Adjacency::default();
    let mut marker = vec![u32::MAX; nc];
    let mut slot = vec![0usize; nc];
    for c in 0..nc {
        for &p in &members[first[c] as usize..first[c + 1] as usize] {
            level.for_each_pair(p as usize, cells[p as usize], |q, w| {
                let d = aggregate[q] as usize;
                if d == c {
                    return;
                }
                if marker[d] != c as u32 {
                    marker[d] = c as u32;
                    slot[d] = adjacency.column.len();
                    adjacency.push(d as u32, w as f32);
                } else {
                    adjacency.weight[slot[d]] += w as f32;
                }
            });
        }
        adjacency.end_row();
    }
    let coarse = Graph::new(adjacency, screening, coarse_cell, coarse_grid);
    (coarse, aggregate)
}

/// Compressed rows under construction.
pub(super) struct Adjacency {
    start: Vec<u32>,
    pub column: Vec<u32>,
    pub weight: Vec<f32>,
}

impl Default for Adjacency {
    fn default() -> Self {
        Self {
            start: vec![0],
            column: Vec::new(),
            weight: Vec::new(),
        }
    }
}

impl Adjacency {
    pub fn push(&mut self, q: u32, w: f32) {
        self.column.push(q);
        self.weight.push(w);
    }

    pub fn end_row(&mut self) {
        self.start.push(self.column.len() as u32);
    }
}

fn find(parent: &mut [u32], mut p: usize) -> usize {
    while parent[p] as usize != p {
        parent[p] = parent[parent[p] as usize];
        p = parent[p] as usize;
    }
    p
}

fn union(parent: &mut [u32], p: usize, q: usize) {
    let (a, b) = (find(parent, p), find(parent, q));
    // The smaller index becomes the root, so that a root is its aggregate's first member in
    // row-major order.
    parent[a.max(b)] = a.min(b) as u32;
}
