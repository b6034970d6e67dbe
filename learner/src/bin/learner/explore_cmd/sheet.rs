//! Contact sheets: thumbnails rendered from the items, laid out as rows (taxonomy), a grid
//! (balanced grid) or at map positions (style map), written as PNG beside the JSON.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use image::{Rgb, RgbImage, imageops};
use indicatif::{ProgressBar, ProgressStyle};
use learner::input::{self, Source};
use rayon::prelude::*;

/// Background of a sheet, and the frame around a representative.
const BACKGROUND: Rgb<u8> = Rgb([236, 236, 236]);
const FRAME: Rgb<u8> = Rgb([32, 96, 192]);
/// Shown in a cell whose item could not be found or rendered.
const MISSING: Rgb<u8> = Rgb([200, 120, 120]);

/// Thumbnails of items by id.
pub struct Thumbnails {
    /// Side in pixels.
    pub size: u32,
    images: HashMap<String, RgbImage>,
    /// Ids that were asked for but not found or not renderable.
    pub missing: usize,
}

impl Thumbnails {
    /// Renders `ids` (distinct) from the items under `inputs` at `size` pixels, in parallel.
    pub fn render(inputs: &[PathBuf], ids: &[&str], size: u32, quiet: bool) -> Result<Self> {
        let found = input::discover(inputs, None)?;
        let by_id: HashMap<&str, &input::Item> =
            found.items.iter().map(|i| (i.id.as_str(), i)).collect();
        let bar = if quiet {
            ProgressBar::hidden()
        } else {
            ProgressBar::new(ids.len() as u64).with_style(
                ProgressStyle::with_template("thumbnails [{bar:30}] {pos}/{len} {eta}")
                    .expect("static template")
                    .progress_chars("=> "),
            )
        };
        let rendered: Vec<(String, Option<RgbImage>)> = ids
            .par_iter()
            .map(|id| {
                let image = by_id.get(id).and_then(|item| thumbnail(item, size));
                bar.inc(1);
                ((*id).to_owned(), image)
            })
            .collect();
        bar.finish_and_clear();
        let missing = rendered.iter().filter(|(_, i)| i.is_none()).count();
        let images = rendered
            .into_iter()
            .filter_map(|(id, i)| i.map(|i| (id, i)))
            .collect();
        Ok(Self {
            size,
            images,
            missing,
        })
    }

    /// The thumbnail of `id`, when it was found and rendered.
    pub fn get(&self, id: &str) -> Option<&RgbImage> {
        self.images.get(id)
    }
}

fn thumbnail(item: &input::Item, size: u32) -> Option<RgbImage> {
    match &item.source {
        Source::SvgFile(path) => {
            let bytes = input::read_limited(path, learner::render::MAX_SVG_BYTES).ok()?;
            learner::render::render_svg_at(&bytes, size).ok()
        }
        Source::SvgText(svg) => learner::render::render_svg_at(svg.as_bytes(), size).ok(),
        Source::RasterFile(_) => {
            let full = item.render().ok()?;
            Some(imageops::thumbnail(&full, size, size))
        }
    }
}

/// A cell of a sheet: an item id, framed or not; `None` leaves the cell empty.
pub struct Cell<'a> {
    pub id: &'a str,
    pub framed: bool,
}

/// Cells in rows of `cols`, `gap` pixels apart.
pub fn grid(thumbs: &Thumbnails, rows: &[Vec<Option<Cell>>], cols: usize) -> RgbImage {
    let gap = (thumbs.size / 8).max(2);
    let pitch = thumbs.size + gap;
    let width = gap + cols.max(1) as u32 * pitch;
    let height = gap + rows.len().max(1) as u32 * pitch;
    let mut sheet = RgbImage::from_pixel(width, height, BACKGROUND);
    for (r, row) in rows.iter().enumerate() {
        for (c, cell) in row.iter().enumerate().take(cols) {
            let Some(cell) = cell else { continue };
            let (x, y) = (gap + c as u32 * pitch, gap + r as u32 * pitch);
            put(&mut sheet, thumbs, cell.id, x, y);
            if cell.framed {
                frame(&mut sheet, x, y, thumbs.size, gap / 2);
            }
        }
    }
    sheet
}

/// The points a scatter sheet of `side` pixels shows with `size`-pixel thumbnails: the map cut
/// into cells of one thumbnail, and in each occupied cell the point nearest its centre (so
/// thumbnails never overlap), as `(point index, column, row)`.
pub fn lattice(points: &[(f32, f32)], side: u32, size: u32) -> Vec<(usize, u32, u32)> {
    let cells = (side / size.max(1)).max(1);
    let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
    for &(x, y) in points {
        lo = [lo[0].min(x), lo[1].min(y)];
        hi = [hi[0].max(x), hi[1].max(y)];
    }
    let span = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(f32::MIN_POSITIVE);
    let mut best: HashMap<(u32, u32), (f32, usize)> = HashMap::new();
    for (i, &(x, y)) in points.iter().enumerate() {
        let u = (x - lo[0]) / span * cells as f32;
        let v = (y - lo[1]) / span * cells as f32;
        let (c, r) = ((u as u32).min(cells - 1), (v as u32).min(cells - 1));
        let d = (u - c as f32 - 0.5).powi(2) + (v - r as f32 - 0.5).powi(2);
        let slot = best.entry((c, r)).or_insert((d, i));
        if d < slot.0 || (d == slot.0 && i < slot.1) {
            *slot = (d, i);
        }
    }
    let mut out: Vec<(usize, u32, u32)> =
        best.into_iter().map(|((c, r), (_, i))| (i, c, r)).collect();
    out.sort_unstable();
    out
}

/// The lattice's thumbnails on a square sheet of `side` pixels.
pub fn scatter(
    thumbs: &Thumbnails,
    ids: &[&str],
    cells: &[(usize, u32, u32)],
    side: u32,
) -> RgbImage {
    let mut sheet = RgbImage::from_pixel(side, side, BACKGROUND);
    for &(i, c, r) in cells {
        put(&mut sheet, thumbs, ids[i], c * thumbs.size, r * thumbs.size);
    }
    sheet
}

fn put(sheet: &mut RgbImage, thumbs: &Thumbnails, id: &str, x: u32, y: u32) {
    match thumbs.get(id) {
        Some(image) => imageops::overlay(sheet, image, i64::from(x), i64::from(y)),
        None => {
            let block = RgbImage::from_pixel(thumbs.size, thumbs.size, MISSING);
            imageops::overlay(sheet, &block, i64::from(x), i64::from(y));
        }
    }
}

fn frame(sheet: &mut RgbImage, x: u32, y: u32, size: u32, width: u32) {
    let (x0, y0) = (x.saturating_sub(width), y.saturating_sub(width));
    let (x1, y1) = (
        (x + size + width).min(sheet.width()),
        (y + size + width).min(sheet.height()),
    );
    for py in y0..y1 {
        for px in x0..x1 {
            let inside = px >= x && px < x + size && py >= y && py < y + size;
            if !inside {
                sheet.put_pixel(px, py, FRAME);
            }
        }
    }
}

/// Writes `sheet` to `path`, saying where on stderr.
pub fn save(sheet: &RgbImage, path: &Path, missing: usize, quiet: bool) -> Result<()> {
    sheet
        .save(path)
        .with_context(|| format!("cannot write {}", path.display()))?;
    if !quiet {
        eprintln!(
            "wrote {} ({}x{})",
            path.display(),
            sheet.width(),
            sheet.height()
        );
    }
    if missing > 0 {
        eprintln!(
            "{missing} items were not found under --items or could not be rendered (red cells)"
        );
    }
    Ok(())
}
