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
    /// A file that must hold data rows has none.
    #[error("{path}: no data rows")]
    EmptyFile {
        /// The file.
        path: PathBuf,
    },
    /// A parameter is outside its valid range.
    #[error("invalid parameter {name} = {value}: {reason}")]
    InvalidParameter {
        /// The parameter's name.
        name: &'static str,
        /// The offending value, as text.
        value: String,
        /// What is allowed.
        reason: &'static str,
    },
    /// There is too little data for the requested computation.
    #[error("not enough data for {what}: need at least {needed}, got {got}")]
    NotEnoughData {
        /// What was being computed.
        what: &'static str,
        /// The minimum.
        needed: usize,
        /// What there is.
        got: usize,
    },
    /// A sample has no spread, so a t statistic (a ratio over its standard deviation) is
    /// undefined.
    #[error("all {n} values equal {value}: the t statistic is undefined without spread")]
    ZeroVariance {
        /// The sample size.
        n: usize,
        /// The common value.
        value: f64,
    },
    /// A features file does not have the columns a model was trained on.
    #[error("features do not match the model: {message}")]
    FeatureMismatch {
        /// The first difference found.
        message: String,
    },
    /// An optimiser failed (not merely stopped early: that is reported in the solver info).
    #[error("{solver} failed: {message}")]
    Solver {
        /// `argmin` or `nlopt`.
        solver: &'static str,
        /// The solver's own message.
        message: String,
    },
    /// A JSON file could not be read or written.
    #[error("{path}: {source}")]
    Json {
        /// The file.
        path: PathBuf,
        /// The parser's error.
        source: serde_json::Error,
    },
    /// Drawing a chart failed.
    #[error("cannot draw {path}: {message}")]
    Plot {
        /// The output file.
        path: PathBuf,
        /// The backend's message.
        message: String,
    },
    /// Writing a file failed.
    #[error("cannot write {path}: {source}")]
    CannotWrite {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// A search has nothing to search for: an empty keyword query, or no keywords, items,
    /// example or diversity request at all.
    #[error("empty query: {0}")]
    EmptyQuery(&'static str),
    /// A query names an item that is not in the library.
    #[error("unknown item '{id}' (not among the {items} items of the library)")]
    UnknownItem {
        /// The id as given.
        id: String,
        /// How many items the library has.
        items: usize,
    },
    /// A library to search has no items with features.
    #[error("the library has no items with features")]
    EmptyLibrary,
    /// A feature vector given to the search has the wrong length.
    #[error("query vector has {got} values, the index expects {expected}")]
    QueryDimension {
        /// The index's number of features.
        expected: usize,
        /// The query's.
        got: usize,
    },
    /// The keyword engine (tantivy) failed.
    #[error("keyword index: {what}: {message}")]
    Keywords {
        /// What was being done.
        what: &'static str,
        /// tantivy's message.
        message: String,
    },
    /// A search index file is not one this version wrote, or is damaged.
    #[error("{path}: not a usable search index ({reason})")]
    InvalidIndex {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// A flat array of coordinates is not a whole number of points of the given dimension.
    #[error("{len} values are not a whole number of points of dimension {dim}")]
    NotAMatrix {
        /// How many values were given.
        len: usize,
        /// The dimension of one point.
        dim: usize,
    },
    /// A coordinate is NaN, infinite, or so large that squared distances could overflow.
    #[error(
        "point {row}, coordinate {column}: {value} is not finite or exceeds {limit:e} in magnitude"
    )]
    BadCoordinate {
        /// 0-based point.
        row: usize,
        /// 0-based coordinate.
        column: usize,
        /// The value.
        value: f64,
        /// The largest magnitude allowed.
        limit: f64,
    },
    /// A clustering needs a matrix with more entries than memory allows.
    #[error(
        "{what}: {n} points need {bytes} bytes of pairwise distances; at most {limit} points are supported"
    )]
    TooManyPoints {
        /// What was being computed.
        what: &'static str,
        /// How many points were given.
        n: usize,
        /// The limit.
        limit: usize,
        /// Bytes the distance matrix would take.
        bytes: u128,
    },
    /// Memory for a computation could not be allocated.
    #[error("cannot allocate {bytes} bytes for {what}")]
    OutOfMemory {
        /// What the memory was for.
        what: &'static str,
        /// How much was asked for.
        bytes: u128,
    },
    /// A linkage (a merge tree) read from outside is not a valid one.
    #[error("invalid linkage: {0}")]
    InvalidLinkage(String),
    // Exploration (explore::library, explore::taxonomy)
    /// Requested semantic labels that no item of the library has.
    #[error("no item has the label(s) {missing:?}; the library's {total} labels include {known:?}")]
    UnknownLabels {
        /// The requested labels not found.
        missing: Vec<String>,
        /// Up to 20 of the library's labels, the most frequent first.
        known: Vec<String>,
        /// How many labels the library has.
        total: usize,
    },
    /// The taxonomy's pruning thresholds leave no branch.
    #[error(
        "κ = {kappa}, τ = {tau} prune every branch: the whole library has {items} items{per_label}; \
         lower κ (keep branches with more than κ items) or τ (more than τ items of each label)"
    )]
    PrunedEverything {
        /// κ, the size a kept branch must exceed.
        kappa: usize,
        /// τ, the count of each requested label a kept branch must exceed.
        tau: usize,
        /// Items in the library.
        items: usize,
        /// ", of which N `label`" for each requested label (empty without labels).
        per_label: String,
    },
    // t-SNE (explore::tsne)
    /// t-SNE is given too few points for its perplexity.
    #[error(
        "t-SNE with perplexity {perplexity} needs at least {needed} points (⌊3·perplexity⌋ neighbours each), got {n}; lower the perplexity"
    )]
    TsneTooFewPoints {
        /// How many points were given.
        n: usize,
        /// The perplexity asked for.
        perplexity: f64,
        /// The fewest points it needs.
        needed: usize,
    },
    /// t-SNE is given more points than it supports.
    #[error("t-SNE of {n} points: at most {limit} points are supported")]
    TsneTooManyPoints {
        /// How many points were given.
        n: usize,
        /// The limit.
        limit: usize,
    },
    /// The gradient descent left finite numbers.
    #[error("t-SNE diverged (point {point} is not finite) with learning rate {learning_rate}")]
    TsneDiverged {
        /// The first point that is not finite.
        point: usize,
        /// The learning rate used.
        learning_rate: f64,
    },
    /// An embedding or an affinity matrix does not match the points it should describe.
    #[error("{what}: expected {expected} points, got {got}")]
    TsneShapeMismatch {
        /// What was compared.
        what: &'static str,
        /// The number of points expected.
        expected: usize,
        /// The number given.
        got: usize,
    },
    // Balanced grid (explore::grid)
    /// A grid with a zero side or more nodes than supported.
    #[error("a {rows}x{cols} grid is not supported: {reason}")]
    BadGridShape {
        /// Rows `M`.
        rows: usize,
        /// Columns `N`.
        cols: usize,
        /// What is allowed.
        reason: &'static str,
    },
    /// The labels (or ids) do not give one entry per item.
    #[error("{what}: {got} entries for {expected} items")]
    LengthMismatch {
        /// Which input.
        what: &'static str,
        /// The number of items.
        expected: usize,
        /// The number of entries given.
        got: usize,
    },
    /// A linear assignment problem with more rows than columns, or a cost that is not finite.
    #[error("invalid assignment problem ({rows}x{cols}): {reason}")]
    BadAssignment {
        /// Rows (items).
        rows: usize,
        /// Columns (cells).
        cols: usize,
        /// What is wrong.
        reason: String,
    },
}

/// `Result` with this crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
