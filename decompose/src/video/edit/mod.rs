//! Video edits through the clustered reflectance (Ye, Garces, Liu, Dai & Gutierrez, "Intrinsic
//! Video and Applications", SIGGRAPH 2014, §6; thesis §3.8, "Applications").
//!
//! A per-frame edit of a decomposed video flickers as soon as anything it depends on (a
//! histogram, a maximum, a stroke's reach) changes from frame to frame. Every edit here is
//! therefore **decided once** — from strokes on the first frame and from the cluster table of
//! the whole sequence ([`ClusterMeans`]) — into a fixed per-cluster (or per-value) rule, and
//! then **applied to each frame through its cluster labels**: a pixel's edit depends only on
//! its cluster id and its own reflectance and shading, never on the rest of its frame. The
//! propagation of the method keeps a surface's cluster id over time, so the edit follows it.
//! This is the design of the light-field edits (one edit decided on the centre view, applied
//! coherently to every view), with cluster labels in place of the disparity.
//!
//! The edits, one module each:
//! - [`segment`]: foreground/background strokes on frame 0 → the set of foreground clusters →
//!   a matte and a cutout per frame;
//! - [`recolour`]: scribbles on frame 0, each with a target colour → a diagonal (per-channel
//!   gain) reflectance transfer function per scribbled cluster;
//! - [`transfer`]: histogram matching of the reflectance against a source palette, fitted once
//!   on frame 0, applied as one fixed value mapping to every frame;
//! - [`stylise`]: reflectance saturation, shading flattened towards frame 0's mean, and an edge
//!   layer drawn on cluster boundaries (stable over time, unlike reflectance gradients);
//! - [`material`]: a shading curve ([`crate::edit::Curve`]) on the shading of chosen clusters,
//!   normalised by a scale fixed on frame 0.
//!
//! Each edit returns the edited layers as a [`Decomposition`] (`R′`, `S′`); the edited frame
//! is their product.
//!
//! **Unassigned pixels** (label [`Labels::NONE`], the pixels the method could not give a
//! cluster) have no cluster to carry an edit, and guessing one per frame would bring the
//! flicker back. They are therefore left **unedited** by every edit (their `R × S` is the
//! input), count as **background** for the segmentation, and never draw an edge.

pub mod material;
pub mod recolour;
pub mod segment;
pub mod stylise;
pub mod transfer;

#[cfg(test)]
pub(crate) mod fixture;

use crate::color::linear_to_lab;
use crate::decomposition::{Decomposition, Labels};
use crate::error::{Error, Result};
use crate::image::{Image, Mask};

/// One decomposed frame as the edits read it: linear RGB reflectance, linear grey shading and
/// the cluster labels, all of one size.
#[derive(Clone, Copy, Debug)]
pub struct Frame<'a> {
    /// Reflectance, 3 channels.
    pub reflectance: &'a Image,
    /// Shading, 1 channel.
    pub shading: &'a Image,
    /// Cluster labels ([`Labels::NONE`] for unassigned pixels).
    pub labels: &'a Labels,
}

impl<'a> Frame<'a> {
    /// Checks the channel counts and that the three layers share one size.
    pub fn new(reflectance: &'a Image, shading: &'a Image, labels: &'a Labels) -> Result<Self> {
        if reflectance.is_empty() {
            return Err(Error::EmptyImage {
                width: reflectance.width(),
                height: reflectance.height(),
            });
        }
        if reflectance.channels() != 3 {
            return Err(Error::param(
                "reflectance channels",
                reflectance.channels(),
                "must be 3",
            ));
        }
        if shading.channels() != 1 {
            return Err(Error::param(
                "shading channels",
                shading.channels(),
                "must be 1",
            ));
        }
        reflectance.check_dims(shading.dims())?;
        reflectance.check_dims((labels.width, labels.height))?;
        if labels.data.len() != reflectance.len() {
            return Err(Error::param(
                "labels.data.len()",
                labels.data.len(),
                "must equal width * height",
            ));
        }
        Ok(Self {
            reflectance,
            shading,
            labels,
        })
    }

    /// `R × S`: the frame as decomposed, unedited.
    pub fn compose(&self) -> Image {
        crate::edit::compose(self.reflectance, self.shading)
    }

    /// Applies `f(pixel, label, reflectance, shading) -> (reflectance′, shading′)` to every
    /// assigned pixel; unassigned pixels keep their layers (the module's rule).
    pub(crate) fn edit_assigned(
        &self,
        mut f: impl FnMut(usize, u32, [f32; 3], f32) -> ([f32; 3], f32),
    ) -> Decomposition {
        let mut r = self.reflectance.clone();
        let mut s = self.shading.clone();
        for (i, &l) in self.labels.data.iter().enumerate() {
            if l == Labels::NONE {
                continue;
            }
            let (r2, s2) = f(i, l, self.reflectance.rgb(i), self.shading.px(i)[0]);
            r.px_mut(i).copy_from_slice(&r2);
            s.px_mut(i)[0] = s2;
        }
        Decomposition {
            reflectance: r,
            shading: s,
        }
    }
}

/// The cluster table the edits are decided from: per cluster id, the mean reflectance and the
/// pixel count, accumulated over any number of frames (memory grows with the number of
/// clusters, not with the length of the video). Built from the whole sequence it also knows
/// the clusters that appear after frame 0 (completion adds clusters, §3.6), so every edit
/// decides them too.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ClusterMeans {
    sums: Vec<[f64; 3]>,
    counts: Vec<u64>,
}

impl ClusterMeans {
    /// An empty table.
    pub fn new() -> Self {
        Self::default()
    }

    /// The table of the given frames.
    pub fn from_frames<'a>(frames: impl IntoIterator<Item = &'a Frame<'a>>) -> Self {
        let mut t = Self::new();
        for f in frames {
            t.add(f);
        }
        t
    }

    /// Adds the assigned pixels of one frame.
    pub fn add(&mut self, frame: &Frame) {
        for (i, &l) in frame.labels.data.iter().enumerate() {
            if l == Labels::NONE {
                continue;
            }
            let k = l as usize;
            if k >= self.counts.len() {
                self.counts.resize(k + 1, 0);
                self.sums.resize(k + 1, [0.0; 3]);
            }
            let p = frame.reflectance.rgb(i);
            for c in 0..3 {
                self.sums[k][c] += p[c] as f64;
            }
            self.counts[k] += 1;
        }
    }

    /// One past the largest cluster id seen.
    pub fn len(&self) -> usize {
        self.counts.len()
    }

    /// True when no pixel was added.
    pub fn is_empty(&self) -> bool {
        self.counts.iter().all(|&c| c == 0)
    }

    /// Number of pixels of cluster `id` seen.
    pub fn count(&self, id: u32) -> u64 {
        self.counts.get(id as usize).copied().unwrap_or(0)
    }

    /// The mean reflectance of cluster `id`, `None` for a cluster never seen.
    pub fn mean(&self, id: u32) -> Option<[f32; 3]> {
        let n = self.count(id);
        (n > 0).then(|| self.sums[id as usize].map(|v| (v / n as f64) as f32))
    }

    /// The ids of the clusters seen, ascending.
    pub fn ids(&self) -> impl Iterator<Item = u32> + '_ {
        (0..self.counts.len() as u32).filter(|&k| self.counts[k as usize] > 0)
    }

    /// The seen cluster whose mean reflectance is nearest to `id`'s (CIELab distance) among
    /// `candidates`; `None` when `id` or every candidate is unseen. Ties go to the lower id.
    pub(crate) fn nearest(&self, id: u32, candidates: &[u32]) -> Option<u32> {
        let lab = |k: u32| {
            self.mean(k)
                .map(|m| linear_to_lab(m.map(|v| v.clamp(0.0, 1.0))))
        };
        let here = lab(id)?;
        let mut best: Option<(f32, u32)> = None;
        for &k in candidates {
            let Some(there) = lab(k) else { continue };
            let d: f32 = (0..3).map(|c| (here[c] - there[c]).powi(2)).sum();
            if best.is_none_or(|(bd, bk)| d < bd || (d == bd && k < bk)) {
                best = Some((d, k));
            }
        }
        best.map(|(_, k)| k)
    }
}

/// Per cluster id, how many pixels of `mask` fall on it (unassigned pixels do not count).
/// Errors when the mask and the labels differ in size.
pub fn stroke_votes(labels: &Labels, mask: &Mask) -> Result<Vec<u64>> {
    if mask.dims() != (labels.width, labels.height) {
        return Err(Error::ShapeMismatch {
            expected: (labels.width, labels.height),
            got: mask.dims(),
        });
    }
    let mut votes = Vec::new();
    for (i, &l) in labels.data.iter().enumerate() {
        if l == Labels::NONE || !mask.at(i) {
            continue;
        }
        let k = l as usize;
        if k >= votes.len() {
            votes.resize(k + 1, 0);
        }
        votes[k] += 1;
    }
    Ok(votes)
}

/// The clusters a region drawn on a frame touches (at least one assigned pixel), ascending.
pub fn clusters_touched(labels: &Labels, region: &Mask) -> Result<Vec<u32>> {
    let votes = stroke_votes(labels, region)?;
    Ok((0..votes.len() as u32)
        .filter(|&k| votes[k as usize] > 0)
        .collect())
}

/// A per-cluster-id flag, false for ids beyond the table (clusters the edit never saw).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct ClusterSet(Vec<bool>);

impl ClusterSet {
    pub(crate) fn from_ids(ids: &[u32]) -> Self {
        let mut v = vec![false; ids.iter().map(|&k| k as usize + 1).max().unwrap_or(0)];
        for &k in ids {
            v[k as usize] = true;
        }
        Self(v)
    }

    pub(crate) fn contains(&self, id: u32) -> bool {
        self.0.get(id as usize).copied().unwrap_or(false)
    }

    pub(crate) fn ids(&self) -> Vec<u32> {
        (0..self.0.len() as u32)
            .filter(|&k| self.0[k as usize])
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::fixture::{BG, FG, sequence};
    use super::*;

    #[test]
    fn frame_checks_sizes_and_channels() {
        let seq = sequence(false);
        let f = &seq[0];
        assert!(Frame::new(&f.reflectance, &f.shading, &f.labels).is_ok());
        assert!(Frame::new(&f.shading, &f.shading, &f.labels).is_err());
        assert!(Frame::new(&f.reflectance, &f.reflectance, &f.labels).is_err());
        let small = Labels {
            width: 4,
            height: 4,
            data: vec![0; 16],
            count: 1,
        };
        assert!(matches!(
            Frame::new(&f.reflectance, &f.shading, &small),
            Err(Error::ShapeMismatch { .. })
        ));
    }

    #[test]
    fn cluster_means_cover_every_frame_and_skip_unassigned() {
        let seq = sequence(true);
        let frames: Vec<Frame> = seq.iter().map(|f| f.frame()).collect();
        let t = ClusterMeans::from_frames(&frames);
        // Cluster 2 appears after frame 0 only; the table still knows it.
        assert_eq!(t.ids().collect::<Vec<_>>(), vec![0, 1, 2]);
        let assigned: u64 = seq
            .iter()
            .map(|f| f.labels.data.iter().filter(|&&l| l != Labels::NONE).count() as u64)
            .sum();
        assert_eq!(t.count(0) + t.count(1) + t.count(2), assigned);
        for c in 0..3 {
            assert!((t.mean(FG).unwrap()[c] - super::fixture::FG_COLOUR[c]).abs() < 1e-6);
            assert!((t.mean(BG).unwrap()[c] - super::fixture::BG_COLOUR[c]).abs() < 1e-6);
        }
        assert_eq!(t.mean(7), None);
        assert_eq!(t.nearest(2, &[FG, BG]), Some(BG));
    }
}

/// Temporal stability of every edit: on a sequence whose reflectance is constant per cluster,
/// the edited reflectance is constant per cluster, with the same value in every frame.
#[cfg(test)]
mod stability {
    use super::fixture::{FG, rect, sequence};
    use super::*;
    use crate::edit::{Curve, StyliseParams};

    fn assert_constant_per_cluster(name: &str, edited: &[(Decomposition, &Labels)]) {
        let mut value: Vec<Option<[f32; 3]>> = Vec::new();
        for (t, (d, labels)) in edited.iter().enumerate() {
            for (i, &l) in labels.data.iter().enumerate() {
                if l == Labels::NONE {
                    continue;
                }
                if value.len() <= l as usize {
                    value.resize(l as usize + 1, None);
                }
                let r = d.reflectance.rgb(i);
                match value[l as usize] {
                    None => value[l as usize] = Some(r),
                    Some(v) => assert_eq!(v, r, "{name}: cluster {l}, frame {t}, pixel {i}"),
                }
            }
        }
    }

    #[test]
    fn every_edit_keeps_constant_clusters_constant() {
        let seq = sequence(true);
        let frames: Vec<Frame> = seq.iter().map(|f| f.frame()).collect();
        let table = ClusterMeans::from_frames(&frames);
        let first = &frames[0];
        let run = |name: &str, f: &dyn Fn(&Frame) -> Decomposition| {
            let edited: Vec<(Decomposition, &Labels)> =
                frames.iter().map(|fr| (f(fr), fr.labels)).collect();
            assert_constant_per_cluster(name, &edited);
        };
        let rc = recolour::ClusterRecolour::from_scribbles(
            first.labels,
            &table,
            &[recolour::Scribble {
                mask: rect(3, 5, 5, 6),
                target: [0.1, 0.6, 0.2],
            }],
        )
        .unwrap();
        assert_eq!(rc.clusters(), vec![FG]);
        run("recolour", &|f| rc.apply(f));
        let src = Image::from_fn(8, 8, |x, y| [x as f32 / 8.0, y as f32 / 8.0, 0.3]);
        let tr = transfer::ColourTransfer::fit(first, &src).unwrap();
        run("transfer", &|f| tr.apply(f));
        let st = stylise::VideoStylise::fit(first, &StyliseParams::default()).unwrap();
        run("stylise", &|f| st.apply(f));
        let curve = Curve::new(&[(0.0, 0.1), (0.6, 0.4), (1.0, 1.0)]).unwrap();
        let me = material::MaterialEdit::fit(first, curve, None).unwrap();
        run("material", &|f| me.apply(f));
        // The segmentation of a constant sequence is a function of the label alone.
        let seg = segment::StrokeSegmentation::from_strokes(
            first.labels,
            &table,
            &rect(3, 5, 5, 6),
            &rect(0, 2, 0, 2),
        )
        .unwrap();
        for f in &frames {
            let m = seg.mask(f.labels);
            for (i, &l) in f.labels.data.iter().enumerate() {
                assert_eq!(m.at(i), l == FG);
            }
        }
    }
}
