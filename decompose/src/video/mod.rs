//! Intrinsic video (Ye, Garces, Liu, Dai & Gutierrez, "Intrinsic Video and Applications",
//! SIGGRAPH 2014; thesis ch. 3, Algorithm 1).
//!
//! Decomposing every frame on its own flickers. The method decomposes the first frame only
//! (the Retinex of [`crate::retinex`]), groups its reflectance into clusters, and carries the
//! clusters forward along the optical flow; pixels the propagation cannot assign with
//! confidence are completed by a local decomposition, and the video is walked forwards and
//! backwards so that every pixel ends up assigned once. The pieces, each a module of its own:
//!
//! - [`frames`]: the input, a folder of frames or a video file decoded by the system's
//!   `ffmpeg`, read lazily one frame at a time so that memory does not grow with the length
//!   (backward passes re-read frames from disk);
//! - [`segment`]: step 2, the reflectance clusters of the first frame: Felzenszwalb–Huttenlocher
//!   graph segmentation (σ = 0.8, K = 50, min = 256, §3.4) and the merge of adjacent segments
//!   by mean colour;
//! - [`flow`]: step 3, coarse-to-fine TV-L1 optical flow between consecutive frames (Zach,
//!   Pock & Bischof 2007, with the IPOL 2013 defaults);
//! - [`propagate`]: steps 4 and 5, the cluster tables `𝓡_k`, `𝓘_k` (§3.4), the
//!   high-confidence MAP propagation of the clusters along the flow (§3.5.1–3.5.2) and the
//!   stopping condition (§3.5.3).
//! - [`edit`]: the applications (§3.8): segmentation, recolouring, colour transfer,
//!   stylisation and material editing, each decided once and applied to every frame through
//!   the cluster labels;
//! - [`truth`]: the evaluation's ground truth, a sequence folder with `input/`,
//!   `reflectance/`, `shading/` frames and the exact flow as Middlebury `.flo` files
//!   (rendered by `scripts/render_video.py`, described in `docs/video-data.md`), read lazily;
//! - [`method`]: the whole method, [`method::decompose_video`]: the first frame's Retinex and
//!   clusters, forward propagation with the stopping condition over three passes (`M` = 30,
//!   20, 10), completion of stopping frames (eqs. 3.8–3.10) with backward propagation, and the
//!   residual Laplace fill (eq. 3.11), with per-frame state in a scratch folder.
//! - [`score`]: the evaluation's figures, per-frame LMSE and temporal flicker (the mean
//!   absolute change of log grey reflectance along the flow);
//! - [`labels_io`]: cluster ids as lossless 16-bit PNG files (`decompose video`'s `labels/`);
//! - [`baseline`]: the per-frame methods the evaluation compares against (Zhao et al. Retinex
//!   and the clustering method of ch. 2 on every frame alone).

pub mod baseline;
pub mod edit;
pub mod flow;
pub mod frames;
pub mod labels_io;
pub mod method;
pub mod propagate;
pub mod score;
pub mod segment;
pub mod truth;
