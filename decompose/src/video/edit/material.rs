//! Material editing of a video by a shading curve (Ye et al. 2014 §6; thesis §3.8): the
//! shading of chosen clusters goes through a tone curve of control points, interpolated by
//! monotone cubic Hermite splines ([`crate::edit::Curve`]); the reflectance is kept. Steepening
//! the upper part of the curve makes a surface look glossier, flattening it more matte.
//!
//! The curve's x and y are fractions of one shading **scale fixed on frame 0** (the largest
//! assigned shading of frame 0), not of each frame's maximum, which would move with the
//! content and make the edit pump. Shading above frame 0's range (a light coming closer)
//! continues along the curve's end slope ([`crate::edit::Curve::eval_extended`]), so the
//! identity points are the identity in every frame. The result is floored at 0.
//!
//! Clusters not chosen are unedited, and so are unassigned pixels when clusters are chosen;
//! a curve on every cluster is one fixed function of the shading and edits unassigned pixels
//! too (the module's rule).

use crate::decomposition::{Decomposition, Labels};
use crate::edit::Curve;
use crate::error::{Error, Result};

use super::{ClusterSet, Frame};

/// A shading curve on chosen clusters, with its scale decided on frame 0.
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialEdit {
    curve: Curve,
    clusters: Option<ClusterSet>,
    scale: f32,
}

impl MaterialEdit {
    /// The edit of `curve` on `clusters` (`None`: every cluster), with x and y in units of
    /// `scale`. Errors: [`Error::InvalidParam`] when `scale` is not finite and positive.
    pub fn new(curve: Curve, clusters: Option<&[u32]>, scale: f32) -> Result<Self> {
        if !(scale.is_finite() && scale > 0.0) {
            return Err(Error::param(
                "shading scale",
                scale,
                "must be finite and > 0",
            ));
        }
        Ok(Self {
            curve,
            clusters: clusters.map(ClusterSet::from_ids),
            scale,
        })
    }

    /// The edit with its scale taken from frame 0: the largest shading of an assigned pixel.
    /// Errors: [`Error::InvalidParam`] when frame 0 has no assigned pixel with positive shading.
    pub fn fit(first: &Frame, curve: Curve, clusters: Option<&[u32]>) -> Result<Self> {
        let scale = first
            .labels
            .data
            .iter()
            .enumerate()
            .filter(|&(_, &l)| l != Labels::NONE)
            .map(|(i, _)| first.shading.px(i)[0])
            .filter(|v| v.is_finite())
            .fold(0.0f32, f32::max);
        Self::new(curve, clusters, scale)
    }

    /// The shading scale the curve's axes are fractions of.
    pub fn scale(&self) -> f32 {
        self.scale
    }

    /// Whether cluster `id` is edited ([`Labels::NONE`]: whether unassigned pixels are).
    pub fn edits(&self, id: u32) -> bool {
        self.clusters
            .as_ref()
            .is_none_or(|c| id != Labels::NONE && c.contains(id))
    }

    /// The edited layers of one frame.
    pub fn apply(&self, frame: &Frame) -> Decomposition {
        let curve = |s: f32| self.curve.eval_extended(s / self.scale).max(0.0) * self.scale;
        match &self.clusters {
            None => frame.edit_all(|_, _, r, s| (r, curve(s))),
            Some(set) => {
                frame.edit_assigned(|_, l, r, s| (r, if set.contains(l) { curve(s) } else { s }))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::fixture::{BG, FG, sequence};
    use super::*;

    #[test]
    fn identity_points_are_the_identity_in_every_frame() {
        let seq = sequence(false);
        for pts in [
            vec![(0.0, 0.0), (1.0, 1.0)],
            vec![(0.0, 0.0), (0.25, 0.25), (0.5, 0.5), (1.0, 1.0)],
        ] {
            let curve = Curve::new(&pts).unwrap();
            let m = MaterialEdit::fit(&seq[0].frame(), curve, None).unwrap();
            for f in &seq {
                let out = m.apply(&f.frame());
                assert_eq!(out.reflectance, f.reflectance);
                for (a, b) in out.shading.data().iter().zip(f.shading.data()) {
                    // Frames 1 and 2 reach 1.4× frame 0's scale: past the curve's end.
                    assert!((a - b).abs() < 1e-5 * b.max(1.0), "{a} vs {b}");
                }
            }
        }
    }

    #[test]
    fn the_curve_touches_only_the_chosen_clusters_with_a_fixed_scale() {
        let seq = sequence(false);
        let curve = Curve::new(&[(0.0, 0.0), (0.5, 0.8), (1.0, 1.0)]).unwrap();
        let m = MaterialEdit::fit(&seq[0].frame(), curve.clone(), Some(&[FG])).unwrap();
        let max0 = seq[0].shading.max();
        assert_eq!(m.scale(), max0);
        assert!(m.edits(FG) && !m.edits(BG));
        for f in &seq {
            let out = m.apply(&f.frame());
            for (i, &l) in f.labels.data.iter().enumerate() {
                let (s, s2) = (f.shading.px(i)[0], out.shading.px(i)[0]);
                if l == FG {
                    let want = curve.eval_extended(s / max0) * max0;
                    assert!((s2 - want).abs() < 1e-6);
                    if s < max0 {
                        assert!(s2 > s, "the curve brightens below frame 0's maximum");
                    }
                } else {
                    assert_eq!(s, s2);
                }
            }
        }
        // On every cluster, the curve is one function of the shading: unassigned pixels too.
        let all = MaterialEdit::fit(&seq[0].frame(), curve.clone(), None).unwrap();
        assert!(all.edits(Labels::NONE) && !m.edits(Labels::NONE));
        let out = all.apply(&seq[1].frame());
        let none = seq[1]
            .labels
            .data
            .iter()
            .position(|&l| l == Labels::NONE)
            .unwrap();
        let s = seq[1].shading.px(none)[0];
        assert!((out.shading.px(none)[0] - curve.eval_extended(s / max0) * max0).abs() < 1e-6);
        assert!(MaterialEdit::new(curve, None, 0.0).is_err());
    }
}
