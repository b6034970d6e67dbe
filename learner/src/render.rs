//! Rendering clip art to the 400x400 canvas the features see (§5.3: "we render each
//! illustration at 400x400"): SVG through usvg/resvg, raster images through `image`; both fitted
//! with aspect ratio preserved, centred, and composited onto white.
//!
//! Untrusted input is refused with an error, never a panic: files over [`MAX_SVG_BYTES`] or
//! [`MAX_RASTER_MEGAPIXELS`], element nesting deeper than [`MAX_NESTING`], zero, non-finite or
//! over-[`MAX_SVG_EXTENT`] viewBoxes, and references to external files (only `data:` URLs are
//! rendered, so a drawing looks the same on every machine).

use std::io::Cursor;
use std::sync::{Arc, Mutex, OnceLock};

use image::{ImageReader, RgbImage, RgbaImage};

use crate::{Error, Result};

/// Side length of the canvas in pixels (the paper's 400x400).
pub const CANVAS_SIZE: u32 = 400;
/// Largest SVG file accepted, in bytes (20 MB).
pub const MAX_SVG_BYTES: u64 = 20 * 1024 * 1024;
/// Largest raster image accepted, in megapixels.
pub const MAX_RASTER_MEGAPIXELS: u32 = 50;
/// Largest raster file accepted, in bytes (a 50-megapixel PNG compresses well below this).
pub const MAX_RASTER_BYTES: u64 = 200 * 1024 * 1024;
/// Deepest element nesting accepted in an SVG (usvg converts recursively).
pub const MAX_NESTING: usize = 256;
/// Largest viewBox side accepted, in user units.
pub const MAX_SVG_EXTENT: f32 = 1.0e6;

/// The system font database, loaded once per process (text in SVGs needs it).
fn font_database() -> Arc<usvg::fontdb::Database> {
    static FONTS: OnceLock<Arc<usvg::fontdb::Database>> = OnceLock::new();
    FONTS
        .get_or_init(|| {
            let mut db = usvg::fontdb::Database::new();
            db.load_system_fonts();
            Arc::new(db)
        })
        .clone()
}

/// Renders SVG bytes onto a white 400x400 canvas.
pub fn render_svg(svg: &[u8]) -> Result<RgbImage> {
    render_svg_at(svg, CANVAS_SIZE)
}

/// Parses untrusted SVG bytes with every check of this module (size, nesting, a usable
/// viewBox, no external files; system fonts for text). The platform re-serialises the tree to
/// store a drawing's vector source and nests it in mash-up compositions (§5.7.3).
pub fn parse_svg(svg: &[u8]) -> Result<usvg::Tree> {
    if svg.len() as u64 > MAX_SVG_BYTES {
        return Err(Error::FileTooLarge {
            size: svg.len() as u64,
            limit: MAX_SVG_BYTES,
        });
    }
    let depth = max_element_depth(svg);
    if depth > MAX_NESTING {
        return Err(Error::InvalidSvg(format!(
            "elements nested {depth} deep, over the limit of {MAX_NESTING}"
        )));
    }
    if let Some([_, _, w, h]) = root_view_box(svg) {
        // usvg silently falls back to a default size on a degenerate viewBox; a user wants to know.
        if !(w.is_finite() && h.is_finite() && w > 0.0 && h > 0.0) {
            return Err(Error::UnusableSvgSize {
                width: w,
                height: h,
            });
        }
    }
    let external: Arc<Mutex<Option<String>>> = Arc::default();
    let seen = external.clone();
    let options = usvg::Options {
        fontdb: font_database(),
        image_href_resolver: usvg::ImageHrefResolver {
            resolve_data: usvg::ImageHrefResolver::default_data_resolver(),
            resolve_string: Box::new(move |href, _| {
                if let Ok(mut slot) = seen.lock() {
                    slot.get_or_insert_with(|| href.chars().take(200).collect());
                }
                None
            }),
        },
        ..usvg::Options::default()
    };
    let tree =
        usvg::Tree::from_data(svg, &options).map_err(|e| Error::InvalidSvg(e.to_string()))?;
    if let Some(href) = external.lock().ok().and_then(|s| s.clone()) {
        return Err(Error::InvalidSvg(format!(
            "references an external file '{href}'"
        )));
    }
    let view = tree.size();
    let (w, h) = (view.width(), view.height());
    if !(w.is_finite() && h.is_finite())
        || w <= 0.0
        || h <= 0.0
        || w > MAX_SVG_EXTENT
        || h > MAX_SVG_EXTENT
    {
        return Err(Error::UnusableSvgSize {
            width: w,
            height: h,
        });
    }
    Ok(tree)
}

/// Renders SVG bytes onto a white `size`x`size` canvas.
pub fn render_svg_at(svg: &[u8], size: u32) -> Result<RgbImage> {
    let tree = parse_svg(svg)?;
    let view = tree.size();
    let (w, h) = (view.width(), view.height());
    let mut pixmap = tiny_skia::Pixmap::new(size, size).ok_or(Error::EmptyImage {
        width: size,
        height: size,
    })?;
    pixmap.fill(tiny_skia::Color::WHITE);
    let scale = size as f32 / w.max(h);
    let (dx, dy) = (
        (size as f32 - w * scale) * 0.5,
        (size as f32 - h * scale) * 0.5,
    );
    let transform = tiny_skia::Transform::from_row(scale, 0.0, 0.0, scale, dx, dy);
    resvg::render(&tree, transform, &mut pixmap.as_mut());
    // The pixmap started opaque white, so every pixel is opaque and premultiplied == straight.
    let rgb = pixmap
        .pixels()
        .iter()
        .flat_map(|p| [p.red(), p.green(), p.blue()])
        .collect();
    RgbImage::from_raw(size, size, rgb).ok_or(Error::EmptyImage {
        width: size,
        height: size,
    })
}

/// Decodes a PNG/JPEG/TIFF and fits it onto a white 400x400 canvas.
pub fn render_raster(bytes: &[u8]) -> Result<RgbImage> {
    Ok(flatten_on_white(&render_raster_rgba(bytes)?))
}

/// Decodes a PNG/JPEG/TIFF and fits it onto a transparent 400x400 canvas, keeping its alpha:
/// [`render_raster`] before the composite onto white (a composition places the cut-out on its
/// own background, §5.7.3).
pub fn render_raster_rgba(bytes: &[u8]) -> Result<RgbaImage> {
    if bytes.len() as u64 > MAX_RASTER_BYTES {
        return Err(Error::FileTooLarge {
            size: bytes.len() as u64,
            limit: MAX_RASTER_BYTES,
        });
    }
    let reader = ImageReader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| Error::InvalidImage(e.to_string()))?;
    let (width, height) = reader
        .into_dimensions()
        .map_err(|e| Error::InvalidImage(e.to_string()))?;
    check_raster_size(width, height)?;
    let mut reader = ImageReader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| Error::InvalidImage(e.to_string()))?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(width);
    limits.max_image_height = Some(height);
    limits.max_alloc = Some(u64::from(MAX_RASTER_MEGAPIXELS) * 1_000_000 * 16);
    reader.limits(limits);
    let decoded = reader
        .decode()
        .map_err(|e| Error::InvalidImage(e.to_string()))?;
    Ok(fit_rgba(&decoded.to_rgba8(), CANVAS_SIZE))
}

fn check_raster_size(width: u32, height: u32) -> Result<()> {
    if width == 0 || height == 0 {
        return Err(Error::EmptyImage { width, height });
    }
    let megapixels = width as f64 * height as f64 / 1e6;
    if megapixels > MAX_RASTER_MEGAPIXELS as f64 {
        return Err(Error::ImageTooLarge {
            width,
            height,
            megapixels,
            limit: MAX_RASTER_MEGAPIXELS,
        });
    }
    Ok(())
}

/// Scales `image` to fit `size`x`size` (aspect preserved, Catmull-Rom; never upscaled by more
/// than needed), centres it and composites its alpha onto white.
pub fn fit_on_white(image: &RgbaImage, size: u32) -> RgbImage {
    flatten_on_white(&fit_rgba(image, size))
}

/// Scales `image` to fit `size`x`size` as [`fit_on_white`] does, centred on a transparent
/// canvas.
pub fn fit_rgba(image: &RgbaImage, size: u32) -> RgbaImage {
    let (w, h) = image.dimensions();
    let scale = size as f64 / w.max(h) as f64;
    let nw = ((w as f64 * scale).round() as u32).clamp(1, size);
    let nh = ((h as f64 * scale).round() as u32).clamp(1, size);
    let resized = if (nw, nh) == (w, h) {
        image.clone()
    } else {
        image::imageops::resize(image, nw, nh, image::imageops::FilterType::CatmullRom)
    };
    let (ox, oy) = ((size - nw) / 2, (size - nh) / 2);
    let mut out = RgbaImage::new(size, size);
    image::imageops::replace(&mut out, &resized, i64::from(ox), i64::from(oy));
    out
}

/// Composites straight-alpha `image` onto white (a transparent pixel becomes white).
pub fn flatten_on_white(image: &RgbaImage) -> RgbImage {
    let (w, h) = image.dimensions();
    let mut out = RgbImage::new(w, h);
    for (x, y, p) in image.enumerate_pixels() {
        let a = p[3] as u32;
        let blend = |c: u8| ((c as u32 * a + 255 * (255 - a) + 127) / 255) as u8;
        out.put_pixel(x, y, image::Rgb([blend(p[0]), blend(p[1]), blend(p[2])]));
    }
    out
}

/// The deepest element nesting in an XML document, by a tolerant byte scan (comments,
/// processing instructions, declarations and CDATA are skipped; malformed input just yields
/// some depth, and the parser reports the real error).
pub fn max_element_depth(xml: &[u8]) -> usize {
    let (mut depth, mut max) = (0usize, 0usize);
    let mut i = 0;
    while i < xml.len() {
        if xml[i] != b'<' {
            i += 1;
            continue;
        }
        let rest = &xml[i..];
        if rest.starts_with(b"<!--") {
            i += find(rest, b"-->").map_or(xml.len(), |e| e + 3);
        } else if rest.starts_with(b"<![CDATA[") {
            i += find(rest, b"]]>").map_or(xml.len(), |e| e + 3);
        } else if rest.starts_with(b"<?") || rest.starts_with(b"<!") {
            i += find(rest, b">").map_or(xml.len(), |e| e + 1);
        } else if rest.starts_with(b"</") {
            depth = depth.saturating_sub(1);
            i += 2;
        } else {
            // An opening tag: find its end, skipping quoted attribute values.
            let mut j = 1;
            let mut quote = None;
            while j < rest.len() {
                match (quote, rest[j]) {
                    (None, b'"' | b'\'') => quote = Some(rest[j]),
                    (Some(q), c) if c == q => quote = None,
                    (None, b'>') => break,
                    _ => {}
                }
                j += 1;
            }
            let self_closing = j > 0 && j < rest.len() && rest[j - 1] == b'/';
            if !self_closing {
                depth += 1;
                max = max.max(depth);
            }
            i += j + 1;
        }
    }
    max
}

/// The `viewBox` of the root `<svg>` element, when present and made of four numbers.
fn root_view_box(svg: &[u8]) -> Option<[f32; 4]> {
    let start = find(svg, b"<svg")?;
    let tag_len = find(&svg[start..], b">")?;
    let tag = std::str::from_utf8(&svg[start..start + tag_len]).ok()?;
    let at = tag.find("viewBox")?;
    let rest = tag[at + "viewBox".len()..]
        .trim_start()
        .strip_prefix('=')?
        .trim_start();
    let quote = rest.chars().next()?;
    let value = rest[1..].split(quote).next()?;
    let numbers: Vec<f32> = value
        .split(|c: char| c.is_whitespace() || c == ',')
        .filter(|s| !s.is_empty())
        .map(str::parse)
        .collect::<Result<_, _>>()
        .ok()?;
    numbers.try_into().ok()
}

fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).position(|w| w == needle)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn svg(body: &str, view_box: &str) -> Vec<u8> {
        format!(r#"<svg xmlns="http://www.w3.org/2000/svg" viewBox="{view_box}">{body}</svg>"#)
            .into_bytes()
    }

    #[test]
    fn wide_drawing_is_centred_with_aspect_preserved() {
        let img = render_svg(&svg(
            r#"<rect width="200" height="100" fill="red"/>"#,
            "0 0 200 100",
        ))
        .unwrap();
        assert_eq!(img.dimensions(), (400, 400));
        assert_eq!(img.get_pixel(200, 200).0, [255, 0, 0]);
        assert_eq!(img.get_pixel(200, 50).0, [255, 255, 255]); // letterbox above
        assert_eq!(img.get_pixel(200, 101).0, [255, 0, 0]);
        assert_eq!(img.get_pixel(200, 298).0, [255, 0, 0]);
        assert_eq!(img.get_pixel(200, 350).0, [255, 255, 255]);
    }

    #[test]
    fn transparent_svg_is_white() {
        let img = render_svg(&svg("", "0 0 10 10")).unwrap();
        assert!(img.pixels().all(|p| p.0 == [255; 3]));
    }

    #[test]
    fn half_transparent_black_becomes_grey() {
        let img = render_svg(&svg(
            r#"<rect width="10" height="10" fill="black" fill-opacity="0.5"/>"#,
            "0 0 10 10",
        ))
        .unwrap();
        let v = img.get_pixel(200, 200)[0];
        assert!((126..=129).contains(&v), "{v}");
    }

    #[test]
    fn malformed_svgs_are_errors() {
        assert!(matches!(render_svg(b"<svg"), Err(Error::InvalidSvg(_))));
        assert!(matches!(
            render_svg(b"not xml at all"),
            Err(Error::InvalidSvg(_))
        ));
        assert!(matches!(
            render_svg(&svg("<rect/>", "0 0 0 0")),
            Err(Error::UnusableSvgSize { .. })
        ));
        assert!(matches!(
            render_svg(&svg("<rect/>", "0, 0, 10, -5")),
            Err(Error::UnusableSvgSize { .. })
        ));
        assert!(matches!(
            render_svg(&svg(r#"<rect width="1e9" height="1e9"/>"#, "0 0 1e9 1e9")),
            Err(Error::UnusableSvgSize { .. })
        ));
    }

    #[test]
    fn external_reference_is_refused() {
        let body = r#"<image href="/etc/passwd.png" width="10" height="10"/>"#;
        let err = render_svg(&svg(body, "0 0 10 10")).unwrap_err();
        assert!(
            err.to_string().contains("external file '/etc/passwd.png'"),
            "{err}"
        );
    }

    #[test]
    fn deep_nesting_is_refused_not_a_stack_overflow() {
        let body = "<g>".repeat(100_000) + &"</g>".repeat(100_000);
        assert!(
            matches!(render_svg(&svg(&body, "0 0 10 10")), Err(Error::InvalidSvg(m)) if m.contains("nested"))
        );
    }

    #[test]
    fn oversized_svg_is_refused_before_parsing() {
        let big = vec![b' '; (MAX_SVG_BYTES + 1) as usize];
        assert!(matches!(render_svg(&big), Err(Error::FileTooLarge { .. })));
    }

    #[test]
    fn nesting_scan_ignores_comments_and_self_closing_tags() {
        assert_eq!(
            max_element_depth(b"<?xml?><!-- <a><b> --><svg><g><rect/><path d='>'/></g></svg>"),
            2
        );
    }

    #[test]
    fn raster_is_fitted_and_composited() {
        let mut rgba = RgbaImage::from_pixel(100, 50, image::Rgba([0, 0, 255, 255]));
        rgba.put_pixel(0, 0, image::Rgba([0, 0, 0, 0]));
        let mut png = Vec::new();
        image::DynamicImage::ImageRgba8(rgba)
            .write_to(&mut Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        let img = render_raster(&png).unwrap();
        assert_eq!(img.get_pixel(200, 200).0, [0, 0, 255]);
        assert_eq!(img.get_pixel(200, 10).0, [255, 255, 255]);
    }

    #[test]
    fn raster_errors() {
        assert!(matches!(
            render_raster(b"\x89PNG garbage"),
            Err(Error::InvalidImage(_))
        ));
        assert!(matches!(render_raster(b""), Err(Error::InvalidImage(_))));
    }
}
