//! Middlebury `.flo` files (Baker, Scharstein, Lewis, Roth, Black & Szeliski, "A Database and
//! Evaluation Methodology for Optical Flow", IJCV 2011; the format of their `flow-code`):
//!
//! ```text
//! bytes 0..4    "PIEH" (the little-endian float 202021.25, a sanity check)
//! bytes 4..8    width, little-endian i32
//! bytes 8..12   height, little-endian i32
//! then          width·height pairs (u, v) of little-endian f32, rows top to bottom
//! ```
//!
//! A component whose magnitude exceeds [`UNKNOWN_FLOW_THRESHOLD`] (or that is NaN) marks the
//! pixel's flow as unknown; writers use [`UNKNOWN_FLOW`]. The sign convention is the file
//! writer's business: ours (`scripts/render_video.py`) is that of [`crate::video::flow`],
//! `next(x + u, y + v) ≈ prev(x, y)`, which is also Middlebury's.

use std::path::Path;

use crate::error::{Error, Result};
use crate::video::flow::Flow;

/// The first four bytes of a `.flo` file.
pub const FLO_MAGIC: &[u8; 4] = b"PIEH";

/// The value Middlebury's code writes for an unknown flow component (`UNKNOWN_FLOW`).
pub const UNKNOWN_FLOW: f32 = 1e10;

/// Components with a larger magnitude mark the flow as unknown (`UNKNOWN_FLOW_THRESH`).
pub const UNKNOWN_FLOW_THRESHOLD: f32 = 1e9;

/// Whether a flow vector is known: both components finite and within
/// [`UNKNOWN_FLOW_THRESHOLD`] (Middlebury's `unknown_flow` negated).
pub fn is_known(u: f32, v: f32) -> bool {
    u.abs() <= UNKNOWN_FLOW_THRESHOLD && v.abs() <= UNKNOWN_FLOW_THRESHOLD
}

fn malformed(path: &Path, message: String) -> Error {
    Error::Format {
        path: path.to_path_buf(),
        message,
    }
}

/// Reads a `.flo` file. Errors: [`Error::Io`] when it cannot be read, [`Error::Format`] (with
/// the path) for a bad magic number, a non-positive size, or a length that does not match
/// the header (truncated or with trailing bytes).
pub fn read_flo(path: impl AsRef<Path>) -> Result<Flow> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    if bytes.len() < 12 {
        return Err(malformed(
            path,
            format!("truncated .flo header ({} bytes, need 12)", bytes.len()),
        ));
    }
    if &bytes[0..4] != FLO_MAGIC {
        return Err(malformed(
            path,
            format!(
                "not a .flo file (magic {:?}, expected \"PIEH\")",
                String::from_utf8_lossy(&bytes[0..4])
            ),
        ));
    }
    let int = |i: usize| i32::from_le_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    let (w, h) = (int(4), int(8));
    if w <= 0 || h <= 0 {
        return Err(malformed(path, format!("bad .flo size {w}x{h}")));
    }
    let n = w as usize * h as usize;
    let expected = n
        .checked_mul(8)
        .and_then(|b| b.checked_add(12))
        .ok_or_else(|| malformed(path, format!("bad .flo size {w}x{h}")))?;
    if bytes.len() != expected {
        let what = if bytes.len() < expected {
            "truncated"
        } else {
            "trailing bytes in"
        };
        return Err(malformed(
            path,
            format!(
                "{what} .flo data: {} bytes, a {w}x{h} flow needs {expected}",
                bytes.len()
            ),
        ));
    }
    let mut u = Vec::with_capacity(n);
    let mut v = Vec::with_capacity(n);
    for pair in bytes[12..].chunks_exact(8) {
        u.push(f32::from_le_bytes([pair[0], pair[1], pair[2], pair[3]]));
        v.push(f32::from_le_bytes([pair[4], pair[5], pair[6], pair[7]]));
    }
    Flow::from_vecs(w as u32, h as u32, u, v)
}

/// Writes a flow as a `.flo` file (unknown vectors are written as they are held, normally
/// [`UNKNOWN_FLOW`]). Errors: [`Error::InvalidParam`] for an empty flow or one too large for
/// the format's i32 sizes, [`Error::Io`] when the file cannot be written.
pub fn write_flo(path: impl AsRef<Path>, flow: &Flow) -> Result<()> {
    let path = path.as_ref();
    let (w, h) = flow.dims();
    if w == 0 || h == 0 || w > i32::MAX as u32 || h > i32::MAX as u32 {
        return Err(Error::param(
            "flow.dims()",
            format!("{w}x{h}"),
            "a .flo file holds 1 to 2^31 - 1 pixels per side",
        ));
    }
    let mut bytes = Vec::with_capacity(12 + 8 * flow.u().len());
    bytes.extend_from_slice(FLO_MAGIC);
    bytes.extend_from_slice(&(w as i32).to_le_bytes());
    bytes.extend_from_slice(&(h as i32).to_le_bytes());
    for (u, v) in flow.u().iter().zip(flow.v()) {
        bytes.extend_from_slice(&u.to_le_bytes());
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    std::fs::write(path, bytes).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Reads only the size from a `.flo` header (for checks before any frame is loaded).
pub(super) fn read_flo_size(path: &Path) -> Result<(u32, u32)> {
    use std::io::Read;
    let mut head = [0u8; 12];
    let mut file = std::fs::File::open(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })?;
    file.read_exact(&mut head)
        .map_err(|_| malformed(path, "truncated .flo header (need 12 bytes)".into()))?;
    if &head[0..4] != FLO_MAGIC {
        return Err(malformed(
            path,
            "not a .flo file (magic is not \"PIEH\")".into(),
        ));
    }
    let w = i32::from_le_bytes([head[4], head[5], head[6], head[7]]);
    let h = i32::from_le_bytes([head[8], head[9], head[10], head[11]]);
    if w <= 0 || h <= 0 {
        return Err(malformed(path, format!("bad .flo size {w}x{h}")));
    }
    Ok((w as u32, h as u32))
}
