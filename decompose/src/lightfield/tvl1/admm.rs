//! The two fused passes of one linearised-ADMM iteration (see the module docs for the updates).
//!
//! Both passes are data parallel over spatial lines (one image row of one view): every output
//! element is a fixed function of the previous iterate, so the result does not depend on how
//! rayon splits the work. The row and column terms are combined as `(row + col) + (y + x)`, and
//! IEEE addition is commutative, so swapping the angular axes gives bit-identical results.

use rayon::prelude::*;

/// Shape of the 4D grid and its element strides (channels interleaved, stride 1).
#[derive(Clone, Copy, Debug)]
pub(super) struct Grid {
    pub rows: usize,
    pub cols: usize,
    pub height: usize,
    pub width: usize,
    pub channels: usize,
    /// Element strides of `(row, col, y, x)` in the primal buffers.
    pub strides: [usize; 4],
}

impl Grid {
    /// `(row, col, y)` of spatial line `line`.
    fn line_coords(&self, line: usize) -> (usize, usize, usize) {
        let y = line % self.height;
        let view = line / self.height;
        (view / self.cols, view % self.cols, y)
    }

    /// Squared operator norm bound of the forward-difference gradient: 4 per axis that has
    /// more than one sample (an axis of length 1 contributes nothing).
    pub fn gradient_norm_sq(&self) -> f32 {
        let active = [self.rows, self.cols, self.height, self.width]
            .iter()
            .filter(|&&n| n > 1)
            .count();
        4.0 * active.max(1) as f32
    }
}

/// Dual (multiplier) update, eq. (D) of the module docs:
/// `y ← Π_{‖·‖≤1}(y + ρ ∇ū)`, isotropic over the four axes and all channels of a pixel.
///
/// `y` holds, per pixel, `[row | col | y | x]` blocks of `channels` values each.
///
/// Returns `max |yᵏ⁺¹ − yᵏ|` over all entries (a maximum: exact for any evaluation order).
pub(super) fn dual_pass(g: &Grid, ubar: &[f32], y: &mut [f32], rho: f32) -> f32 {
    let line_len = g.width * 4 * g.channels;
    y.par_chunks_mut(line_len)
        .enumerate()
        .map(|(line, yl)| match g.channels {
            // Literal channel counts let the inlined kernel unroll the channel loop.
            1 => dual_line(g, ubar, yl, line, rho, 1),
            3 => dual_line(g, ubar, yl, line, rho, 3),
            c => dual_line(g, ubar, yl, line, rho, c),
        })
        .reduce(|| 0.0, f32::max)
}

#[inline(always)]
fn dual_line(g: &Grid, ubar: &[f32], yl: &mut [f32], line: usize, rho: f32, c: usize) -> f32 {
    let (r, col, yy) = g.line_coords(line);
    let [sr, sc, sy, _] = g.strides;
    let n = g.width * c;
    let base = line * n;
    let u0 = &ubar[base..base + n];
    // Forward neighbours along each axis; `None` at the last sample (Neumann: zero gradient).
    let ur = (r + 1 < g.rows).then(|| &ubar[base + sr..base + sr + n]);
    let uc = (col + 1 < g.cols).then(|| &ubar[base + sc..base + sc + n]);
    let uy = (yy + 1 < g.height).then(|| &ubar[base + sy..base + sy + n]);
    // `y + ρ∇ū` for channel `k` of pixel `x`, as [row, col, y, x].
    let step = |yp: &[f32], x: usize, k: usize| {
        let p = x * c;
        let u = u0[p + k];
        let gr = ur.map_or(0.0, |s| s[p + k] - u);
        let gc = uc.map_or(0.0, |s| s[p + k] - u);
        let gy = uy.map_or(0.0, |s| s[p + k] - u);
        let gx = if x + 1 < g.width {
            u0[p + c + k] - u
        } else {
            0.0
        };
        [
            yp[k] + rho * gr,
            yp[c + k] + rho * gc,
            yp[2 * c + k] + rho * gy,
            yp[3 * c + k] + rho * gx,
        ]
    };
    let mut change = 0.0f32;
    for x in 0..g.width {
        let yp = &mut yl[x * 4 * c..(x + 1) * 4 * c];
        let mut norm = [0.0f32; 4];
        for k in 0..c {
            let v = step(yp, x, k);
            for a in 0..4 {
                norm[a] += v[a] * v[a];
            }
        }
        let norm_sq = (norm[0] + norm[1]) + (norm[2] + norm[3]);
        let s = if norm_sq > 1.0 {
            1.0 / norm_sq.sqrt()
        } else {
            1.0
        };
        // Recomputing the step (cheap arithmetic) instead of buffering it keeps the kernel
        // allocation-free for any channel count.
        for k in 0..c {
            let v = step(yp, x, k);
            for (a, va) in v.iter().enumerate() {
                let new = va * s;
                change = change.max((new - yp[a * c + k]).abs());
                yp[a * c + k] = new;
            }
        }
    }
    change
}

/// Primal update, eq. (P) of the module docs: `u ← f + shrink(u + τ div y − f, τβ)`, then
/// `ū ← 2u − u_old`. Returns `max |u − u_old|`, the convergence measure (a maximum, so exact
/// and independent of the evaluation order).
pub(super) fn primal_pass(
    g: &Grid,
    y: &[f32],
    f: &[f32],
    u: &mut [f32],
    ubar: &mut [f32],
    tau: f32,
    tau_beta: f32,
) -> f32 {
    let n = g.width * g.channels;
    u.par_chunks_mut(n)
        .zip(ubar.par_chunks_mut(n))
        .enumerate()
        .map(|(line, (ul, bl))| match g.channels {
            1 => primal_line(g, y, f, ul, bl, line, tau, tau_beta, 1),
            3 => primal_line(g, y, f, ul, bl, line, tau, tau_beta, 3),
            c => primal_line(g, y, f, ul, bl, line, tau, tau_beta, c),
        })
        .reduce(|| 0.0, f32::max)
}

#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn primal_line(
    g: &Grid,
    y: &[f32],
    f: &[f32],
    ul: &mut [f32],
    bl: &mut [f32],
    line: usize,
    tau: f32,
    tau_beta: f32,
    c: usize,
) -> f32 {
    let (r, col, yy) = g.line_coords(line);
    let n = g.width * c;
    let ny = 4 * n;
    let y_line = |l: usize| &y[l * ny..(l + 1) * ny];
    let y0 = y_line(line);
    // Backward neighbours' multipliers; absent at the first sample (Neumann boundary).
    let yr = (r > 0).then(|| y_line(line - g.cols * g.height));
    let yc = (col > 0).then(|| y_line(line - g.height));
    let yb = (yy > 0).then(|| y_line(line - 1));
    let fl = &f[line * n..(line + 1) * n];
    let mut change = 0.0f32;
    for x in 0..g.width {
        let q = x * 4 * c;
        for k in 0..c {
            // div y = −∇ᵀy: backward differences of each axis' multiplier; the multiplier of
            // the last sample along an axis is always 0, so it needs no test.
            let dr = y0[q + k] - yr.map_or(0.0, |s| s[q + k]);
            let dc = y0[q + c + k] - yc.map_or(0.0, |s| s[q + c + k]);
            let dy = y0[q + 2 * c + k] - yb.map_or(0.0, |s| s[q + 2 * c + k]);
            let dx = y0[q + 3 * c + k] - if x > 0 { y0[q - c + k] } else { 0.0 };
            let div = (dr + dc) + (dy + dx);
            let i = x * c + k;
            let old = ul[i];
            let fv = fl[i];
            let d = old + tau * div - fv;
            // Proximal map of τβ|· − f|: soft-threshold the residual towards the data.
            let shrunk = if d > tau_beta {
                d - tau_beta
            } else if d < -tau_beta {
                d + tau_beta
            } else {
                0.0
            };
            let new = fv + shrunk;
            ul[i] = new;
            bl[i] = new + (new - old);
            change = change.max((new - old).abs());
        }
    }
    change
}
