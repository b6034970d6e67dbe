//! The vote of step 8's single-image decompositions on the border levelling's offsets
//! ([`super::BorderLevelParams::view_vote`]).
//!
//! The border levelling assumes the shading continuous across every border between two
//! clusters. Where a cast shadow is a cluster of its own, the shading does jump there, and the
//! levelling makes the shadow's reflectance black (rendered tuning seq24: its first frame 0.054
//! against per-frame Retinex's 0.033). Locally, such a border looks like the achromatic albedo
//! borders the levelling is for (a grey cube on a white floor). A third estimate breaks the tie:
//! the single-image decompositions of step 8 (the light-field method on one view, with the
//! colour-line and white/black albedo cues), which make other errors than Zhao's Retinex of
//! the first frame.
//!
//! Per cluster `k`, `v_k` is the median over its pixels of every frame of
//! `ln S − (ln S_v − m_t)`: the offset that would give the cluster the single view's shading
//! (`S` the propagated shading, `S_v` the frame's single-view shading, `m_t` the frame's median
//! of `ln S_v − ln S`, which puts the single view on the video's scale as step 8 does). Both
//! `δ` and `v` are taken relative to the largest cluster. A cluster keeps its offset `δ_k`
//! when it moves the cluster towards the single view's level (`|δ_k − v_k| < |v_k|`), else
//! keeps the first frame's level (`δ_k` = 0). The clusters of the user's strokes keep their
//! offsets: the single views do not see the strokes.
//!
//! Leave-one-sequence-out on the 28 rendered tuning sequences chose this rule among {no vote,
//! this rule, the median of `0`, `δ_k`, `v_k`} in 24 of 28 folds: cross-validated mean LMSE
//! 0.0434 against 0.0444 without the vote. On seeds 29–36, scored once against a rule fixed
//! beforehand, 0.0353 against 0.0371 (`docs/video-data.md`, "Eighth session").
//!
//! Memory: one histogram (4 KiB) per cluster.

use super::histogram::Histogram;
use crate::decomposition::Labels;

/// Per cluster, the histogram of `ln S − (ln S_v − m_t)` over its pixels of every frame.
#[derive(Clone, Debug, Default)]
pub(crate) struct ViewLevels {
    clusters: Vec<Histogram>,
}

impl ViewLevels {
    /// Adds one frame: `labels` per pixel ([`Labels::NONE`] where none), `shading` the
    /// propagated linear grey shading, `view` the frame's single-image shading.
    pub fn add_frame(&mut self, labels: &[u32], shading: &[f32], view: &[f32]) {
        let lit = |s: f32, v: f32| s > 0.0 && v > 0.0 && s.is_finite() && v.is_finite();
        let mut ratios: Vec<f32> = shading
            .iter()
            .zip(view)
            .filter(|&(&s, &v)| lit(s, v))
            .map(|(s, v)| v.ln() - s.ln())
            .collect();
        if ratios.is_empty() {
            return;
        }
        let mid = ratios.len() / 2;
        let m = *ratios.select_nth_unstable_by(mid, f32::total_cmp).1;
        for ((&l, &s), &v) in labels.iter().zip(shading).zip(view) {
            if l == Labels::NONE || !lit(s, v) {
                continue;
            }
            let k = l as usize;
            if self.clusters.len() <= k {
                self.clusters.resize_with(k + 1, Histogram::default);
            }
            self.clusters[k].add(f64::from(s.ln() - (v.ln() - m)));
        }
    }

    /// `v_k` of the module docs; `None` for a cluster without a lit pixel.
    fn level(&self, k: usize) -> Option<f64> {
        self.clusters
            .get(k)
            .filter(|h| h.samples() > 0)
            .map(Histogram::median)
    }

    /// The vote of the module docs on the offsets `delta` (one per cluster), relative to the
    /// cluster `reference` (the largest). Clusters the single views never saw keep theirs, and
    /// so do the clusters for which `fixed` is true (those of the user's strokes, which the
    /// single views do not see).
    pub fn vote(&self, delta: &mut [f64], reference: usize, fixed: impl Fn(usize) -> bool) {
        let (Some(&d_ref), Some(v_ref)) = (delta.get(reference), self.level(reference)) else {
            return;
        };
        for (k, d) in delta.iter_mut().enumerate() {
            if fixed(k) {
                continue;
            }
            let Some(v) = self.level(k) else { continue };
            let (dk, vk) = (*d - d_ref, v - v_ref);
            if (dk - vk).abs() >= vk.abs() {
                *d = d_ref;
            }
        }
    }
}
