//! Stylisation of a video (Ye et al. 2014 §6; the video form of [`crate::edit::stylise`]):
//! reflectance saturation, flattened shading and an edge layer.
//!
//! Two choices of the image version would flicker on a video and are fixed instead:
//! - the shading is flattened towards **frame 0's** mean assigned shading, not each frame's
//!   (a surface entering the view would otherwise brighten or darken every other);
//! - the edges are the **cluster boundaries** of the labels (a pixel whose right or lower
//!   neighbour has another assigned cluster), not thresholded reflectance gradients, so an
//!   edge exists exactly as long as the two clusters meet. `StyliseParams::edge_threshold` is
//!   therefore unused here.
//!
//! The edge layer darkens the shading (`S′ = flattened S × (1 − edge_strength)` on edges), so
//! `R′` is the saturated reflectance alone and a cluster of constant reflectance stays
//! constant. Saturation and flattening are fixed functions of a pixel's values, so unassigned
//! pixels get them too; they never draw an edge, and a boundary with an unassigned pixel is
//! not an edge either (it comes and goes with the method's confidence).

use crate::decomposition::{Decomposition, Labels};
use crate::edit::{StyliseParams, saturate};
use crate::error::{Error, Result};
use crate::image::Mask;

use super::Frame;

/// A stylisation decided on frame 0.
#[derive(Clone, Debug, PartialEq)]
pub struct VideoStylise {
    params: StyliseParams,
    mean_shading: f32,
}

impl VideoStylise {
    /// Validates `params` and takes frame 0's mean assigned shading as the flattening target.
    /// Errors: [`Error::InvalidParam`] for parameters out of range or a frame 0 without
    /// assigned pixels.
    pub fn fit(first: &Frame, params: &StyliseParams) -> Result<Self> {
        params.validate()?;
        let (mut sum, mut n) = (0.0f64, 0usize);
        for (i, &l) in first.labels.data.iter().enumerate() {
            if l != Labels::NONE {
                sum += first.shading.px(i)[0] as f64;
                n += 1;
            }
        }
        if n == 0 {
            return Err(Error::param(
                "frame 0",
                "no assigned pixel",
                "stylisation takes its flat shading from frame 0's clustered pixels",
            ));
        }
        Ok(Self {
            params: params.clone(),
            mean_shading: (sum / n as f64) as f32,
        })
    }

    /// The shading every pixel is flattened towards.
    pub fn mean_shading(&self) -> f32 {
        self.mean_shading
    }

    /// The edited layers of one frame (every pixel; edges only on cluster boundaries).
    pub fn apply(&self, frame: &Frame) -> Decomposition {
        let edges = edges(frame.labels);
        let p = &self.params;
        frame.edit_all(|i, _, r, s| {
            let edge = if edges.at(i) {
                1.0 - p.edge_strength
            } else {
                1.0
            };
            let flat = (1.0 - p.flatten) * s + p.flatten * self.mean_shading;
            (saturate(r, p.saturation), flat * edge)
        })
    }
}

/// The cluster boundaries of a frame: pixels whose right or lower neighbour belongs to another
/// cluster, both assigned.
pub fn edges(labels: &Labels) -> Mask {
    let (w, h) = (labels.width as usize, labels.height as usize);
    let at = |x: usize, y: usize| labels.data[y * w + x];
    Mask::from_fn(labels.width, labels.height, |x, y| {
        let (x, y) = (x as usize, y as usize);
        let l = at(x, y);
        if l == Labels::NONE {
            return false;
        }
        let differs = |m: u32| m != Labels::NONE && m != l;
        (x + 1 < w && differs(at(x + 1, y))) || (y + 1 < h && differs(at(x, y + 1)))
    })
}

#[cfg(test)]
mod tests {
    use super::super::fixture::{BG, FG, H, W, in_square, sequence, square_x};
    use super::*;

    #[test]
    fn edges_follow_the_moving_square() {
        let seq = sequence(false);
        for (t, f) in seq.iter().enumerate() {
            let e = edges(&f.labels);
            let x0 = square_x(t);
            // The square's last row has the background below; its last column has it right.
            assert!(e.at((7 * W + x0 + 2) as usize));
            assert!(e.at((5 * W + x0 + 4) as usize));
            // Inside the square: no edge.
            assert!(!e.at((5 * W + x0 + 1) as usize));
            // Next to the unassigned column (frames 1, 2): no edge on either side.
            if t > 0 {
                assert!(!e.at((5 * W + x0 - 2) as usize));
                assert!(!e.at((5 * W + x0 - 1) as usize));
            }
            assert!(in_square(t, x0, 4));
        }
    }

    #[test]
    fn flattening_uses_frame_0_and_edges_darken_the_shading() {
        let seq = sequence(false);
        let p = StyliseParams {
            flatten: 1.0,
            edge_strength: 0.5,
            saturation: 1.0,
            ..Default::default()
        };
        let st = VideoStylise::fit(&seq[0].frame(), &p).unwrap();
        let mean0 = seq[0].shading.data().iter().sum::<f32>() / (W * H) as f32;
        assert!((st.mean_shading() - mean0).abs() < 1e-6);
        for f in &seq {
            let out = st.apply(&f.frame());
            let e = edges(&f.labels);
            for (i, &l) in f.labels.data.iter().enumerate() {
                let s = out.shading.px(i)[0];
                // Unassigned pixels are flattened too, but never on an edge.
                assert!(l != Labels::NONE || !e.at(i));
                if e.at(i) {
                    assert!((s - 0.5 * mean0).abs() < 1e-6);
                } else {
                    assert!((s - mean0).abs() < 1e-6);
                }
                if l == FG || l == BG {
                    // Saturation 1: the reflectance is kept (up to the HSV round trip).
                    for c in 0..3 {
                        assert!((out.reflectance.px(i)[c] - f.reflectance.px(i)[c]).abs() < 1e-6);
                    }
                }
            }
        }
        let bad = StyliseParams {
            edge_strength: 1.5,
            ..Default::default()
        };
        assert!(VideoStylise::fit(&seq[0].frame(), &bad).is_err());
    }
}
