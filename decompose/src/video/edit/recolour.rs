//! Recolouring a video by scribbles on its first frame (Ye et al. 2014 §6, "recolouring"):
//! each scribble carries a target colour; the clusters it covers get a reflectance transfer
//! function that maps their mean reflectance to that colour, applied in every frame.
//!
//! The transfer function is diagonal, a per-channel gain `g = t / m` (`m`: the cluster's mean
//! reflectance over the whole sequence, `t`: the target): `R′ = g ⊙ R`. It maps the mean
//! exactly to the target (the mean of `g ⊙ R` is `g ⊙ m`), and it keeps the within-cluster
//! variation as ratios (`R′/m′ = R/m`), which is how texture lives in a reflectance that
//! multiplies the shading per channel. The shading is unchanged, so the new colour is lit as
//! the old one was. A mean channel below [`MIN_MEAN`] is taken as [`MIN_MEAN`] (a black
//! cluster cannot be scaled into colour; its mean then lands below the target).
//!
//! A cluster covered by several scribbles follows the one with most pixels on it (ties: the
//! first given). Unassigned pixels and clusters no scribble covers are unedited.

use crate::decomposition::{Decomposition, Labels};
use crate::error::{Error, Result};
use crate::image::Mask;

use super::{ClusterMeans, Frame, stroke_votes};

/// Smallest mean reflectance channel a gain divides by.
pub const MIN_MEAN: f32 = 1e-4;

/// A scribble on frame 0 and the reflectance its clusters should take.
#[derive(Clone, Debug, PartialEq)]
pub struct Scribble {
    /// The scribbled pixels.
    pub mask: Mask,
    /// The target mean reflectance, linear RGB (the decomposition's scale: a white surface
    /// is about 1).
    pub target: [f32; 3],
}

/// Per-cluster reflectance gains, decided once from scribbles.
#[derive(Clone, Debug, PartialEq)]
pub struct ClusterRecolour {
    gains: Vec<Option<[f32; 3]>>,
}

impl ClusterRecolour {
    /// Decides the gains from `scribbles` drawn on frame 0 (`labels`: frame 0's) and the
    /// cluster table of the sequence.
    ///
    /// Errors: [`Error::InvalidParam`] for no scribble, a target that is not finite and
    /// non-negative, or a scribble that covers no assigned pixel of frame 0;
    /// [`Error::ShapeMismatch`] for a scribble of another size than frame 0.
    pub fn from_scribbles(
        labels: &Labels,
        clusters: &ClusterMeans,
        scribbles: &[Scribble],
    ) -> Result<Self> {
        if scribbles.is_empty() {
            return Err(Error::param("scribbles", 0, "give at least one scribble"));
        }
        // (votes, scribble) of the scribble winning each cluster so far.
        let mut winner: Vec<Option<(u64, usize)>> = vec![None; clusters.len()];
        for (si, s) in scribbles.iter().enumerate() {
            if !s.target.iter().all(|v| v.is_finite() && *v >= 0.0) {
                return Err(Error::param(
                    "scribble target",
                    format!("{:?}", s.target),
                    "must be finite and >= 0",
                ));
            }
            let votes = stroke_votes(labels, &s.mask)?;
            if votes.iter().all(|&v| v == 0) {
                return Err(Error::param(
                    "scribble",
                    si,
                    "covers no assigned pixel of frame 0",
                ));
            }
            if votes.len() > winner.len() {
                winner.resize(votes.len(), None);
            }
            for (k, &v) in votes.iter().enumerate() {
                if v > 0 && winner[k].is_none_or(|(best, _)| v > best) {
                    winner[k] = Some((v, si));
                }
            }
        }
        let gains = winner
            .iter()
            .enumerate()
            .map(|(k, w)| {
                let (_, si) = (*w)?;
                let m = clusters.mean(k as u32)?;
                let t = scribbles[si].target;
                Some([0, 1, 2].map(|c| t[c] / m[c].max(MIN_MEAN)))
            })
            .collect();
        Ok(Self { gains })
    }

    /// The gain of cluster `id`, `None` when it is not recoloured.
    pub fn gain(&self, id: u32) -> Option<[f32; 3]> {
        self.gains.get(id as usize).copied().flatten()
    }

    /// The recoloured clusters, ascending.
    pub fn clusters(&self) -> Vec<u32> {
        (0..self.gains.len() as u32)
            .filter(|&k| self.gain(k).is_some())
            .collect()
    }

    /// The edited layers of one frame: `g ⊙ R` on recoloured clusters, the shading unchanged.
    pub fn apply(&self, frame: &Frame) -> Decomposition {
        frame.edit_assigned(|_, l, r, s| match self.gain(l) {
            Some(g) => ([r[0] * g[0], r[1] * g[1], r[2] * g[2]], s),
            None => (r, s),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::fixture::{BG, FG, LATE, rect, sequence};
    use super::*;

    #[test]
    fn only_the_chosen_cluster_changes_and_its_mean_hits_the_target() {
        let seq = sequence(false);
        let frames: Vec<Frame> = seq.iter().map(|f| f.frame()).collect();
        let table = ClusterMeans::from_frames(&frames);
        let target = [0.1, 0.2, 0.7];
        let sc = Scribble {
            mask: rect(3, 6, 5, 6),
            target,
        };
        let rc = ClusterRecolour::from_scribbles(&seq[0].labels, &table, &[sc]).unwrap();
        assert_eq!(rc.clusters(), vec![FG]);
        let edited: Vec<Decomposition> = frames.iter().map(|f| rc.apply(f)).collect();
        let mut after = ClusterMeans::new();
        for (f, e) in frames.iter().zip(&edited) {
            // The shading is the input's; R′ × S′ is the composite.
            assert_eq!(e.shading, *f.shading);
            let g = rc.gain(FG).unwrap();
            for (i, &l) in f.labels.data.iter().enumerate() {
                let (r, r2) = (f.reflectance.px(i), e.reflectance.px(i));
                if l == FG {
                    // Within-cluster variation kept: the same ratio for every pixel.
                    for c in 0..3 {
                        assert!((r2[c] - r[c] * g[c]).abs() < 1e-7);
                    }
                } else {
                    assert_eq!(r, r2, "pixel {i} (label {l}) must be unedited");
                }
            }
            after.add(&Frame::new(&e.reflectance, &e.shading, f.labels).unwrap());
        }
        let m = after.mean(FG).unwrap();
        for c in 0..3 {
            assert!((m[c] - target[c]).abs() < 1e-4, "{m:?} vs {target:?}");
        }
        assert_eq!(after.mean(BG), table.mean(BG));
        assert_eq!(after.mean(LATE), table.mean(LATE));
    }

    #[test]
    fn overlapping_scribbles_go_by_majority_and_bad_ones_are_refused() {
        let seq = sequence(true);
        let frames: Vec<Frame> = seq.iter().map(|f| f.frame()).collect();
        let table = ClusterMeans::from_frames(&frames);
        let a = Scribble {
            mask: rect(0, 3, 5, 6), // 2 background pixels, 1 on the square
            target: [1.0, 0.0, 0.0],
        };
        let b = Scribble {
            mask: rect(3, 7, 6, 7), // 4 on the square
            target: [0.0, 1.0, 0.0],
        };
        let rc = ClusterRecolour::from_scribbles(&seq[0].labels, &table, &[a.clone(), b]).unwrap();
        assert_eq!(rc.gain(FG).unwrap()[0], 0.0);
        assert!(rc.gain(BG).unwrap()[0] > 1.0);
        assert!(ClusterRecolour::from_scribbles(&seq[0].labels, &table, &[]).is_err());
        let nan = Scribble {
            target: [f32::NAN, 0.0, 0.0],
            ..a.clone()
        };
        assert!(ClusterRecolour::from_scribbles(&seq[0].labels, &table, &[nan]).is_err());
        let on_none = Scribble {
            mask: rect(4, 5, 4, 8),
            ..a
        };
        assert!(ClusterRecolour::from_scribbles(&seq[1].labels, &table, &[on_none]).is_err());
    }
}
