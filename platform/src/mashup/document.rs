//! The composition document: what a mash-up canvas holds (§5.7.3), as JSON
//!
//! ```json
//! {"version":1,"width":800,"height":600,"background":"grass",
//!  "pieces":[{"item":12,"x":400,"y":300,"scale":1,"rotation":0}]}
//! ```
//!
//! `pieces` are listed bottom to top (layer order). A piece is its item's drawing fitted into a
//! [`PIECE_SIZE`]-pixel square, multiplied by `scale`, rotated by `rotation` degrees (clockwise)
//! about its centre, with the centre at (`x`, `y`) in document pixels.
//!
//! Everything a client sends is checked here before it is stored or rendered: size of the JSON
//! first, then its shape (no unknown fields), then every number and name; the items' library is
//! checked against the database by [`crate::mashup::store::check_items`].

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::backgrounds;
use crate::error::{AppError, Result};
use crate::store::ids::ItemId;

/// The document format's version.
pub const VERSION: u32 = 1;
/// Largest document JSON accepted, in bytes.
pub const MAX_DOCUMENT_BYTES: usize = 256 * 1024;
/// Smallest and largest canvas side, in pixels.
pub const MIN_SIDE: u32 = 16;
/// Largest canvas side, in pixels.
pub const MAX_SIDE: u32 = 4096;
/// Most pieces on one canvas.
pub const MAX_PIECES: usize = 200;
/// Side of the square an item is fitted into at scale 1, in document pixels.
pub const PIECE_SIZE: f64 = 160.0;
/// Smallest scale of a piece.
pub const MIN_SCALE: f64 = 0.05;
/// Largest scale of a piece.
pub const MAX_SCALE: f64 = 20.0;
/// Rotations are within ±this many degrees.
pub const MAX_ROTATION: f64 = 360.0;

/// A composition.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Document {
    /// Always 1.
    pub version: u32,
    /// Canvas width in pixels (16–4096).
    #[schema(minimum = 16, maximum = 4096)]
    pub width: u32,
    /// Canvas height in pixels (16–4096).
    #[schema(minimum = 16, maximum = 4096)]
    pub height: u32,
    /// One of the 11 background names (`blank`, `grass`, …).
    #[schema(value_type = backgrounds::BackgroundName)]
    pub background: String,
    /// The pieces, bottom to top (at most 200).
    #[schema(max_items = 200)]
    pub pieces: Vec<Piece>,
}

/// One piece of clip art on the canvas.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct Piece {
    /// The item (of the composition's library).
    pub item: ItemId,
    /// Centre, in canvas pixels (−width … 2·width).
    pub x: f64,
    /// Centre, in canvas pixels (−height … 2·height).
    pub y: f64,
    /// Size relative to a 160-pixel square (0.05–20).
    pub scale: f64,
    /// Clockwise rotation in degrees (−360 … 360).
    pub rotation: f64,
}

impl Document {
    /// An empty canvas.
    pub fn empty(width: u32, height: u32, background: &str) -> Self {
        Self {
            version: VERSION,
            width,
            height,
            background: background.into(),
            pieces: Vec::new(),
        }
    }

    /// Reads and [`validate`](Self::validate)s a document from JSON bytes; the size is checked
    /// before anything is parsed.
    pub fn parse(bytes: &[u8]) -> Result<Self> {
        if bytes.len() > MAX_DOCUMENT_BYTES {
            return Err(AppError::TooLarge(format!(
                "document: {} bytes, the limit is {MAX_DOCUMENT_BYTES}",
                bytes.len()
            )));
        }
        let doc: Self = crate::web::extract::strict_json::from_slice(bytes)
            .map_err(|e| AppError::BadRequest(format!("document: {e}")))?;
        doc.validate()?;
        Ok(doc)
    }

    /// The document as JSON (as stored).
    pub fn to_json(&self) -> Result<String> {
        serde_json::to_string(self).map_err(AppError::internal)
    }

    /// Checks every field: version, canvas size, background name, number of pieces, every
    /// piece's numbers finite and in range, and the JSON size. A 400 names the field at fault
    /// (a 413 for an oversized document).
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(AppError::BadRequest(format!("document: {m}")));
        if self.version != VERSION {
            return bad(format!("version: {VERSION} expected, not {}", self.version));
        }
        for (name, side) in [("width", self.width), ("height", self.height)] {
            if !(MIN_SIDE..=MAX_SIDE).contains(&side) {
                return bad(format!(
                    "{name}: {MIN_SIDE}..={MAX_SIDE} pixels, not {side}"
                ));
            }
        }
        if backgrounds::by_name(&self.background).is_none() {
            let known: Vec<&str> = backgrounds::BACKGROUNDS.iter().map(|b| b.name).collect();
            return bad(format!(
                "background: unknown {:?} (one of {})",
                self.background.chars().take(40).collect::<String>(),
                known.join(", ")
            ));
        }
        if self.pieces.len() > MAX_PIECES {
            return bad(format!(
                "pieces: at most {MAX_PIECES}, not {}",
                self.pieces.len()
            ));
        }
        let (w, h) = (f64::from(self.width), f64::from(self.height));
        for (i, p) in self.pieces.iter().enumerate() {
            let checks = [
                ("x", p.x, -w, 2.0 * w),
                ("y", p.y, -h, 2.0 * h),
                ("scale", p.scale, MIN_SCALE, MAX_SCALE),
                ("rotation", p.rotation, -MAX_ROTATION, MAX_ROTATION),
            ];
            for (name, value, lo, hi) in checks {
                if !value.is_finite() || value < lo || value > hi {
                    return bad(format!("pieces[{i}].{name}: {lo}..={hi}, not {value}"));
                }
            }
            if p.item.0 <= 0 {
                return bad(format!("pieces[{i}].item: not an item id ({})", p.item));
            }
        }
        let size = self.to_json()?.len();
        if size > MAX_DOCUMENT_BYTES {
            return Err(AppError::TooLarge(format!(
                "document: {size} bytes, the limit is {MAX_DOCUMENT_BYTES}"
            )));
        }
        Ok(())
    }

    /// The distinct items, in order of first appearance (bottom to top).
    pub fn items(&self) -> Vec<ItemId> {
        let mut out: Vec<ItemId> = Vec::new();
        for p in &self.pieces {
            if !out.contains(&p.item) {
                out.push(p.item);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn doc(pieces: &str) -> String {
        format!(
            r#"{{"version":1,"width":800,"height":600,"background":"grass","pieces":[{pieces}]}}"#
        )
    }

    const PIECE: &str = r#"{"item":7,"x":100,"y":50.5,"scale":1.5,"rotation":-30}"#;

    fn refused(json: &str) -> String {
        match Document::parse(json.as_bytes()) {
            Ok(d) => panic!("accepted {d:?}"),
            Err(e) => {
                assert!(
                    matches!(e, AppError::BadRequest(_) | AppError::TooLarge(_)),
                    "{e:?}"
                );
                e.to_string()
            }
        }
    }

    #[test]
    fn a_valid_document_round_trips() {
        let json = doc(&format!("{PIECE},{PIECE}"));
        let d = Document::parse(json.as_bytes()).expect("valid");
        assert_eq!(d.pieces.len(), 2);
        assert_eq!(d.pieces[0].item, ItemId(7));
        assert_eq!(d.items(), vec![ItemId(7)]);
        let again = Document::parse(d.to_json().expect("json").as_bytes()).expect("again");
        assert_eq!(again, d);
        // Whole numbers written as floats are accepted for integer fields (JSON Schema).
        let float_sizes = doc("").replace("800", "800.0");
        assert!(Document::parse(float_sizes.as_bytes()).is_ok());
    }

    #[test]
    fn every_bad_field_is_refused_with_its_name() {
        assert!(refused("{").contains("not valid JSON"));
        assert!(refused("[1,800,600,\"grass\",[]]").contains("document"));
        assert!(refused(&doc("").replace("\"version\":1", "\"version\":2")).contains("version"));
        assert!(refused(&doc("").replace("800", "8")).contains("width"));
        assert!(refused(&doc("").replace("600", "5000")).contains("height"));
        assert!(refused(&doc("").replace("grass", "lava")).contains("background"));
        assert!(refused(&doc("").replace("}", ",\"extra\":1}")).contains("extra"));
        assert!(refused(&doc(&PIECE.replace("1.5", "0"))).contains("pieces[0].scale"));
        assert!(refused(&doc(&PIECE.replace("1.5", "1e9"))).contains("scale"));
        assert!(refused(&doc(&PIECE.replace("-30", "720"))).contains("rotation"));
        assert!(refused(&doc(&PIECE.replace("100", "99999"))).contains("pieces[0].x"));
        assert!(refused(&doc(&PIECE.replace("50.5", "\"50\""))).contains("pieces[0].y"));
        assert!(refused(&doc(&PIECE.replace("7", "-7"))).contains("item"));
        assert!(refused(&doc(&PIECE.replace("7", "7.5"))).contains("item"));
        assert!(
            refused(&doc(
                &PIECE.replace("\"rotation\":-30", "\"rotation\":-30,\"z\":1")
            ))
            .contains("z")
        );
        assert!(refused(&doc(&PIECE.replace(",\"rotation\":-30", ""))).contains("rotation"));
        // NaN and infinities are not JSON; an overflowing number is refused by the parser.
        assert!(refused(&doc(&PIECE.replace("100", "1e999"))).contains("JSON"));
    }

    #[test]
    fn too_many_pieces_and_oversized_documents_are_refused() {
        let many = vec![PIECE; MAX_PIECES + 1].join(",");
        assert!(refused(&doc(&many)).contains("at most 200"));
        let ok = vec![PIECE; MAX_PIECES].join(",");
        assert!(Document::parse(doc(&ok).as_bytes()).is_ok());
        let padded = format!("{}{}", doc(""), " ".repeat(MAX_DOCUMENT_BYTES));
        let e = Document::parse(padded.as_bytes()).expect_err("oversized");
        assert!(matches!(e, AppError::TooLarge(_)), "{e:?}");
    }
}
