//! The final residual completion (eq. 3.11): the pixels that neither propagation nor completion
//! assigned get a harmonic shading, `ΔS = 0` on them with `S` of the assigned pixels as the
//! Dirichlet boundary, and `R = I / S`; they take the cluster of the nearest labelled pixel.

use std::collections::VecDeque;

use crate::decomposition::{Labels, SHADING_FLOOR};
use crate::error::Result;
use crate::image::{Image, neighbours4};
use crate::solver::SolverParams;

use super::complete::poisson_blend;
use super::state::{FrameState, PixelSource};

/// Fills every unassigned pixel of `state` (eq. 3.11); returns how many there were.
///
/// The Laplace equation is the Poisson blend of eq. 3.9 with a zero guidance field, solved on
/// the linear shading. A connected piece of unassigned pixels that touches no assigned pixel
/// (only possible when a whole frame is unassigned) has no boundary: it takes a constant
/// shading equal to its brightest luminance, so that its brightest pixel is white, the gauge of
/// the first frame's Retinex.
pub(crate) fn fill_residual(
    input: &Image,
    state: &mut FrameState,
    solver: &SolverParams,
) -> Result<usize> {
    let (w, h) = (state.width as usize, state.height as usize);
    let hole: Vec<bool> = state
        .source
        .iter()
        .map(|&s| s == PixelSource::Unassigned)
        .collect();
    let count = hole.iter().filter(|&&v| v).count();
    if count == 0 {
        return Ok(0);
    }
    let boundary: Vec<f64> = state.shading.iter().map(|&s| f64::from(s)).collect();
    let zero = vec![0.0; w * h];
    let mut s = poisson_blend(w, h, &hole, &zero, &boundary, solver)?;
    let floor = (input.max() * SHADING_FLOOR).max(f32::MIN_POSITIVE);
    // Pieces without a boundary came out at the anchor value 0: give them their gauge.
    let lum = |p: usize| {
        let [r, g, b] = input.rgb(p);
        crate::color::luminance([r, g, b])
    };
    for piece in free_pieces(w, h, &hole, &state.source) {
        let top = piece.iter().map(|&p| lum(p)).fold(0.0f32, f32::max);
        for p in piece {
            s[p] = f64::from(top);
        }
    }
    for p in (0..w * h).filter(|&p| hole[p]) {
        let v = s[p] as f32;
        state.shading[p] = if v.is_finite() { v.max(floor) } else { floor };
        state.source[p] = PixelSource::Residual;
    }
    fill_labels(w, h, &hole, &mut state.labels);
    Ok(count)
}

/// The 4-connected pieces of `hole` with no assigned 4-neighbour.
fn free_pieces(w: usize, h: usize, hole: &[bool], source: &[PixelSource]) -> Vec<Vec<usize>> {
    let mut seen = vec![false; w * h];
    let mut out = Vec::new();
    for start in 0..w * h {
        if !hole[start] || seen[start] {
            continue;
        }
        seen[start] = true;
        let (mut piece, mut queue, mut touches) = (Vec::new(), VecDeque::from([start]), false);
        while let Some(p) = queue.pop_front() {
            piece.push(p);
            for q in neighbours4(w, h, p) {
                if hole[q] {
                    if !seen[q] {
                        seen[q] = true;
                        queue.push_back(q);
                    }
                } else if source[q] != PixelSource::Unassigned {
                    touches = true;
                }
            }
        }
        if !touches {
            out.push(piece);
        }
    }
    out
}

/// Gives each `hole` pixel the label of the nearest labelled pixel (breadth-first from all
/// labelled pixels at once, 4-connected; ties go to the first reached in row-major order).
fn fill_labels(w: usize, h: usize, hole: &[bool], labels: &mut [u32]) {
    let mut queue: VecDeque<usize> = (0..w * h)
        .filter(|&p| !hole[p] && labels[p] != Labels::NONE)
        .collect();
    while let Some(p) = queue.pop_front() {
        for q in neighbours4(w, h, p) {
            if hole[q] && labels[q] == Labels::NONE {
                labels[q] = labels[p];
                queue.push_back(q);
            }
        }
    }
}
