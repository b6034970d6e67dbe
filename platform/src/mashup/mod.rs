//! Clip-art mash-ups (Garces et al. 2014 §5.7.3): a scene composed of pieces of one library's
//! clip art on a background, kept as a small JSON [`document::Document`], stored per library
//! ([`store`]) and rendered on the server to SVG — every piece keeping its vector drawing — and
//! to PNG ([`render`]).
//!
//! The admin canvas (`/admin/mashup`) and, later, the worker mash-up study use the same three
//! parts; nothing here knows about pages or sessions.
//!
//! ```no_run
//! # async fn demo(db: &platform::store::db::Db) -> platform::error::Result<()> {
//! use platform::mashup::{document::Document, render, store};
//! let doc = Document::parse(br#"{"version":1,"width":800,"height":600,
//!     "background":"grass","pieces":[]}"#)?;
//! let library = platform::studies::library::ensure_existing(db, "icons").await?;
//! store::check_items(db, library, &doc).await?;
//! let sources = render::load_sources(db, &doc).await?;
//! let svg = render::svg(&doc, &sources)?;
//! let png = render::png(&doc, &sources)?;
//! # let _ = (svg, png); Ok(()) }
//! ```

pub mod backgrounds;
pub mod document;
pub mod render;
pub mod store;

pub use document::{Document, Piece};
