//! A tiny decomposed sequence with known clusters for the edit tests: 3 frames of 16×12.
//!
//! - cluster [`BG`]: the background, everywhere else;
//! - cluster [`FG`]: a 5×4 square moving 3 px right per frame, its texture moving with it;
//! - cluster [`LATE`]: a 2×2 patch close to the background's colour, present from frame 1
//!   only (a cluster that completion adds after frame 0);
//! - unassigned pixels: the column the square uncovers in frames 1 and 2;
//! - shading: a horizontal ramp brightened by 20% per frame (a light moving closer), so that
//!   frames 1 and 2 are brighter than anything frame 0 shows.

use crate::decomposition::Labels;
use crate::image::{Image, Mask};

use super::Frame;

/// The background cluster.
pub(crate) const BG: u32 = 0;
/// The moving square.
pub(crate) const FG: u32 = 1;
/// The cluster that appears in frame 1.
pub(crate) const LATE: u32 = 2;
pub(crate) const BG_COLOUR: [f32; 3] = [0.2, 0.5, 0.3];
pub(crate) const FG_COLOUR: [f32; 3] = [0.8, 0.3, 0.2];
pub(crate) const LATE_COLOUR: [f32; 3] = [0.25, 0.45, 0.3];
pub(crate) const W: u32 = 16;
pub(crate) const H: u32 = 12;
pub(crate) const FRAMES: usize = 3;

/// One frame's layers, owned.
pub(crate) struct OwnedFrame {
    pub(crate) reflectance: Image,
    pub(crate) shading: Image,
    pub(crate) labels: Labels,
}

impl OwnedFrame {
    pub(crate) fn frame(&self) -> Frame<'_> {
        Frame::new(&self.reflectance, &self.shading, &self.labels).unwrap()
    }
}

/// The square's left column in frame `t`.
pub(crate) fn square_x(t: usize) -> u32 {
    2 + 3 * t as u32
}

/// Whether (x, y) is on the square in frame `t`.
pub(crate) fn in_square(t: usize, x: u32, y: u32) -> bool {
    (square_x(t)..square_x(t) + 5).contains(&x) && (4..8).contains(&y)
}

fn label(t: usize, x: u32, y: u32) -> u32 {
    if in_square(t, x, y) {
        FG
    } else if t > 0 && x == square_x(t) - 1 && (4..8).contains(&y) {
        Labels::NONE
    } else if t > 0 && (12..14).contains(&x) && (1..3).contains(&y) {
        LATE
    } else {
        BG
    }
}

/// The sequence; with `constant`, every cluster's reflectance is its colour exactly, otherwise
/// it carries a texture (a ramp of ±10%, all values distinct within a cluster and frame).
pub(crate) fn sequence(constant: bool) -> Vec<OwnedFrame> {
    (0..FRAMES)
        .map(|t| {
            let reflectance = Image::from_fn(W, H, |x, y| {
                let (colour, v) = match label(t, x, y) {
                    FG => {
                        let (dx, dy) = (x - square_x(t), y - 4);
                        (FG_COLOUR, (dy * 5 + dx) as f32 / 19.0)
                    }
                    LATE => (LATE_COLOUR, ((y - 1) * 2 + x - 12) as f32 / 3.0),
                    _ => (BG_COLOUR, (y * W + x) as f32 / (W * H - 1) as f32),
                };
                let v = if constant { 1.0 } else { 0.9 + 0.2 * v };
                colour.map(|c| c * v)
            });
            let shading = Image::from_fn(W, H, |x, _| {
                [(0.3 + 0.04 * x as f32) * (1.0 + 0.2 * t as f32)]
            });
            let labels = Labels {
                width: W,
                height: H,
                data: (0..W * H).map(|i| label(t, i % W, i / W)).collect(),
                count: 3,
            };
            OwnedFrame {
                reflectance,
                shading,
                labels,
            }
        })
        .collect()
}

/// A stroke: the pixels of a rectangle `x0..x1` × `y0..y1`.
pub(crate) fn rect(x0: u32, x1: u32, y0: u32, y1: u32) -> Mask {
    Mask::from_fn(W, H, |x, y| (x0..x1).contains(&x) && (y0..y1).contains(&y))
}
