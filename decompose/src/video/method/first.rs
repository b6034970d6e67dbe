//! Steps 1 and 2 on the first frame: the Retinex of Zhao et al. with the user's strokes and
//! local-threshold masks (§3.4), then the reflectance clusters and their tables `𝓡_k`, `𝓘_k`.

use crate::error::Result;
use crate::image::Image;
use crate::progress::{Progress, ProgressFn};
use crate::retinex::{self, Strokes};
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
