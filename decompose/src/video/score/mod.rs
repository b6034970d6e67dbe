//! Scores of a video decomposition (issue 20, "Evaluation"): accuracy of every frame against
//! ground truth, and temporal flicker, with or without ground truth.
//!
//! # Accuracy
//!
//! [`frame_lmse`] is the Grosse et al. LMSE of [`crate::metrics::score`], exactly as
//! `decompose eval` computes it on the MIT images: grey reflectance and grey shading, 20×20
//! windows with stride 10, each window scaled by its least-squares factor, the mean of the
//! reflectance and shading LMSE. Every pixel is scored (the rendered rooms are closed: every
//! pixel sees a surface). The sequence's figure is the mean over the frames.
//!
//! # Flicker
//!
//! A surface point should keep its reflectance from frame to frame. For a pair of consecutive
//! frames `t`, `t + 1` and a flow `(u, v)` from `t` to `t + 1` (the convention of
//! [`crate::video::flow`]: the pixel `p = (x, y)` of frame `t` is seen at `p + (u, v)` in
//! frame `t + 1`), the pair's flicker is
//!
//! ```text
//! F_t = mean over valid p of | L_{t+1}(p + flow(p)) − L_t(p) |,
//! L_t = ln max(grey(R_t), ε),   grey = mean of the R, G, B channels,   ε = LOG_FLOOR = 1e-3
//! ```
//!
//! where `L_{t+1}(p + flow(p))` is sampled bilinearly from the log image (logs are
//! interpolated, not reflectances). A pixel `p` is *valid* when its flow is known
//! ([`crate::video::truth::is_known`]: rendered truth marks occluded and out-of-view points
//! unknown; an estimated flow is known everywhere) and the warped position lies inside the
//! frame: `0 ≤ x + u ≤ w − 1` and `0 ≤ y + v ≤ h − 1` (no border replication). A pair without
//! a valid pixel has no flicker value and is left out, and so is a pair with a black frame (a
//! reflectance 0 everywhere: a fade, a cut through black, which every method outputs black):
//! there is no reflectance to compare. The sequence's flicker is the mean of
//! the pairs' `F_t`, every pair weighing the same.
//!
//! The logarithm makes the measure independent of one global scale of the whole video (a
//! decomposition is defined up to a scale), but not of a scale that changes from frame to frame,
//! which is exactly what a viewer sees as flicker: a reflectance that brightens by a factor
//! `k` between two frames scores `|ln k|`. Grey rather than per channel because the methods'
//! ambiguity is the brightness scale; chroma flicker of a per-frame method shows up in the
//! grey value as well. The floor ε: decompositions put their 99.5th percentile at 1 and the
//! rendered albedos are in (0.04, 1), so only near-black estimates are floored. For real
//! footage (no ground truth), the flow is estimated from the input frames by
//! [`crate::video::flow::flow`]; the flicker then also contains that flow's errors, the same
//! for every method, so it compares methods but is not an absolute figure.

#[cfg(test)]
mod tests;

use crate::error::{Error, Result};
use crate::image::{Image, Mask};
use crate::metrics;
use crate::video::flow::Flow;
use crate::video::truth::is_known;

/// `ε`: grey reflectance values are floored here before the logarithm (see the module docs).
pub const LOG_FLOOR: f32 = 1e-3;

/// The Grosse et al. LMSE of one frame's estimate against its truth: the `lmse` field of
/// [`crate::metrics::score`] with every pixel scored (see the module docs).
/// Errors with [`Error::ShapeMismatch`] when the four images differ in size.
pub fn frame_lmse(
    est_reflectance: &Image,
    est_shading: &Image,
    true_reflectance: &Image,
    true_shading: &Image,
) -> Result<f64> {
    let mask = Mask::full(true_reflectance.width(), true_reflectance.height());
    Ok(metrics::score(
        est_reflectance,
        est_shading,
        true_reflectance,
        true_shading,
        &mask,
    )?
    .lmse)
}

/// `L = ln max(grey(R), ε)` of a reflectance (one channel); see the module docs.
pub fn log_grey(reflectance: &Image) -> Image {
    let c = reflectance.channels().max(1) as f32;
    let mut out = Image::new(reflectance.width(), reflectance.height(), 1);
    for i in 0..reflectance.len() {
        let g = reflectance.px(i).iter().sum::<f32>() / c;
        // NaN would poison the mean; a method that produced one is floored like black.
        let g = if g.is_finite() {
            g.max(LOG_FLOOR)
        } else {
            LOG_FLOOR
        };
        out.px_mut(i)[0] = g.ln();
    }
    out
}

/// The flicker of one pair of frames.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct PairFlicker {
    /// `F_t`, the mean absolute change of log grey reflectance over the valid pixels (0 when
    /// there is none).
    pub mean: f64,
    /// Number of valid pixels (known flow, warped position inside the frame).
    pub pixels: usize,
}

/// The flicker `F_t` between two log-grey reflectances ([`log_grey`]) of consecutive frames,
/// with the flow from the first to the second (see the module docs). Errors with
/// [`Error::ShapeMismatch`] when the sizes differ and [`Error::InvalidParam`] for an image
/// with more than one channel.
pub fn pair_flicker(log_prev: &Image, log_next: &Image, flow: &Flow) -> Result<PairFlicker> {
    log_prev.check_dims(log_next.dims())?;
    log_prev.check_dims(flow.dims())?;
    if log_prev.channels() != 1 || log_next.channels() != 1 {
        return Err(Error::param(
            "channels",
            log_prev.channels().max(log_next.channels()),
            "flicker compares one-channel log-grey images (see log_grey)",
        ));
    }
    let (w, h) = (log_prev.width() as usize, log_prev.height() as usize);
    let next = log_next.data();
    let (mut sum, mut pixels) = (0.0f64, 0usize);
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let (u, v) = (flow.u()[i], flow.v()[i]);
            if !is_known(u, v) {
                continue;
            }
            let (sx, sy) = (x as f64 + u as f64, y as f64 + v as f64);
            if !(sx >= 0.0 && sy >= 0.0 && sx <= (w - 1) as f64 && sy <= (h - 1) as f64) {
                continue;
            }
            let (x0, y0) = (sx.floor() as usize, sy.floor() as usize);
            let (x1, y1) = ((x0 + 1).min(w - 1), (y0 + 1).min(h - 1));
            let (fx, fy) = (sx - x0 as f64, sy - y0 as f64);
            let at = |xx: usize, yy: usize| next[yy * w + xx] as f64;
            let warped = (1.0 - fy) * ((1.0 - fx) * at(x0, y0) + fx * at(x1, y0))
                + fy * ((1.0 - fx) * at(x0, y1) + fx * at(x1, y1));
            sum += (warped - log_prev.data()[i] as f64).abs();
            pixels += 1;
        }
    }
    Ok(PairFlicker {
        mean: if pixels > 0 { sum / pixels as f64 } else { 0.0 },
        pixels,
    })
}

/// The scores of one decomposed sequence.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct SequenceScores {
    /// Mean of [`Self::lmse_frames`] (NaN without ground truth).
    pub lmse: f64,
    /// The LMSE of every frame (empty without ground truth).
    pub lmse_frames: Vec<f64>,
    /// Mean of the pairs' flicker `F_t` over the pairs with a valid pixel (NaN when none).
    pub flicker: f64,
    /// `F_t` of every pair `(t, t + 1)`, in order (`None`: no valid pixel).
    pub flicker_pairs: Vec<Option<f64>>,
    /// Valid pixels summed over the pairs.
    pub flicker_pixels: usize,
}

/// Scores a sequence one frame at a time, keeping only the previous frame's log reflectance,
/// so that memory does not grow with the length of the video.
#[derive(Debug, Default)]
pub struct SequenceScorer {
    /// The previous frame's log grey reflectance; `None` before the first frame and after a
    /// black one.
    prev: Option<Image>,
    scores: SequenceScores,
    frames: usize,
}

impl SequenceScorer {
    /// A scorer before the first frame.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds the next frame's estimate. `truth` is the frame's true (reflectance, shading),
    /// when there is ground truth (give it for every frame or for none); `flow_from_prev` the
    /// flow from the previous frame to this one (ignored for the first frame; required for
    /// the others). Errors: [`Error::InvalidParam`] for a missing flow, a size mismatch from
    /// [`frame_lmse`] or [`pair_flicker`].
    pub fn push(
        &mut self,
        reflectance: &Image,
        shading: &Image,
        truth: Option<(&Image, &Image)>,
        flow_from_prev: Option<&Flow>,
    ) -> Result<()> {
        if let Some((r, s)) = truth {
            let l = frame_lmse(reflectance, shading, r, s)?;
            self.scores.lmse_frames.push(l);
        }
        let black = reflectance.data().iter().all(|&v| v == 0.0);
        let log = (!black).then(|| log_grey(reflectance));
        if self.frames > 0 {
            let flow = flow_from_prev.ok_or_else(|| {
                Error::param(
                    "flow_from_prev",
                    self.frames,
                    "every frame after the first needs the flow from the frame before",
                )
            })?;
            let pair = match (&self.prev, &log) {
                (Some(prev), Some(log)) => {
                    let f = pair_flicker(prev, log, flow)?;
                    self.scores.flicker_pixels += f.pixels;
                    (f.pixels > 0).then_some(f.mean)
                }
                // A black frame on either side: nothing to compare.
                _ => None,
            };
            self.scores.flicker_pairs.push(pair);
        }
        self.prev = log;
        self.frames += 1;
        Ok(())
    }

    /// Frames pushed so far.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// The scores of the frames pushed (means as described on [`SequenceScores`]).
    pub fn finish(self) -> SequenceScores {
        let mut s = self.scores;
        s.lmse = mean(s.lmse_frames.iter().copied());
        s.flicker = mean(s.flicker_pairs.iter().flatten().copied());
        s
    }
}

/// Mean of the values, NaN for none.
fn mean(values: impl Iterator<Item = f64>) -> f64 {
    let (sum, n) = values.fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    if n == 0 { f64::NAN } else { sum / n as f64 }
}
