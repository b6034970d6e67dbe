//! `learner map --html DIR`: a self-contained static page of the style map (like PixPlot's
//! output): `index.html`, `map.js`, `map.css`, `points.js` (the points, as a script so the page
//! also opens from the file system) and thumbnail atlases `atlas-N.png`. Put the folder on any
//! web server, or open `index.html`.

use std::path::Path;

use anyhow::{Context, Result};
use image::{Rgb, RgbImage, imageops};
use serde_json::json;

use super::sheet::Thumbnails;

const INDEX: &str = include_str!("html/index.html");
const SCRIPT: &str = include_str!("html/map.js");
const STYLE: &str = include_str!("html/map.css");

/// Thumbnails per atlas row (an atlas holds `PER_ROW²`).
const PER_ROW: usize = 32;

/// One point of the page: id, label name index, position.
pub struct PagePoint<'a> {
    pub id: &'a str,
    pub label: u32,
    pub x: f32,
    pub y: f32,
}

/// Writes the page into `dir` (created if needed).
pub fn write(
    dir: &Path,
    points: &[PagePoint],
    labels: &[String],
    thumbs: &Thumbnails,
) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let write = |name: &str, bytes: &[u8]| {
        let path = dir.join(name);
        std::fs::write(&path, bytes).with_context(|| format!("cannot write {}", path.display()))
    };
    write("index.html", INDEX.as_bytes())?;
    write("map.js", SCRIPT.as_bytes())?;
    write("map.css", STYLE.as_bytes())?;
    let (x, y) = normalise(points);
    let per_atlas = PER_ROW * PER_ROW;
    let size = thumbs.size;
    let mut atlases = Vec::new();
    for (a, chunk) in points.chunks(per_atlas).enumerate() {
        let rows = chunk.len().div_ceil(PER_ROW) as u32;
        let mut atlas =
            RgbImage::from_pixel(PER_ROW as u32 * size, rows * size, Rgb([255, 255, 255]));
        for (k, p) in chunk.iter().enumerate() {
            if let Some(t) = thumbs.get(p.id) {
                let (cx, cy) = ((k % PER_ROW) as u32 * size, (k / PER_ROW) as u32 * size);
                imageops::overlay(&mut atlas, t, i64::from(cx), i64::from(cy));
            }
        }
        let name = format!("atlas-{a}.png");
        let path = dir.join(&name);
        atlas
            .save(&path)
            .with_context(|| format!("cannot write {}", path.display()))?;
        atlases.push(name);
    }
    let data = json!({
        "ids": points.iter().map(|p| p.id).collect::<Vec<_>>(),
        "label": points.iter().map(|p| p.label).collect::<Vec<_>>(),
        "labels": labels,
        "x": x,
        "y": y,
        "atlas": (0..points.len()).map(|i| i / per_atlas).collect::<Vec<_>>(),
        "cell": (0..points.len()).map(|i| i % per_atlas).collect::<Vec<_>>(),
        "per_row": PER_ROW,
        "thumb": size,
        "atlases": atlases,
    });
    write(
        "points.js",
        format!("window.STYLE_MAP = {data};\n").as_bytes(),
    )?;
    Ok(())
}

/// Positions scaled into [0, 1]² keeping the aspect ratio, centred, rounded to 5 decimals.
fn normalise(points: &[PagePoint]) -> (Vec<f64>, Vec<f64>) {
    let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
    for p in points {
        lo = [lo[0].min(p.x), lo[1].min(p.y)];
        hi = [hi[0].max(p.x), hi[1].max(p.y)];
    }
    let span = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(f32::MIN_POSITIVE);
    let offset = [
        (span - (hi[0] - lo[0])) / 2.0,
        (span - (hi[1] - lo[1])) / 2.0,
    ];
    let round = |v: f32| (f64::from(v) * 1e5).round() / 1e5;
    points
        .iter()
        .map(|p| {
            (
                round((p.x - lo[0] + offset[0]) / span),
                round((p.y - lo[1] + offset[1]) / span),
            )
        })
        .unzip()
}
