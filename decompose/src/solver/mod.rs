//! Weighted sparse linear least squares, shared by every method in the crate.
//!
//! The thesis solves its systems with Jacobi-preconditioned QMR (ch. 2, §2.4). We replace it, as
//! the issue allows, by a direct method: the weighted normal equations
//! `(AᵀWA + εD) x = AᵀWb` are factorised with faer's sparse Cholesky (AMD ordering), followed
//! by iterative refinement. `ε` is a tiny relative Tikhonov damping (`D` = mean diagonal) that
//! keeps the matrix positive definite when the equations leave some unknowns free (for instance
//! the global scale of a connected group of clusters, fixed afterwards by each method's gauge
//! equation; see [`LinearSystem::components`]). The test `sparse_equals_dense_least_squares`
//! checks the result against a dense QR least-squares solution.

use faer::Mat;
use faer::linalg::solvers::Solve;
use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
use faer::sparse::{SparseColMat, Triplet};

use crate::error::{Error, Result};

/// Parameters of [`LinearSystem::solve`].
#[derive(Clone, Debug, PartialEq)]
pub struct SolverParams {
    /// Relative Tikhonov damping ε (times the mean diagonal of AᵀWA). Default 1e-9.
    pub damping: f64,
    /// Maximum iterative-refinement steps after the direct solve. Default 3.
    pub refinement_steps: usize,
    /// Relative normal-equation residual ‖AᵀW(b − Ax) − εDx‖ / ‖AᵀWb‖ accepted. Default 1e-6.
    pub tolerance: f64,
}

impl Default for SolverParams {
    fn default() -> Self {
        Self {
            damping: 1e-9,
            refinement_steps: 3,
            tolerance: 1e-6,
        }
    }
}

impl SolverParams {
    /// Checks the ranges.
    pub fn validate(&self) -> Result<()> {
        if !(self.damping.is_finite() && self.damping >= 0.0) {
            return Err(Error::param(
                "damping",
                self.damping,
                "must be finite and >= 0",
            ));
        }
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return Err(Error::param(
                "tolerance",
                self.tolerance,
                "must be finite and > 0",
            ));
        }
        Ok(())
    }
}

/// What a solve did.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct SolverInfo {
    /// Number of unknowns.
    pub unknowns: usize,
    /// Number of equations (rows of A).
    pub equations: usize,
    /// Stored entries of the lower triangle of the normal matrix.
    pub normal_nonzeros: usize,
    /// Triangular solves performed: 1 + refinement steps.
    pub iterations: usize,
    /// Final relative normal-equation residual.
    pub residual: f64,
    /// Weighted sum of squared equation residuals Σ w (aᵀx − b)².
    pub objective: f64,
    /// Whether the residual reached the tolerance.
    pub converged: bool,
}

/// A sparse weighted least-squares problem, built one equation at a time.
#[derive(Clone, Debug, Default)]
pub struct LinearSystem {
    unknowns: usize,
    row_start: Vec<usize>,
    cols: Vec<u32>,
    vals: Vec<f64>,
    rhs: Vec<f64>,
    weight: Vec<f64>,
}

impl LinearSystem {
    /// An empty system over `unknowns` unknowns.
    pub fn new(unknowns: usize) -> Self {
        Self {
            unknowns,
            row_start: vec![0],
            ..Default::default()
        }
    }

    /// Number of unknowns.
    pub fn unknowns(&self) -> usize {
        self.unknowns
    }

    /// Number of equations.
    pub fn equations(&self) -> usize {
        self.rhs.len()
    }

    /// Adds the equation `Σ coef·x[index] = rhs` with least-squares weight `weight` (the squared
    /// residual is multiplied by it). Non-finite or out-of-range terms make the whole equation
    /// be skipped, so that degenerate pixels cannot poison the system; returns whether it was
    /// added.
    pub fn add(&mut self, terms: &[(usize, f64)], rhs: f64, weight: f64) -> bool {
        if !(rhs.is_finite() && weight.is_finite() && weight > 0.0)
            || terms
                .iter()
                .any(|&(i, c)| i >= self.unknowns || !c.is_finite())
        {
            return false;
        }
        for &(i, c) in terms {
            self.cols.push(i as u32);
            self.vals.push(c);
        }
        self.row_start.push(self.cols.len());
        self.rhs.push(rhs);
        self.weight.push(weight);
        true
    }

    fn row(&self, r: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let (a, b) = (self.row_start[r], self.row_start[r + 1]);
        self.cols[a..b]
            .iter()
            .zip(&self.vals[a..b])
            .map(|(&c, &v)| (c as usize, v))
    }

    /// Groups of unknowns linked by at least one equation (union–find). Each method fixes the
    /// free scale of every group with its gauge; an unknown in no equation is its own group.
    pub fn components(&self) -> Vec<usize> {
        let mut parent: Vec<usize> = (0..self.unknowns).collect();
        fn find(p: &mut [usize], mut i: usize) -> usize {
            while p[i] != i {
                p[i] = p[p[i]];
                i = p[i];
            }
            i
        }
        for r in 0..self.equations() {
            let mut first = None;
            for (c, v) in self.row(r) {
                if v == 0.0 {
                    continue;
                }
                match first {
                    None => first = Some(c),
                    Some(f) => {
                        let (a, b) = (find(&mut parent, f), find(&mut parent, c));
                        if a != b {
                            parent[a.max(b)] = a.min(b);
                        }
                    }
                }
            }
        }
        (0..self.unknowns).map(|i| find(&mut parent, i)).collect()
    }

    /// The residual `aᵀx − b` of every equation, in the order they were added.
    pub fn residuals(&self, x: &[f64]) -> Vec<f64> {
        (0..self.equations())
            .map(|r| self.row(r).map(|(c, v)| v * x[c]).sum::<f64>() - self.rhs[r])
            .collect()
    }

    /// The same equations with every weight multiplied by `factors[r]` (one per equation;
    /// iteratively reweighted least squares).
    pub fn reweighted(&self, factors: &[f64]) -> Self {
        let mut out = self.clone();
        for (w, f) in out.weight.iter_mut().zip(factors) {
            *w *= f;
        }
        out
    }

    /// The weighted residual Σ w (aᵀx − b)².
    pub fn objective(&self, x: &[f64]) -> f64 {
        (0..self.equations())
            .map(|r| {
                let ax: f64 = self.row(r).map(|(c, v)| v * x[c]).sum();
                self.weight[r] * (ax - self.rhs[r]).powi(2)
            })
            .sum()
    }

    /// Solves the weighted least-squares problem (see the module docs).
    pub fn solve(&self, params: &SolverParams) -> Result<(Vec<f64>, SolverInfo)> {
        params.validate()?;
        self.solve_with(params, None).map(|(x, info, _)| (x, info))
    }

    /// Iteratively reweighted least squares: after a first [`LinearSystem::solve`], each of
    /// `iterations` passes multiplies every equation's original weight by
    /// `factor(residual)` (residual of the previous pass) and solves again. The weights change
    /// but not the sparsity of the normal matrix, so its symbolic Cholesky factorisation
    /// (ordering and elimination tree) is computed once and reused by every pass.
    pub fn solve_irls(
        &self,
        params: &SolverParams,
        iterations: usize,
        factor: impl Fn(f64) -> f64,
    ) -> Result<(Vec<f64>, SolverInfo)> {
        params.validate()?;
        let (mut x, mut info, symbolic) = self.solve_with(params, None)?;
        for _ in 0..iterations {
            let factors: Vec<f64> = self.residuals(&x).into_iter().map(&factor).collect();
            if factors.iter().any(|f| !(f.is_finite() && *f > 0.0)) {
                return Err(Error::param(
                    "irls factor",
                    "non-positive or non-finite",
                    "must be finite and > 0 for every residual",
                ));
            }
            (x, info, _) = self
                .reweighted(&factors)
                .solve_with(params, symbolic.as_ref())?;
        }
        Ok((x, info))
    }

    /// The solve behind [`LinearSystem::solve`]; reuses `symbolic` when given (it must come
    /// from a system with the same equations) and returns the one it used.
    fn solve_with(
        &self,
        params: &SolverParams,
        symbolic: Option<&SymbolicLlt<usize>>,
    ) -> Result<(Vec<f64>, SolverInfo, Option<SymbolicLlt<usize>>)> {
        let n = self.unknowns;
        let mut info = SolverInfo {
            unknowns: n,
            equations: self.equations(),
            ..Default::default()
        };
        if n == 0 {
            info.converged = true;
            return Ok((Vec::new(), info, None));
        }
        // Lower triangle of AᵀWA as (col, row, value) keys, merged after sorting.
        let mut entries: Vec<(u64, f64)> = Vec::with_capacity(self.cols.len() * 2);
        let mut atb = vec![0.0; n];
        let mut diag = vec![0.0; n];
        for r in 0..self.equations() {
            let w = self.weight[r];
            let (a, b) = (self.row_start[r], self.row_start[r + 1]);
            for p in a..b {
                let (i, vi) = (self.cols[p] as usize, self.vals[p]);
                atb[i] += w * vi * self.rhs[r];
                for q in a..b {
                    let (j, vj) = (self.cols[q] as usize, self.vals[q]);
                    if j > i {
                        continue;
                    }
                    if i == j {
                        diag[i] += w * vi * vj;
                    } else {
                        // column j, row i (i > j): lower triangle.
                        entries.push((((j as u64) << 32) | i as u64, w * vi * vj));
                    }
                }
            }
        }
        entries.sort_unstable_by_key(|e| e.0);
        let mean_diag = diag.iter().sum::<f64>() / n as f64;
        let eps = params.damping * if mean_diag > 0.0 { mean_diag } else { 1.0 };
        let mut triplets: Vec<Triplet<usize, usize, f64>> =
            Vec::with_capacity(entries.len() / 2 + n);
        for (i, d) in diag.iter().enumerate() {
            // Unknowns that appear in no equation get a unit diagonal so the matrix stays SPD.
            let d = if *d > 0.0 { d + eps } else { 1.0 };
            triplets.push(Triplet::new(i, i, d));
        }
        let mut k = 0;
        while k < entries.len() {
            let key = entries[k].0;
            let mut v = 0.0;
            while k < entries.len() && entries[k].0 == key {
                v += entries[k].1;
                k += 1;
            }
            triplets.push(Triplet::new(
                (key & 0xffff_ffff) as usize,
                (key >> 32) as usize,
                v,
            ));
        }
        drop(entries);
        info.normal_nonzeros = triplets.len();
        let fail = |m: String| Error::Solver {
            unknowns: n,
            message: m,
        };
        let mat = SparseColMat::<usize, f64>::try_new_from_triplets(n, n, &triplets)
            .map_err(|e| fail(format!("{e:?}")))?;
        drop(triplets);
        let symbolic = match symbolic {
            Some(s) => s.clone(),
            None => SymbolicLlt::try_new(mat.symbolic(), faer::Side::Lower)
                .map_err(|e| fail(format!("{e:?}")))?,
        };
        let llt = Llt::try_new_with_symbolic(symbolic.clone(), mat.as_ref(), faer::Side::Lower)
            .map_err(|e| fail(format!("{e:?}")))?;

        let b = Mat::<f64>::from_fn(n, 1, |i, _| atb[i]);
        let bnorm = atb.iter().map(|v| v * v).sum::<f64>().sqrt();
        let mut x = llt.solve(&b);
        info.iterations = 1;
        let sym_mul = |x: &Mat<f64>| -> Mat<f64> {
            // y = M x using the lower triangle only.
            let mut y = Mat::<f64>::zeros(n, 1);
            let m = mat.as_ref();
            for j in 0..n {
                let col_idx = m.row_idx_of_col_raw(j);
                let col_val = m.val_of_col(j);
                for (&i, &v) in col_idx.iter().zip(col_val) {
                    y[(i, 0)] += v * x[(j, 0)];
                    if i != j {
                        y[(j, 0)] += v * x[(i, 0)];
                    }
                }
            }
            y
        };
        let rel = |r: &Mat<f64>| {
            let rn = (0..n).map(|i| r[(i, 0)].powi(2)).sum::<f64>().sqrt();
            if bnorm > 0.0 { rn / bnorm } else { rn }
        };
        let mut r = &b - sym_mul(&x);
        info.residual = rel(&r);
        for _ in 0..params.refinement_steps {
            if info.residual <= params.tolerance * 1e-3 {
                break;
            }
            let dx = llt.solve(&r);
            x += dx;
            info.iterations += 1;
            r = &b - sym_mul(&x);
            info.residual = rel(&r);
        }
        let xs: Vec<f64> = (0..n).map(|i| x[(i, 0)]).collect();
        if xs.iter().any(|v| !v.is_finite()) {
            return Err(fail("non-finite solution".into()));
        }
        info.converged = info.residual <= params.tolerance;
        if !info.converged {
            return Err(Error::NoConvergence {
                iterations: info.iterations,
                residual: info.residual,
            });
        }
        info.objective = self.objective(&xs);
        Ok((xs, info, Some(symbolic)))
    }
}

/// Subtracts, in every group of `components`, the mean of `x` over the group: the gauge
/// `Σ x_i = 0` of eq. 2.8, applied per connected group.
pub fn zero_mean_per_component(x: &mut [f64], components: &[usize]) {
    let mut sum = vec![0.0; x.len()];
    let mut cnt = vec![0usize; x.len()];
    for (i, &c) in components.iter().enumerate() {
        sum[c] += x[i];
        cnt[c] += 1;
    }
    for (i, &c) in components.iter().enumerate() {
        x[i] -= sum[c] / cnt[c] as f64;
    }
}

#[cfg(test)]
mod tests;
