//! Style features of clip art and the learned style metric of Garces et al., "A Similarity
//! Measure for Illustration Style" (SIGGRAPH 2014).
//!
//! The pipeline is SVG/PNG/Iconify → [`render`] (400x400 on white) → [`features`] (169 named
//! values of §5.3); [`explore`] starts the style taxonomy of Garces et al. 2016 (Ward
//! clustering, §6.5.1). Everything here is pure computation over in-memory data: no printing, no
//! terminal, no network.
//!
//! ```
//! let svg = br##"<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 10 10">
//!   <circle cx="5" cy="5" r="4" fill="#e33" stroke="black" stroke-width="0.5"/></svg>"##;
//! let canvas = learner::render::render_svg(svg)?;
//! let features = learner::features::extract(canvas)?;
//! assert_eq!(features.len(), learner::features::FEATURE_COUNT);
//! # Ok::<(), learner::Error>(())
//! ```

pub mod edges;
mod error;
pub mod eval;
pub mod explore;
pub mod features;
pub mod iconify;
pub mod input;
pub mod mask;
pub mod metric;
pub mod plane;
pub mod render;
pub mod search;
mod simd;
pub mod stats;
pub mod table;
pub mod triplets;

pub use error::{Error, Result};
