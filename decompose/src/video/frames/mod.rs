//! The input of `decompose video INPUT`: a folder of frames or a video file, read one frame at
//! a time.
//!
//! - A **folder**: every PNG, JPEG or TIFF file in it (hidden files and sub-folders aside), in
//!   natural order of the names (`frame2.png` before `frame10.png`, as file managers sort).
//! - A **file**: a video, decoded by the system's `ffmpeg` into a scratch folder of lossless
//!   PNG frames when it is opened (see the `ffmpeg` submodule), then read like a folder.
//!
//! [`FrameSource::open`] lists the frames and reads every frame's header, so that a frame of
//! another size or with an unreadable header is reported before any work starts;
//! [`FrameSource::frame`] decodes one frame from disk each time it is called, so memory holds
//! only the frames the caller keeps, whatever the length of the video. Frames are converted
//! to linear RGB by [`crate::io`] with the same [`LoadOptions`] as single images (`--linear`).
//! Every error names the frame: its index and its file.

mod ffmpeg;
#[cfg(test)]
mod tests;

use std::path::{Path, PathBuf};

use image::ImageReader;

use crate::error::{Error, Result};
use crate::image::Image;
use crate::io::{LoadOptions, load_rgb};
use crate::lightfield::io::natural_cmp;

/// File extensions taken as frames in a folder (compared in lower case).
pub const FRAME_EXTENSIONS: [&str; 5] = ["png", "jpg", "jpeg", "tif", "tiff"];

/// A frame whose brightest channel is at most this is black: it holds nothing to decompose (a
/// fade, black leader, a cut through black). The single-image methods refuse such an image
/// ([`Error::AllBlack`]) with the same threshold; the video method and the per-frame
/// baselines output it black.
pub const BLACK_LEVEL: f32 = 1e-6;

/// Whether `frame` is black ([`BLACK_LEVEL`]).
pub fn is_black(frame: &Image) -> bool {
    frame.max() <= BLACK_LEVEL
}

/// How to open a frame source.
#[derive(Clone, Debug)]
pub struct FrameOptions {
    /// How frame files are decoded (sRGB or linear, size limit), as for single images.
    pub load: LoadOptions,
    /// The program that decodes video files. Default `ffmpeg` (looked up on `PATH`).
    pub ffmpeg: PathBuf,
    /// Where a video's decoded frames go; a fresh sub-folder is made there and deleted when
    /// the source is dropped. Default: the system's temporary folder.
    pub scratch: Option<PathBuf>,
}

impl Default for FrameOptions {
    fn default() -> Self {
        Self {
            load: LoadOptions::default(),
            ffmpeg: PathBuf::from("ffmpeg"),
            scratch: None,
        }
    }
}

/// A sequence of equally sized frames on disk, decoded on demand.
#[derive(Debug)]
pub struct FrameSource {
    input: PathBuf,
    paths: Vec<PathBuf>,
    size: (u32, u32),
    load: LoadOptions,
    /// The decoded frames of a video; deleted on drop (declared last: dropped last).
    scratch: Option<ffmpeg::ScratchDir>,
}

impl FrameSource {
    /// Opens a folder of frames or a video file (anything that is not a folder is given to
    /// `ffmpeg`). Errors: [`Error::NoFrames`] for a folder without image files,
    /// [`Error::Frame`] for a frame whose header cannot be read, [`Error::FrameSize`] for a
    /// frame of another size than frame 0, [`Error::Ffmpeg`] when ffmpeg cannot decode the file
    /// and [`Error::MissingProgram`] when ffmpeg is not installed.
    pub fn open(path: impl AsRef<Path>, opts: &FrameOptions) -> Result<Self> {
        let input = path.as_ref().to_path_buf();
        let meta = std::fs::metadata(&input).map_err(|source| Error::Io {
            path: input.clone(),
            source,
        })?;
        let (dir, scratch) = if meta.is_dir() {
            (input.clone(), None)
        } else {
            let base = opts.scratch.clone().unwrap_or_else(std::env::temp_dir);
            let scratch = ffmpeg::ScratchDir::new(&base)?;
            ffmpeg::decode_to_folder(&opts.ffmpeg, &input, scratch.path())?;
            (scratch.path().to_path_buf(), Some(scratch))
        };
        let paths = list_frames(&dir)?;
        if paths.is_empty() {
            return Err(match scratch {
                Some(_) => Error::Ffmpeg {
                    path: input,
                    message: "the video decoded to no frames".into(),
                },
                None => Error::NoFrames { path: input },
            });
        }
        let mut size = (0, 0);
        for (index, p) in paths.iter().enumerate() {
            let got = header_size(p).map_err(|e| frame_error(index, p, e))?;
            if index == 0 {
                size = got;
            } else if got != size {
                return Err(Error::FrameSize {
                    index,
                    path: p.clone(),
                    expected: size,
                    got,
                });
            }
        }
        Ok(Self {
            input,
            paths,
            size,
            load: opts.load,
            scratch,
        })
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.paths.len()
    }

    /// Never true: opening fails on a sequence without frames.
    pub fn is_empty(&self) -> bool {
        self.paths.is_empty()
    }

    /// (width, height) of every frame.
    pub fn size(&self) -> (u32, u32) {
        self.size
    }

    /// The folder or video file this source was opened from.
    pub fn input(&self) -> &Path {
        &self.input
    }

    /// Whether the input is a video file (decoded into a scratch folder).
    pub fn is_video(&self) -> bool {
        self.scratch.is_some()
    }

    /// The file behind frame `index` (in the scratch folder for a video).
    ///
    /// # Panics
    /// When `index >= self.len()`.
    pub fn path(&self, index: usize) -> &Path {
        &self.paths[index]
    }

    /// Reads frame `index` from disk as linear RGB. Each call decodes the file again: keep the
    /// frames you need. Errors name the frame: [`Error::Frame`] (unreadable, with the cause)
    /// and [`Error::FrameSize`] (the file changed size since opening).
    pub fn frame(&self, index: usize) -> Result<Image> {
        let Some(p) = self.paths.get(index) else {
            return Err(Error::InvalidParam {
                name: "frame",
                value: index.to_string(),
                reason: "is past the last frame",
            });
        };
        let img = load_rgb(p, self.load).map_err(|e| frame_error(index, p, e))?;
        if img.dims() != self.size {
            return Err(Error::FrameSize {
                index,
                path: p.clone(),
                expected: self.size,
                got: img.dims(),
            });
        }
        Ok(img)
    }

    /// The frames in order, each read when the iterator reaches it.
    pub fn iter(&self) -> impl Iterator<Item = Result<Image>> + '_ {
        (0..self.len()).map(|i| self.frame(i))
    }
}

fn frame_error(index: usize, path: &Path, source: Error) -> Error {
    Error::Frame {
        index,
        path: path.to_path_buf(),
        source: Box::new(source),
    }
}

/// Width and height from the file's header only.
fn header_size(path: &Path) -> Result<(u32, u32)> {
    let codec = |e: &dyn std::fmt::Display| Error::Codec {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let reader = ImageReader::open(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let reader = reader.with_guessed_format().map_err(|e| codec(&e))?;
    reader.into_dimensions().map_err(|e| codec(&e))
}

/// The frame files of `dir`, in natural order of their names.
fn list_frames(dir: &Path) -> Result<Vec<PathBuf>> {
    let io = |source| Error::Io {
        path: dir.to_path_buf(),
        source,
    };
    let mut names = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(io)? {
        let entry = entry.map_err(io)?;
        let name = entry.file_name().to_string_lossy().into_owned();
        let ext = Path::new(&name)
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        let is_frame = ext.is_some_and(|e| FRAME_EXTENSIONS.contains(&e.as_str()));
        if is_frame && !name.starts_with('.') && entry.path().is_file() {
            names.push(name);
        }
    }
    names.sort_by(|a, b| natural_cmp(a, b));
    Ok(names.into_iter().map(|n| dir.join(n)).collect())
}
