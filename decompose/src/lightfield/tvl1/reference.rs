//! A slow, independent reference for eq. 4.3 in `f64`: *exact* ADMM in the form of Yang, Zhang
//! & Yin (2009) with two splits, `w = ∇u` and `z = u − f`, whose `u`-step
//! `(ρ_w ∇ᵀ∇ + ρ_z I) u = r` is solved exactly in the eigenbasis of the Neumann Laplacian (a
//! tensor product of 1D DCT-II bases, here as dense per-axis matrices). No linearisation, no
//! extrapolation, separate code: a different algorithm from `admm.rs`.
//!
//! It stops on a duality-gap certificate: the multiplier `y = λ_w` lies in the unit ball per
//! ray, and after scaling it so that `|∇ᵀy| ≤ β` elementwise, `D(y) = ⟨f, ∇ᵀy⟩` is a lower
//! bound on `min E` (for any such `y`,
//! `E(u) ≥ ⟨u, ∇ᵀy⟩ + β‖u − f‖₁ ≥ ⟨f, ∇ᵀy⟩`). So `E(u) − D(y)` bounds the suboptimality.

/// The reference's answer.
pub(super) struct Reference {
    pub u: Vec<f64>,
    /// `E(u)`.
    pub primal: f64,
    /// `D(y)`, a certified lower bound on `min E`.
    pub dual: f64,
    pub iterations: usize,
}

struct Shape {
    n: [usize; 4],
    c: usize,
    /// Strides of `(row, col, y, x)`, channel stride 1.
    s: [usize; 4],
    len: usize,
}

impl Shape {
    fn new(n: [usize; 4], c: usize) -> Self {
        let s = [n[1] * n[2] * n[3] * c, n[2] * n[3] * c, n[3] * c, c];
        Self {
            n,
            c,
            s,
            len: n[0] * s[0],
        }
    }

    fn coord(&self, i: usize, a: usize) -> usize {
        (i / self.s[a]) % self.n[a]
    }

    /// Forward differences, `g[a·len + i]`, zero past the last sample (Neumann).
    fn grad(&self, u: &[f64]) -> Vec<f64> {
        let mut g = vec![0.0; 4 * self.len];
        for a in 0..4 {
            for i in 0..self.len {
                if self.coord(i, a) + 1 < self.n[a] {
                    g[a * self.len + i] = u[i + self.s[a]] - u[i];
                }
            }
        }
        g
    }

    /// The adjoint of [`Shape::grad`].
    fn grad_t(&self, g: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.len];
        for a in 0..4 {
            for i in 0..self.len {
                if self.coord(i, a) + 1 < self.n[a] {
                    let v = g[a * self.len + i];
                    out[i] -= v;
                    out[i + self.s[a]] += v;
                }
            }
        }
        out
    }

    /// Isotropic TV over axes and channels plus `β‖u − f‖₁`.
    fn energy(&self, u: &[f64], f: &[f64], beta: f64) -> f64 {
        let g = self.grad(u);
        let mut e = 0.0;
        for p in (0..self.len).step_by(self.c) {
            let mut sq = 0.0;
            for a in 0..4 {
                for k in 0..self.c {
                    sq += g[a * self.len + p + k].powi(2);
                }
            }
            e += sq.sqrt();
        }
        e + beta * u.iter().zip(f).map(|(a, b)| (a - b).abs()).sum::<f64>()
    }

    /// Applies the orthonormal DCT-II basis `V` (or `Vᵀ` when `forward`) along axis `a`.
    fn transform(&self, x: &mut [f64], a: usize, basis: &[f64], forward: bool) {
        let n = self.n[a];
        let mut fibre = vec![0.0; n];
        for start in 0..self.len {
            if self.coord(start, a) != 0 {
                continue;
            }
            for (j, out) in fibre.iter_mut().enumerate() {
                *out = (0..n)
                    .map(|i| {
                        let v = if forward {
                            basis[i * n + j]
                        } else {
                            basis[j * n + i]
                        };
                        v * x[start + i * self.s[a]]
                    })
                    .sum();
            }
            for (i, v) in fibre.iter().enumerate() {
                x[start + i * self.s[a]] = *v;
            }
        }
    }
}

/// `V[i·n + j] = α_j cos(π j (i + ½) / n)` and the eigenvalues `2 − 2cos(πj/n)` of the 1D
/// Neumann Laplacian (a path graph).
fn dct_basis(n: usize) -> (Vec<f64>, Vec<f64>) {
    let pi = std::f64::consts::PI;
    let mut v = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..n {
            let alpha = if j == 0 {
                (1.0 / n as f64).sqrt()
            } else {
                (2.0 / n as f64).sqrt()
            };
            v[i * n + j] = alpha * (pi * j as f64 * (i as f64 + 0.5) / n as f64).cos();
        }
    }
    let mu = (0..n)
        .map(|j| 2.0 - 2.0 * (pi * j as f64 / n as f64).cos())
        .collect();
    (v, mu)
}

/// Minimises eq. 4.3 for `f` laid out like a `LightField` of shape `n = [rows, cols, height,
/// width]` with `c` channels; stops when `E − D ≤ gap_tol·E` or after `max_iter`.
pub(super) fn solve(
    n: [usize; 4],
    c: usize,
    f: &[f64],
    beta: f64,
    gap_tol: f64,
    max_iter: usize,
) -> Reference {
    let sh = Shape::new(n, c);
    assert_eq!(f.len(), sh.len);
    let (rho_w, rho_z) = (2.0, 2.0 * beta.max(0.05));
    let bases: Vec<(Vec<f64>, Vec<f64>)> = n.iter().map(|&m| dct_basis(m)).collect();
    // Eigenvalue of (ρ_w ∇ᵀ∇ + ρ_z I) for each sample of the transformed grid.
    let mut diag = vec![0.0; sh.len];
    for (i, d) in diag.iter_mut().enumerate() {
        let lap: f64 = (0..4).map(|a| bases[a].1[sh.coord(i, a)]).sum();
        *d = rho_z + rho_w * lap;
    }
    let mut u = f.to_vec();
    let mut w = sh.grad(&u);
    let mut z = vec![0.0; sh.len];
    let mut lw = vec![0.0; 4 * sh.len];
    let mut lz = vec![0.0; sh.len];
    let mut best = Reference {
        u: u.clone(),
        primal: sh.energy(&u, f, beta),
        dual: f64::NEG_INFINITY,
        iterations: 0,
    };
    for it in 1..=max_iter {
        // u-step: exact solve in the DCT eigenbasis.
        let t: Vec<f64> = w.iter().zip(&lw).map(|(w, l)| rho_w * w - l).collect();
        let mut r = sh.grad_t(&t);
        for i in 0..sh.len {
            r[i] += rho_z * (f[i] + z[i]) - lz[i];
        }
        for (a, (basis, _)) in bases.iter().enumerate() {
            sh.transform(&mut r, a, basis, true);
        }
        for (x, d) in r.iter_mut().zip(&diag) {
            *x /= d;
        }
        for (a, (basis, _)) in bases.iter().enumerate() {
            sh.transform(&mut r, a, basis, false);
        }
        u = r;
        // w-step: isotropic shrinkage per ray over axes and channels; z-step: soft threshold.
        let gu = sh.grad(&u);
        for p in (0..sh.len).step_by(c) {
            let idx = |a: usize, k: usize| a * sh.len + p + k;
            let mut sq = 0.0;
            for a in 0..4 {
                for k in 0..c {
                    sq += (gu[idx(a, k)] + lw[idx(a, k)] / rho_w).powi(2);
                }
            }
            let norm = sq.sqrt();
            let scale = if norm > 1.0 / rho_w {
                1.0 - 1.0 / (rho_w * norm)
            } else {
                0.0
            };
            for a in 0..4 {
                for k in 0..c {
                    w[idx(a, k)] = scale * (gu[idx(a, k)] + lw[idx(a, k)] / rho_w);
                }
            }
        }
        for i in 0..sh.len {
            let t = u[i] - f[i] + lz[i] / rho_z;
            z[i] = t.signum() * (t.abs() - beta / rho_z).max(0.0);
        }
        for i in 0..4 * sh.len {
            lw[i] += rho_w * (gu[i] - w[i]);
        }
        for i in 0..sh.len {
            lz[i] += rho_z * (u[i] - f[i] - z[i]);
        }
        if it % 20 == 0 || it == max_iter {
            let primal = sh.energy(&u, f, beta);
            let dual = certified_dual(&sh, &lw, f, beta);
            if primal < best.primal {
                best.primal = primal;
                best.u = u.clone();
            }
            best.dual = best.dual.max(dual);
            best.iterations = it;
            if best.primal - best.dual <= gap_tol * best.primal.abs().max(1e-12) {
                break;
            }
        }
    }
    best
}

/// `D(y)` for the multiplier `y`, after scaling it into the dual feasible set
/// (`‖y(p)‖ ≤ 1` per ray, `|∇ᵀy| ≤ β` elementwise).
fn certified_dual(sh: &Shape, y: &[f64], f: &[f64], beta: f64) -> f64 {
    let mut max_norm: f64 = 0.0;
    for p in (0..sh.len).step_by(sh.c) {
        let mut sq = 0.0;
        for a in 0..4 {
            for k in 0..sh.c {
                sq += y[a * sh.len + p + k].powi(2);
            }
        }
        max_norm = max_norm.max(sq.sqrt());
    }
    let t = sh.grad_t(y);
    let max_t = t.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let mut scale = 1.0 / max_norm.max(1.0);
    if max_t * scale > beta {
        scale = beta / max_t;
    }
    scale * t.iter().zip(f).map(|(t, f)| t * f).sum::<f64>()
}
