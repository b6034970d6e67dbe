//! One uploaded file, checked before anything is stored. The limits are the ones the upload
//! form states: [`MAX_UPLOAD_BYTES`] per file, [`MAX_UPLOAD_FILES`] files per upload.

use std::io::Cursor;

use image::{RgbImage, RgbaImage};

use crate::error::{AppError, Result};

/// Largest accepted file, in bytes (5 MB: a large SVG or a 4096x4096 PNG photo of a drawing).
pub const MAX_UPLOAD_BYTES: usize = 5 * 1024 * 1024;
/// Most files in one upload (the request's size limit follows from the two).
pub const MAX_UPLOAD_FILES: usize = 20;
/// Largest accepted raster upload side, in pixels.
pub const MAX_UPLOAD_SIDE: u32 = 4096;

/// The limit in words, as the form and every "too large" message say it.
pub fn limit_in_words() -> String {
    format!(
        "{} MB per file, {MAX_UPLOAD_FILES} files per upload",
        MAX_UPLOAD_BYTES / (1024 * 1024)
    )
}

/// Validates one uploaded file (by name and content) and renders it: the 400x400 rendering on
/// white and, for a raster, the same with its transparency kept (the mash-up's cut-out). SVG
/// must parse and render; rasters must be PNG/JPEG within [`MAX_UPLOAD_SIDE`]; everything
/// within [`MAX_UPLOAD_BYTES`].
pub fn validate_upload(filename: &str, bytes: &[u8]) -> Result<(RgbImage, Option<RgbaImage>)> {
    if bytes.is_empty() {
        return Err(AppError::BadRequest(format!("{filename}: empty file")));
    }
    if bytes.len() > MAX_UPLOAD_BYTES {
        return Err(AppError::TooLarge(format!(
            "{filename}: file too large (the limit is {})",
            limit_in_words()
        )));
    }
    let lower = filename.to_ascii_lowercase();
    if lower.ends_with(".svg") {
        learner::render::render_svg(bytes)
            .map(|image| (image, None))
            .map_err(|e| AppError::BadRequest(format!("{filename}: not a usable SVG: {e}")))
    } else if lower.ends_with(".png") || lower.ends_with(".jpg") || lower.ends_with(".jpeg") {
        let reader = image::ImageReader::new(Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| AppError::BadRequest(format!("{filename}: {e}")))?;
        let (w, h) = reader
            .into_dimensions()
            .map_err(|e| AppError::BadRequest(format!("{filename}: not a readable image: {e}")))?;
        if w == 0 || h == 0 || w > MAX_UPLOAD_SIDE || h > MAX_UPLOAD_SIDE {
            return Err(AppError::BadRequest(format!(
                "{filename}: {w}x{h} pixels, the limit is {MAX_UPLOAD_SIDE}x{MAX_UPLOAD_SIDE}"
            )));
        }
        let cutout = learner::render::render_raster_rgba(bytes)
            .map_err(|e| AppError::BadRequest(format!("{filename}: not a readable image: {e}")))?;
        Ok((learner::render::flatten_on_white(&cutout), Some(cutout)))
    } else {
        Err(AppError::BadRequest(format!(
            "{filename}: unsupported type (use .svg, .png, .jpg)"
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uploads_are_validated() {
        assert!(matches!(
            validate_upload("a.svg", b"<svg"),
            Err(AppError::BadRequest(_))
        ));
        assert!(matches!(
            validate_upload("a.exe", b"MZ"),
            Err(AppError::BadRequest(_))
        ));
        assert!(matches!(
            validate_upload("a.png", b"not a png"),
            Err(AppError::BadRequest(_))
        ));
        assert!(matches!(
            validate_upload("a.svg", &vec![b' '; MAX_UPLOAD_BYTES + 1]),
            Err(AppError::TooLarge(_))
        ));
        let ok = br#"<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 10 10"><rect width="5" height="5" fill="red"/></svg>"#;
        assert_eq!(
            validate_upload("a.svg", ok)
                .map(|(i, c)| (i.width(), c.is_none()))
                .ok(),
            Some((400, true))
        );
    }
}
