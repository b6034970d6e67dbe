//! Per-frame baselines for the intrinsic-video evaluation (issue 20): every frame decomposed on
//! its own, with no temporal coherence, by one of the single-image methods:
//!
//! - [`PerFrameMethod::Retinex`]: the closed-form Retinex of Zhao et al. ([`crate::retinex`],
//!   the method the video pipeline uses on its first frame), without strokes;
//! - [`PerFrameMethod::Clustering`]: the clustering method of thesis ch. 2
//!   ([`crate::clustering`]), as `decompose image` runs it (default parameters, seed 0).
//!
//! Frames are read from the [`FrameSource`] one at a time and handed to a callback in order,
//! as the video method hands its results to a frame sink, so memory holds one frame whatever
//! the length. These are what flickers: each frame's decomposition picks its own scale and its
//! own clusters.

use std::time::Instant;

use crate::clustering::{self, ClusteringParams};
use crate::decomposition::{Decomposition, Labels};
use crate::error::{Error, Result};
use crate::image::Image;
use crate::progress::{Progress, ProgressFn};
use crate::retinex::{self, RetinexParams, Strokes};
use crate::video::frames::{FrameSource, is_black};

/// Which single-image method decomposes every frame.
#[derive(Clone, Debug, PartialEq)]
pub enum PerFrameMethod {
    /// Zhao et al. Retinex on every frame (no strokes).
    Retinex(RetinexParams),
    /// The clustering method (thesis ch. 2) on every frame.
    Clustering(ClusteringParams),
}

impl PerFrameMethod {
    /// Per-frame Retinex with the thesis' parameters.
    pub fn retinex() -> Self {
        Self::Retinex(RetinexParams::default())
    }

    /// Per-frame clustering with the thesis' parameters (those of `decompose image`).
    pub fn clustering() -> Self {
        Self::Clustering(ClusteringParams::default())
    }

    /// A short name: `retinex` or `clustering`.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Retinex(_) => "retinex",
            Self::Clustering(_) => "clustering",
        }
    }

    /// Decomposes one image (linear RGB) with this method; the clusters for clustering. A
    /// black frame ([`is_black`]: a fade, a cut through black) has nothing to decompose and
    /// comes out black, reflectance and shading 0 (and no cluster), as in the video method.
    pub fn decompose(
        &self,
        frame: &crate::image::Image,
    ) -> Result<(Decomposition, Option<Labels>)> {
        if is_black(frame) {
            let (w, h) = frame.dims();
            let black = Decomposition {
                reflectance: Image::new(w, h, 3),
                shading: Image::new(w, h, 1),
            };
            let labels = matches!(self, Self::Clustering(_)).then(|| Labels {
                width: w,
                height: h,
                data: vec![Labels::NONE; w as usize * h as usize],
                count: 0,
            });
            return Ok((black, labels));
        }
        match self {
            Self::Retinex(p) => {
                retinex::decompose(frame, None, &Strokes::default(), p, &mut |_| {})
                    .map(|(d, _)| (d, None))
            }
            Self::Clustering(p) => clustering::decompose(frame, None, p, &mut |_| {})
                .map(|o| (o.decomposition, Some(o.clusters))),
        }
    }
}

/// One frame's per-frame result, handed to the callback of [`per_frame`].
#[derive(Debug)]
pub struct PerFrameResult<'a> {
    /// Position in the sequence, from 0.
    pub index: usize,
    /// The frame's decomposition (`reflectance × shading = frame`).
    pub decomposition: &'a Decomposition,
    /// The clusters, for the clustering method.
    pub clusters: Option<&'a Labels>,
}

/// Timings of a per-frame run.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct PerFrameStats {
    /// Method name ([`PerFrameMethod::name`]).
    pub method: &'static str,
    /// Decomposition time of every frame in milliseconds (reading the frame excluded).
    pub frame_ms: Vec<f64>,
    /// Wall time of the whole run in milliseconds, reading frames and the callback included.
    pub total_ms: f64,
}

/// Decomposes the first `count` frames of `source` (every frame when `count` is larger) each
/// on its own with `method` and hands each result to `each`, in order. Errors: the source's
/// [`Error::Frame`] for an unreadable frame, a method's error wrapped in [`Error::Frame`]
/// naming the frame, and whatever `each` returns.
pub fn per_frame(
    source: &FrameSource,
    count: usize,
    method: &PerFrameMethod,
    each: &mut dyn FnMut(PerFrameResult<'_>) -> Result<()>,
    progress: ProgressFn,
) -> Result<PerFrameStats> {
    let t0 = Instant::now();
    let n = source.len().min(count);
    let mut stats = PerFrameStats {
        method: method.name(),
        ..Default::default()
    };
    for index in 0..n {
        progress(Progress {
            stage: method.name(),
            fraction: index as f32 / n as f32,
        });
        let frame = source.frame(index)?;
        let t = Instant::now();
        let (d, clusters) = method.decompose(&frame).map_err(|e| Error::Frame {
            index,
            path: source.path(index).to_path_buf(),
            source: Box::new(e),
        })?;
        stats.frame_ms.push(t.elapsed().as_secs_f64() * 1e3);
        each(PerFrameResult {
            index,
            decomposition: &d,
            clusters: clusters.as_ref(),
        })?;
    }
    progress(Progress {
        stage: method.name(),
        fraction: 1.0,
    });
    stats.total_ms = t0.elapsed().as_secs_f64() * 1e3;
    Ok(stats)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::{Depth, Encoding, save};
    use crate::synthetic;
    use crate::video::frames::FrameOptions;

    #[test]
    fn every_frame_is_decomposed_alone_in_order_with_an_exact_product() {
        let dir = tempfile::tempdir().unwrap();
        let mut truth = Vec::new();
        for t in 0..3u64 {
            let g = synthetic::scene(32, 24, t);
            save(
                dir.path().join(format!("f{t}.png")),
                &g.input,
                Encoding::Linear,
                Depth::Sixteen,
            )
            .unwrap();
            truth.push(g);
        }
        let opts = FrameOptions {
            load: crate::io::LoadOptions {
                linear: true,
                ..Default::default()
            },
            ..Default::default()
        };
        let source = FrameSource::open(dir.path(), &opts).unwrap();
        for method in [PerFrameMethod::retinex(), PerFrameMethod::clustering()] {
            let mut seen = Vec::new();
            let stats = per_frame(
                &source,
                usize::MAX,
                &method,
                &mut |r| {
                    let frame = source.frame(r.index)?;
                    let back = r.decomposition.reconstruct();
                    for (a, b) in back.data().iter().zip(frame.data()) {
                        assert!((a - b).abs() <= 1e-5 + 1e-4 * b.abs(), "{a} vs {b}");
                    }
                    // Each frame alone: the same as decomposing it directly.
                    let (alone, _) = method.decompose(&frame)?;
                    assert_eq!(&alone, r.decomposition);
                    assert_eq!(r.clusters.is_some(), method.name() == "clustering");
                    seen.push(r.index);
                    Ok(())
                },
                &mut |_| {},
            )
            .unwrap();
            assert_eq!(seen, vec![0, 1, 2]);
            assert_eq!(stats.frame_ms.len(), 3);
            assert_eq!(stats.method, method.name());
        }
    }

    #[test]
    fn a_black_frame_comes_out_black_with_no_cluster() {
        let black = crate::image::Image::new(8, 6, 3);
        for m in [PerFrameMethod::retinex(), PerFrameMethod::clustering()] {
            let (d, labels) = m.decompose(&black).unwrap();
            assert!(
                d.reflectance.data().iter().all(|&v| v == 0.0),
                "{}",
                m.name()
            );
            assert!(d.shading.data().iter().all(|&v| v == 0.0), "{}", m.name());
            assert_eq!(d.reflectance.channels(), 3);
            assert_eq!(d.shading.channels(), 1);
            match labels {
                Some(l) => {
                    assert_eq!(m.name(), "clustering");
                    assert!(l.data.iter().all(|&v| v == Labels::NONE));
                }
                None => assert_eq!(m.name(), "retinex"),
            }
        }
    }
}
