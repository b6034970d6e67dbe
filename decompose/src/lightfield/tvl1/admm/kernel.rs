//! The per-line kernels of one sweep: the dual update (D) and the primal update (P).

use super::Grid;

/// The per-line updates and their constants.
pub(super) struct Kernel<'a> {
    pub g: Grid,
    pub n: usize,
    pub rho: f32,
    pub tau: f32,
    pub tau_beta: f32,
    pub row_mask: &'a [f32],
    pub col_mask: &'a [f32],
    /// One line of zeros: the multipliers above the first line.
    pub zeros: &'a [f32],
}

impl Kernel<'_> {
    /// Dual update (D) of one line: `y ← Π(y + ρ∇ū)`, isotropic over the four axes and the
    /// channels of each ray. `below` is `ū` of the next line (`None` for the last line).
    /// Returns `max |Δy|`.
    pub fn dual(
        &self,
        u: &[f32],
        below: Option<&[f32]>,
        y: &mut [f32],
        scratch: &mut [f32],
    ) -> f32 {
        let (n, c) = (self.n, self.g.channels);
        let shifts = [self.g.cols * c, c, 0, self.g.pixel()];
        let blk = scratch.len() / 5;
        let (v, sq) = scratch.split_at_mut(4 * blk);
        let mut change = 0.0f32;
        let mut start = 0;
        while start < n {
            let end = (start + blk).min(n);
            let m = end - start;
            for a in 0..4 {
                let ya = &y[a * n + start..a * n + end];
                let va = &mut v[a * blk..a * blk + m];
                match a {
                    // Angular axes: the forward neighbour is in the same pixel block; the mask
                    // zeroes the gradient of the last row / column.
                    0 | 1 => {
                        let s = shifts[a];
                        let mask = if a == 0 { self.row_mask } else { self.col_mask };
                        let inner = (n - s).saturating_sub(start).min(m);
                        // An empty range may start past the end of the line: clamp it.
                        let s0 = (start + s).min(n);
                        let (r0, r1) = (start..start + inner, s0..s0 + inner);
                        for ((((o, &yv), &un), &uv), &mk) in va[..inner]
                            .iter_mut()
                            .zip(&ya[..inner])
                            .zip(&u[r1])
                            .zip(&u[r0.clone()])
                            .zip(&mask[r0])
                        {
                            *o = yv + self.rho * ((un - uv) * mk);
                        }
                        va[inner..].copy_from_slice(&ya[inner..]);
                    }
                    2 => match below {
                        Some(b) => {
                            for (((o, &yv), &bv), &uv) in va
                                .iter_mut()
                                .zip(ya)
                                .zip(&b[start..end])
                                .zip(&u[start..end])
                            {
                                *o = yv + self.rho * (bv - uv);
                            }
                        }
                        None => va.copy_from_slice(ya),
                    },
                    _ => {
                        let s = shifts[3];
                        let inner = (n - s).saturating_sub(start).min(m);
                        // An empty range may start past the end of the line: clamp it.
                        let s0 = (start + s).min(n);
                        let (r0, r1) = (start..start + inner, s0..s0 + inner);
                        for (((o, &yv), &un), &uv) in va[..inner]
                            .iter_mut()
                            .zip(&ya[..inner])
                            .zip(&u[r1])
                            .zip(&u[r0])
                        {
                            *o = yv + self.rho * (un - uv);
                        }
                        va[inner..].copy_from_slice(&ya[inner..]);
                    }
                }
            }
            let (vr, rest) = v.split_at(blk);
            let (vc, rest) = rest.split_at(blk);
            let (vy, vx) = rest.split_at(blk);
            for ((((o, &a), &b), &cc), &d) in sq[..m]
                .iter_mut()
                .zip(&vr[..m])
                .zip(&vc[..m])
                .zip(&vy[..m])
                .zip(&vx[..m])
            {
                *o = (a * a + b * b) + (cc * cc + d * d);
            }
            // Projection factor 1/max(1, ‖v‖) per ray (channels summed in order), branch-free
            // so that it vectorises.
            if c == 1 {
                for e in sq[..m].iter_mut() {
                    *e = 1.0 / (if *e > 1.0 { *e } else { 1.0 }).sqrt();
                }
            } else {
                for px in sq[..m].chunks_exact_mut(c) {
                    let mut total = 0.0f32;
                    for &e in px.iter() {
                        total += e;
                    }
                    px.fill(1.0 / (if total > 1.0 { total } else { 1.0 }).sqrt());
                }
            }
            for a in 0..4 {
                let ya = &mut y[a * n + start..a * n + end];
                for ((o, &vv), &s) in ya.iter_mut().zip(&v[a * blk..a * blk + m]).zip(&sq[..m]) {
                    let new = vv * s;
                    // A select rather than `f32::max` so that the loop vectorises.
                    let delta = (new - *o).abs();
                    change = if delta > change { delta } else { change };
                    *o = new;
                }
            }
            start = end;
        }
        change
    }

    /// Primal update (P) of one line: `u ← f + shrink(u + τ div y − f, τβ)`, `ū ← 2u − u_old`.
    /// `y_above` holds the multipliers of the previous line (`None` for the first line);
    /// `known` the line's known-data flags (1 or 0; empty: all known), which scale `τβ`.
    /// Returns `max |Δu|`.
    pub fn primal(
        &self,
        y: &[f32],
        y_above: Option<&[f32]>,
        f: &[f32],
        known: &[f32],
        u: &mut [f32],
        ubar: &mut [f32],
    ) -> f32 {
        let (n, c) = (self.n, self.g.channels);
        let (yr, yc, yy, yx) = (&y[..n], &y[n..2 * n], &y[2 * n..3 * n], &y[3 * n..4 * n]);
        let above = y_above.map_or(self.zeros, |a| &a[2 * n..3 * n]);
        let (sr, sc, sx) = (self.g.cols * c, c, self.g.pixel());
        let (tau, tb) = (self.tau, self.tau_beta);
        // One element of (P) given the four backward differences.
        let update =
            |i: usize, dr: f32, dc: f32, dy: f32, dx: f32, u: &mut [f32], ub: &mut [f32]| {
                let div = (dr + dc) + (dy + dx);
                let old = u[i];
                let fv = f[i];
                let d = old + tau * div - fv;
                let tb = if known.is_empty() { tb } else { tb * known[i] };
                // Proximal map of τβ|· − f|: soft-threshold the residual towards the data.
                let lo = if d < -tb { -tb } else { d };
                let clamped = if lo > tb { tb } else { lo };
                let new = fv + (d - clamped);
                u[i] = new;
                ub[i] = new + (new - old);
                (new - old).abs()
            };
        // Backward differences along the in-line axes: before the first sample the multiplier
        // counts as 0, and where a shift wraps into the previous pixel block it lands on a
        // last-row/column multiplier, which is exactly +0. The first pixel block (where the
        // shifts can leave the line) takes the careful path, the rest a straight loop.
        let back = |p: &[f32], s: usize, i: usize| p[i] - if i >= s { p[i - s] } else { 0.0 };
        let head = sx.min(n);
        let mut change = 0.0f32;
        for i in 0..head {
            let delta = update(
                i,
                back(yr, sr, i),
                back(yc, sc, i),
                yy[i] - above[i],
                back(yx, sx, i),
                u,
                ubar,
            );
            change = if delta > change { delta } else { change };
        }
        let len = n - head;
        let (yr0, yr1) = (&yr[head..][..len], &yr[head - sr..][..len]);
        let (yc0, yc1) = (&yc[head..][..len], &yc[head - sc..][..len]);
        let (yy0, yy1) = (&yy[head..][..len], &above[head..][..len]);
        let (yx0, yx1) = (&yx[head..][..len], &yx[head - sx..][..len]);
        let fl = &f[head..][..len];
        let ul = &mut u[head..][..len];
        let bl = &mut ubar[head..][..len];
        let div = |t: usize| {
            ((yr0[t] - yr1[t]) + (yc0[t] - yc1[t])) + ((yy0[t] - yy1[t]) + (yx0[t] - yx1[t]))
        };
        // Two copies of the loop so that the common one (all data known) keeps a constant
        // threshold and vectorises.
        if known.is_empty() {
            for t in 0..len {
                let delta = primal_step(div(t), fl[t], tau, tb, &mut ul[t], &mut bl[t]);
                change = if delta > change { delta } else { change };
            }
        } else {
            let kl = &known[head..][..len];
            for t in 0..len {
                let delta = primal_step(div(t), fl[t], tau, tb * kl[t], &mut ul[t], &mut bl[t]);
                change = if delta > change { delta } else { change };
            }
        }
        change
    }
}

/// One element of (P): `u ← f + shrink(u + τ div − f, tb)`, `ū ← 2u − u_old`; returns `|Δu|`.
#[inline(always)]
fn primal_step(div: f32, fv: f32, tau: f32, tb: f32, u: &mut f32, ubar: &mut f32) -> f32 {
    let old = *u;
    let d = old + tau * div - fv;
    // Selects rather than `f32::clamp`/`max` so that the loops vectorise.
    let lo = if d < -tb { -tb } else { d };
    let clamped = if lo > tb { tb } else { lo };
    let new = fv + (d - clamped);
    *u = new;
    *ubar = new + (new - old);
    (new - old).abs()
}
