//! The crate's single error type.

use std::path::PathBuf;

/// Everything that can go wrong in this crate. Variants carry the offending values.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or written.
    #[error("cannot access {path}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The image decoder or encoder failed (unsupported or corrupt file).
    #[error("cannot decode or encode image {path}: {message}")]
    Codec {
        /// The file (empty for in-memory data).
        path: PathBuf,
        /// The decoder's message.
        message: String,
    },
    /// An image with zero width or height.
    #[error("image has zero size ({width}x{height})")]
    EmptyImage {
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
    },
    /// An image larger than the configured limit.
    #[error("image of {width}x{height} pixels exceeds the limit of {limit} pixels")]
    TooLarge {
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
        /// The maximum number of pixels accepted.
        limit: u64,
    },
    /// A pixel holds NaN or an infinite value (float TIFF).
    #[error("pixel ({x}, {y}) holds a non-finite value")]
    NonFinite {
        /// Column.
        x: u32,
        /// Row.
        y: u32,
    },
    /// A pixel holds a negative value (float TIFF).
    #[error("pixel ({x}, {y}) holds a negative value {value}")]
    Negative {
        /// Column.
        x: u32,
        /// Row.
        y: u32,
        /// The value.
        value: f32,
    },
    /// The image (inside the mask) has no light at all: nothing to decompose.
    #[error("image is black everywhere inside the mask (max value {max})")]
    AllBlack {
        /// Largest channel value found.
        max: f32,
    },
    /// Two images that must share a size do not.
    #[error("size mismatch: expected {expected:?}, got {got:?}")]
    ShapeMismatch {
        /// Expected (width, height).
        expected: (u32, u32),
        /// Actual (width, height).
        got: (u32, u32),
    },
    /// The mask selects no pixel.
    #[error("mask selects no pixel")]
    EmptyMask,
    /// A parameter is outside its valid range.
    #[error("invalid parameter {name} = {value}: {reason}")]
    InvalidParam {
        /// The parameter's name.
        name: &'static str,
        /// Its value, formatted.
        value: String,
        /// What is required.
        reason: &'static str,
    },
    /// The sparse factorisation failed (matrix not positive definite or out of memory).
    #[error("linear solver failed on a {unknowns}-unknown system: {message}")]
    Solver {
        /// Number of unknowns.
        unknowns: usize,
        /// The factorisation's message.
        message: String,
    },
    /// The solution did not reach the requested residual.
    #[error(
        "solver did not converge after {iterations} iterations (relative residual {residual:e})"
    )]
    NoConvergence {
        /// Iterations performed.
        iterations: usize,
        /// Final relative residual.
        residual: f64,
    },
    /// Malformed judgement file (IIW JSON) or other structured input.
    #[error("malformed input {path}: {message}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A folder given as a frame sequence holds no image file.
    #[error("no frames in {path} (expected PNG, JPEG or TIFF files)")]
    NoFrames {
        /// The folder.
        path: PathBuf,
    },
    /// One frame of a sequence cannot be read or decoded; the cause is the source.
    #[error("cannot read frame {index} ({path})")]
    Frame {
        /// Position of the frame in the sequence, from 0.
        index: usize,
        /// The frame's file.
        path: PathBuf,
        /// What went wrong.
        source: Box<Error>,
    },
    /// A frame's size differs from the first frame's.
    #[error("frame {index} ({path}) is {got:?} pixels but frame 0 is {expected:?}")]
    FrameSize {
        /// Position of the frame in the sequence, from 0.
        index: usize,
        /// The frame's file.
        path: PathBuf,
        /// Frame 0's (width, height).
        expected: (u32, u32),
        /// This frame's (width, height).
        got: (u32, u32),
    },
    /// Every view of a light field is black: there is nothing to decompose.
    #[error("the light field is black in every view (max value {max}): nothing to decompose")]
    AllBlackLightField {
        /// Largest value found.
        max: f32,
    },
    /// Every frame of a video is black: there is nothing to decompose.
    #[error("every frame of {path} is black ({frames} frames): nothing to decompose")]
    AllFramesBlack {
        /// The folder or video file.
        path: PathBuf,
        /// How many frames it has.
        frames: usize,
    },
    /// `ffmpeg` could not decode a file (not a video, or a codec it lacks).
    #[error("ffmpeg cannot decode {path}: {message}")]
    Ffmpeg {
        /// The input file.
        path: PathBuf,
        /// The last line ffmpeg wrote to its standard error.
        message: String,
    },
    /// An external program the operation needs is not installed.
    #[error("{program} is not installed or not on PATH ({hint})")]
    MissingProgram {
        /// The program that was run.
        program: String,
        /// How to get it.
        hint: &'static str,
    },
}

/// The crate's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    pub(crate) fn param(name: &'static str, value: impl ToString, reason: &'static str) -> Self {
        Error::InvalidParam {
            name,
            value: value.to_string(),
            reason,
        }
    }
}
