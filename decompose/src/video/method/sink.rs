//! What [`super::decompose_video`] hands back: the final frames, through a [`FrameSink`], and
//! the run's statistics; and the last stage that produces them (the residual fill, eq. 3.11,
//! frame by frame).

use std::time::Instant;

use serde::Serialize;

use crate::color::luminance;
use crate::decomposition::{Labels, white_point};
use crate::error::Result;
use crate::image::Image;
use crate::progress::{Progress, ProgressFn};
use crate::retinex::Strokes;
use crate::video::flow::{Flow, invert};
use crate::video::frames::is_black;

use super::fusion::{Fusion, Members};
use super::levels::{self, LevelSummary};
use super::passes;
use super::residual;
use super::state::{Member, PixelSource};

/// One frame's final result, lent to a [`FrameSink`].
#[derive(Clone, Copy, Debug)]
pub struct VideoFrame<'a> {
    /// Frame number, from 0.
    pub index: usize,
    /// Reflectance, 3 channels, linear, on the first frame's scale (its 99.5th percentile is
    /// 1); `reflectance × shading` is the input frame.
    pub reflectance: &'a Image,
    /// Shading, 1 channel, linear.
    pub shading: &'a Image,
    /// The cluster of every pixel (`count` = the clusters known at the end of the run).
    pub clusters: &'a Labels,
}

/// Receives the final frames of [`super::decompose_video`]: called exactly once per frame, in
/// order 0, 1, …, n − 1, after all the passes.
pub trait FrameSink {
    /// Takes one frame; an error stops the run.
    fn frame(&mut self, frame: VideoFrame<'_>) -> Result<()>;
}

/// A frame held in memory (for tests and evaluation of short sequences).
#[derive(Clone, Debug, PartialEq)]
pub struct OwnedFrame {
    /// Frame number.
    pub index: usize,
    /// Reflectance, 3 channels.
    pub reflectance: Image,
    /// Shading, 1 channel.
    pub shading: Image,
    /// Clusters.
    pub clusters: Labels,
}

/// Collects every frame in memory: only for short sequences.
impl FrameSink for Vec<OwnedFrame> {
    fn frame(&mut self, f: VideoFrame<'_>) -> Result<()> {
        self.push(OwnedFrame {
            index: f.index,
            reflectance: f.reflectance.clone(),
            shading: f.shading.clone(),
            clusters: f.clusters.clone(),
        });
        Ok(())
    }
}

/// Any closure over [`VideoFrame`] is a sink.
impl<F: FnMut(VideoFrame<'_>) -> Result<()>> FrameSink for F {
    fn frame(&mut self, f: VideoFrame<'_>) -> Result<()> {
        self(f)
    }
}

/// What happened to one frame.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct FrameStats {
    /// Frame number.
    pub index: usize,
    /// Fraction of the pixels whose value came from propagation (§3.5).
    pub assigned_by_propagation: f64,
    /// Fraction from completion (§3.6; all of frame 0, decomposed in step 1).
    pub completed: f64,
    /// Fraction from the residual Laplace fill (eq. 3.11). The three fractions sum to 1.
    pub residual: f64,
    /// How many times the frame was a stopping frame and was completed (0 to 3: at most once
    /// per pass).
    pub completion_passes: u32,
    /// Optical flow computed into this frame, milliseconds.
    pub flow_ms: f64,
    /// Propagation into this frame, milliseconds.
    pub propagate_ms: f64,
    /// Completion and residual fill of this frame (frame 0: its Retinex and clusters),
    /// milliseconds.
    pub complete_ms: f64,
    /// Step 8's single-image decomposition of this frame (after the passes, as many frames at
    /// a time as there are threads), milliseconds; 0 when the step is off.
    pub view_ms: f64,
    /// Step 8's blend and average along the flow on this frame (in the output), milliseconds;
    /// 0 when the step is off.
    pub fusion_ms: f64,
    /// Whether the frame is black (a fade, black leader, a cut through black): its
    /// reflectance and shading are output black, and step 8 blends nothing into it.
    pub black: bool,
}

/// What happened in a [`super::decompose_video`] run.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct VideoStats {
    /// One entry per frame, in order.
    pub frames: Vec<FrameStats>,
    /// The frames completed because propagation stopped there (§3.5.3) in any pass, in
    /// increasing order, each once.
    pub stopping_frames: Vec<usize>,
    /// Steps 1–2 on the first frame with light, milliseconds.
    pub first_frame_ms: f64,
    /// The first frame with light, where steps 1–2 ran: 0 unless the video opens on black
    /// frames, which are output black.
    pub first_lit_frame: usize,
    /// The whole run, milliseconds.
    pub total_ms: f64,
    /// Wall time of step 8's single-image decompositions (all frames, several at a time),
    /// milliseconds; 0 when the step is off.
    pub views_ms: f64,
    /// Number of clusters at the end (first frame's plus those made by completion).
    pub clusters: usize,
    /// The border levelling (module `levels`): pairs of touching clusters, mean |offset| (natural
    /// log), milliseconds of the solve; zeros when it is off.
    pub levels: LevelSummary,
}

/// The residual fill (eq. 3.11) of every frame, the border levelling (module `levels`) over
/// all of them, then the sink, frame by frame; fills in the fractions.
pub(crate) fn output(
    run: &mut passes::Run,
    strokes: &Strokes,
    sink: &mut dyn FrameSink,
    progress: ProgressFn,
) -> Result<LevelSummary> {
    let n = run.source.len();
    let dims = run.source.size();
    let mut evidence = levels::BorderEvidence::default();
    let voting = run.params.levels.as_ref().is_some_and(|l| l.view_vote)
        && run.params.fusion.as_ref().is_some_and(|f| f.uses_view());
    let mut views = levels::ViewLevels::default();
    for t in 0..n {
        let img = run.source.frame(t)?;
        let mut st = run.scratch.load_state(t, dims)?;
        let t0 = Instant::now();
        residual::fill_residual(&img, &mut st, &run.params.retinex.solver)?;
        if voting && let Some(view) = run.scratch.load_member_shading(Member::View, t, dims)? {
            views.add_frame(&st.labels, &st.shading, &view);
        }
        if run.params.levels.is_some() {
            evidence.add_frame(dims.0 as usize, &st.labels, &st.shading);
            if t == run.first_lit {
                let lum: Vec<f32> = (0..st.len()).map(|i| luminance(img.rgb(i))).collect();
                evidence.add_strokes(dims.0 as usize, &st.labels, &st.shading, &lum, strokes);
            }
        }
        run.stats[t].complete_ms += t0.elapsed().as_secs_f64() * 1e3;
        let frac = |kind| st.source.iter().filter(|&&s| s == kind).count() as f64 / st.len() as f64;
        let fs = &mut run.stats[t];
        fs.assigned_by_propagation = frac(PixelSource::Propagation);
        fs.completed = frac(PixelSource::Completion);
        fs.residual = frac(PixelSource::Residual);
        // The final state stays in the scratch folder (every pixel assigned).
        run.scratch.save_state(t, &st)?;
        progress(Progress {
            stage: "output",
            fraction: 1.0 - passes::OUTPUT_SHARE * (1.0 - (t + 1) as f32 / (2 * n) as f32),
        });
    }
    let clusters = run.tables.cluster_count();
    let t0 = Instant::now();
    let mut delta = match &run.params.levels {
        Some(p) => evidence.offsets(clusters, p)?,
        None => Vec::new(),
    };
    if voting && let Some(largest) = evidence.largest_cluster() {
        views.vote(&mut delta, largest, |k| evidence.in_strokes(k));
    }
    let mean_abs_offset = if delta.is_empty() {
        0.0
    } else {
        delta.iter().map(|d| d.abs()).sum::<f64>() / delta.len() as f64
    };
    let summary = LevelSummary {
        ms: t0.elapsed().as_secs_f64() * 1e3,
        pairs: evidence.pair_count(),
        mean_abs_offset,
    };
    drop(evidence);
    let mut fusion = run.params.fusion.as_ref().map(Fusion::new);
    let stroked = stroke_pixels(strokes, dims);
    for t in 0..n {
        let img = run.source.frame(t)?;
        let mut st = run.scratch.load_state(t, dims)?;
        // Black frames were left black by the passes (`FrameState::black`: shading 0, so
        // R × S = I = 0); here they are only counted.
        run.stats[t].black = is_black(&img);
        levels::apply(&st.labels, &mut st.shading, &delta);
        if t == run.first_lit && !delta.is_empty() {
            // Back on the first frame's scale: its 99.5th percentile of reflectance is 1 again
            // (one factor for the whole video, left out of `mean_abs_offset`).
            if let Some(q) = white_point(&st.reflectance(&img), |_| true) {
                delta.iter_mut().for_each(|d| *d -= f64::from(q).ln());
                st.shading.iter_mut().for_each(|s| *s *= q);
            }
        }
        if let Some(fusion) = fusion.as_mut() {
            let t0 = Instant::now();
            let back = back_flow(run, t, dims)?;
            let keep = stroked.as_deref().filter(|_| t == run.first_lit);
            let (members, view_ms) = cached_members(run, fusion.params(), t, dims, &img)?;
            fusion.fuse(&img, &mut st.shading, &back, &members, keep)?;
            run.stats[t].view_ms += view_ms;
            run.stats[t].fusion_ms += t0.elapsed().as_secs_f64() * 1e3 - view_ms;
        }
        let reflectance = st.reflectance(&img);
        let shading = Image::from_vec(dims.0, dims.1, 1, std::mem::take(&mut st.shading))?;
        let labels = st.labels(clusters);
        sink.frame(VideoFrame {
            index: t,
            reflectance: &reflectance,
            shading: &shading,
            clusters: &labels,
        })?;
        progress(Progress {
            stage: "output",
            fraction: 1.0 - passes::OUTPUT_SHARE * (1.0 - (n + t + 1) as f32 / (2 * n) as f32),
        });
    }
    Ok(summary)
}

/// Frame t's single-image shadings for step 8: from the scratch folder where
/// [`passes::Run::cache_views`] put them, else computed now (with the time that took, ms).
fn cached_members(
    run: &passes::Run,
    params: &super::FusionParams,
    t: usize,
    dims: (u32, u32),
    img: &Image,
) -> Result<(Members, f64)> {
    let load = |member, used: bool| {
        if used {
            run.scratch.load_member_shading(member, t, dims)
        } else {
            Ok(None)
        }
    };
    let cached = Members {
        view: load(Member::View, params.uses_view())?,
        clustering: load(Member::Clustering, params.uses_clustering())?,
    };
    let complete = (cached.view.is_some() || !params.uses_view())
        && (cached.clustering.is_some() || !params.uses_clustering());
    if complete {
        return Ok((cached, 0.0));
    }
    let t0 = Instant::now();
    let fresh = super::fusion::members(img, params)?;
    Ok((fresh, t0.elapsed().as_secs_f64() * 1e3))
}

/// The flow from frame `t` back to `t − 1` for step 8: the cached backward flow, else the
/// cached forward flow inverted, else (frame 0, or the no-flow ablation) the zero flow.
fn back_flow(run: &passes::Run, t: usize, dims: (u32, u32)) -> Result<Flow> {
    if t == 0 {
        return Ok(Flow::zeros(dims.0, dims.1));
    }
    if let Some(b) = run.scratch.load_flow(t - 1, false, dims)? {
        return Ok(b);
    }
    Ok(match run.scratch.load_flow(t - 1, true, dims)? {
        Some(f) => invert(&f, INVERSION_STEPS),
        None => Flow::zeros(dims.0, dims.1),
    })
}

/// The pixels of the first frame's constant-albedo and constant-shading strokes, if any.
fn stroke_pixels(strokes: &Strokes, dims: (u32, u32)) -> Option<Vec<bool>> {
    let masks: Vec<_> = (strokes.constant_albedo.iter())
        .chain(&strokes.constant_shading)
        .filter(|m| m.dims() == dims)
        .collect();
    if masks.is_empty() {
        return None;
    }
    let n = dims.0 as usize * dims.1 as usize;
    Some((0..n).map(|i| masks.iter().any(|m| m.at(i))).collect())
}

/// Fixed-point steps of the flow inversion (`video::flow::invert`).
const INVERSION_STEPS: usize = 3;
