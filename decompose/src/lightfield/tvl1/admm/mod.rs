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

use kernel::Kernel;

mod kernel;

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
