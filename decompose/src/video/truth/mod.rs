//! Ground truth for `decompose eval-video --truth DIR` (issue 20): a sequence folder with the
//! input frames, their exact reflectance and shading, and optionally the exact optical flow.
//!
//! ```text
//! SEQ/input/000000.png …        linear 16-bit RGB input, = reflectance × shading
//! SEQ/reflectance/000000.png …  linear 16-bit RGB reflectance
//! SEQ/shading/000000.png …      linear 16-bit grey shading
//! SEQ/flow/000000.flo …         optional: Middlebury .flo, frame t to t + 1 (one fewer file)
//! SEQ/sequence.json             optional: frames, width, height, seed, split, what moves, …
//! ```
//!
//! Frames are matched by name: `reflectance/` and `shading/` hold a file of the same name as
//! every input frame, and `flow/` a `.flo` file with the same stem for every frame but the
//! last. The flow follows the convention of [`crate::video::flow`]:
//! `next(x + u, y + v) ≈ prev(x, y)`, unknown vectors (occluded in frame t + 1 or leaving the
//! frame) hold [`UNKNOWN_FLOW`] (see [`is_known`]). `scripts/render_video.py` writes this
//! layout; `docs/video-data.md` describes the rendered sequences.
//!
//! [`load_truth`] checks the whole layout from the file names and headers (every missing
//! file, size mismatch or malformed `.flo` header is reported by path before any pixel is
//! read); the frames themselves are decoded when asked for, one at a time, so memory does not
//! grow with the length of the sequence.

mod flo;
#[cfg(test)]
mod tests;

use std::path::{Path, PathBuf};

use serde::Deserialize;

use crate::error::{Error, Result};
use crate::image::Image;
use crate::io::{LoadOptions, load_gray, load_rgb};
use crate::video::flow::Flow;
use crate::video::frames::{FrameOptions, FrameSource};

pub use flo::{FLO_MAGIC, UNKNOWN_FLOW, UNKNOWN_FLOW_THRESHOLD, is_known, read_flo, write_flo};

/// What `sequence.json` says about a rendered sequence (fields the reader does not know are
/// ignored; see `docs/video-data.md` for all of them).
#[derive(Clone, Debug, Deserialize, PartialEq)]
pub struct SequenceInfo {
    /// Number of frames.
    pub frames: usize,
    /// Frame width, pixels.
    pub width: u32,
    /// Frame height, pixels.
    pub height: u32,
    /// The scene's seed.
    #[serde(default)]
    pub seed: Option<u64>,
    /// `tune`, `test` or `fixture`.
    #[serde(default)]
    pub split: Option<String>,
    /// `camera`, `light` or `object`: what moves.
    #[serde(default)]
    pub motion: Option<String>,
    /// The same in words.
    #[serde(default)]
    pub what_moves: Option<String>,
}

/// A sequence with ground truth, checked but not yet decoded (see the module docs).
#[derive(Debug)]
pub struct VideoTruth {
    dir: PathBuf,
    input: FrameSource,
    names: Vec<String>,
    flow: Option<Vec<PathBuf>>,
    info: Option<SequenceInfo>,
}

/// Linear decoding: every file of the layout holds linear values.
const LINEAR: LoadOptions = LoadOptions {
    linear: true,
    max_pixels: crate::io::DEFAULT_MAX_PIXELS,
};

/// Opens a sequence folder in the layout of the module docs and checks it: errors are
/// [`Error::NoFrames`] (no input frame), [`Error::Frame`] naming a missing reflectance,
/// shading or flow file (with the index of its frame), [`Error::FrameSize`] naming a frame
/// or flow file of another size than input frame 0, [`Error::Format`] for a malformed
/// `sequence.json`, a `.flo` header that is not one, a `flow/` folder with extra files, or a
/// `sequence.json` that disagrees with the frames.
pub fn load_truth(dir: impl AsRef<Path>) -> Result<VideoTruth> {
    let dir = dir.as_ref().to_path_buf();
    let opts = FrameOptions {
        load: LINEAR,
        ..Default::default()
    };
    let input_dir = dir.join("input");
    if !input_dir.is_dir() {
        return Err(Error::NoFrames { path: input_dir });
    }
    let input = FrameSource::open(&input_dir, &opts)?;
    let names: Vec<String> = (0..input.len())
        .map(|i| {
            input
                .path(i)
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default()
        })
        .collect();
    let size = input.size();
    for sub in ["reflectance", "shading"] {
        for (index, name) in names.iter().enumerate() {
            let path = dir.join(sub).join(name);
            check_size(index, &path, size, header_size(&path))?;
        }
    }
    let flow_dir = dir.join("flow");
    let flow = if flow_dir.is_dir() {
        let paths: Vec<PathBuf> = names[..names.len() - 1]
            .iter()
            .map(|n| flow_dir.join(Path::new(n).with_extension("flo")))
            .collect();
        for (index, path) in paths.iter().enumerate() {
            check_size(index, path, size, flo::read_flo_size(path))?;
        }
        let files = std::fs::read_dir(&flow_dir)
            .map_err(|source| Error::Io {
                path: flow_dir.clone(),
                source,
            })?
            .filter_map(|e| e.ok())
            .filter(|e| e.path().extension().is_some_and(|x| x == "flo"))
            .count();
        if files != paths.len() {
            return Err(Error::Format {
                path: flow_dir,
                message: format!(
                    "holds {files} .flo files; {} frames need {} (one per frame but the last, \
                     named as the frames)",
                    names.len(),
                    paths.len()
                ),
            });
        }
        Some(paths)
    } else {
        None
    };
    let json = dir.join("sequence.json");
    let info = if json.is_file() {
        let text = std::fs::read_to_string(&json).map_err(|source| Error::Io {
            path: json.clone(),
            source,
        })?;
        let info: SequenceInfo = serde_json::from_str(&text).map_err(|e| Error::Format {
            path: json.clone(),
            message: e.to_string(),
        })?;
        if info.frames != names.len() || (info.width, info.height) != size {
            return Err(Error::Format {
                path: json,
                message: format!(
                    "says {} frames of {}x{}, input/ holds {} of {}x{}",
                    info.frames,
                    info.width,
                    info.height,
                    names.len(),
                    size.0,
                    size.1
                ),
            });
        }
        Some(info)
    } else {
        None
    };
    Ok(VideoTruth {
        dir,
        input,
        names,
        flow,
        info,
    })
}

fn header_size(path: &Path) -> Result<(u32, u32)> {
    image::image_dimensions(path).map_err(|e| match e {
        image::ImageError::IoError(source) => Error::Io {
            path: path.to_path_buf(),
            source,
        },
        e => Error::Codec {
            path: path.to_path_buf(),
            message: e.to_string(),
        },
    })
}

/// Wraps a header read: a failure becomes [`Error::Frame`] naming the file, another size
/// [`Error::FrameSize`].
fn check_size(
    index: usize,
    path: &Path,
    expected: (u32, u32),
    got: Result<(u32, u32)>,
) -> Result<()> {
    let got = got.map_err(|e| Error::Frame {
        index,
        path: path.to_path_buf(),
        source: Box::new(e),
    })?;
    if got != expected {
        return Err(Error::FrameSize {
            index,
            path: path.to_path_buf(),
            expected,
            got,
        });
    }
    Ok(())
}

impl VideoTruth {
    /// The sequence folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.names.len()
    }

    /// Never true: [`load_truth`] fails without frames.
    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }

    /// (width, height) of every frame.
    pub fn size(&self) -> (u32, u32) {
        self.input.size()
    }

    /// File name of frame `index` (the same in `input/`, `reflectance/` and `shading/`).
    ///
    /// # Panics
    /// When `index >= self.len()`.
    pub fn name(&self, index: usize) -> &str {
        &self.names[index]
    }

    /// `sequence.json`, when the folder has one.
    pub fn info(&self) -> Option<&SequenceInfo> {
        self.info.as_ref()
    }

    /// The input frames as a [`FrameSource`] (linear decoding), e.g. for the video pipeline.
    pub fn input_frames(&self) -> &FrameSource {
        &self.input
    }

    /// Input frame `index`, linear RGB.
    pub fn input(&self, index: usize) -> Result<Image> {
        self.input.frame(index)
    }

    /// Reflectance of frame `index`, linear RGB.
    pub fn reflectance(&self, index: usize) -> Result<Image> {
        self.read(index, "reflectance", |p| load_rgb(p, LINEAR))
    }

    /// Shading of frame `index`, linear, one channel (a colour file is averaged).
    pub fn shading(&self, index: usize) -> Result<Image> {
        self.read(index, "shading", |p| load_gray(p, LINEAR))
    }

    /// Whether the folder has a `flow/` folder.
    pub fn has_flow(&self) -> bool {
        self.flow.is_some()
    }

    /// The true flow from frame `index` to frame `index + 1`, unknown vectors included (see
    /// [`is_known`]). Errors with [`Error::InvalidParam`] when the folder has no flow or
    /// `index + 1` is past the last frame, [`Error::Frame`] when the file cannot be read.
    pub fn flow(&self, index: usize) -> Result<Flow> {
        let Some(paths) = &self.flow else {
            return Err(Error::param(
                "flow",
                index,
                "the sequence has no flow/ folder",
            ));
        };
        let Some(path) = paths.get(index) else {
            return Err(Error::param(
                "flow",
                index,
                "is past the last pair of frames",
            ));
        };
        let flow = read_flo(path).map_err(|e| Error::Frame {
            index,
            path: path.clone(),
            source: Box::new(e),
        })?;
        check_size(index, path, self.size(), Ok(flow.dims()))?;
        Ok(flow)
    }

    fn read(
        &self,
        index: usize,
        sub: &str,
        load: impl Fn(&Path) -> Result<Image>,
    ) -> Result<Image> {
        let Some(name) = self.names.get(index) else {
            return Err(Error::param("frame", index, "is past the last frame"));
        };
        let path = self.dir.join(sub).join(name);
        let img = load(&path).map_err(|e| Error::Frame {
            index,
            path: path.clone(),
            source: Box::new(e),
        })?;
        check_size(index, &path, self.size(), Ok(img.dims()))?;
        Ok(img)
    }
}

/// Which pixels of a flow are known ([`is_known`]), row-major.
pub fn known_mask(flow: &Flow) -> Vec<bool> {
    flow.u()
        .iter()
        .zip(flow.v())
        .map(|(&u, &v)| is_known(u, v))
        .collect()
}

/// Mean endpoint error `mean ‖estimate − truth‖` over the pixels where `truth` is known, and
/// how many pixels that is (the mean is 0 when none is). Errors with
/// [`Error::ShapeMismatch`] when the flows differ in size.
pub fn known_endpoint_error(estimate: &Flow, truth: &Flow) -> Result<(f64, usize)> {
    if estimate.dims() != truth.dims() {
        return Err(Error::ShapeMismatch {
            expected: truth.dims(),
            got: estimate.dims(),
        });
    }
    let (mut sum, mut n) = (0.0f64, 0usize);
    for i in 0..truth.u().len() {
        let (tu, tv) = (truth.u()[i], truth.v()[i]);
        if is_known(tu, tv) {
            let du = (estimate.u()[i] - tu) as f64;
            let dv = (estimate.v()[i] - tv) as f64;
            sum += du.hypot(dv);
            n += 1;
        }
    }
    Ok((if n == 0 { 0.0 } else { sum / n as f64 }, n))
}
