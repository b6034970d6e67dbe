//! One linearised-ADMM iteration as a single fused sweep (see the module docs for the updates).
//!
//! The solver works in a *pixel-major* copy of the light field: index
//! `((y·width + x)·views + view)·channels + k`. Every neighbour of a sample along the two
//! angular axes and along `x` is then in the same spatial line (one image row of all views,
//! `width·views·channels` values), and along `y` in the next line, so a sweep reads each
//! buffer once from memory instead of once per axis.
//!
//! The sweep runs over lines. For line `L` it updates the multipliers (D), which need `ū` of
//! lines `L` and `L + 1`, then the primal variable (P), which needs the new multipliers of
//! lines `L` and `L − 1` and overwrites `ū` of line `L` (no longer needed: line `L − 1` was
//! already done). Lines are split into chunks processed in parallel; a chunk's first primal
//! update waits for the end of the sweep because it needs the previous chunk's last
//! multipliers, and the previous chunk's last dual update reads this chunk's first `ū` line,
//! which is kept unchanged until then. Every value is therefore the same function of the
//! previous iterate whatever the chunking, so results do not depend on the thread count.
//!
//! Along each axis the multiplier of the last sample is always exactly `+0` (its gradient is
//! 0 under Neumann boundaries), which lets the backward differences of (P) run over a whole
//! line with one shift per axis. The row and column terms are combined as
//! `(row + col) + (y + x)`; IEEE addition is commutative, so swapping the angular axes gives
//! bit-identical results.

use rayon::prelude::*;

/// Elements per block of the dual kernel's scratch (rounded down to whole pixels).
const BLOCK: usize = 192;

/// Shape of the 4D grid.
#[derive(Clone, Copy, Debug)]
pub(super) struct Grid {
    pub rows: usize,
    pub cols: usize,
    pub height: usize,
    pub width: usize,
    pub channels: usize,
}

impl Grid {
    fn views(&self) -> usize {
        self.rows * self.cols
    }

    /// Values per spatial pixel: all views, all channels.
    fn pixel(&self) -> usize {
        self.views() * self.channels
    }

    /// Values per spatial line.
    pub fn line(&self) -> usize {
        self.width * self.pixel()
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

/// Copies a light-field buffer (views-major, the `LightField` layout) into pixel-major order.
pub(super) fn to_pixel_major(g: &Grid, src: &[f32]) -> Vec<f32> {
    let (c, w, view_len) = (g.channels, g.width, g.width * g.height * g.channels);
    let mut out = vec![0.0; src.len()];
    out.par_chunks_mut(g.line())
        .enumerate()
        .for_each(|(y, line)| {
            for (x, px) in line.chunks_exact_mut(g.pixel()).enumerate() {
                for (v, dst) in px.chunks_exact_mut(c).enumerate() {
                    let s = v * view_len + (y * w + x) * c;
                    dst.copy_from_slice(&src[s..s + c]);
                }
            }
        });
    out
}

/// The inverse of [`to_pixel_major`].
pub(super) fn from_pixel_major(g: &Grid, src: &[f32]) -> Vec<f32> {
    let (c, w, h) = (g.channels, g.width, g.height);
    let mut out = vec![0.0; src.len()];
    out.par_chunks_mut(w * h * c)
        .enumerate()
        .for_each(|(v, view)| {
            for (i, dst) in view.chunks_exact_mut(c).enumerate() {
                let s = i * g.pixel() + v * c;
                dst.copy_from_slice(&src[s..s + c]);
            }
        });
    out
}

/// Buffers of the solver, all pixel-major, allocated once per run.
pub(super) struct State {
    g: Grid,
    /// `f`, `u`, `ū`.
    f: Vec<f32>,
    u: Vec<f32>,
    ubar: Vec<f32>,
    /// Multipliers: per line, four planes `[row, col, y, x]` of one line each.
    y: Vec<f32>,
    /// 1 where the sample has a forward neighbour along the row (resp. col) axis, else 0;
    /// one line long.
    row_mask: Vec<f32>,
    col_mask: Vec<f32>,
    zeros: Vec<f32>,
    /// Per sample, 1 where `f` is known and 0 where it is not (no fidelity term: the filter
    /// fills the sample in); empty when every sample is known.
    known: Vec<f32>,
    /// Lines per chunk of the parallel sweep.
    chunk_lines: usize,
    /// Per chunk: a copy of the next chunk's first `ū` line, and the dual kernel's scratch.
    chunks: Vec<(Vec<f32>, Vec<f32>)>,
}

impl State {
    pub fn new(g: Grid, f_views_major: &[f32]) -> Self {
        // Enough chunks to balance the threads, few enough that the serial boundary lines
        // stay cheap; the chunking does not change the result.
        let chunk_lines = g.height.div_ceil(8 * rayon::current_num_threads()).max(1);
        Self::with_chunk_lines(g, f_views_major, chunk_lines)
    }

    /// [`State::new`] with a given number of lines per parallel chunk.
    pub fn with_chunk_lines(g: Grid, f_views_major: &[f32], chunk_lines: usize) -> Self {
        let f = to_pixel_major(&g, f_views_major);
        let n = g.line();
        let (c, cols, views) = (g.channels, g.cols, g.views());
        let mask = |has: &dyn Fn(usize, usize) -> bool| -> Vec<f32> {
            (0..n)
                .map(|i| {
                    let v = (i / c) % views;
                    if has(v / cols, v % cols) { 1.0 } else { 0.0 }
                })
                .collect()
        };
        let row_mask = mask(&|r, _| r + 1 < g.rows);
        let col_mask = mask(&|_, col| col + 1 < g.cols);
        let blk = (BLOCK / c).max(1) * c;
        let chunks = (0..g.height.div_ceil(chunk_lines))
            .map(|_| (vec![0.0; n], vec![0.0; 5 * blk]))
            .collect();
        Self {
            g,
            u: f.clone(),
            ubar: f.clone(),
            y: vec![0.0; 4 * f.len()],
            known: Vec::new(),
            f,
            row_mask,
            col_mask,
            zeros: vec![0.0; n],
            chunk_lines,
            chunks,
        }
    }

    /// Marks the samples whose data is unknown (views-major flags, one per sample).
    pub fn set_unknown(&mut self, unknown_views_major: &[bool]) {
        let as_f32: Vec<f32> = unknown_views_major
            .iter()
            .map(|&u| if u { 0.0 } else { 1.0 })
            .collect();
        self.known = to_pixel_major(&self.g, &as_f32);
    }

    /// The current `u`, pixel-major; frees everything else.
    pub fn into_u(self) -> Vec<f32> {
        self.u
    }

    /// One iteration; returns `max(max |Δu|, max |Δy|)`.
    pub fn iterate(&mut self, rho: f32, tau: f32, tau_beta: f32) -> f32 {
        let g = self.g;
        let n = g.line();
        let cl = self.chunk_lines;
        // Keep each chunk's view of the next chunk's first ū line (unchanged until phase 2).
        let ubar = &self.ubar;
        self.chunks
            .par_iter_mut()
            .enumerate()
            .for_each(|(ci, (next, _))| {
                let l = (ci + 1) * cl;
                if l < g.height {
                    next.copy_from_slice(&ubar[l * n..(l + 1) * n]);
                }
            });
        let k = Kernel {
            g,
            n,
            rho,
            tau,
            tau_beta,
            row_mask: &self.row_mask,
            col_mask: &self.col_mask,
            zeros: &self.zeros,
        };
        let known = &self.known;
        let known_line = |start: usize| -> &[f32] {
            if known.is_empty() {
                &[]
            } else {
                &known[start..start + n]
            }
        };
        // Phase 1: per chunk, dual updates of all lines and primal updates of all but the first.
        let change = self
            .u
            .par_chunks_mut(cl * n)
            .zip(self.ubar.par_chunks_mut(cl * n))
            .zip(self.y.par_chunks_mut(cl * 4 * n))
            .zip(self.f.par_chunks(cl * n))
            .zip(self.chunks.par_iter_mut())
            .enumerate()
            .map(|(ci, ((((u, ub), y), f), (next, scratch)))| {
                let lines = u.len() / n;
                let mut change = 0.0f32;
                for l in 0..lines {
                    let global = ci * cl + l;
                    let below = if global + 1 == g.height {
                        None
                    } else if l + 1 < lines {
                        Some(&ub[(l + 1) * n..(l + 2) * n])
                    } else {
                        Some(&next[..])
                    };
                    let (y_done, y_rest) = y.split_at_mut(l * 4 * n);
                    let y_cur = &mut y_rest[..4 * n];
                    change = change.max(k.dual(&ub[l * n..(l + 1) * n], below, y_cur, scratch));
                    if l > 0 {
                        let y_prev = &y_done[(l - 1) * 4 * n..];
                        let r = l * n..(l + 1) * n;
                        let start = (ci * cl + l) * n;
                        change = change.max(k.primal(
                            y_cur,
                            Some(y_prev),
                            &f[r.clone()],
                            known_line(start),
                            &mut u[r.clone()],
                            &mut ub[r],
                        ));
                    }
                }
                change
            })
            .reduce(|| 0.0, f32::max);
        // Phase 2: the first line of every chunk, now that all multipliers are new.
        let y = &self.y;
        let f = &self.f;
        let change2 = self
            .u
            .par_chunks_mut(cl * n)
            .zip(self.ubar.par_chunks_mut(cl * n))
            .enumerate()
            .map(|(ci, (u, ub))| {
                let l = ci * cl;
                let y_prev = (l > 0).then(|| &y[(l - 1) * 4 * n..l * 4 * n]);
                k.primal(
                    &y[l * 4 * n..(l + 1) * 4 * n],
                    y_prev,
                    &f[l * n..(l + 1) * n],
                    known_line(l * n),
                    &mut u[..n],
                    &mut ub[..n],
                )
            })
            .reduce(|| 0.0, f32::max);
        change.max(change2)
    }
}

/// The per-line updates and their constants.
struct Kernel<'a> {
    g: Grid,
    n: usize,
    rho: f32,
    tau: f32,
    tau_beta: f32,
    row_mask: &'a [f32],
    col_mask: &'a [f32],
    /// One line of zeros: the multipliers above the first line.
    zeros: &'a [f32],
}

impl Kernel<'_> {
    /// Dual update (D) of one line: `y ← Π(y + ρ∇ū)`, isotropic over the four axes and the
    /// channels of each ray. `below` is `ū` of the next line (`None` for the last line).
    /// Returns `max |Δy|`.
    fn dual(&self, u: &[f32], below: Option<&[f32]>, y: &mut [f32], scratch: &mut [f32]) -> f32 {
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
    fn primal(
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pixel_major_round_trips() {
        let g = Grid {
            rows: 2,
            cols: 3,
            height: 4,
            width: 5,
            channels: 3,
        };
        let src: Vec<f32> = (0..2 * 3 * 4 * 5 * 3).map(|i| i as f32).collect();
        let pm = to_pixel_major(&g, &src);
        // Sample (row 1, col 2, y 3, x 4, channel 2) in both layouts.
        let views_major = (((3 + 2) * 4 + 3) * 5 + 4) * 3 + 2;
        let pixel_major = ((3 * 5 + 4) * 6 + (3 + 2)) * 3 + 2;
        assert_eq!(pm[pixel_major], src[views_major]);
        assert_eq!(from_pixel_major(&g, &pm), src);
    }
}
