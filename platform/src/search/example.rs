//! Search by an uploaded drawing (issue 17: "by an uploaded SVG/PNG featurised on the fly"):
//! the file is rendered and described by the same 169 features as a library import
//! ([`crate::studies::library::insert_item`]: `learner::render`, then `learner::features`),
//! and the results are ordered by style distance `d` (eq. 5.5) to it, like a "more like this"
//! item that is not in the library (Garces et al. 2014 §5.7.3).

use std::io::Cursor;

use base64::Engine;
use image::RgbImage;

use crate::error::{AppError, Result};
use crate::studies::library::MAX_UPLOAD_SIDE;

/// Largest accepted drawing, in bytes.
pub const MAX_EXAMPLE_BYTES: usize = 2 * 1024 * 1024;
/// Largest request carrying one: the drawing plus the form's other fields.
pub const MAX_EXAMPLE_REQUEST: usize = MAX_EXAMPLE_BYTES + 64 * 1024;
/// Side of the thumbnail shown as the reference, in pixels.
const THUMBNAIL_SIDE: u32 = 128;

/// An uploaded drawing, featurised.
#[derive(Debug, Clone)]
pub struct Example {
    /// Its 169 features, in the catalogue's order.
    pub features: Vec<f64>,
    /// A small PNG of its rendering as a `data:` URL, to show it as the reference.
    pub thumbnail: String,
}

/// What the bytes are, by their content (a browser's file name and type are only hints).
enum Kind {
    Svg,
    Raster,
}

fn kind(bytes: &[u8]) -> Option<Kind> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") || bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
        return Some(Kind::Raster);
    }
    let text = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let start = text.iter().position(|b| !b.is_ascii_whitespace())?;
    (text[start] == b'<').then_some(Kind::Svg)
}

/// The message of a file over [`MAX_EXAMPLE_BYTES`].
pub fn too_big(filename: &str) -> AppError {
    AppError::BadRequest(format!(
        "{filename}: file too big (the limit is {} MB)",
        MAX_EXAMPLE_BYTES / (1024 * 1024)
    ))
}

/// Renders and featurises an uploaded drawing (CPU work: call it off the async threads).
/// Every refusal is a 400 naming the file and the reason: empty, too big, not an SVG, PNG
/// or JPEG, a malformed SVG or image, too many pixels, or a blank drawing.
pub fn featurise(filename: &str, bytes: &[u8]) -> Result<Example> {
    let bad = |why: String| AppError::BadRequest(format!("{filename}: {why}"));
    if bytes.is_empty() {
        return Err(bad("empty file".into()));
    }
    if bytes.len() > MAX_EXAMPLE_BYTES {
        return Err(too_big(filename));
    }
    let image: RgbImage = match kind(bytes) {
        None => {
            return Err(bad(
                "not an image: upload an SVG, PNG or JPEG drawing".into()
            ));
        }
        Some(Kind::Svg) => {
            learner::render::render_svg(bytes).map_err(|e| bad(format!("not a usable SVG: {e}")))?
        }
        Some(Kind::Raster) => {
            let (w, h) = image::ImageReader::new(Cursor::new(bytes))
                .with_guessed_format()
                .map_err(|e| bad(format!("not a readable image: {e}")))?
                .into_dimensions()
                .map_err(|e| bad(format!("not a readable image: {e}")))?;
            if w == 0 || h == 0 || w > MAX_UPLOAD_SIDE || h > MAX_UPLOAD_SIDE {
                return Err(bad(format!(
                    "{w}x{h} pixels, the limit is {MAX_UPLOAD_SIDE}x{MAX_UPLOAD_SIDE}"
                )));
            }
            learner::render::render_raster(bytes)
                .map_err(|e| bad(format!("not a readable image: {e}")))?
        }
    };
    let thumbnail = thumbnail(&image)?;
    let features = match learner::features::extract(image) {
        Ok(f) => f.to_vec(),
        Err(learner::Error::BlankImage) => {
            return Err(bad(
                "blank drawing (nothing but white on the canvas): it has no style to compare"
                    .into(),
            ));
        }
        Err(e) => return Err(bad(format!("style features failed: {e}"))),
    };
    Ok(Example {
        features,
        thumbnail,
    })
}

/// `data:image/png;base64,…` of the rendering, [`THUMBNAIL_SIDE`] pixels wide.
fn thumbnail(image: &RgbImage) -> Result<String> {
    let small = image::imageops::resize(
        image,
        THUMBNAIL_SIDE,
        THUMBNAIL_SIDE,
        image::imageops::FilterType::Triangle,
    );
    let mut png = Vec::new();
    small
        .write_to(&mut Cursor::new(&mut png), image::ImageFormat::Png)
        .map_err(AppError::internal)?;
    Ok(format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(png)
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn message(r: Result<Example>) -> String {
        match r {
            Err(AppError::BadRequest(m)) => m,
            other => panic!("expected a 400, got {other:?}"),
        }
    }

    #[test]
    fn bad_files_are_refused_with_the_reason() {
        assert!(message(featurise("a.svg", b"")).contains("a.svg: empty file"));
        assert!(message(featurise("a.txt", b"hello")).contains("not an image"));
        assert!(message(featurise("a.svg", b"<svg")).contains("not a usable SVG"));
        assert!(message(featurise("a.png", b"\x89PNG\r\n\x1a\nxx")).contains("not a readable"));
        let big = vec![b' '; MAX_EXAMPLE_BYTES + 1];
        assert!(message(featurise("big.svg", &big)).contains("too big"));
        let blank = br#"<svg xmlns="http://www.w3.org/2000/svg" width="10" height="10"/>"#;
        assert!(message(featurise("blank.svg", blank)).contains("blank drawing"));
    }

    #[test]
    fn a_drawing_gets_169_features_and_a_png_thumbnail() {
        let svg = br##"<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 10 10"><circle cx="5" cy="5" r="4" fill="#c33"/></svg>"##;
        let e = featurise("dot.svg", svg).expect("features");
        assert_eq!(e.features.len(), learner::features::FEATURE_COUNT);
        assert!(e.features.iter().all(|v| v.is_finite()));
        let b64 = e
            .thumbnail
            .strip_prefix("data:image/png;base64,")
            .expect("data URL");
        let png = base64::engine::general_purpose::STANDARD
            .decode(b64)
            .expect("base64");
        let img = image::load_from_memory(&png).expect("a PNG");
        assert_eq!(
            (img.width(), img.height()),
            (THUMBNAIL_SIDE, THUMBNAIL_SIDE)
        );
    }
}
