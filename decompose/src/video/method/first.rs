//! Steps 1 and 2 on the first frame: the Retinex of Zhao et al. with the user's strokes and
//! local-threshold masks (§3.4), then the reflectance clusters and their tables `𝓡_k`, `𝓘_k`.
//!
//! "The first frame" is the first frame with light ([`first_lit_frame`]): a video that fades
//! in from black, or opens on black leader, starts its decomposition at its first lit frame;
//! the black frames before it are output black ([`FrameState::black`]).

use crate::error::{Error, Result};
use crate::image::Image;
use crate::progress::{Progress, ProgressFn};
use crate::retinex::{self, Strokes};
use crate::video::frames::{FrameSource, is_black};
use crate::video::propagate::ClusterTables;
use crate::video::segment::reflectance_clusters;

use super::VideoParams;
use super::state::{FrameState, PixelSource};

/// The first frame's state (every pixel counted as [`PixelSource::Completion`]) and the tables.
pub(crate) fn first_frame(
    input: &Image,
    strokes: &Strokes,
    params: &VideoParams,
    progress: ProgressFn,
) -> Result<(FrameState, ClusterTables)> {
    let (d, _) = retinex::decompose(input, None, strokes, &params.retinex, &mut |p| {
        progress(Progress {
            stage: "first frame",
            fraction: p.fraction * FIRST_FRAME_SHARE,
        })
    })?;
    let clusters = reflectance_clusters(&d.reflectance, &params.segment, &params.merge)?;
    let tables = ClusterTables::from_frame(input, &d.reflectance, &clusters)?;
    let (w, h) = input.dims();
    let n = input.len();
    let state = FrameState {
        width: w,
        height: h,
        labels: clusters.data,
        source: vec![PixelSource::Completion; n],
        shading: d.shading.into_vec(),
    };
    Ok((state, tables))
}

/// The share of the progress bar given to the first frame.
pub(crate) const FIRST_FRAME_SHARE: f32 = 0.05;

/// The index and image of the first frame of `source` that is not black; frames are read in
/// order until one is found, so an ordinary video reads only frame 0.
/// [`Error::AllFramesBlack`] when every frame is black.
pub(crate) fn first_lit_frame(source: &FrameSource) -> Result<(usize, Image)> {
    for t in 0..source.len() {
        let img = source.frame(t)?;
        if !is_black(&img) {
            return Ok((t, img));
        }
    }
    Err(Error::AllFramesBlack {
        path: source.input().to_path_buf(),
        frames: source.len(),
    })
}
