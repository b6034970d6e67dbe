//! The passes of Algorithm 1: forward propagation with the stopping condition, completion of
//! each stopping frame followed by backward propagation of its new clusters, three times with
//! `M` = 30, 20, 10 (see the module docs of `method` for the reading).

use std::time::Instant;

use rayon::prelude::*;

use crate::error::Result;
use crate::image::Image;
use crate::image::Mask;
use crate::progress::{Progress, ProgressFn};
use crate::video::flow::{Flow, flow};
use crate::video::frames::{FrameSource, is_black};
use crate::video::propagate::{
    ClusterTables, PropagateParams, ReflectanceMemo, propagate_with, should_stop,
};

use super::complete::complete_frame;
use super::first::FIRST_FRAME_SHARE;
use super::fusion::members;
use super::state::{FrameState, Member, PixelSource, Scratch};
use super::{FrameStats, VideoParams};

/// Everything a run keeps in memory besides the two or three frames being worked on: the
/// tables, per-frame counters (a few numbers each) and the list of stopping frames.
pub(crate) struct Run<'a> {
    pub source: &'a FrameSource,
    pub params: &'a VideoParams,
    pub scratch: Scratch,
    pub tables: ClusterTables,
    /// The colour-ball reflectances of the current tables (`PropagateParams::reflectance_radius`).
    pub memo: ReflectanceMemo,
    pub stats: Vec<FrameStats>,
    pub stopping: Vec<usize>,
    /// The first frame with light, decomposed by step 1 (0 unless the video opens on black).
    pub first_lit: usize,
}

/// The frame propagation starts from: its number, state and image.
struct Side<'a> {
    index: usize,
    state: &'a FrameState,
    img: &'a Image,
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

impl Run<'_> {
    fn dims(&self) -> (u32, u32) {
        self.source.size()
    }

    /// The propagation parameters of pass `pass` (0, 1, 2), with the ablation applied.
    fn pass_params(&self, pass: usize) -> PropagateParams {
        let mut p = self.params.propagate.clone();
        p.m = PropagateParams::PASS_WINDOWS[pass];
        if self.params.ablation.no_confidence_threshold {
            // Every MAP cluster is taken: ε as small as validation allows, β = 1.
            p.epsilon = f64::MIN_POSITIVE;
            p.beta = 1.0;
        }
        p
    }

    /// The flow from frame `from` to frame `to` (= from ± 1), cached in the scratch folder; the
    /// zero flow under the `no_optical_flow` ablation. Time goes to frame `to`.
    fn flow(&mut self, from: usize, to: usize, a: &Image, b: &Image) -> Result<Flow> {
        let (w, h) = self.dims();
        if self.params.ablation.no_optical_flow {
            return Ok(Flow::zeros(w, h));
        }
        let (t, forward) = if to > from { (from, true) } else { (to, false) };
        if let Some(f) = self.scratch.load_flow(t, forward, (w, h))? {
            return Ok(f);
        }
        let t0 = Instant::now();
        let f = flow(a, b, &self.params.flow)?;
        self.scratch.save_flow(t, forward, &f)?;
        self.stats[to].flow_ms += ms(t0);
        Ok(f)
    }

    /// Propagates the clusters of frame `from` into the unassigned pixels of frame `to`
    /// (`state`, `img`); returns how many were assigned.
    fn propagate_into(
        &mut self,
        from: Side<'_>,
        to: usize,
        state: &mut FrameState,
        img: &Image,
        pp: &PropagateParams,
    ) -> Result<usize> {
        if state.unassigned() == 0 {
            return Ok(0);
        }
        let f = self.flow(from.index, to, from.img, img)?;
        let t0 = Instant::now();
        let labels = from.state.labels(self.tables.cluster_count());
        // Only the still unassigned pixels are decided: after the first pass that is a few
        // percent of a frame, and a pixel's decision does not depend on the others.
        let open: Vec<bool> = state
            .source
            .iter()
            .map(|&s| s == PixelSource::Unassigned)
            .collect();
        let prop = propagate_with(
            &self.tables,
            &labels,
            img,
            &f,
            pp,
            &mut self.memo,
            Some(&open),
        )?;
        let floor = (img.max() * crate::decomposition::SHADING_FLOOR).max(f32::MIN_POSITIVE);
        let mut added = 0;
        for i in 0..state.len() {
            let l = prop.labels.data[i];
            if state.source[i] != PixelSource::Unassigned || l == crate::Labels::NONE {
                continue;
            }
            // Grey shading fitting I ≈ R̂ S in least squares; R = I / S keeps R × S = I.
            let (rh, px) = (prop.reflectance.rgb(i), img.rgb(i));
            let num: f32 = (0..3).map(|c| px[c] * rh[c]).sum();
            let den: f32 = rh.iter().map(|v| v * v).sum();
            let s = if den > 0.0 { num / den } else { 0.0 };
            state.shading[i] = if s.is_finite() { s.max(floor) } else { floor };
            state.labels[i] = l;
            state.source[i] = PixelSource::Propagation;
            added += 1;
        }
        self.stats[to].propagate_ms += ms(t0);
        Ok(added)
    }

    /// Step 8's single-image shading of every frame, cached in the scratch folder (a frame
    /// already cached is skipped). The frames are independent, so they run as many at a time
    /// as there are threads: after the first pass the propagation decides only a few percent
    /// of each frame and leaves a core idle, and one decomposition (its solve is serial) keeps
    /// about one core busy. `bench --video` (800×600, 100 frames): 64.6–67.6 s, against
    /// 67.3–70.0 s with one frame at a time beside the third pass's propagation.
    /// Returns the wall time in milliseconds (0 when step 8 is off or does not blend).
    pub fn cache_views(&mut self, progress: ProgressFn) -> Result<f64> {
        let Some(fusion) = self.params.fusion.as_ref().filter(|f| f.blends()) else {
            return Ok(0.0);
        };
        let t_start = Instant::now();
        let n = self.source.len();
        let (source, scratch) = (self.source, &self.scratch);
        let missing = |t: usize| {
            (fusion.uses_view() && !scratch.has_member_shading(Member::View, t))
                || (fusion.uses_clustering() && !scratch.has_member_shading(Member::Clustering, t))
        };
        let frames: Vec<usize> = (0..n).filter(|&t| missing(t)).collect();
        let batch = rayon::current_num_threads().max(1);
        for (done, chunk) in frames.chunks(batch).enumerate() {
            let took: Vec<Result<f64>> = chunk
                .par_iter()
                .map(|&t| {
                    let img = source.frame(t)?;
                    let t0 = Instant::now();
                    let m = members(&img, fusion)?;
                    for (kind, shading) in
                        [(Member::View, m.view), (Member::Clustering, m.clustering)]
                    {
                        if let Some(shading) = shading {
                            scratch.save_member_shading(kind, t, img.dims(), &shading)?;
                        }
                    }
                    Ok(ms(t0))
                })
                .collect();
            for (&t, took_ms) in chunk.iter().zip(took) {
                self.stats[t].view_ms += took_ms?;
            }
            progress(Progress {
                stage: VIEW_STAGE,
                fraction: stage_fraction(
                    VIEWS,
                    ((done + 1) * batch).min(frames.len()) as f32 / frames.len() as f32,
                ),
            });
        }
        Ok(ms(t_start))
    }

    /// One forward pass (`pass` = 0, 1, 2): frames 1..n in order; see the module docs.
    pub fn forward_pass(&mut self, pass: usize, progress: ProgressFn) -> Result<()> {
        let n = self.source.len();
        let pp = self.pass_params(pass);
        let mut prev_img = self.source.frame(0)?;
        let mut prev = self.scratch.load_state(0, self.dims())?;
        let mut last_stop = 0;
        let mut next_img = if n > 1 {
            Some(self.source.frame(1)?)
        } else {
            None
        };
        if let Some(img1) = next_img
            .as_ref()
            .filter(|_| !self.scratch.has_flow(0, true))
        {
            // Frame 1's flow has nothing to overlap with (later passes find it cached).
            self.flow(0, 1, &prev_img, img1)?;
        }
        for t in 1..n {
            let img = match next_img.take() {
                Some(img) => img,
                None => self.source.frame(t)?,
            };
            // The flow t → t + 1 depends on the frames alone: computed on the other core
            // while this frame is propagated and completed (the two use one core each for
            // much of their time), then cached for `propagate_into` at t + 1.
            next_img = if t + 1 < n {
                Some(self.source.frame(t + 1)?)
            } else {
                None
            };
            let prefetch = next_img.as_ref().filter(|_| {
                !self.params.ablation.no_optical_flow && !self.scratch.has_flow(t, true)
            });
            let flow_params = self.params.flow.clone();
            let (ahead, this) = rayon::join(
                || {
                    prefetch.map(|next| {
                        let t0 = Instant::now();
                        flow(&img, next, &flow_params).map(|f| (f, ms(t0)))
                    })
                },
                || self.forward_frame(t, &pp, &img, &prev, &prev_img, &mut last_stop),
            );
            let state = this?;
            if let Some(f) = ahead {
                let (f, took) = f?;
                self.scratch.save_flow(t, true, &f)?;
                self.stats[t + 1].flow_ms += took;
            }
            progress(Progress {
                stage: PASS_STAGES[pass],
                fraction: stage_fraction(pass, t as f32 / (n - 1).max(1) as f32),
            });
            prev = state;
            prev_img = img;
        }
        Ok(())
    }

    /// Frame `t` of a forward pass: propagation from `t − 1`, completion when it stops (then
    /// backward propagation); returns its state.
    fn forward_frame(
        &mut self,
        t: usize,
        pp: &PropagateParams,
        img: &Image,
        prev: &FrameState,
        prev_img: &Image,
        last_stop: &mut usize,
    ) -> Result<FrameState> {
        let dims = self.dims();
        let fresh = !self.scratch.has_state(t);
        if fresh && is_black(img) {
            // A black frame (a cut or fade through black) has nothing to propagate into or
            // complete: it stays black, and no cluster of black pixels enters the tables,
            // where it would catch the dark colours of later frames.
            let state = FrameState::black(dims.0, dims.1);
            self.scratch.save_state(t, &state)?;
            return Ok(state);
        }
        let mut state = self.scratch.load_state(t, dims)?;
        if state.unassigned() > 0 {
            let from = Side {
                index: t - 1,
                state: prev,
                img: prev_img,
            };
            self.propagate_into(from, t, &mut state, img, pp)?;
            let hole = if self.params.ablation.complete_every_frame {
                Some(
                    state
                        .source
                        .iter()
                        .map(|&s| s == PixelSource::Unassigned)
                        .collect(),
                )
            } else {
                stop_region(&state.assigned_mask(), pp.m, pp.alpha)?
            };
            if let Some(hole) = hole {
                let t0 = Instant::now();
                complete_frame(img, &mut state, &hole, &mut self.tables, self.params)?;
                self.stats[t].complete_ms += ms(t0);
                self.stats[t].completion_passes += 1;
                self.stopping.push(t);
                self.scratch.save_state(t, &state)?;
                self.backward_from(t, *last_stop, img, &state, pp)?;
                *last_stop = t;
            } else {
                self.scratch.save_state(t, &state)?;
            }
        } else if fresh {
            self.scratch.save_state(t, &state)?;
        }
        Ok(state)
    }

    /// Backward propagation after the completion of stopping frame `ts` (§3.6): the clusters
    /// of `ts` are carried to `ts − 1`, `ts − 2`, … into their unassigned pixels, down to the
    /// frame after the previous stopping frame `stop_at` of this pass, and no further than a
    /// frame that gains no pixel.
    fn backward_from(
        &mut self,
        ts: usize,
        stop_at: usize,
        img: &Image,
        state: &FrameState,
        pp: &PropagateParams,
    ) -> Result<()> {
        let dims = self.dims();
        let mut next_img = img.clone();
        let mut next = state.clone();
        for t in (stop_at + 1..ts).rev() {
            let mut cur = self.scratch.load_state(t, dims)?;
            if cur.unassigned() == 0 {
                break;
            }
            let cur_img = self.source.frame(t)?;
            let from = Side {
                index: t + 1,
                state: &next,
                img: &next_img,
            };
            let added = self.propagate_into(from, t, &mut cur, &cur_img, pp)?;
            if added == 0 {
                break;
            }
            self.scratch.save_state(t, &cur)?;
            next = cur;
            next_img = cur_img;
        }
        Ok(())
    }
}

/// The pixels to complete at a stopping frame: the unassigned pixels of every `m×m` window
/// (inside the frame, clipped to it when the frame is smaller) in which more than the fraction
/// `alpha` is unassigned, i.e. the windows that make [`should_stop`] true; `None` when there
/// is no such window.
pub(crate) fn stop_region(assigned: &Mask, m: u32, alpha: f64) -> Result<Option<Vec<bool>>> {
    if !should_stop(assigned, m, alpha)? {
        return Ok(None);
    }
    let (w, h) = (assigned.dims().0 as usize, assigned.dims().1 as usize);
    let (mw, mh) = ((m as usize).min(w), (m as usize).min(h));
    let data = assigned.data();
    let integral = |value: &dyn Fn(usize) -> u32| {
        let stride = w + 1;
        let mut sat = vec![0u32; stride * (h + 1)];
        for y in 0..h {
            let mut row = 0u32;
            for x in 0..w {
                row += value(y * w + x);
                sat[(y + 1) * stride + x + 1] = sat[y * stride + x + 1] + row;
            }
        }
        move |x0: usize, y0: usize, x1: usize, y1: usize| {
            sat[y1 * stride + x1] + sat[y0 * stride + x0]
                - sat[y0 * stride + x1]
                - sat[y1 * stride + x0]
        }
    };
    // Windows by their top-left corner, then every pixel that some triggering window covers.
    let unassigned = integral(&|i| u32::from(!data[i]));
    let limit = alpha * (mw * mh) as f64;
    let mut trigger = vec![false; w * h];
    for y in 0..=h - mh {
        for x in 0..=w - mw {
            trigger[y * w + x] = unassigned(x, y, x + mw, y + mh) as f64 > limit;
        }
    }
    let triggers = integral(&|i| u32::from(trigger[i]));
    let mut hole = vec![false; w * h];
    for y in 0..h {
        for x in 0..w {
            let (x0, y0) = ((x + 1).saturating_sub(mw), (y + 1).saturating_sub(mh));
            hole[y * w + x] = !data[y * w + x] && triggers(x0, y0, x + 1, y + 1) > 0;
        }
    }
    Ok(Some(hole))
}

const PASS_STAGES: [&str; 3] = ["pass 1 (M = 30)", "pass 2 (M = 20)", "pass 3 (M = 10)"];
/// The progress stage of step 8's single-image decompositions ([`Run::cache_views`]).
const VIEW_STAGE: &str = "single-image decompositions";
/// The stage index of [`Run::cache_views`] in [`stage_fraction`], after the three passes.
const VIEWS: usize = 3;

/// Share of the progress bar after `done` of stage `stage` (the passes 0, 1, 2, then
/// [`VIEWS`]); they share what the first frame and the output leave, in proportion to their
/// time in `bench --video` (the first pass computes the flows).
pub(crate) fn stage_fraction(stage: usize, done: f32) -> f32 {
    let span = 1.0 - FIRST_FRAME_SHARE - OUTPUT_SHARE;
    let (start, width) = match stage {
        0 => (0.0, 0.6),
        1 => (0.6, 0.15),
        2 => (0.75, 0.05),
        _ => (0.8, 0.2),
    };
    FIRST_FRAME_SHARE + span * (start + width * done)
}

/// The share of the progress bar given to the residual fill and the output.
pub(crate) const OUTPUT_SHARE: f32 = 0.1;
