//! Light fields on disk: the folder layout of the HCI 4D light-field benchmark (Honauer,
//! Johannsen, Kondermann & Goldluecke, ACCV 2016), which is what users have, and a generic
//! folder of sub-aperture views on a known grid (for instance views exported from a Lytro as
//! `NAME_RR_CC.png`).
//!
//! HCI layout: `input_Cam000.png … input_Cam080.png`, views row-major from the top-left
//! camera, a `parameters.cfg` (INI; `[extrinsics] num_cams_x / num_cams_y` give the grid) and an
//! optional centre-view disparity `gt_disp_lowres.pfm` ([`pfm`]). Every problem names the file:
//! a missing view, views of different sizes, an unreadable image, a malformed `parameters.cfg`
//! or PFM.

mod cfg;
mod output;
pub mod pfm;
mod truth;

use std::path::{Path, PathBuf};

pub use cfg::HciParameters;
pub use output::{contact_sheet, serpentine, write_animation, write_views};
pub use truth::load_truth;

use crate::error::{Error, Result};
use crate::image::Image;
use crate::io::{LoadOptions, load_rgb};
use crate::lightfield::LightField;

/// Image extensions accepted for views (lower case).
const VIEW_EXTENSIONS: [&str; 5] = ["png", "jpg", "jpeg", "tif", "tiff"];

/// A light field read from a folder, with what is needed to write results under the input's
/// own names.
#[derive(Clone, Debug)]
pub struct LightFieldFolder {
    /// The views, linear RGB.
    pub field: LightField,
    /// File name of every view, row-major (`input_Cam000.png`, `scene_00_00.png`, …).
    pub names: Vec<String>,
    /// `parameters.cfg`, when the folder has one.
    pub parameters: Option<HciParameters>,
    /// The centre view's disparity (`gt_disp_lowres.pfm`), when the folder has one.
    pub disparity: Option<Image>,
}

/// How the views of a folder are arranged.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FolderLayout {
    /// The HCI benchmark's names and `parameters.cfg`.
    Hci,
    /// `rows × cols` images: named `…_RR_CC.ext` (row and column numbers, any base), or else
    /// taken row-major in natural sort order of their names.
    Grid {
        /// Views per column.
        rows: usize,
        /// Views per row.
        cols: usize,
    },
}

fn format_error(path: &Path, message: impl Into<String>) -> Error {
    Error::Format {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

fn io_error(path: &Path, source: std::io::Error) -> Error {
    Error::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Reads a light-field folder. `layout` `None` means HCI when the folder has
/// `input_Cam000.*` or `parameters.cfg`, and an error asking for a grid otherwise.
pub fn load_folder(
    dir: &Path,
    layout: Option<FolderLayout>,
    opts: LoadOptions,
) -> Result<LightFieldFolder> {
    if !dir.is_dir() {
        return Err(format_error(dir, "is not a folder of light-field views"));
    }
    let images = list_images(dir)?;
    let layout = match layout {
        Some(l) => l,
        None if dir.join("parameters.cfg").is_file()
            || images.iter().any(|n| n.starts_with("input_Cam")) =>
        {
            FolderLayout::Hci
        }
        None => {
            return Err(format_error(
                dir,
                "is not an HCI light field (no parameters.cfg or input_Cam000.png); give the \
                 view grid, e.g. --grid 9x9",
            ));
        }
    };
    let (rows, cols, names, parameters) = match layout {
        FolderLayout::Hci => {
            let (rows, cols, parameters) = hci_grid(dir, &images)?;
            let names = hci_names(dir, &images, rows * cols)?;
            (rows, cols, names, parameters)
        }
        FolderLayout::Grid { rows, cols } => {
            if rows == 0 || cols == 0 {
                return Err(Error::param(
                    "grid",
                    format!("{rows}x{cols}"),
                    "needs at least one row and one column",
                ));
            }
            (rows, cols, grid_names(dir, &images, rows, cols)?, None)
        }
    };
    let views = read_views(dir, &names, opts)?;
    let field = LightField::from_views(rows, cols, &views)?;
    let disparity = match layout {
        FolderLayout::Hci => read_disparity(dir, field.dims())?,
        FolderLayout::Grid { .. } => None,
    };
    Ok(LightFieldFolder {
        field,
        names,
        parameters,
        disparity,
    })
}

/// Image files of `dir` (names only), sorted naturally.
fn list_images(dir: &Path) -> Result<Vec<String>> {
    let entries = std::fs::read_dir(dir).map_err(|e| io_error(dir, e))?;
    let mut names = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| io_error(dir, e))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        let ext = Path::new(&name)
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase());
        if entry.path().is_file() && ext.is_some_and(|e| VIEW_EXTENSIONS.contains(&e.as_str())) {
            names.push(name);
        }
    }
    names.sort_by(|a, b| natural_cmp(a, b));
    Ok(names)
}

/// Compares names with digit runs as numbers (`view2` before `view10`), as file managers do.
pub fn natural_cmp(a: &str, b: &str) -> std::cmp::Ordering {
    fn chunks(s: &str) -> Vec<(bool, &str)> {
        let mut out = Vec::new();
        let mut start = 0;
        let bytes = s.as_bytes();
        for i in 1..=bytes.len() {
            if i == bytes.len() || bytes[i].is_ascii_digit() != bytes[start].is_ascii_digit() {
                out.push((bytes[start].is_ascii_digit(), &s[start..i]));
                start = i;
            }
        }
        out
    }
    let (ca, cb) = (chunks(a), chunks(b));
    for ((da, xa), (db, xb)) in ca.iter().zip(&cb) {
        let ord = if *da && *db {
            let (ta, tb) = (xa.trim_start_matches('0'), xb.trim_start_matches('0'));
            ta.len().cmp(&tb.len()).then_with(|| ta.cmp(tb))
        } else {
            xa.cmp(xb)
        };
        if ord.is_ne() {
            return ord;
        }
    }
    ca.len().cmp(&cb.len()).then_with(|| a.cmp(b))
}

/// The HCI grid: from `parameters.cfg` when present, else a square number of `input_Cam` views.
fn hci_grid(dir: &Path, images: &[String]) -> Result<(usize, usize, Option<HciParameters>)> {
    let cfg_path = dir.join("parameters.cfg");
    if cfg_path.is_file() {
        let text = std::fs::read_to_string(&cfg_path).map_err(|e| io_error(&cfg_path, e))?;
        let p = HciParameters::parse(&text, &cfg_path)?;
        return Ok((p.num_cams_y, p.num_cams_x, Some(p)));
    }
    let n = images.iter().filter(|n| n.starts_with("input_Cam")).count();
    let side = (n as f64).sqrt().round() as usize;
    if n == 0 || side * side != n {
        return Err(format_error(
            dir,
            format!(
                "has {n} input_Cam views and no parameters.cfg; without it the grid must be \
                 square (e.g. 81 views for 9x9)"
            ),
        ));
    }
    Ok((side, side, None))
}

/// `input_Cam000 … input_CamNNN` with whatever image extension each has; names the first
/// missing view.
fn hci_names(dir: &Path, images: &[String], count: usize) -> Result<Vec<String>> {
    (0..count)
        .map(|i| {
            let stem = format!("input_Cam{i:03}");
            images
                .iter()
                .find(|n| Path::new(n).file_stem().is_some_and(|s| s == stem.as_str()))
                .cloned()
                .ok_or_else(|| {
                    format_error(
                        &dir.join(format!("{stem}.png")),
                        format!("view {i} of {count} is missing"),
                    )
                })
        })
        .collect()
}

/// Parses the trailing `_RR_CC` of a file stem.
fn grid_position(name: &str) -> Option<(usize, usize)> {
    let stem = Path::new(name).file_stem()?.to_str()?;
    let mut parts = stem.rsplitn(3, '_');
    let col = parts.next()?.parse().ok()?;
    let row = parts.next()?.parse().ok()?;
    parts.next()?;
    Some((row, col))
}

fn grid_names(dir: &Path, images: &[String], rows: usize, cols: usize) -> Result<Vec<String>> {
    let positions: Option<Vec<(usize, usize)>> = images.iter().map(|n| grid_position(n)).collect();
    if let Some(positions) = positions.filter(|p| !p.is_empty()) {
        // Numbers may start at 0 or 1: offset by the smallest seen.
        let r0 = positions.iter().map(|p| p.0).min().unwrap_or(0);
        let c0 = positions.iter().map(|p| p.1).min().unwrap_or(0);
        let mut slots: Vec<Option<String>> = vec![None; rows * cols];
        for (name, &(r, c)) in images.iter().zip(&positions) {
            let (r, c) = (r - r0, c - c0);
            if r >= rows || c >= cols {
                return Err(format_error(
                    &dir.join(name),
                    format!("is view ({r}, {c}), outside the {rows}x{cols} grid"),
                ));
            }
            if let Some(other) = &slots[r * cols + c] {
                return Err(format_error(
                    &dir.join(name),
                    format!("is view ({r}, {c}), like {other}"),
                ));
            }
            slots[r * cols + c] = Some(name.clone());
        }
        return slots
            .into_iter()
            .enumerate()
            .map(|(i, s)| {
                s.ok_or_else(|| {
                    format_error(
                        dir,
                        format!(
                            "has no view ({}, {}) of the {rows}x{cols} grid",
                            i / cols,
                            i % cols
                        ),
                    )
                })
            })
            .collect();
    }
    if images.len() != rows * cols {
        return Err(format_error(
            dir,
            format!(
                "has {} images, but a {rows}x{cols} grid needs {}",
                images.len(),
                rows * cols
            ),
        ));
    }
    Ok(images.to_vec())
}

/// Reads every view in parallel; the first failure (in view order) names its file, and so does
/// a view whose size differs from the first's.
fn read_views(dir: &Path, names: &[String], opts: LoadOptions) -> Result<Vec<Image>> {
    use rayon::prelude::*;
    let views: Vec<Image> = names
        .par_iter()
        .map(|n| load_rgb(dir.join(n), opts))
        .collect::<Result<_>>()?;
    let dims = views[0].dims();
    for (view, name) in views.iter().zip(names) {
        if view.dims() != dims {
            return Err(format_error(
                &dir.join(name),
                format!(
                    "is {}x{} but {} is {}x{}: every view must have one size",
                    view.width(),
                    view.height(),
                    names[0],
                    dims.0,
                    dims.1
                ),
            ));
        }
    }
    Ok(views)
}

fn read_disparity(dir: &Path, dims: (u32, u32)) -> Result<Option<Image>> {
    let path: PathBuf = dir.join("gt_disp_lowres.pfm");
    if !path.is_file() {
        return Ok(None);
    }
    let disparity = pfm::read(&path)?;
    if disparity.dims() != dims || disparity.channels() != 1 {
        return Err(format_error(
            &path,
            format!(
                "is {}x{} with {} channel(s); the views are {}x{} and a disparity map has one",
                disparity.width(),
                disparity.height(),
                disparity.channels(),
                dims.0,
                dims.1
            ),
        ));
    }
    Ok(Some(disparity))
}

#[cfg(test)]
mod tests;
