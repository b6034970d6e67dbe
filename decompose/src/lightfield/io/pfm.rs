//! Portable float maps (PFM), the format of the HCI benchmark's disparity maps: a header
//! `PF` (RGB) or `Pf` (grey), `width height`, and a scale whose sign gives the byte order
//! (negative: little-endian), then 32-bit floats with rows stored **bottom to top**.

use std::path::Path;

use crate::error::{Error, Result};
use crate::image::Image;

fn bad(path: &Path, message: impl Into<String>) -> Error {
    Error::Format {
        path: path.to_path_buf(),
        message: message.into(),
    }
}

/// Reads a PFM file into an image (1 or 3 channels, top row first).
pub fn read(path: &Path) -> Result<Image> {
    let bytes = std::fs::read(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    decode(&bytes, path)
}

/// Splits off one whitespace-delimited header token.
fn token<'a>(bytes: &'a [u8], at: &mut usize, path: &Path) -> Result<&'a str> {
    while *at < bytes.len() && bytes[*at].is_ascii_whitespace() {
        *at += 1;
    }
    let start = *at;
    while *at < bytes.len() && !bytes[*at].is_ascii_whitespace() {
        *at += 1;
    }
    if start == *at || start > 64 {
        return Err(bad(path, "truncated or malformed PFM header"));
    }
    std::str::from_utf8(&bytes[start..*at]).map_err(|_| bad(path, "PFM header is not ASCII"))
}

/// Decodes PFM bytes; `path` labels errors.
pub fn decode(bytes: &[u8], path: &Path) -> Result<Image> {
    let mut at = 0;
    let channels = match token(bytes, &mut at, path)? {
        "PF" => 3,
        "Pf" => 1,
        other => {
            return Err(bad(
                path,
                format!("starts with {other:?}, not the PFM magic PF or Pf"),
            ));
        }
    };
    let dim = |s: &str| {
        s.parse::<u32>()
            .ok()
            .filter(|&v| v > 0 && v <= 1 << 16)
            .ok_or_else(|| bad(path, format!("PFM size {s:?} is not between 1 and 65536")))
    };
    let width = dim(token(bytes, &mut at, path)?)?;
    let height = dim(token(bytes, &mut at, path)?)?;
    let scale: f32 = token(bytes, &mut at, path)?
        .parse()
        .ok()
        .filter(|s: &f32| s.is_finite() && *s != 0.0)
        .ok_or_else(|| bad(path, "PFM scale is not a non-zero number"))?;
    // Exactly one whitespace byte separates the header from the data.
    at += 1;
    let n = width as usize * height as usize * channels;
    let data = bytes.get(at..).unwrap_or(&[]);
    if data.len() != n * 4 {
        return Err(bad(
            path,
            format!(
                "holds {} data bytes, but {width}x{height}x{channels} floats need {}",
                data.len(),
                n * 4
            ),
        ));
    }
    let row = width as usize * channels;
    let mut out = vec![0.0f32; n];
    for (i, chunk) in data.chunks_exact(4).enumerate() {
        let b = [chunk[0], chunk[1], chunk[2], chunk[3]];
        let v = if scale < 0.0 {
            f32::from_le_bytes(b)
        } else {
            f32::from_be_bytes(b)
        };
        // File row r (from the bottom) is image row height−1−r.
        let (r, c) = (i / row, i % row);
        out[(height as usize - 1 - r) * row + c] = v;
    }
    Image::from_vec(width, height, channels, out)
}

/// Encodes an image of 1 or 3 channels as little-endian PFM.
pub fn encode(img: &Image) -> Result<Vec<u8>> {
    let magic = match img.channels() {
        1 => "Pf",
        3 => "PF",
        c => return Err(Error::param("channels", c, "PFM holds 1 or 3 channels")),
    };
    let mut out = format!("{magic}\n{} {}\n-1\n", img.width(), img.height()).into_bytes();
    let row = img.width() as usize * img.channels();
    for r in (0..img.height() as usize).rev() {
        for v in &img.data()[r * row..(r + 1) * row] {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    Ok(out)
}

/// Writes an image of 1 or 3 channels as a little-endian PFM file.
pub fn write(path: &Path, img: &Image) -> Result<()> {
    std::fs::write(path, encode(img)?).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })
}
