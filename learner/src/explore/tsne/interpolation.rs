//! The repulsive sums of the t-SNE gradient by polynomial interpolation and FFT (FIt-SNE:
//! Linderman et al. 2019, "Fast interpolation-based t-SNE for improved visualization of
//! single-cell RNA-seq data", Nature Methods, §Methods "2-D case").
//!
//! With `K(y, y') = 1/(1 + ‖y − y'‖²)²` the repulsive force and `Z` are four sums of one kernel
//! over charges `q_j ∈ {1, y_j,x, y_j,y, ‖y_j‖²}`:
//!
//! `Σ_j w_ij² (y_i − y_j) = y_i φ_1(i) − (φ_2(i), φ_3(i))`,
//! `Σ_j w_ij = (1 + ‖y_i‖²) φ_1(i) − 2 y_i·(φ_2(i), φ_3(i)) + φ_4(i)` (the `j = i` term is 1),
//! `φ_c(i) = Σ_j K(y_i, y_j) q_j,c`.
//!
//! The bounding square of the embedding is cut into `B × B` boxes, each with `p × p`
//! equispaced nodes (`p` = `n_interpolation_points`, `B = max(min_num_intervals, span /
//! ints_in_interval)`, rounded up to a size with no prime factor above 5 for the FFT); every
//! charge is spread onto the `p²` nodes of its box by the Lagrange polynomials of those nodes,
//! the node potentials are the kernel's (Toeplitz) convolution over the `pB × pB` node grid,
//! done by FFT on a grid of twice that side, and each point's potentials are interpolated back
//! from its box's nodes. Coordinates are taken relative to the square's centre so that `‖y‖²`
//! stays small beside the span.
//!
//! Deterministic for any thread count: the charges are spread point by point in index order,
//! every FFT row is transformed on its own (in fixed chunks), and each point's interpolation is
//! its own.

use std::cell::RefCell;
use std::sync::Arc;

use rayon::prelude::*;
use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};

use super::quadtree::Repulsion;

/// Boxes per side at most: beyond it the boxes widen (the approximation coarsens) rather than
/// the grids growing without bound (a `6·400`-point FFT side: about 90 MB per grid).
pub const MAX_INTERVALS: usize = 400;

/// Rows per parallel task of the row transforms and transposes.
const ROWS: usize = 8;

thread_local! {
    /// The planner keeps its plans: the FFT side changes rarely between iterations.
    static PLANNER: RefCell<FftPlanner<f64>> = RefCell::new(FftPlanner::new());
}

/// The interpolation parameters (openTSNE's names).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Interpolation {
    /// `p`: nodes per box side.
    pub points: usize,
    /// The fewest boxes per side.
    pub min_intervals: usize,
    /// The widest box side.
    pub ints_in_interval: f64,
}

type C = Complex<f64>;

/// The smallest `m ≥ n` with no prime factor above 5.
fn smooth(mut n: usize) -> usize {
    loop {
        let mut m = n;
        for f in [2, 3, 5] {
            while m.is_multiple_of(f) {
                m /= f;
            }
        }
        if m == 1 {
            return n;
        }
        n += 1;
    }
}

/// Boxes per side for a span (the square's side).
pub(super) fn boxes(span: f64, params: &Interpolation) -> usize {
    let wanted = (span / params.ints_in_interval).ceil();
    let wanted = if wanted.is_finite() && wanted > 0.0 {
        wanted.min(MAX_INTERVALS as f64) as usize
    } else {
        1
    };
    smooth(wanted.max(params.min_intervals).max(1)).min(MAX_INTERVALS)
}

/// The Lagrange basis of nodes `(j + ½)/p` on `[0, 1]`, evaluated at `u`, into `out`.
fn lagrange(u: f64, p: usize, out: &mut [f64]) {
    let node = |j: usize| (j as f64 + 0.5) / p as f64;
    for (j, o) in out.iter_mut().enumerate() {
        let mut v = 1.0;
        for m in 0..p {
            if m != j {
                v *= (u - node(m)) / (node(j) - node(m));
            }
        }
        *o = v;
    }
}

/// Transforms every row (length `m`) of `data` in place.
fn rows(fft: &Arc<dyn Fft<f64>>, data: &mut [C], m: usize) {
    let scratch = fft.get_inplace_scratch_len();
    data.par_chunks_mut(m * ROWS).for_each_init(
        || vec![C::default(); scratch],
        |s, chunk| fft.process_with_scratch(chunk, s),
    );
}

/// `dst[r][c] = src[c][r]` for the first `dst.len() / m` rows of `dst` (`src` is `m × m`).
fn transpose(src: &[C], dst: &mut [C], m: usize) {
    dst.par_chunks_mut(m * ROWS)
        .enumerate()
        .for_each(|(b, block)| {
            let r0 = b * ROWS;
            let height = block.len() / m;
            for c in 0..m {
                let from = &src[c * m + r0..c * m + r0 + height];
                for (dr, &v) in from.iter().enumerate() {
                    block[dr * m + c] = v;
                }
            }
        });
}

/// The repulsion on every point (force and its share of `Z`, the `j = i` term removed).
pub(super) fn repulsion(y: &[[f64; 2]], params: &Interpolation) -> Vec<Repulsion> {
    let p = params.points;
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in y.iter().flatten() {
        lo = lo.min(*v);
        hi = hi.max(*v);
    }
    let span = (hi - lo).max(1e-9 * (1.0 + lo.abs().max(hi.abs())));
    let b = boxes(span, params);
    let box_width = span / b as f64;
    let h = box_width / p as f64;
    let centre = lo + span / 2.0;
    // Node grid side and FFT side (a circulant embedding of the Toeplitz kernel).
    let nodes = b * p;
    let m = 2 * nodes;

    // Each point's first node and Lagrange weights per axis, relative coordinates.
    let located: Vec<([usize; 2], Vec<f64>)> = y
        .par_iter()
        .map(|yi| {
            let mut first = [0; 2];
            let mut w = vec![0.0; 2 * p];
            for d in 0..2 {
                let t = (yi[d] - lo) / box_width;
                let k = (t.floor().max(0.0) as usize).min(b - 1);
                first[d] = k * p;
                lagrange(t - k as f64, p, &mut w[d * p..(d + 1) * p]);
            }
            (first, w)
        })
        .collect();

    // Charges (1, x) and (y, ‖y‖²) as two complex grids, spread in index order.
    let mut a = vec![C::default(); m * m];
    let mut c = vec![C::default(); m * m];
    for (yi, (first, w)) in y.iter().zip(&located) {
        let (x0, y0) = (yi[0] - centre, yi[1] - centre);
        let (qa, qc) = (C::new(1.0, x0), C::new(y0, x0 * x0 + y0 * y0));
        for (r, &wr) in w[p..].iter().enumerate() {
            let row = (first[1] + r) * m + first[0];
            for (s, &ws) in w[..p].iter().enumerate() {
                a[row + s] += qa * (wr * ws);
                c[row + s] += qc * (wr * ws);
            }
        }
    }

    let (forward, inverse) = PLANNER
        .with_borrow_mut(|planner| (planner.plan_fft_forward(m), planner.plan_fft_inverse(m)));
    let mut scratch = vec![C::default(); m * m];

    // The kernel at node offsets (r, s) mod m; it is even in both axes and symmetric in them,
    // so its transform is real and equal to its own transpose.
    let offset = |i: usize| -> Option<f64> {
        match i {
            i if i < nodes => Some(i as f64),
            i if i > nodes => Some(i as f64 - m as f64),
            _ => None,
        }
    };
    let mut kernel = vec![C::default(); m * m];
    kernel.par_chunks_mut(m).enumerate().for_each(|(r, row)| {
        if let Some(dr) = offset(r) {
            for (s, v) in row.iter_mut().enumerate() {
                if let Some(ds) = offset(s) {
                    let q = 1.0 + h * h * (dr * dr + ds * ds);
                    *v = C::new(1.0 / (q * q), 0.0);
                }
            }
        }
    });
    rows(&forward, &mut kernel, m);
    transpose(&kernel, &mut scratch, m);
    rows(&forward, &mut scratch, m);
    let spectrum: Vec<f64> = scratch.par_iter().map(|v| v.re).collect();
    drop(kernel);

    // Convolve each charge grid: rows (only the first `nodes` hold charges), transpose, rows,
    // times the kernel's spectrum, and back; only the first `nodes` rows of the result matter.
    for grid in [&mut a, &mut c] {
        rows(&forward, &mut grid[..nodes * m], m);
        transpose(grid, &mut scratch, m);
        rows(&forward, &mut scratch, m);
        scratch
            .par_iter_mut()
            .zip(spectrum.par_iter())
            .for_each(|(v, k)| *v *= *k);
        rows(&inverse, &mut scratch, m);
        transpose(&scratch, &mut grid[..nodes * m], m);
        rows(&inverse, &mut grid[..nodes * m], m);
    }

    let scale = 1.0 / (m * m) as f64;
    y.par_iter()
        .zip(located.par_iter())
        .map(|(yi, (first, w))| {
            let (mut pa, mut pc) = (C::default(), C::default());
            for (r, &wr) in w[p..].iter().enumerate() {
                let row = (first[1] + r) * m + first[0];
                for (s, &ws) in w[..p].iter().enumerate() {
                    pa += a[row + s] * (wr * ws);
                    pc += c[row + s] * (wr * ws);
                }
            }
            let phi = [pa.re * scale, pa.im * scale, pc.re * scale, pc.im * scale];
            let (x0, y0) = (yi[0] - centre, yi[1] - centre);
            Repulsion {
                force: [x0 * phi[0] - phi[1], y0 * phi[0] - phi[2]],
                z: (1.0 + x0 * x0 + y0 * y0) * phi[0] - 2.0 * (x0 * phi[1] + y0 * phi[2]) + phi[3]
                    - 1.0,
            }
        })
        .collect()
}
