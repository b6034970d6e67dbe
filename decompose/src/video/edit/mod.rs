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
//! flicker back. The rule, by what an edit depends on:
//! - an edit decided **per cluster** leaves them **unedited** (their `R × S` is the input):
//!   recolouring, a material curve on chosen clusters; for the segmentation they are
//!   **background**, and they never draw a stylisation edge;
//! - an edit that is **one fixed function of the pixel's own values** (the colour transfer's
//!   mapping, the stylisation's saturation and flattening, a material curve on every cluster)
//!   needs no cluster, so it is applied to them too: it is the same function in every frame
//!   and cannot flicker, and leaving them out would leave holes of the old look wherever the
//!   propagation was unsure.

pub mod material;
pub mod recolour;
pub mod segment;
pub mod stylise;
pub mod transfer;

#[cfg(test)]
pub(crate) mod fixture;
#[cfg(test)]
mod tests;

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
    /// assigned pixel; unassigned pixels keep their layers (the rule of per-cluster edits).
    pub(crate) fn edit_assigned(
        &self,
        f: impl FnMut(usize, u32, [f32; 3], f32) -> ([f32; 3], f32),
    ) -> Decomposition {
        self.edit_pixels(true, f)
    }

    /// Applies `f` to every pixel, unassigned ones included (the rule of edits that are a
    /// fixed function of the pixel's values); `f` sees their label as [`Labels::NONE`].
    pub(crate) fn edit_all(
        &self,
        f: impl FnMut(usize, u32, [f32; 3], f32) -> ([f32; 3], f32),
    ) -> Decomposition {
        self.edit_pixels(false, f)
    }

    fn edit_pixels(
        &self,
        assigned_only: bool,
        mut f: impl FnMut(usize, u32, [f32; 3], f32) -> ([f32; 3], f32),
    ) -> Decomposition {
        let mut r = self.reflectance.clone();
        let mut s = self.shading.clone();
        for (i, &l) in self.labels.data.iter().enumerate() {
            if assigned_only && l == Labels::NONE {
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
            for (sum, v) in self.sums[k].iter_mut().zip(p) {
                *sum += v as f64;
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
