//! Image files: PNG, JPEG and TIFF in 8 or 16 bits (and 32-bit float TIFF), masks, and output
//! encoding.
//!
//! Integer files are taken to be sRGB-encoded and are linearised unless
//! [`LoadOptions::linear`] is set (RAW-derived linear files, the MIT data set). Float TIFFs are
//! always taken as linear. Outputs are display-gamma (sRGB-encoded) by default: the linear
//! values an algorithm produces would look too dark on screen, and the MIT convention of
//! storing linear 16-bit data is available with [`Encoding::Linear`].

use std::io::Cursor;
use std::path::Path;

use image::{DynamicImage, ImageBuffer, ImageReader, Luma, Rgb};

use crate::color::{linear_to_srgb, srgb_to_linear};
use crate::error::{Error, Result};
use crate::image::{Image, Mask};

/// Default cap on input size: 100 megapixels.
pub const DEFAULT_MAX_PIXELS: u64 = 100_000_000;

/// How to interpret an input file.
#[derive(Clone, Copy, Debug)]
pub struct LoadOptions {
    /// The integer samples are already linear (no sRGB decoding).
    pub linear: bool,
    /// Largest accepted width × height.
    pub max_pixels: u64,
}

impl Default for LoadOptions {
    fn default() -> Self {
        Self {
            linear: false,
            max_pixels: DEFAULT_MAX_PIXELS,
        }
    }
}

/// Transfer curve of a written file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    /// sRGB-encoded (display gamma); the default for outputs.
    Srgb,
    /// Linear samples.
    Linear,
}

/// Bits per sample of a written file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Depth {
    /// 8 bits.
    Eight,
    /// 16 bits.
    Sixteen,
}

fn read_bytes(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })
}

fn codec(path: &Path, e: impl ToString) -> Error {
    Error::Codec {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

fn decode(bytes: &[u8], path: &Path, max_pixels: u64) -> Result<DynamicImage> {
    let reader = ImageReader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| codec(path, e))?;
    let (w, h) = reader.into_dimensions().map_err(|e| codec(path, e))?;
    if w == 0 || h == 0 {
        return Err(Error::EmptyImage {
            width: w,
            height: h,
        });
    }
    if w as u64 * h as u64 > max_pixels {
        return Err(Error::TooLarge {
            width: w,
            height: h,
            limit: max_pixels,
        });
    }
    let mut reader = ImageReader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| codec(path, e))?;
    let mut limits = image::Limits::default();
    // 16 bytes per pixel covers RGBA f32; the default 512 MiB cap would refuse large valid inputs.
    limits.max_alloc = Some(max_pixels.saturating_mul(16));
    reader.limits(limits);
    reader.decode().map_err(|e| codec(path, e))
}

/// Decodes an in-memory file into linear RGB. `path` only labels errors.
pub fn decode_rgb(bytes: &[u8], path: &Path, opts: LoadOptions) -> Result<Image> {
    let img = decode(bytes, path, opts.max_pixels)?;
    let float = matches!(
        img,
        DynamicImage::ImageRgb32F(_) | DynamicImage::ImageRgba32F(_)
    );
    let rgb = img.to_rgb32f();
    let (w, h) = rgb.dimensions();
    let mut data = rgb.into_raw();
    for (i, v) in data.iter_mut().enumerate() {
        let (x, y) = (((i / 3) % w as usize) as u32, ((i / 3) / w as usize) as u32);
        if !v.is_finite() {
            return Err(Error::NonFinite { x, y });
        }
        if *v < 0.0 {
            return Err(Error::Negative { x, y, value: *v });
        }
        if !float && !opts.linear {
            *v = srgb_to_linear(*v);
        }
    }
    Image::from_vec(w, h, 3, data)
}

/// Reads a PNG/JPEG/TIFF file into linear RGB.
pub fn load_rgb(path: impl AsRef<Path>, opts: LoadOptions) -> Result<Image> {
    let path = path.as_ref();
    decode_rgb(&read_bytes(path)?, path, opts)
}

/// Reads a single-channel linear image (e.g. ground-truth shading); colour files are averaged.
pub fn load_gray(path: impl AsRef<Path>, opts: LoadOptions) -> Result<Image> {
    let rgb = load_rgb(path, opts)?;
    let mut out = Image::new(rgb.width(), rgb.height(), 1);
    for i in 0..rgb.len() {
        let p = rgb.px(i);
        out.px_mut(i)[0] = (p[0] + p[1] + p[2]) / 3.0;
    }
    Ok(out)
}

/// Reads a mask: a pixel is selected when its mean sample exceeds half of full scale.
pub fn load_mask(path: impl AsRef<Path>) -> Result<Mask> {
    let path = path.as_ref();
    let img = decode(&read_bytes(path)?, path, DEFAULT_MAX_PIXELS)?.to_rgb32f();
    let (w, h) = img.dimensions();
    let data = img
        .pixels()
        .map(|p| (p.0[0] + p.0[1] + p.0[2]) / 3.0 > 0.5)
        .collect();
    Mask::from_vec(w, h, data)
}

fn quantise(v: f32, enc: Encoding, max: f32) -> f32 {
    let v = if v.is_finite() {
        v.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let v = match enc {
        Encoding::Srgb => linear_to_srgb(v),
        Encoding::Linear => v,
    };
    (v * max).round()
}

/// Writes a 1- or 3-channel image with values in [0, 1] (clamped) as PNG or TIFF (by extension).
pub fn save(path: impl AsRef<Path>, img: &Image, enc: Encoding, depth: Depth) -> Result<()> {
    let path = path.as_ref();
    let (w, h) = img.dims();
    let res = match (img.channels(), depth) {
        (1, Depth::Eight) => {
            let d = img.data().iter().map(|&v| quantise(v, enc, 255.0) as u8);
            ImageBuffer::<Luma<u8>, _>::from_raw(w, h, d.collect::<Vec<_>>()).map(|b| b.save(path))
        }
        (1, Depth::Sixteen) => {
            let d = img.data().iter().map(|&v| quantise(v, enc, 65535.0) as u16);
            ImageBuffer::<Luma<u16>, _>::from_raw(w, h, d.collect::<Vec<_>>()).map(|b| b.save(path))
        }
        (3, Depth::Eight) => {
            let d = img.data().iter().map(|&v| quantise(v, enc, 255.0) as u8);
            ImageBuffer::<Rgb<u8>, _>::from_raw(w, h, d.collect::<Vec<_>>()).map(|b| b.save(path))
        }
        (3, Depth::Sixteen) => {
            let d = img.data().iter().map(|&v| quantise(v, enc, 65535.0) as u16);
            ImageBuffer::<Rgb<u16>, _>::from_raw(w, h, d.collect::<Vec<_>>()).map(|b| b.save(path))
        }
        (c, _) => return Err(Error::param("channels", c, "must be 1 or 3 to save")),
    };
    match res {
        Some(Ok(())) => Ok(()),
        Some(Err(e)) => Err(codec(path, e)),
        None => Err(codec(path, "buffer size does not match dimensions")),
    }
}

/// Writes a 1- or 3-channel image as a 32-bit float RGB TIFF: linear, unclipped, unscaled (a
/// 1-channel image is written as three equal channels: the `image` crate's TIFF writer, and
/// [`load_rgb`], handle floating-point colour only). Non-finite values are refused.
pub fn save_float_tiff(path: impl AsRef<Path>, img: &Image) -> Result<()> {
    let path = path.as_ref();
    let (w, h) = img.dims();
    let data: Vec<f32> = match img.channels() {
        3 => img.data().to_vec(),
        1 => img.data().iter().flat_map(|&v| [v, v, v]).collect(),
        c => return Err(Error::param("channels", c, "must be 1 or 3 to save")),
    };
    if let Some(i) = data.iter().position(|v| !v.is_finite()) {
        let p = (i / 3) as u32;
        return Err(Error::NonFinite {
            x: p % w.max(1),
            y: p / w.max(1),
        });
    }
    match ImageBuffer::<Rgb<f32>, _>::from_raw(w, h, data) {
        Some(b) => DynamicImage::ImageRgb32F(b)
            .save_with_format(path, image::ImageFormat::Tiff)
            .map_err(|e| codec(path, e)),
        None => Err(codec(path, "buffer size does not match dimensions")),
    }
}

/// Writes 8-bit sRGB colours given as bytes (false-colour maps, plots) to a PNG file.
pub fn save_rgb8(path: impl AsRef<Path>, width: u32, height: u32, rgb: Vec<u8>) -> Result<()> {
    let path = path.as_ref();
    match ImageBuffer::<Rgb<u8>, _>::from_raw(width, height, rgb) {
        Some(b) => b.save(path).map_err(|e| codec(path, e)),
        None => Err(codec(path, "buffer size does not match dimensions")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn garbage_is_a_codec_error() {
        let e = decode_rgb(b"not an image", Path::new("x.png"), LoadOptions::default());
        assert!(matches!(e, Err(Error::Codec { .. })), "{e:?}");
    }

    #[test]
    fn round_trip_16_bit_linear() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.png");
        let img = Image::from_fn(4, 3, |x, y| [x as f32 / 4.0, y as f32 / 3.0, 0.5]);
        save(&p, &img, Encoding::Linear, Depth::Sixteen).unwrap();
        let back = load_rgb(
            &p,
            LoadOptions {
                linear: true,
                ..Default::default()
            },
        )
        .unwrap();
        for (a, b) in img.data().iter().zip(back.data()) {
            assert!((a - b).abs() < 1e-4);
        }
    }

    #[test]
    fn round_trip_8_bit_srgb() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.png");
        let img = Image::from_fn(4, 3, |x, _| [x as f32 / 4.0, 0.2, 0.9]);
        save(&p, &img, Encoding::Srgb, Depth::Eight).unwrap();
        let back = load_rgb(&p, LoadOptions::default()).unwrap();
        for (a, b) in img.data().iter().zip(back.data()) {
            assert!((a - b).abs() < 0.01, "{a} {b}");
        }
    }

    #[test]
    fn too_large_is_refused_before_decoding() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.png");
        save(&p, &Image::new(20, 20, 3), Encoding::Srgb, Depth::Eight).unwrap();
        let e = load_rgb(
            &p,
            LoadOptions {
                max_pixels: 100,
                ..Default::default()
            },
        );
        assert!(
            matches!(e, Err(Error::TooLarge { limit: 100, .. })),
            "{e:?}"
        );
    }
}
