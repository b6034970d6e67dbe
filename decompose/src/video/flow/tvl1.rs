//! The TV-L1 iteration at one pyramid level (Zach, Pock & Bischof 2007, Prop. 1 and 2; IPOL
//! 2013, Algorithm 1 without its outer multiscale loop).
//!
//! With `u = (u₁, u₂)` the flow, `v` the auxiliary field and `p₁, p₂` the dual fields of the
//! two total variations, each warp linearises the data term around the current flow `u₀`:
//!
//! ```text
//! ρ(u) = I₁(x + u₀) + ∇I₁(x + u₀)·(u − u₀) − I₀(x)
//! ```
//!
//! and then repeats, until the mean of `|uⁿ⁺¹ − uⁿ|²` is at most `ε²`:
//!
//! ```text
//! v = u + { λθ∇I₁ if ρ(u) < −λθ|∇I₁|²;  −λθ∇I₁ if ρ(u) > λθ|∇I₁|²;  −ρ(u)∇I₁/|∇I₁|² otherwise }
//! u = v + θ div p                                        (thresholding, then the TV step)
//! p = (p + (τ/θ)∇u) / (1 + (τ/θ)|∇u|)                     (Chambolle's fixed point, per component)
//! ```
//!
//! `∇` is the forward difference (zero past the last row/column) and `div` its negative
//! adjoint, so `div p` is exactly `−∇ᵀp`.
//!
//! Layout: the flow is `[u₁, u₂]` per pixel and the duals `[p₁₁, p₁₂, p₂₁, p₂₂]` per pixel,
//! so one iteration is two parallel sweeps over row chunks (the `v`/`u` update, then the `p`
//! update), with no allocation. The convergence sum is taken per chunk in `f64` and added in
//! chunk order, so the iteration count and the result do not depend on the thread count.

use rayon::prelude::*;

use super::TvL1FlowParams;
use super::plane::{Plane, Taps, rows_per_chunk};

/// Below this, `|∇I₁|²` counts as zero and the thresholding leaves `u` unchanged (IPOL's
/// `GRAD_IS_ZERO`).
const GRAD_IS_ZERO: f32 = 1e-10;

/// Runs the warps and inner iterations at one level, refining `u` in place; returns the total
/// number of inner iterations and the last convergence measure (mean `|Δu|²`).
pub(super) fn solve_level(
    i0: &Plane,
    i1: &Plane,
    u: &mut [[f32; 2]],
    params: &TvL1FlowParams,
) -> (usize, f32) {
    let (w, h) = (i0.w, i0.h);
    let n = w * h;
    let (i1x, i1y) = i1.centred_gradient();
    // I₁ and its gradient interleaved, so one set of bicubic taps serves all three.
    let stack: Vec<[f32; 3]> = (0..n)
        .map(|i| [i1.data[i], i1x.data[i], i1y.data[i]])
        .collect();
    let rows = rows_per_chunk(w);
    let chunk = rows * w;
    let lt = params.lambda * params.theta;
    let theta = params.theta;
    let taut = params.tau / params.theta;
    let stop = params.epsilon * params.epsilon;

    // Per pixel after warping: [∂xI₁(x+u₀), ∂yI₁(x+u₀), |∇I₁|², ρ's constant part].
    let mut data = vec![[0.0f32; 4]; n];
    let mut dual = vec![[0.0f32; 4]; n];
    let chunks = h.div_ceil(rows);
    let mut boundary = Vec::with_capacity(chunks.saturating_sub(1) * w);
    let k = Consts { lt, theta };
    let mut total = 0;
    let mut change = f32::INFINITY;
    for _ in 0..params.warps {
        data.par_chunks_mut(w)
            .zip(u.par_chunks(w))
            .enumerate()
            .for_each(|(y, (drow, urow))| {
                for (x, (d, uu)) in drow.iter_mut().zip(urow).enumerate() {
                    let taps = Taps::new(x as f32 + uu[0], y as f32 + uu[1], w, h);
                    let [iw, ix, iy] = taps.apply3(&stack, w);
                    let rho_c = iw - ix * uu[0] - iy * uu[1] - i0.data[y * w + x];
                    *d = [ix, iy, ix * ix + iy * iy, rho_c];
                }
            });

        let mut iterations = 0;
        loop {
            iterations += 1;
            // One fused sweep per chunk of rows: the primal step of row r + 1 (which still
            // needs the old duals of rows r and r + 1), then the dual step of row r (which
            // needs the new flow of rows r and r + 1). A chunk's first row reads the old duals
            // of the row above from `boundary`; its last row's dual step waits for the next
            // chunk's flow (second sweep). The arithmetic is that of the two-pass scheme.
            boundary.clear();
            for c in 1..chunks {
                let y = c * rows - 1;
                boundary.extend_from_slice(&dual[y * w..(y + 1) * w]);
            }
            let sums: Vec<f64> = u
                .par_chunks_mut(chunk)
                .zip(dual.par_chunks_mut(chunk))
                .enumerate()
                .map(|(c, (uc, pc))| {
                    let y0 = c * rows;
                    let nr = uc.len() / w;
                    let row = |r: usize| r * w..(r + 1) * w;
                    let above = (c > 0).then(|| &boundary[(c - 1) * w..c * w]);
                    let data_row = |r: usize| &data[(y0 + r) * w..(y0 + r + 1) * w];
                    let mut sum = primal_row(
                        &mut uc[row(0)],
                        data_row(0),
                        &pc[row(0)],
                        above,
                        y0 + 1 < h,
                        &k,
                    ) as f64;
                    for r in 0..nr {
                        if r + 1 < nr {
                            let last = y0 + r + 2 >= h;
                            let (up, here) = pc.split_at(row(r + 1).start);
                            sum += primal_row(
                                &mut uc[row(r + 1)],
                                data_row(r + 1),
                                &here[..w],
                                Some(&up[row(r)]),
                                !last,
                                &k,
                            ) as f64;
                            let (top, bottom) = uc.split_at(row(r + 1).start);
                            dual_row(&mut pc[row(r)], &top[row(r)], &bottom[..w], taut);
                        } else if y0 + r + 1 == h {
                            // The image's last row: no row below (zero forward difference).
                            let urow = &uc[row(r)];
                            dual_row(&mut pc[row(r)], urow, urow, taut);
                        }
                    }
                    sum
                })
                .collect();
            change = (sums.iter().sum::<f64>() / n as f64) as f32;
            let uref: &[[f32; 2]] = u;
            dual.par_chunks_mut(chunk).enumerate().for_each(|(c, pc)| {
                let y = c * rows + pc.len() / w - 1;
                if y + 1 < h {
                    let start = pc.len() - w;
                    let prow = &mut pc[start..];
                    dual_row(
                        prow,
                        &uref[y * w..(y + 1) * w],
                        &uref[(y + 1) * w..(y + 2) * w],
                        taut,
                    );
                }
            });
            if change <= stop || iterations >= params.max_iterations {
                break;
            }
        }
        total += iterations;
    }
    (total, change)
}

struct Consts {
    /// λθ.
    lt: f32,
    /// θ.
    theta: f32,
}

/// The primal step on one row: thresholding (Prop. 2) then `u = v + θ div p` (Prop. 1).
/// `prow` holds the duals of this row, `above` those of the row above (`None` on the first
/// row); returns the row's `Σ|uⁿ⁺¹ − uⁿ|²`.
#[inline]
fn primal_row(
    urow: &mut [[f32; 2]],
    drow: &[[f32; 4]],
    prow: &[[f32; 4]],
    above: Option<&[[f32; 4]]>,
    not_last_row: bool,
    k: &Consts,
) -> f32 {
    let lt = k.lt;
    let mut row_sum = 0.0f32;
    for x in 0..urow.len() {
        let [ix, iy, g2, rho_c] = drow[x];
        let uu = urow[x];
        let rho = rho_c + ix * uu[0] + iy * uu[1];
        let (d1, d2) = if rho < -lt * g2 {
            (lt * ix, lt * iy)
        } else if rho > lt * g2 {
            (-lt * ix, -lt * iy)
        } else if g2 < GRAD_IS_ZERO {
            (0.0, 0.0)
        } else {
            (-rho * ix / g2, -rho * iy / g2)
        };
        let div = divergence(prow, above, x, not_last_row);
        let new = [uu[0] + d1 + k.theta * div[0], uu[1] + d2 + k.theta * div[1]];
        let (e1, e2) = (new[0] - uu[0], new[1] - uu[1]);
        row_sum += e1 * e1 + e2 * e2;
        urow[x] = new;
    }
    row_sum
}

/// The dual step on one row: `p = (p + (τ/θ)∇u) / (1 + (τ/θ)|∇u|)` for both components, with
/// `below` the flow of the next row (this row itself on the last row: zero difference).
#[inline]
fn dual_row(prow: &mut [[f32; 4]], urow: &[[f32; 2]], below: &[[f32; 2]], taut: f32) {
    let w = urow.len();
    for x in 0..w {
        let here = urow[x];
        let right = if x + 1 < w { urow[x + 1] } else { here };
        let down = below[x];
        let (u1x, u1y) = (right[0] - here[0], down[0] - here[0]);
        let (u2x, u2y) = (right[1] - here[1], down[1] - here[1]);
        let r1 = 1.0 / (1.0 + taut * (u1x * u1x + u1y * u1y).sqrt());
        let r2 = 1.0 / (1.0 + taut * (u2x * u2x + u2y * u2y).sqrt());
        let p = &mut prow[x];
        *p = [
            (p[0] + taut * u1x) * r1,
            (p[1] + taut * u1y) * r1,
            (p[2] + taut * u2x) * r2,
            (p[3] + taut * u2y) * r2,
        ];
    }
}

/// `div p` of both dual fields at column `x` of a row (`prow`, with `pup` the row above, `None`
/// on the first row; `not_last_row` false on the last): backward differences, the negative
/// adjoint of the forward gradient with its zero difference past the last column/row.
#[inline]
fn divergence(
    prow: &[[f32; 4]],
    pup: Option<&[[f32; 4]]>,
    x: usize,
    not_last_row: bool,
) -> [f32; 2] {
    let here = prow[x];
    let (mut d1, mut d2) = (0.0, 0.0);
    if x + 1 < prow.len() {
        d1 += here[0];
        d2 += here[2];
    }
    if x > 0 {
        d1 -= prow[x - 1][0];
        d2 -= prow[x - 1][2];
    }
    if not_last_row {
        d1 += here[1];
        d2 += here[3];
    }
    if let Some(up) = pup {
        d1 -= up[x][1];
        d2 -= up[x][3];
    }
    [d1, d2]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `div` is the negative adjoint of the forward gradient: ⟨∇u, p⟩ = −⟨u, div p⟩ for any
    /// `u` and `p` (what makes the dual step a projection of the right problem).
    #[test]
    fn divergence_is_minus_the_adjoint_of_the_forward_gradient() {
        let (w, h) = (5, 4);
        let n = w * h;
        let u: Vec<f32> = (0..n).map(|i| ((i * 7) % 11) as f32 * 0.3 - 1.0).collect();
        let p: Vec<[f32; 4]> = (0..n)
            .map(|i| {
                let a = ((i * 5) % 13) as f32 * 0.2 - 1.2;
                [a, 0.5 - a * a, 0.0, 0.0]
            })
            .collect();
        let mut grad_dot = 0.0f64;
        let mut div_dot = 0.0f64;
        for i in 0..n {
            let (x, y) = (i % w, i / w);
            let ux = if x + 1 < w { u[i + 1] - u[i] } else { 0.0 };
            let uy = if y + 1 < h { u[i + w] - u[i] } else { 0.0 };
            grad_dot += (ux * p[i][0] + uy * p[i][1]) as f64;
            let up = if y > 0 {
                Some(&p[i - x - w..i - x])
            } else {
                None
            };
            div_dot += (u[i] * divergence(&p[i - x..i - x + w], up, x, y + 1 < h)[0]) as f64;
        }
        assert!((grad_dot + div_dot).abs() < 1e-4, "{grad_dot} vs {div_dot}");
    }
}
