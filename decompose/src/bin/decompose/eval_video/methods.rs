//! The methods `eval-video` runs: the one place that knows how to run each.

use anyhow::Result;
use clap::ValueEnum;

use decompose::Image;
use decompose::retinex::Strokes;
use decompose::video::baseline::{PerFrameMethod, per_frame};
use decompose::video::flow::TvL1FlowParams;
use decompose::video::frames::FrameSource;
use decompose::video::method::{
    Ablation, BorderLevelParams, FAST_FLOW_MAX_SOLVED_PIXELS, FusionParams, VideoFrame,
    VideoParams, decompose_video,
};
use decompose::video::propagate::PropagateParams;

use crate::common::TempDir;

#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug, PartialOrd, Ord)]
pub(crate) enum VideoMethod {
    /// The intrinsic-video method (thesis ch. 3, `decompose video`).
    Ours,
    /// Zhao et al. Retinex on every frame alone.
    Retinex,
    /// The clustering method (thesis ch. 2) on every frame alone.
    Clustering,
    /// Every method above.
    All,
}

/// One method as it is run: the match in [`run_method`] is the one place that knows how.
#[derive(Clone, Debug)]
pub(super) enum Runner {
    /// The video method with these parameters, under this name.
    Ours(&'static str, Box<VideoParams>),
    PerFrame(PerFrameMethod),
}

impl Runner {
    pub(super) fn name(&self) -> String {
        match self {
            Runner::Ours(name, _) => (*name).to_string(),
            Runner::PerFrame(m) => format!("per-frame {}", m.name()),
        }
    }
}

/// The runs asked for: the methods in a fixed order, then with `ablations` the three
/// ablations of Fig. 3.11, the method without its per-frame blend (step 8), with the eighth and
/// the twelfth sessions' blends, without its border
/// levelling (the thesis' levels), without the single views' vote on those levels, with the
/// thesis' confidence test, with the faster flow (`--flow-max-pixels 262144`) and with the
/// thesis' exact colour bins.
pub(super) fn runners(methods: &[VideoMethod], ablations: bool) -> Vec<Runner> {
    let mut wanted: Vec<VideoMethod> = if methods.is_empty() || methods.contains(&VideoMethod::All)
    {
        vec![
            VideoMethod::Ours,
            VideoMethod::Retinex,
            VideoMethod::Clustering,
        ]
    } else {
        methods.to_vec()
    };
    wanted.sort();
    wanted.dedup();
    let mut runs: Vec<Runner> = wanted
        .into_iter()
        .filter_map(|m| match m {
            VideoMethod::Ours => Some(Runner::Ours("ours", Box::default())),
            VideoMethod::Retinex => Some(Runner::PerFrame(PerFrameMethod::retinex())),
            VideoMethod::Clustering => Some(Runner::PerFrame(PerFrameMethod::clustering())),
            VideoMethod::All => None,
        })
        .collect();
    if ablations {
        let with = |ablation: Ablation| {
            Box::new(VideoParams {
                ablation,
                ..Default::default()
            })
        };
        runs.extend([
            Runner::Ours(
                "ours, completion every frame",
                with(Ablation {
                    complete_every_frame: true,
                    ..Default::default()
                }),
            ),
            Runner::Ours(
                "ours, no confidence test",
                with(Ablation {
                    no_confidence_threshold: true,
                    ..Default::default()
                }),
            ),
            Runner::Ours(
                "ours, no optical flow",
                with(Ablation {
                    no_optical_flow: true,
                    ..Default::default()
                }),
            ),
            Runner::Ours(
                "ours, no per-frame blend (thesis)",
                Box::new(VideoParams {
                    fusion: None,
                    ..Default::default()
                }),
            ),
            Runner::Ours(
                "ours, no clustering member (eighth-session blend)",
                Box::new(VideoParams {
                    fusion: Some(FusionParams {
                        beta: 0.5,
                        clustering_weight: 0.0,
                        median_share: 0.0,
                        ..Default::default()
                    }),
                    ..Default::default()
                }),
            ),
            Runner::Ours(
                "ours, weighted mean of the members (twelfth-session blend)",
                Box::new(VideoParams {
                    fusion: Some(FusionParams {
                        median_share: 0.0,
                        ..Default::default()
                    }),
                    ..Default::default()
                }),
            ),
            Runner::Ours(
                "ours, first-frame levels (thesis)",
                Box::new(VideoParams {
                    levels: None,
                    ..Default::default()
                }),
            ),
            Runner::Ours(
                "ours, levels without the vote",
                Box::new(VideoParams {
                    levels: Some(BorderLevelParams {
                        view_vote: false,
                        ..Default::default()
                    }),
                    ..Default::default()
                }),
            ),
            Runner::Ours(
                "ours, thesis' ε = 0.8, β = 2",
                Box::new(VideoParams {
                    propagate: PropagateParams {
                        epsilon: PropagateParams::default().epsilon,
                        beta: PropagateParams::default().beta,
                        ..VideoParams::default().propagate
                    },
                    ..Default::default()
                }),
            ),
            Runner::Ours(
                "ours, flow solved up to 512² pixels",
                Box::new(VideoParams {
                    flow: TvL1FlowParams {
                        max_solved_pixels: Some(FAST_FLOW_MAX_SOLVED_PIXELS),
                        ..VideoParams::default().flow
                    },
                    ..Default::default()
                }),
            ),
            Runner::Ours(
                "ours, exact colour bins (thesis)",
                Box::new(VideoParams {
                    propagate: PropagateParams {
                        reflectance_radius: 0.0,
                        ..VideoParams::default().propagate
                    },
                    ..Default::default()
                }),
            ),
        ]);
    }
    runs
}

/// Runs one method on every frame of `source`, handing every frame's (reflectance, shading)
/// to `each` in order; returns the method's own time in milliseconds (scoring excluded).
pub(super) fn run_method(
    runner: &Runner,
    source: &FrameSource,
    each: &mut dyn FnMut(usize, &Image, &Image) -> Result<()>,
) -> Result<f64> {
    // `each` errors are anyhow; the library's callbacks want decompose::Error, so they are
    // parked here and re-raised after the run.
    let mut failure: Option<anyhow::Error> = None;
    let mut park = |index: usize, e: anyhow::Error| {
        failure = Some(e);
        decompose::Error::InvalidParam {
            name: "frame",
            value: index.to_string(),
            reason: "could not be scored",
        }
    };
    let result = match runner {
        Runner::Ours(_, params) => {
            let scratch = TempDir::new(&std::env::temp_dir(), "decompose-eval-video-")?;
            decompose_video(
                source,
                &Strokes::default(),
                params,
                scratch.path(),
                &mut |f: VideoFrame<'_>| {
                    each(f.index, f.reflectance, f.shading).map_err(|e| park(f.index, e))
                },
                &mut |_| {},
            )
            .map(|s| s.total_ms)
        }
        Runner::PerFrame(m) => per_frame(
            source,
            usize::MAX,
            m,
            &mut |r| {
                let d = r.decomposition;
                each(r.index, &d.reflectance, &d.shading).map_err(|e| park(r.index, e))
            },
            &mut |_| {},
        )
        .map(|s| s.frame_ms.iter().sum::<f64>()),
    };
    if let Some(e) = failure {
        return Err(e);
    }
    Ok(result?)
}
