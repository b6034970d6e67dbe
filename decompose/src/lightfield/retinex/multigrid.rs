//! Aggregation multigrid for the per-view system `A = L(ω^occ) + μI` (see the parent module),
//! used as the preconditioner of conjugate gradients.
//!
//! Level 0 is the pixel grid (`retinex/grid.rs`); each coarser level aggregates 2×2 blocks of
//! the previous level's cells, split where a block is crossed by weak (occlusion) pairs, with
//! piecewise-constant prolongation `P` and the Galerkin operator `PᵀAP`, again a graph
//! Laplacian plus screening (`retinex/graph.rs`), down to a level small enough for an exact
//! banded Cholesky solve (`retinex/cholesky.rs`).
//!
//! A cycle on level `l` from `x = 0`: one forward Gauss–Seidel sweep, restriction of the
//! residual (`Pᵀ`), the coarse problem, `x += α P x_c`, one backward Gauss–Seidel sweep. The
//! backward sweep is the adjoint of the forward one and the coarsest solve is exact, so a
//! V-cycle is a symmetric preconditioner (positive definite for `α < 2`). The K-cycle (Notay &
//! Vassilevski 2008, "Recursive Krylov-based multigrid cycles") solves each coarse problem
//! with two steps of conjugate gradients preconditioned by the next cycle; unsmoothed
//! aggregation loses accuracy with every level of a V-cycle, and the K-cycle largely removes
//! that for about twice the coarse work (on a 512² view, 6 levels: 11 iterations against 22).

use super::cholesky::BandCholesky;
use super::graph::{self, Graph};
use super::grid::{self, Level};

/// How a level solves its coarse problem.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cycle {
    /// One recursive cycle: cheapest, but unsmoothed aggregation loses accuracy with every level.
    V,
    /// Two recursive cycles accelerated by conjugate gradients on every coarse level (Notay &
    /// Vassilevski 2008): about twice the coarse work, convergence nearly independent of depth.
    /// Makes the preconditioner nonlinear, so the outer solve is flexible CG.
    K,
}

/// Parameters of the multigrid preconditioner.
#[derive(Clone, Debug, PartialEq)]
pub struct MultigridParams {
    /// `α`: factor on the coarse correction, in (0, 2): piecewise-constant prolongation makes
    /// the coarse operator stiffer than a rediscretisation, and a V-cycle under-corrects smooth
    /// errors (Braess 1995). Default 1: with the K-cycle, 1.5 saves at most 2 iterations
    /// (parent module's figures).
    pub over_correction: f64,
    /// Gauss–Seidel sweeps before and after the coarse correction. Default 1.
    pub smoothing_steps: usize,
    /// Coarsening stops once a level has at most this many unknowns; that level is solved
    /// exactly by a banded Cholesky factorisation. Default 1024 (about 32² for a square view).
    pub coarsest_size: usize,
    /// A pair joins an aggregate only if its weight is at least this fraction of the stronger
    /// of its two nodes' strongest pairs (`retinex/graph.rs`). Default 0.1: the occlusion cue's
    /// 0.01 pairs are weak, the albedo cue does not enter `A`.
    pub strength: f64,
    /// The cycle. Default [`Cycle::K`].
    pub cycle: Cycle,
}

impl Default for MultigridParams {
    fn default() -> Self {
        Self {
            over_correction: 1.0,
            smoothing_steps: 1,
            coarsest_size: 1024,
            cycle: Cycle::K,
            strength: 0.1,
        }
    }
}

/// The levels, the aggregate maps between them and the coarsest factorisation.
pub(super) struct Hierarchy {
    /// Level 0.
    pub fine: Level,
    /// Levels 1.. (`coarse[l − 1]` is level `l`).
    coarse: Vec<Graph>,
    /// `aggregates[l][p]`: the node of level `l + 1` that node `p` of level `l` belongs to.
    pub aggregates: Vec<Vec<u32>>,
    coarsest: BandCholesky,
    params: MultigridParams,
}

/// Work vectors of one level transition `l → l + 1`.
pub(super) struct Work {
    /// Coarse right-hand side and solution.
    b: Vec<f64>,
    x: Vec<f64>,
    /// Residual on level `l`, and one grid row (level 0 only).
    residual: Vec<f64>,
    row: Vec<f64>,
    /// The K-cycle's vectors on level `l + 1` (empty for a V-cycle).
    krylov: [Vec<f64>; 4],
}

impl Hierarchy {
    /// Coarsens `fine` until [`MultigridParams::coarsest_size`], or until aggregation stalls
    /// (a level disconnected by weak pairs everywhere).
    pub fn new(fine: Level, params: &MultigridParams) -> Self {
        let mut coarse: Vec<Graph> = Vec::new();
        let mut aggregates = Vec::new();
        // Level 0 is aggregated straight from the grid (no graph copy of the finest level).
        if fine.width * fine.height > params.coarsest_size.max(1) {
            let (next, aggregate) = grid::coarsen_grid(&fine, params.strength);
            if next.len() * 5 <= fine.width * fine.height * 4 {
                aggregates.push(aggregate);
                coarse.push(next);
            }
        }
        while let Some(last) = coarse.last() {
            if last.len() <= params.coarsest_size.max(1) {
                break;
            }
            let (next, aggregate) = graph::coarsen(last, params.strength);
            if next.len() * 5 > last.len() * 4 {
                break;
            }
            aggregates.push(aggregate);
            coarse.push(next);
        }
        let coarsest = match coarse.last() {
            Some(last) => BandCholesky::new(last),
            None => BandCholesky::new(&graph::from_level(&fine)),
        };
        Self {
            fine,
            coarse,
            aggregates,
            coarsest,
            params: params.clone(),
        }
    }

    /// Number of levels.
    pub fn levels(&self) -> usize {
        self.aggregates.len() + 1
    }

    fn len(&self, level: usize) -> usize {
        match level {
            0 => self.fine.width * self.fine.height,
            l => self.coarse[l - 1].len(),
        }
    }

    fn apply(&self, level: usize, x: &[f64], out: &mut [f64]) {
        match level {
            0 => self.fine.apply(x, out),
            l => self.coarse[l - 1].apply(x, out),
        }
    }

    /// Work vectors for [`Self::precondition`].
    pub fn work(&self) -> Vec<Work> {
        (0..self.aggregates.len())
            .map(|l| {
                let (n, nc) = (self.len(l), self.len(l + 1));
                let k = if self.params.cycle == Cycle::K { nc } else { 0 };
                Work {
                    b: vec![0.0; nc],
                    x: vec![0.0; nc],
                    residual: vec![0.0; if l == 0 { 0 } else { n }],
                    row: vec![0.0; if l == 0 { self.fine.width } else { 0 }],
                    krylov: std::array::from_fn(|_| vec![0.0; k]),
                }
            })
            .collect()
    }

    /// `z = B r` from `z = 0` on the finest level.
    pub fn precondition(&self, r: &[f64], z: &mut [f64], work: &mut [Work]) {
        self.cycle(0, r, z, work);
    }

    /// One cycle on `level`; `work` starts at the transition `level → level + 1`.
    fn cycle(&self, level: usize, b: &[f64], x: &mut [f64], work: &mut [Work]) {
        if level == self.aggregates.len() {
            self.coarsest.solve(b, x);
            return;
        }
        let (here, below) = work.split_at_mut(1);
        let w = &mut here[0];
        let aggregate = &self.aggregates[level];
        match level {
            0 => self.fine.forward(b, x, true, &mut w.row),
            l => self.coarse[l - 1].forward(b, x, true),
        }
        for _ in 1..self.params.smoothing_steps {
            match level {
                0 => self.fine.forward(b, x, false, &mut w.row),
                l => self.coarse[l - 1].forward(b, x, false),
            }
        }
        // Restriction: `Pᵀ (b − A x)`; on the grid row by row, without a residual vector.
        w.b.fill(0.0);
        if level == 0 {
            self.fine
                .restrict_residual(b, x, aggregate, &mut w.b, &mut w.row);
        } else {
            self.apply(level, x, &mut w.residual);
            for ((ax, bi), &c) in w.residual.iter().zip(b).zip(aggregate) {
                w.b[c as usize] += bi - ax;
            }
        }
        if self.params.cycle == Cycle::K && level + 1 < self.aggregates.len() {
            self.krylov(level + 1, &w.b, &mut w.x, &mut w.krylov, below);
        } else {
            self.cycle(level + 1, &w.b, &mut w.x, below);
        }
        let alpha = self.params.over_correction;
        for (xi, &c) in x.iter_mut().zip(aggregate) {
            *xi += alpha * w.x[c as usize];
        }
        for _ in 0..self.params.smoothing_steps.max(1) {
            match level {
                0 => self.fine.backward(b, x, &mut w.row),
                l => self.coarse[l - 1].backward(b, x),
            }
        }
    }

    /// The K-cycle's coarse solve (Notay & Vassilevski 2008, Algorithm 2.1 with two inner
    /// iterations): two steps of flexible conjugate gradients on `level` preconditioned by
    /// [`Self::cycle`], the second skipped when the first reduced the residual fourfold.
    /// `work` starts at the transition `level → level + 1`.
    fn krylov(
        &self,
        level: usize,
        r: &[f64],
        x: &mut [f64],
        vectors: &mut [Vec<f64>; 4],
        work: &mut [Work],
    ) {
        let dot = |u: &[f64], v: &[f64]| u.iter().zip(v).map(|(a, b)| a * b).sum::<f64>();
        let [c2, v1, v2, r2] = vectors;
        self.cycle(level, r, x, work);
        self.apply(level, x, v1);
        let rho1 = dot(x, v1).max(f64::MIN_POSITIVE);
        let alpha1 = dot(x, r);
        for k in 0..r.len() {
            r2[k] = r[k] - alpha1 / rho1 * v1[k];
        }
        if dot(r2, r2) <= 0.0625 * dot(r, r) {
            x.iter_mut().for_each(|v| *v *= alpha1 / rho1);
            return;
        }
        self.cycle(level, r2, c2, work);
        self.apply(level, c2, v2);
        let (gamma, beta, alpha2) = (dot(c2, v1), dot(c2, v2), dot(c2, r2));
        let rho2 = (beta - gamma * gamma / rho1).max(f64::MIN_POSITIVE);
        let (s1, s2) = (
            alpha1 / rho1 - gamma * alpha2 / (rho1 * rho2),
            alpha2 / rho2,
        );
        for (x, c2) in x.iter_mut().zip(c2.iter()) {
            *x = s1 * *x + s2 * c2;
        }
    }
}
