//! Server-side rendering of a composition (§5.7.3: the paper's canvas exported the mash-ups the
//! raters compared). The SVG keeps every piece's vector drawing: each item's stored SVG is
//! re-serialised by usvg with a per-piece id prefix (`p3-…`), so two copies of one item never
//! share an id, and nested in a `<g id="piece-N">` carrying the piece's translate, rotate and
//! scale; raster items are embedded as PNG `<image>`s of their cut-out (alpha kept, so the
//! background shows around them) and the background photograph as a JPEG data URI. The PNG is that SVG rendered by resvg, so both exports show the same picture.

use std::collections::HashMap;
use std::fmt::Write as _;

use base64::Engine as _;
use sqlx::Row;

use super::backgrounds;
use super::document::{Document, PIECE_SIZE};
use crate::error::{AppError, Result};
use crate::store::db::Db;
use crate::store::ids::ItemId;

/// What a piece's item is drawn from.
#[derive(Debug, Clone)]
pub enum ItemSource {
    /// The usvg-normalised SVG stored on import.
    Svg(String),
    /// A stored 400x400 PNG: a raster item's cut-out with its transparency (migration 0017),
    /// or the opaque rendering of items imported before cut-outs or SVGs were kept.
    Png(Vec<u8>),
}

/// The drawings of a document's items, by id.
pub type Sources = HashMap<ItemId, ItemSource>;

/// Loads the drawing of every item of `doc` (the caller has checked they are in its library).
pub async fn load_sources(db: &Db, doc: &Document) -> Result<Sources> {
    let wanted = doc.items();
    let mut out = Sources::new();
    if wanted.is_empty() {
        return Ok(out);
    }
    let placeholders: Vec<String> = (1..=wanted.len()).map(|i| format!("${i}")).collect();
    let sql = format!(
        "SELECT id, svg, cutout, png FROM items WHERE id IN ({})",
        placeholders.join(", ")
    );
    // Safe: the text holds only generated `$n` placeholders; the ids are bound.
    let mut query = sqlx::query(sqlx::AssertSqlSafe(sql));
    for id in &wanted {
        query = query.bind(id.0);
    }
    for row in query.fetch_all(&db.pool).await? {
        let id = ItemId(row.try_get("id")?);
        let svg: Option<String> = row.try_get("svg")?;
        let source = match (svg, row.try_get::<Option<Vec<u8>>, _>("cutout")?) {
            (Some(s), _) => ItemSource::Svg(s),
            (None, Some(cutout)) => ItemSource::Png(cutout),
            (None, None) => ItemSource::Png(row.try_get("png")?),
        };
        out.insert(id, source);
    }
    Ok(out)
}

/// Formats a number for an attribute: three decimals, no trailing zeros.
fn num(v: f64) -> String {
    let s = format!("{v:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
}

fn data_uri(mime: &str, bytes: &[u8]) -> String {
    format!(
        "data:{mime};base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    )
}

/// The inside of a re-serialised item SVG (without its `<svg …>` root) and its size.
fn nested_svg(svg: &str, prefix: &str) -> Result<(String, f64, f64)> {
    let tree = learner::render::parse_svg(svg.as_bytes())
        .map_err(|e| AppError::internal(format!("stored item SVG: {e}")))?;
    let size = tree.size();
    let text = tree.to_string(&usvg::WriteOptions {
        id_prefix: Some(prefix.to_string()),
        indent: usvg::Indent::None,
        ..usvg::WriteOptions::default()
    });
    let start = text
        .find("<svg")
        .and_then(|i| text[i..].find('>').map(|j| i + j + 1));
    let inner = match (start, text.rfind("</svg>")) {
        (Some(s), Some(e)) if s <= e => text[s..e].to_string(),
        // `<svg …/>`: an empty drawing.
        _ => String::new(),
    };
    Ok((inner, f64::from(size.width()), f64::from(size.height())))
}

/// The composition as a standalone SVG document.
pub fn svg(doc: &Document, sources: &Sources) -> Result<String> {
    let (w, h) = (doc.width, doc.height);
    let mut out = String::with_capacity(64 * 1024);
    let _ = write!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" width="{w}" height="{h}" viewBox="0 0 {w} {h}">"#
    );
    let _ = write!(
        out,
        r##"<g id="background"><rect width="{w}" height="{h}" fill="#ffffff"/>"##
    );
    let background = backgrounds::by_name(&doc.background)
        .ok_or_else(|| AppError::BadRequest("document: unknown background".into()))?;
    if let Some(jpeg) = background.jpeg {
        let _ = write!(
            out,
            r#"<image width="{w}" height="{h}" preserveAspectRatio="xMidYMid slice" xlink:href="{}"/>"#,
            data_uri("image/jpeg", jpeg)
        );
    }
    out.push_str("</g>");
    for (i, piece) in doc.pieces.iter().enumerate() {
        let source = sources.get(&piece.item).ok_or_else(|| {
            AppError::BadRequest(format!("document: item {} not found", piece.item))
        })?;
        let (inner, iw, ih) = match source {
            ItemSource::Svg(text) => nested_svg(text, &format!("p{i}-"))?,
            ItemSource::Png(png) => {
                let (pw, ph) = image::ImageReader::with_format(
                    std::io::Cursor::new(png),
                    image::ImageFormat::Png,
                )
                .into_dimensions()
                .map_err(AppError::internal)?;
                (
                    format!(
                        r#"<image width="{pw}" height="{ph}" xlink:href="{}"/>"#,
                        data_uri("image/png", png)
                    ),
                    f64::from(pw),
                    f64::from(ph),
                )
            }
        };
        let k = PIECE_SIZE * piece.scale / iw.max(ih).max(f64::MIN_POSITIVE);
        let _ = write!(
            out,
            r#"<g id="piece-{i}" class="piece" data-item="{}" transform="translate({} {}) rotate({}) scale({}) translate({} {})">{inner}</g>"#,
            piece.item,
            num(piece.x),
            num(piece.y),
            num(piece.rotation),
            num(k),
            num(-iw / 2.0),
            num(-ih / 2.0),
        );
    }
    out.push_str("</svg>");
    Ok(out)
}

/// The composition as a PNG of `width`×`height` pixels (the [`svg`] rendered by resvg).
pub fn png(doc: &Document, sources: &Sources) -> Result<Vec<u8>> {
    let text = svg(doc, sources)?;
    let tree = learner::render::parse_svg(text.as_bytes()).map_err(AppError::internal)?;
    let mut pixmap = tiny_skia::Pixmap::new(doc.width, doc.height)
        .ok_or_else(|| AppError::internal("empty canvas"))?;
    pixmap.fill(tiny_skia::Color::WHITE);
    resvg::render(
        &tree,
        tiny_skia::Transform::identity(),
        &mut pixmap.as_mut(),
    );
    // Opaque white underneath, so premultiplied == straight colour.
    let rgb = pixmap
        .pixels()
        .iter()
        .flat_map(|p| [p.red(), p.green(), p.blue()])
        .collect();
    let image = image::RgbImage::from_raw(doc.width, doc.height, rgb)
        .ok_or_else(|| AppError::internal("pixmap size"))?;
    let mut bytes = Vec::new();
    image
        .write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )
        .map_err(AppError::internal)?;
    Ok(bytes)
}

#[cfg(test)]
mod tests;
