//! Aggregation multigrid for the per-view system `A = L(ω^occ) + μI` (see the parent module).
//!
//! Every level is the same kind of operator: a weighted 5-point graph Laplacian on a
//! `width × height` grid plus a non-negative screening diagonal. The coarse grid aggregates 2×2
//! blocks of pixels (1×2, 2×1 or 1×1 at odd edges) into one node, and the prolongation `P` is
//! piecewise constant. Then the Galerkin operator `PᵀAP` is again of that kind: the coarse pair
//! weight is the sum of the fine pair weights that cross between the two blocks, the pairs inside
//! a block cancel (a constant has no gradient), and the coarse screening is the block's sum of the
//! fine screening. So no sparse matrix is ever formed, and an occlusion edge (weight 0.01) stays
//! a weak coarse edge at every level.
//!
//! Piecewise-constant prolongation makes the coarse operator about twice as stiff as a
//! rediscretisation (for a 2D Laplacian `PᵀAP ≈ 2·A_coarse`), so the coarse correction is too
//! small by about 2; the over-correction factor `α` of the V-cycle compensates (Braess 1995,
//! "Towards algebraic multigrid for elliptic problems of second order"; Blaheta 1986).
//!
//! The V-cycle is symmetric (forward Gauss–Seidel before the coarse correction, backward after,
//! an exact coarsest solve), so it is a symmetric preconditioner for conjugate gradients;
//! `α < 2` keeps it positive definite.

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
        let (xr, hw, d) = (&x[r..r + w], &self.horizontal[r..r + w], &self.diagonal[r..r + w]);
        for i in 0..w {
            out[i] = d[i] * xr[i];
        }
        for i in 0..w - 1 {
            out[i] -= hw[i] as f64 * xr[i + 1];
            out[i + 1] -= hw[i] as f64 * xr[i];
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
    fn forward(&self, b: &[f64], x: &mut [f64], from_zero: bool, t: &mut [f64]) {
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
    fn backward(&self, b: &[f64], x: &mut [f64], t: &mut [f64]) {
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

    /// The size of the coarse grid: 2×2 blocks, a half block at an odd edge.
    pub fn coarse_size(&self) -> (usize, usize) {
        (self.width.div_ceil(2), self.height.div_ceil(2))
    }

    /// The Galerkin operator `PᵀAP` for the 2×2 aggregation (see the module docs).
    pub fn coarsen(&self) -> Self {
        let (w, h) = (self.width, self.height);
        let (cw, ch) = self.coarse_size();
        let mut horizontal = vec![0.0f32; cw * ch];
        let mut vertical = vec![0.0f32; cw * ch];
        let mut screening = vec![0.0f64; cw * ch];
        for y in 0..h {
            for x in 0..w {
                let (p, c) = (y * w + x, (y / 2) * cw + x / 2);
                screening[c] += self.screening[p];
                // Only the pairs leaving the block through its right or lower side survive;
                // the ones inside it have a constant on both ends. The last fine column and row
                // carry weight 0, so the coarse ones do too.
                if x % 2 == 1 {
                    horizontal[c] += self.horizontal[p];
                }
                if y % 2 == 1 {
                    vertical[c] += self.vertical[p];
                }
            }
        }
        Self::new(cw, ch, horizontal, vertical, screening)
    }

    /// `coarse_b = Pᵀ (b − A x)`: the residual summed over each block.
    fn restrict_residual(&self, b: &[f64], x: &[f64], coarse_b: &mut [f64], t: &mut [f64]) {
        let w = self.width;
        let cw = w.div_ceil(2);
        coarse_b.fill(0.0);
        for y in 0..self.height {
            self.apply_row(x, y, t);
            let coarse_row = &mut coarse_b[(y / 2) * cw..(y / 2 + 1) * cw];
            for (i, (ax, bi)) in t.iter().zip(&b[y * w..(y + 1) * w]).enumerate() {
                coarse_row[i / 2] += bi - ax;
            }
        }
    }

    /// `x += α P coarse_x`.
    fn prolong_add(&self, coarse_x: &[f64], alpha: f64, x: &mut [f64]) {
        let w = self.width;
        let cw = w.div_ceil(2);
        for (y, row) in x.chunks_exact_mut(w).enumerate() {
            let coarse_row = &coarse_x[(y / 2) * cw..(y / 2 + 1) * cw];
            for (xi, v) in row.iter_mut().enumerate() {
                *v += alpha * coarse_row[xi / 2];
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

/// How a level solves its coarse problem.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Cycle {
    /// One recursive cycle: cheapest, but unsmoothed aggregation loses accuracy with every level.
    V,
    /// Two recursive cycles accelerated by conjugate gradients on every coarse level (Notay &
    /// Vassilevski 2008): about twice the coarse work, convergence independent of the depth.
    /// Makes the preconditioner nonlinear, so the outer solve is flexible CG.
    K,
}

/// Parameters of the multigrid preconditioner.
#[derive(Clone, Debug, PartialEq)]
pub struct MultigridParams {
    /// `α`: factor on the coarse correction (see the module docs), in (0, 2). Default 1.8
    /// (measured: see the parent module's table).
    pub over_correction: f64,
    /// Gauss–Seidel sweeps before and after the coarse correction. Default 1.
    pub smoothing_steps: usize,
    /// Coarsening stops once a level has at most this many unknowns; that level is solved
    /// exactly by a banded Cholesky factorisation. Default 1024 (32² for a square view).
    pub coarsest_size: usize,
    /// The cycle. Default [`Cycle::K`].
    pub cycle: Cycle,
}

impl Default for MultigridParams {
    fn default() -> Self {
        Self {
            over_correction: 1.8,
            smoothing_steps: 1,
            coarsest_size: 1024,
            cycle: Cycle::K,
        }
    }
}

/// The level hierarchy and the coarsest factorisation.
pub(super) struct Hierarchy {
    pub levels: Vec<Level>,
    coarsest: BandCholesky,
    params: MultigridParams,
}

/// Work vectors of one level transition: the coarse right-hand side and solution, and one row
/// of the fine level.
pub(super) struct Work {
    b: Vec<f64>,
    x: Vec<f64>,
    row: Vec<f64>,
    /// Vectors of the K-cycle on the coarse level of this transition (empty for a V-cycle).
    krylov: Krylov,
}

/// The coarse right-hand side, coarse solution and fine row of one transition.
type Vectors<'a> = (&'a mut Vec<f64>, &'a mut Vec<f64>, &'a mut Vec<f64>);

/// Work vectors of [`Hierarchy::krylov`].
#[derive(Default)]
struct Krylov {
    c2: Vec<f64>,
    v1: Vec<f64>,
    v2: Vec<f64>,
    r2: Vec<f64>,
}

impl Hierarchy {
    /// Coarsens `fine` until [`MultigridParams::coarsest_size`] (or a 1×1 grid).
    pub fn new(fine: Level, params: &MultigridParams) -> Self {
        let mut levels = vec![fine];
        loop {
            let last = levels.last().expect("at least the fine level");
            if last.width * last.height <= params.coarsest_size.max(1)
                || last.width * last.height == 1
            {
                break;
            }
            let next = last.coarsen();
            levels.push(next);
        }
        let coarsest = BandCholesky::new(levels.last().expect("at least the fine level"));
        Self {
            levels,
            coarsest,
            params: params.clone(),
        }
    }

    /// Work vectors for [`Self::precondition`].
    pub fn work(&self) -> Vec<Work> {
        self.levels
            .windows(2)
            .map(|l| Work {
                b: vec![0.0; l[1].width * l[1].height],
                x: vec![0.0; l[1].width * l[1].height],
                row: vec![0.0; l[0].width],
                krylov: if self.params.cycle == Cycle::K {
                    let n = l[1].width * l[1].height;
                    Krylov {
                        c2: vec![0.0; n],
                        v1: vec![0.0; n],
                        v2: vec![0.0; n],
                        r2: vec![0.0; n],
                    }
                } else {
                    Krylov::default()
                },
            })
            .collect()
    }

    /// `z = B r`, one V-cycle from `z = 0` on the finest level.
    pub fn precondition(&self, r: &[f64], z: &mut [f64], work: &mut [Work]) {
        let (mut vectors, mut krylov): (Vec<_>, Vec<_>) = work
            .iter_mut()
            .map(|w| ((&mut w.b, &mut w.x, &mut w.row), &mut w.krylov))
            .unzip();
        self.cycle(0, r, z, &mut vectors, &mut krylov);
    }

    /// One cycle on `level`; `work[0]` belongs to the transition `level → level + 1` and
    /// `krylov[0]` to level `level + 1`.
    fn cycle(
        &self,
        level: usize,
        b: &[f64],
        x: &mut [f64],
        work: &mut [Vectors],
        krylov: &mut [&mut Krylov],
    ) {
        if level + 1 == self.levels.len() {
            self.coarsest.solve(b, x);
            return;
        }
        let a = &self.levels[level];
        let (here, below) = work.split_at_mut(1);
        let (cb, cx, t) = &mut here[0];
        a.forward(b, x, true, t);
        for _ in 1..self.params.smoothing_steps {
            a.forward(b, x, false, t);
        }
        a.restrict_residual(b, x, cb, t);
        if self.params.cycle == Cycle::K && level + 2 < self.levels.len() {
            self.krylov(level + 1, cb, cx, below, krylov);
        } else {
            self.cycle(level + 1, cb, cx, below, &mut krylov[1..]);
        }
        a.prolong_add(cx, self.params.over_correction, x);
        for _ in 0..self.params.smoothing_steps.max(1) {
            a.backward(b, x, t);
        }
    }
}

impl Hierarchy {
    /// The K-cycle's coarse solve (Notay & Vassilevski 2008, Algorithm 2.1 with two inner
    /// iterations): two steps of flexible conjugate gradients on level `level` preconditioned by
    /// [`Self::cycle`], the second skipped when the first reduced the residual by 4.
    /// `work` and `krylov` start at level `level`.
    fn krylov(
        &self,
        level: usize,
        r: &[f64],
        x: &mut [f64],
        work: &mut [Vectors],
        krylov: &mut [&mut Krylov],
    ) {
        let a = &self.levels[level];
        let dot = |u: &[f64], v: &[f64]| u.iter().zip(v).map(|(a, b)| a * b).sum::<f64>();
        let (here, below) = krylov.split_at_mut(1);
        let Krylov { c2, v1, v2, r2 } = &mut *here[0];
        self.cycle(level, r, x, work, below);
        a.apply(x, v1);
        let rho1 = dot(x, v1).max(f64::MIN_POSITIVE);
        let alpha1 = dot(x, r);
        for k in 0..r.len() {
            r2[k] = r[k] - alpha1 / rho1 * v1[k];
        }
        if dot(r2, r2) <= 0.0625 * dot(r, r) {
            x.iter_mut().for_each(|v| *v *= alpha1 / rho1);
            return;
        }
        self.cycle(level, r2, c2, work, below);
        a.apply(c2, v2);
        let (gamma, beta, alpha2) = (dot(c2, v1), dot(c2, v2), dot(c2, r2));
        let rho2 = (beta - gamma * gamma / rho1).max(f64::MIN_POSITIVE);
        let (s1, s2) = (alpha1 / rho1 - gamma * alpha2 / (rho1 * rho2), alpha2 / rho2);
        for (x, c2) in x.iter_mut().zip(c2.iter()) {
            *x = s1 * *x + s2 * c2;
        }
    }
}

/// Cholesky factor of a small level, stored by rows within its band. The grid is numbered along
/// its longer side first so that the band is the shorter side: `n·band²` work to factorise.
struct BandCholesky {
    n: usize,
    band: usize,
    /// Whether unknown `p = y·width + x` is numbered `x·height + y`.
    transposed: bool,
    width: usize,
    height: usize,
    /// Row `i` holds `L[i][i − band ..= i]` at `i·(band + 1) ..`.
    factor: Vec<f64>,
}

impl BandCholesky {
    fn new(level: &Level) -> Self {
        let (w, h) = (level.width, level.height);
        let n = w * h;
        let transposed = w > h;
        let band = w.min(h);
        let index = |p: usize| if transposed { (p % w) * h + p / w } else { p };
        let stride = band + 1;
        let mut factor = vec![0.0; n * stride];
        // Lower triangle of A: entry (i, j), j ≤ i, at i·stride + band − (i − j).
        let mut put = |i: usize, j: usize, v: f64| {
            let (i, j) = (i.max(j), i.min(j));
            factor[i * stride + band - (i - j)] += v;
        };
        for p in 0..n {
            put(index(p), index(p), level.diagonal[p]);
            if p % w + 1 < w {
                put(index(p), index(p + 1), -(level.horizontal[p] as f64));
            }
            if p + w < n {
                put(index(p), index(p + w), -(level.vertical[p] as f64));
            }
        }
        for i in 0..n {
            let lo = i.saturating_sub(band);
            for j in lo..=i {
                let mut s = factor[i * stride + band - (i - j)];
                for k in lo.max(j.saturating_sub(band))..j {
                    s -= factor[i * stride + band - (i - k)] * factor[j * stride + band - (j - k)];
                }
                factor[i * stride + band - (i - j)] = if i == j {
                    // A level's matrix is SPD when μ > 0; the floor only keeps a degenerate
                    // (μ = 0, fully disconnected) level finite.
                    s.max(f64::MIN_POSITIVE).sqrt()
                } else {
                    s / factor[j * stride + band]
                };
            }
        }
        Self {
            n,
            band,
            transposed,
            width: w,
            height: h,
            factor,
        }
    }

    fn solve(&self, b: &[f64], x: &mut [f64]) {
        let (n, band, stride) = (self.n, self.band, self.band + 1);
        let (w, h) = (self.width, self.height);
        let index = |p: usize| {
            if self.transposed {
                (p % w) * h + p / w
            } else {
                p
            }
        };
        let mut y = vec![0.0; n];
        for p in 0..n {
            y[index(p)] = b[p];
        }
        let l = |i: usize, j: usize| self.factor[i * stride + band - (i - j)];
        for i in 0..n {
            let mut s = y[i];
            for k in i.saturating_sub(band)..i {
                s -= l(i, k) * y[k];
            }
            y[i] = s / l(i, i);
        }
        for i in (0..n).rev() {
            let mut s = y[i];
            for k in i + 1..(i + band + 1).min(n) {
                s -= l(k, i) * y[k];
            }
            y[i] = s / l(i, i);
        }
        for p in 0..n {
            x[p] = y[index(p)];
        }
    }
}
