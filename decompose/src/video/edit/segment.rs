//! Segmentation of a video from strokes on its first frame (Ye et al. 2014 §6, "video
//! segmentation"): the strokes pick clusters, the clusters carry the selection through time.
//!
//! 1. Each cluster counts the foreground and background stroke pixels of frame 0 that fall on
//!    it; the majority decides it.
//! 2. A cluster no stroke decides (touched by neither, by both equally, or absent from
//!    frame 0) takes the side of the decided cluster with the nearest mean reflectance
//!    (CIELab distance between [`ClusterMeans`] entries).
//! 3. Each frame's matte is then its labels looked up in that fixed set: it cannot flicker,
//!    and a surface leaves the matte only if its cluster changes.
//!
//! Unassigned pixels and clusters the table never saw are background.

use crate::decomposition::Labels;
use crate::error::{Error, Result};
use crate::image::{Image, Mask};

use super::{ClusterMeans, ClusterSet, Frame, stroke_votes};

/// The foreground clusters of a video, decided once from strokes on frame 0.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StrokeSegmentation {
    foreground: ClusterSet,
    voted: usize,
}

impl StrokeSegmentation {
    /// Decides every cluster of `clusters` (the table of the whole sequence) from the
    /// `foreground` and `background` stroke masks drawn on frame 0 (`labels`: frame 0's).
    ///
    /// Errors: [`Error::ShapeMismatch`] when a stroke mask is not frame 0's size, and
    /// [`Error::InvalidParam`] when the strokes do not decide at least one foreground and one
    /// background cluster (strokes only on unassigned pixels, or only one kind of stroke):
    /// with a single side, the nearest-mean rule would put every cluster on it.
    pub fn from_strokes(
        labels: &Labels,
        clusters: &ClusterMeans,
        foreground: &Mask,
        background: &Mask,
    ) -> Result<Self> {
        let fg = stroke_votes(labels, foreground)?;
        let bg = stroke_votes(labels, background)?;
        let n = clusters.len().max(fg.len()).max(bg.len()) as u32;
        let vote = |v: &[u64], k: u32| v.get(k as usize).copied().unwrap_or(0);
        let (mut fg_ids, mut bg_ids, mut open) = (Vec::new(), Vec::new(), Vec::new());
        for k in 0..n {
            let (f, b) = (vote(&fg, k), vote(&bg, k));
            if f > b {
                fg_ids.push(k);
            } else if b > f {
                bg_ids.push(k);
            } else if clusters.count(k) > 0 {
                open.push(k);
            }
        }
        if fg_ids.is_empty() || bg_ids.is_empty() {
            return Err(Error::param(
                "strokes",
                format!(
                    "{} foreground and {} background clusters",
                    fg_ids.len(),
                    bg_ids.len()
                ),
                "foreground and background strokes must each win at least one cluster \
                 (strokes on unassigned pixels do not count)",
            ));
        }
        let voted = fg_ids.len() + bg_ids.len();
        let decided: Vec<u32> = fg_ids.iter().chain(&bg_ids).copied().collect();
        let is_fg = ClusterSet::from_ids(&fg_ids);
        let mut all_fg = fg_ids.clone();
        for k in open {
            if clusters
                .nearest(k, &decided)
                .is_some_and(|j| is_fg.contains(j))
            {
                all_fg.push(k);
            }
        }
        Ok(Self {
            foreground: ClusterSet::from_ids(&all_fg),
            voted,
        })
    }

    /// Whether cluster `id` is foreground.
    pub fn is_foreground(&self, id: u32) -> bool {
        self.foreground.contains(id)
    }

    /// The foreground cluster ids, ascending.
    pub fn foreground_clusters(&self) -> Vec<u32> {
        self.foreground.ids()
    }

    /// How many clusters the strokes decided by vote (the rest went by nearest mean).
    pub fn voted(&self) -> usize {
        self.voted
    }

    /// The matte of a frame: its foreground pixels.
    pub fn mask(&self, labels: &Labels) -> Mask {
        Mask::from_fn(labels.width, labels.height, |x, y| {
            let l = labels.data[(y * labels.width + x) as usize];
            l != Labels::NONE && self.is_foreground(l)
        })
    }

    /// The cutout of a frame: `R × S` on the foreground, black elsewhere.
    pub fn cutout(&self, frame: &Frame) -> Image {
        let mask = self.mask(frame.labels);
        let mut out = frame.compose();
        for i in 0..out.len() {
            if !mask.at(i) {
                out.px_mut(i).fill(0.0);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::super::fixture::{BG, FG, FRAMES, H, LATE, W, in_square, rect, sequence};
    use super::*;

    fn table(constant: bool) -> (Vec<super::super::fixture::OwnedFrame>, ClusterMeans) {
        let seq = sequence(constant);
        let frames: Vec<Frame> = seq.iter().map(|f| f.frame()).collect();
        let t = ClusterMeans::from_frames(&frames);
        (seq, t)
    }

    #[test]
    fn mask_is_the_moving_square_in_every_frame() {
        let (seq, t) = table(false);
        // A foreground scribble on the square of frame 0, a background one in a corner.
        let fg = rect(3, 5, 5, 7);
        let bg = rect(0, 2, 0, 2);
        let s = StrokeSegmentation::from_strokes(&seq[0].labels, &t, &fg, &bg).unwrap();
        assert_eq!(s.foreground_clusters(), vec![FG]);
        assert_eq!(s.voted(), 2);
        assert!(
            !s.is_foreground(LATE),
            "the late cluster is nearest the background"
        );
        for (ti, f) in seq.iter().enumerate() {
            let m = s.mask(&f.labels);
            for y in 0..H {
                for x in 0..W {
                    let i = (y * W + x) as usize;
                    assert_eq!(m.at(i), in_square(ti, x, y), "frame {ti} ({x}, {y})");
                }
            }
            let cut = s.cutout(&f.frame());
            let full = f.frame().compose();
            for i in 0..cut.len() {
                let want = if m.at(i) { full.px(i) } else { &[0.0; 3][..] };
                assert_eq!(cut.px(i), want);
            }
        }
        assert_eq!(FRAMES, seq.len());
    }

    #[test]
    fn majority_decides_and_unstroked_clusters_go_by_nearest_mean() {
        let (seq, t) = table(true);
        // The foreground stroke spills 2 pixels onto the background; the background stroke
        // covers 6 background pixels: the background stays background.
        let fg = Mask::from_fn(W, H, |x, y| y == 5 && (0..7).contains(&x));
        let bg = rect(10, 16, 0, 1);
        let s = StrokeSegmentation::from_strokes(&seq[0].labels, &t, &fg, &bg).unwrap();
        assert!(s.is_foreground(FG) && !s.is_foreground(BG));
        // Strokes only on the background: refused rather than everything background.
        let e = StrokeSegmentation::from_strokes(&seq[0].labels, &t, &bg, &rect(0, 1, 0, 1));
        assert!(matches!(e, Err(Error::InvalidParam { .. })), "{e:?}");
        // A stroke on unassigned pixels counts for nothing (column 4 of frame 1).
        let none = rect(4, 5, 4, 8);
        let e = StrokeSegmentation::from_strokes(&seq[1].labels, &t, &none, &bg);
        assert!(e.is_err());
        let e = StrokeSegmentation::from_strokes(&seq[0].labels, &t, &Mask::full(3, 3), &bg);
        assert!(matches!(e, Err(Error::ShapeMismatch { .. })));
    }

    #[test]
    fn unassigned_pixels_are_background() {
        let (seq, t) = table(false);
        // Everything but the square is foreground: the unassigned column still is not.
        let s = StrokeSegmentation::from_strokes(
            &seq[0].labels,
            &t,
            &rect(0, 2, 0, 2),
            &rect(3, 5, 5, 7),
        )
        .unwrap();
        let m = s.mask(&seq[1].labels);
        for y in 4..8 {
            assert!(!m.at((y * W + 4) as usize));
        }
        assert!(m.at(0) && s.is_foreground(LATE));
    }
}
