//! The finest level of the multigrid: the view's pixel grid, a weighted 5-point graph
//! Laplacian plus the screening `μI`, with row-wise loops (no per-pixel index arithmetic) since
//! most of the work of a cycle is spent here.

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
