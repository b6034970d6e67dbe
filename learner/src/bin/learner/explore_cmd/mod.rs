//! `learner taxonomy`, `learner map` and `learner grid`: style-based exploration of a library
//! (Garces et al. 2016, "Style-Based Exploration of Illustration Datasets", §6.5, and the style
//! map of §5.7.1). Each writes a JSON other tools can read and, beside it, a contact sheet.
//!
//! * `library`: the shared arguments and loading the library.
//! * `sheet`: thumbnails and contact sheets.
//! * `taxonomy`: the representative styles.
//! * `map`: the style map, and `html` its static page.
//! * `grid`: the balanced grid of a branch, and its baselines.

pub mod grid;
pub mod html;
pub mod library;
pub mod map;
pub mod sheet;
pub mod taxonomy;

use std::path::Path;

use anyhow::{Context, Result};

/// Writes `value` as pretty JSON.
pub fn write_json(path: &Path, value: &serde_json::Value) -> Result<()> {
    let text = serde_json::to_string_pretty(value)?;
    std::fs::write(path, text + "\n").with_context(|| format!("cannot write {}", path.display()))
}
