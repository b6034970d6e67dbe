//! The crate's one error type.

use std::path::PathBuf;

/// Everything that can go wrong in `learner`. Variants carry the facts a user needs to fix the
/// input (file, size, limit), never a bare string from a dependency alone.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Reading a file failed.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// A file is larger than the limit for its kind.
    #[error("file is {size} bytes, over the limit of {limit} bytes")]
    FileTooLarge {
        /// Its size.
        size: u64,
        /// The limit.
        limit: u64,
    },
    /// The SVG could not be parsed or is unsafe to render.
    #[error("invalid SVG: {0}")]
    InvalidSvg(String),
    /// The SVG parses but has nothing to draw at a usable size.
    #[error("SVG has an unusable size {width}x{height}")]
    UnusableSvgSize {
        /// Width in user units.
        width: f32,
        /// Height in user units.
        height: f32,
    },
    /// A raster image could not be decoded.
    #[error("cannot decode image: {0}")]
    InvalidImage(String),
    /// A raster image has more pixels than allowed.
    #[error(
        "image is {width}x{height} = {megapixels:.1} megapixels, over the limit of {limit} megapixels"
    )]
    ImageTooLarge {
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
        /// width·height / 1e6.
        megapixels: f64,
        /// The limit in megapixels.
        limit: u32,
    },
    /// An image has a zero dimension.
    #[error("image has zero size {width}x{height}")]
    EmptyImage {
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
    },
    /// An Iconify icon-set JSON file is malformed.
    #[error("invalid Iconify JSON: {0}")]
    InvalidIconify(String),
    /// A CSV file is malformed.
    #[error("{path}:{line}: {message}")]
    InvalidCsv {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: u64,
        /// What is wrong.
        message: String,
    },
    /// An input path is neither a supported file nor a folder.
    #[error("unsupported input {0}: expected a folder, .svg, .png, .jpg/.jpeg or Iconify .json")]
    UnsupportedInput(PathBuf),
    /// Two inputs produce the same item id.
    #[error("duplicate id '{0}' (the first item with this id is kept)")]
    DuplicateId(String),
    /// The image is all white: there is no drawing to describe.
    #[error("image is blank (no non-white pixels)")]
    BlankImage,
    /// The image is not the size the feature extractor expects.
    #[error("expected a {expected}x{expected} image, got {width}x{height}")]
    WrongCanvasSize {
        /// The expected side length.
        expected: u32,
        /// Actual width.
        width: u32,
        /// Actual height.
        height: u32,
    },
}

/// `Result` with this crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
