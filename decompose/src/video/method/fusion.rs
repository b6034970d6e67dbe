//! Step 8 (not in the thesis): each frame's own single-image decomposition blended into the
//! propagated one, then an average along the flow.
//!
//! Propagation (steps 4–6) carries the first frame's reflectance, clusters and levels to every
//! later frame: it does not flicker, but every error of the first frame's decomposition stays
//! for the whole video, and under a moving light or a moving object the colour table `𝓘_k`
//! learnt on frame 0 meets colours it never saw. A single-image decomposition of frame `t`
//! makes other errors, and flickers. On the twelve rendered tuning sequences the blend of the
//! two beat each alone (`docs/video-data.md`), and averaging the blend along the flow takes
//! most of the flicker back out.
//!
//! Per frame `t`, on the log shading (grey; `R = I / S` keeps `R × S = I` exact):
//!
//! 1. Two single-image decompositions of the frame alone:
//!    - `s_v`: the shading of the light-field method ([`crate::lightfield::decompose`]) run on
//!      the frame as a light field of one view. With one view and no disparity it is the
//!      gradient-domain Retinex of thesis §4.3 with the colour-line albedo cue, and a 2D TV-L1
//!      of its log reflectance; 0.18 s at 800×600 on the 2 cores, against 1.25 s for Zhao's
//!      Retinex;
//!    - `s_c`: the shading of the clustering method of thesis ch. 2 ([`crate::clustering`]),
//!      on the frame scaled down to at most 320×240 pixels
//!      ([`FusionParams::clustering_max_pixels`]) and scaled back up. Its errors are other
//!      than the Retinex family's (cluster levels from border equations instead of
//!      gradients), and its frame-to-frame flicker, large on its own, is what the average of
//!      3. takes out. On the 37 tuning sequences, leave-one-sequence-out: held-out goal count
//!      30 against 27 without it (`docs/video-data.md`, twelfth session).
//!
//!    Each is moved to the video's scale: the median of `s_m − s` over the lit pixels is
//!    subtracted (a single image picks its own white point every frame; left in, that would be
//!    a flicker of the whole frame).
//! 2. The blend `s_b = (1 − μ_m)·[(1 − β − β_c) s + β s_v + β_c s_c] + μ_m·median(s, s_v,
//!    s_c)` per pixel, with `s` the propagated log shading (steps 1–7) and `μ_m` = 0.5
//!    ([`FusionParams::median_share`], thirteenth session): the members go wrong in different
//!    places (a first-frame error carried along, a single image's misread edge, a cluster
//!    level off), and where one of the three is far off the others the median ignores it,
//!    where the weighted mean moves by its weight.
//! 3. The log reflectance level `d = ln Ī − s_b` (`Ī` the mean of the RGB channels) is
//!    averaged along the flow: `D_t = (1 − α) D_{t−1}(p + b(p)) + α d_t(p)`, with `b` the flow
//!    from frame `t` back to `t − 1` (bilinear). A pixel whose predecessor is out of the frame,
//!    unlit, or differs from it in `ln Ī` by more than `gate` (an occlusion, a flow error, a
//!    moving light) keeps `D_t = d_t`.
//! 4. The frame's shading is `Ī / e^{D_t}`. Unlit pixels (`Ī = 0`) keep the propagated shading.
//!
//! Memory: the previous frame's `D` and `ln Ī` (8 bytes a pixel); the two members' shadings are
//! cached in the scratch folder (4 bytes a pixel each).

use rayon::prelude::*;

use crate::clustering::ClusteringParams;
use crate::error::{Error, Result};
use crate::image::Image;
use crate::lightfield::method::PREVIOUS_REFLECTANCE_BETA;
use crate::lightfield::{LightField, LightFieldParams};
use crate::video::flow::Flow;

/// `β` by default: the single view's weight in the blend.
pub const DEFAULT_VIEW_WEIGHT: f32 = 0.4;
/// `β_c` by default: the clustering method's weight in the blend.
pub const DEFAULT_CLUSTERING_WEIGHT: f32 = 0.1;

/// [`FusionParams::median_share`] by default: half median, half weighted mean.
pub const DEFAULT_MEDIAN_SHARE: f32 = 0.5;

/// [`FusionParams::clustering_max_pixels`] by default: 320×240.
pub const DEFAULT_CLUSTERING_MAX_PIXELS: usize = 320 * 240;

/// Parameters of step 8 ([`super::VideoParams::fusion`]).
#[derive(Clone, Debug, PartialEq)]
pub struct FusionParams {
    /// `β`: the weight of the single view (the light-field method) in the log-shading blend,
    /// in [0, 1] (0: not used).
    pub beta: f32,
    /// `β_c`: the weight of the clustering method (thesis ch. 2) in the log-shading blend, in
    /// [0, 1] with `β + β_c ≤ 1` (0: not used; the propagated shading keeps `1 − β − β_c`).
    pub clustering_weight: f32,
    /// `μ_m`: the share of the per-pixel median of the members (the propagated shading and
    /// each single-image shading used, all moved to one scale) in the blend, in [0, 1]; the
    /// rest is their weighted mean. 0 is the weighted mean alone (the twelfth session's
    /// blend). Default [`DEFAULT_MEDIAN_SHARE`]: the members go wrong in different places, and
    /// where one is far off the median ignores it; on the 45 tuning sequences,
    /// leave-one-sequence-out, mean LMSE 0.0394 against 0.0400 for the mean alone and 0.0406
    /// for the median alone (`docs/video-data.md`, thirteenth session).
    pub median_share: f32,
    /// `α`: the rate of the average along the flow, in (0, 1] (1: no averaging).
    pub alpha: f32,
    /// Largest `|ln Ī_t(p) − ln Ī_{t−1}(p + b(p))|` for the average to carry a pixel. Default 0.1.
    pub gate: f32,
    /// The single-image decomposition: the light-field method's parameters (one view, no
    /// disparity). Default [`LightFieldParams::thesis_data_term`] with the reflectance filter at
    /// β = [`PREVIOUS_REFLECTANCE_BETA`]: the light field's defaults with the thesis' data term,
    /// the setting step 8 was tuned and tested with (the light field's per-ray data term and its
    /// β = 2 came later and were not chosen on videos).
    pub view: LightFieldParams,
    /// The clustering method's parameters (those of `decompose image --method clustering`).
    pub clustering: ClusteringParams,
    /// Largest number of pixels the clustering method runs on: a larger frame is scaled down
    /// (bilinear, same aspect) to fit, and the shading scaled back up. Default
    /// [`DEFAULT_CLUSTERING_MAX_PIXELS`], the 320×240 sequences `β_c` was chosen on, which it
    /// leaves untouched; on larger frames the method's cost grows with its clusters (0.5 s a
    /// frame at 800×600 on the synthetic `bench --video` sequence, 10,000+ clusters), which
    /// the 1 frame/s target cannot carry.
    pub clustering_max_pixels: usize,
}

impl Default for FusionParams {
    fn default() -> Self {
        Self {
            beta: DEFAULT_VIEW_WEIGHT,
            clustering_weight: DEFAULT_CLUSTERING_WEIGHT,
            median_share: DEFAULT_MEDIAN_SHARE,
            alpha: 0.1,
            gate: 0.1,
            view: {
                let mut view = LightFieldParams::thesis_data_term();
                view.reflectance_filter.beta = PREVIOUS_REFLECTANCE_BETA;
                view
            },
            clustering: ClusteringParams::default(),
            clustering_max_pixels: DEFAULT_CLUSTERING_MAX_PIXELS,
        }
    }
}

impl FusionParams {
    /// Whether the blend uses a single-image decomposition at all (`β > 0` or `β_c > 0`).
    pub fn blends(&self) -> bool {
        self.uses_view() || self.uses_clustering()
    }

    /// Whether the blend uses the single view (`β > 0`).
    pub fn uses_view(&self) -> bool {
        self.beta > 0.0
    }

    /// Whether the blend uses the clustering method (`β_c > 0`).
    pub fn uses_clustering(&self) -> bool {
        self.clustering_weight > 0.0
    }

    /// Errors with [`Error::InvalidParam`] naming the first value out of range.
    pub fn validate(&self) -> Result<()> {
        if !(0.0..=1.0).contains(&self.beta) {
            return Err(Error::param("beta", self.beta, "must be in [0, 1]"));
        }
        if !(0.0..=1.0).contains(&self.clustering_weight) {
            return Err(Error::param(
                "clustering_weight",
                self.clustering_weight,
                "must be in [0, 1]",
            ));
        }
        if self.beta + self.clustering_weight > 1.0 + 1e-6 {
            return Err(Error::param(
                "clustering_weight",
                self.clustering_weight,
                "beta + clustering_weight must be at most 1",
            ));
        }
        if !(0.0..=1.0).contains(&self.median_share) {
            return Err(Error::param(
                "median_share",
                self.median_share,
                "must be in [0, 1]",
            ));
        }
        if !(self.alpha > 0.0 && self.alpha <= 1.0) {
            return Err(Error::param("alpha", self.alpha, "must be in (0, 1]"));
        }
        if !(self.gate.is_finite() && self.gate >= 0.0) {
            return Err(Error::param("gate", self.gate, "must be finite and >= 0"));
        }
        if self.clustering_max_pixels == 0 {
            return Err(Error::param(
                "clustering_max_pixels",
                self.clustering_max_pixels,
                "must be at least 1",
            ));
        }
        self.view.reflectance_filter.validate()?;
        self.view.data_term.validate()?;
        self.clustering.validate()
    }
}

/// Step 8's state between frames: the previous frame's `D` and `ln Ī` (NaN where unlit).
pub(crate) struct Fusion<'a> {
    params: &'a FusionParams,
    previous: Option<(Vec<f32>, Vec<f32>)>,
}

impl<'a> Fusion<'a> {
    /// Before the first frame.
    pub fn new(params: &'a FusionParams) -> Self {
        Self {
            params,
            previous: None,
        }
    }

    /// The parameters.
    pub fn params(&self) -> &'a FusionParams {
        self.params
    }

    /// Replaces `shading` (one value per pixel of `frame`, the propagated linear shading) by
    /// the fused one. Frames come in order; `back_flow` is the flow from this frame to the one
    /// before (ignored for the first frame); `members`, the frame's single-image shadings
    /// ([`members`]; none: no blend). Pixels in `keep` are not blended (the user's
    /// constant-albedo and constant-shading strokes on the first frame, which the single-image
    /// decompositions do not see).
    pub fn fuse(
        &mut self,
        frame: &Image,
        shading: &mut [f32],
        back_flow: &Flow,
        members: &Members,
        keep: Option<&[bool]>,
    ) -> Result<()> {
        let log_i = log_mean_intensity(frame);
        let weighted: Vec<(&[f32], f32)> = [
            (members.view.as_deref(), self.params.beta),
            (members.clustering.as_deref(), self.params.clustering_weight),
        ]
        .into_iter()
        .filter_map(|(m, w)| m.map(|m| (m, w)))
        .collect();
        let s = blend(shading, &weighted, self.params.median_share, &log_i, keep);
        let d: Vec<f32> = log_i.iter().zip(&s).map(|(i, s)| i - s).collect();
        let fused = match &self.previous {
            Some((prev_d, prev_i)) if self.params.alpha < 1.0 => average_along_flow(
                prev_d,
                prev_i,
                &d,
                &log_i,
                back_flow,
                self.params.alpha,
                self.params.gate,
            )?,
            _ => d,
        };
        for ((out, &l), &f) in shading.iter_mut().zip(&log_i).zip(&fused) {
            if l.is_finite() {
                *out = (l - f).exp();
            }
        }
        self.previous = Some((fused, log_i));
        Ok(())
    }
}

/// One frame's single-image shadings for the blend (`None`: not used or not computed).
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Members {
    /// The single view's shading ([`single_view_shading`]).
    pub view: Option<Vec<f32>>,
    /// The clustering method's shading ([`clustering_shading`]).
    pub clustering: Option<Vec<f32>>,
}

/// The single-image shadings of `frame` that `params` blends; none for a black frame, which
/// has nothing to decompose (and which the single-image methods refuse).
pub(super) fn members(frame: &Image, params: &FusionParams) -> Result<Members> {
    if crate::video::frames::is_black(frame) {
        return Ok(Members::default());
    }
    Ok(Members {
        view: params
            .uses_view()
            .then(|| single_view_shading(frame, &params.view))
            .transpose()?,
        clustering: params
            .uses_clustering()
            .then(|| clustering_shading(frame, params))
            .transpose()?,
    })
}

/// `ln` of the mean of the RGB channels, NaN where it is 0 (unlit).
fn log_mean_intensity(frame: &Image) -> Vec<f32> {
    frame
        .data()
        .par_chunks_exact(3)
        .map(|p| {
            let m = (p[0] + p[1] + p[2]) / 3.0;
            if m > 0.0 { m.ln() } else { f32::NAN }
        })
        .collect()
}

/// The shading of the light-field method on `frame` as a light field of one view (step 8's
/// single-image decomposition).
pub(super) fn single_view_shading(frame: &Image, params: &LightFieldParams) -> Result<Vec<f32>> {
    let (w, h) = frame.dims();
    let lf = LightField::from_vec(1, 1, w, h, 3, frame.data().to_vec())?;
    let (d, _) = crate::lightfield::decompose(&lf, None, params, &mut |_| {})?;
    Ok(d.shading.view_data(0).to_vec())
}

/// The shading of the clustering method (thesis ch. 2) on `frame` alone (step 8's second
/// single-image decomposition), at most [`FusionParams::clustering_max_pixels`] pixels.
pub(super) fn clustering_shading(frame: &Image, params: &FusionParams) -> Result<Vec<f32>> {
    let (w, h) = frame.dims();
    let (sw, sh) = working_size(w, h, params.clustering_max_pixels);
    let small = ((sw, sh) != (w, h)).then(|| frame.resize(sw, sh));
    let input = small.as_ref().unwrap_or(frame);
    let shading = crate::clustering::decompose(input, None, &params.clustering, &mut |_| {})?
        .decomposition
        .shading;
    Ok(match small {
        Some(_) => shading.resize(w, h),
        None => shading,
    }
    .into_vec())
}

/// The largest size of `w`×`h`'s aspect with at most `max_pixels` pixels (at least 1×1);
/// `w`×`h` itself when it fits.
pub(super) fn working_size(w: u32, h: u32, max_pixels: usize) -> (u32, u32) {
    let n = w as usize * h as usize;
    if n <= max_pixels {
        return (w, h);
    }
    let f = (max_pixels as f64 / n as f64).sqrt();
    let (mut sw, mut sh) = (
        ((w as f64 * f).floor() as u32).max(1),
        ((h as f64 * f).floor() as u32).max(1),
    );
    while sw as usize * sh as usize > max_pixels && (sw > 1 || sh > 1) {
        if sw >= sh { sw -= 1 } else { sh -= 1 }
    }
    (sw, sh)
}

/// Per pixel, `(1 − μ_m)·mean + μ_m·median` of the members: `mean = (1 − Σ w_m) ln s +
/// Σ w_m (ln s_m − m_m)` over the weighted members `(s_m, w_m)`, `median` the median of
/// `ln s` and the `ln s_m − m_m` of the members of positive weight (the mean of the middle
/// two for an even count), with `m_m` the median of `ln s_m − ln s` over the lit pixels (each
/// member moved to the propagated shading's scale); `ln s` where `keep`.
pub(super) fn blend(
    propagated: &[f32],
    members: &[(&[f32], f32)],
    median_share: f32,
    log_i: &[f32],
    keep: Option<&[bool]>,
) -> Vec<f32> {
    let ln = |v: f32| v.max(f32::MIN_POSITIVE).ln();
    let used: Vec<(&[f32], f32)> = members.iter().copied().filter(|&(_, w)| w > 0.0).collect();
    let shifts: Vec<f32> = used
        .iter()
        .map(|&(member, _)| {
            let mut diff: Vec<f32> = propagated
                .iter()
                .zip(member)
                .zip(log_i)
                .filter(|(_, l)| l.is_finite())
                .map(|((&s, &v), _)| ln(v) - ln(s))
                .collect();
            // The upper median for an even count, as since the eighth session.
            let k = diff.len() / 2;
            if diff.is_empty() {
                0.0
            } else {
                *diff.select_nth_unstable_by(k, f32::total_cmp).1
            }
        })
        .collect();
    (0..propagated.len())
        .into_par_iter()
        .map_init(Vec::new, |values, p| {
            let own = ln(propagated[p]);
            if keep.is_some_and(|k| k[p]) {
                return own;
            }
            values.clear();
            values.push(own);
            let mut mean = own;
            for (&(member, w), &m) in used.iter().zip(&shifts) {
                let v = ln(member[p]) - m;
                mean += w * (v - own);
                values.push(v);
            }
            if median_share > 0.0 {
                let median = median_of(values).unwrap_or(own);
                (1.0 - median_share) * mean + median_share * median
            } else {
                mean
            }
        })
        .collect()
}

/// The median of `values` (the mean of the middle two for an even count; reorders them);
/// `None` when empty.
fn median_of(values: &mut [f32]) -> Option<f32> {
    let n = values.len();
    if n == 0 {
        return None;
    }
    let k = n / 2;
    let (below, &mut upper, _) = values.select_nth_unstable_by(k, f32::total_cmp);
    Some(if n % 2 == 1 {
        upper
    } else {
        let lower = below.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        0.5 * (lower + upper)
    })
}

/// `D_t(p) = (1 − α) D_{t−1}(p + b(p)) + α d_t(p)` where the predecessor `p + b(p)` is inside
/// the frame and lit and its `ln Ī` is within `gate` of `p`'s; `d_t(p)` elsewhere. Bilinear
/// sampling; a NaN (unlit) corner makes the sample invalid.
pub(super) fn average_along_flow(
    prev_d: &[f32],
    prev_log_i: &[f32],
    d: &[f32],
    log_i: &[f32],
    back_flow: &Flow,
    alpha: f32,
    gate: f32,
) -> Result<Vec<f32>> {
    let (w, h) = (back_flow.width() as usize, back_flow.height() as usize);
    let n = w * h;
    if [prev_d.len(), prev_log_i.len(), d.len(), log_i.len()]
        .iter()
        .any(|&l| l != n)
    {
        return Err(Error::param(
            "back_flow",
            format!("{w}x{h}"),
            "must have one vector per pixel of the frames being averaged",
        ));
    }
    let sample = |data: &[f32], x: f32, y: f32| -> Option<f32> {
        if !(x >= 0.0 && y >= 0.0 && x <= (w - 1) as f32 && y <= (h - 1) as f32) {
            return None;
        }
        let (x0, y0) = (x.floor() as usize, y.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
        let (tx, ty) = (x - x0 as f32, y - y0 as f32);
        let at = |xx: usize, yy: usize| data[yy * w + xx];
        let v = (at(x0, y0) * (1.0 - tx) + at(x1, y0) * tx) * (1.0 - ty)
            + (at(x0, y1) * (1.0 - tx) + at(x1, y1) * tx) * ty;
        v.is_finite().then_some(v)
    };
    Ok((0..n)
        .into_par_iter()
        .map(|p| {
            if !log_i[p].is_finite() {
                return d[p];
            }
            let [u, v] = [back_flow.u()[p], back_flow.v()[p]];
            let (x, y) = ((p % w) as f32 + u, (p / w) as f32 + v);
            match (sample(prev_d, x, y), sample(prev_log_i, x, y)) {
                (Some(pd), Some(pi)) if (pi - log_i[p]).abs() <= gate => {
                    (1.0 - alpha) * pd + alpha * d[p]
                }
                _ => d[p],
            }
        })
        .collect())
}
