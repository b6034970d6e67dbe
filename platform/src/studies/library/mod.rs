//! Libraries of clip art: import from folders / Iconify JSON (through `learner::input`), or one
//! validated upload at a time. Each item is stored rendered (400x400 PNG, what workers see) with
//! its 169 features and an optional style label (used to build control questions).

use std::collections::HashMap;
use std::io::Cursor;

use image::{RgbImage, RgbaImage};
use sqlx::Row;

use crate::error::{AppError, Result};
use crate::store::db::{Db, now_ms};
use crate::store::ids::{ItemId, LibraryId};

mod import;
mod upload;

pub use import::{Labels, import_paths, read_labels};
pub use upload::{
    MAX_UPLOAD_BYTES, MAX_UPLOAD_FILES, MAX_UPLOAD_SIDE, limit_in_words as upload_limit_in_words,
    validate_upload,
};

/// What an import did.
#[derive(Debug, Default, Clone, serde::Serialize)]
pub struct ImportReport {
    /// The library imported into.
    pub library: Option<LibraryId>,
    /// Items stored.
    pub imported: usize,
    /// Items already present (same name), left unchanged.
    pub existing: usize,
    /// Inputs that could not be used (file, and icon for Iconify sets), with the reason.
    pub skipped: Vec<(String, String)>,
    /// Things the researcher should know that did not stop an item (label rows naming no
    /// imported file, say).
    pub warnings: Vec<String>,
}

/// Returns the id of the library called `name`, creating it if needed.
pub async fn ensure_library(db: &Db, name: &str) -> Result<LibraryId> {
    let name = name.trim();
    if name.is_empty() || name.len() > 200 {
        return Err(AppError::BadRequest(
            "library name must be 1-200 characters".into(),
        ));
    }
    if let Some(row) = sqlx::query("SELECT id FROM libraries WHERE name = $1")
        .bind(name)
        .fetch_optional(&db.pool)
        .await?
    {
        return Ok(LibraryId(row.try_get("id")?));
    }
    let id = LibraryId::generate();
    sqlx::query(
        "INSERT INTO libraries (id, name, created_at) VALUES ($1, $2, $3) ON CONFLICT DO NOTHING",
    )
    .bind(id.0)
    .bind(name)
    .bind(now_ms())
    .execute(&mut *db.write_conn().await?)
    .await?;
    let row = sqlx::query("SELECT id FROM libraries WHERE name = $1")
        .bind(name)
        .fetch_one(&db.pool)
        .await?;
    Ok(LibraryId(row.try_get("id")?))
}

/// The id of an existing library (a clear 400 when there is none).
pub async fn ensure_existing(db: &Db, name: &str) -> Result<LibraryId> {
    let row = sqlx::query("SELECT id FROM libraries WHERE name = $1")
        .bind(name)
        .fetch_optional(&db.pool)
        .await?
        .ok_or_else(|| AppError::BadRequest(format!("no library named {name:?}")))?;
    Ok(LibraryId(row.try_get("id")?))
}

/// The names of every library, sorted.
pub async fn library_names(db: &Db) -> Result<Vec<String>> {
    sqlx::query("SELECT name FROM libraries ORDER BY name")
        .fetch_all(&db.pool)
        .await?
        .iter()
        .map(|r| r.try_get("name").map_err(AppError::from))
        .collect()
}

/// A rendered item ready to store.
#[derive(Debug, Clone)]
pub struct NewItem {
    /// Stable name inside the library (learner item id).
    pub name: String,
    /// Style label, if known.
    pub style: Option<String>,
    /// Keywords.
    pub tags: Vec<String>,
    /// 400x400 rendering on white (what the features see).
    pub image: RgbImage,
    /// For a raster item, the same 400x400 rendering with its transparency kept: a mash-up
    /// places it on its own background (§5.7.3). `None` for drawings (their SVG keeps it).
    pub cutout: Option<RgbaImage>,
    /// The drawing's vector source as usvg re-serialised it ([`svg_source`]); `None` for a
    /// raster item. Kept so mash-up exports stay vector (§5.7.3).
    pub svg: Option<String>,
}

/// The vector source stored for an SVG drawing: parsed with the learner's checks and written
/// back by usvg, so what the server keeps and serves has no scripts, external references or
/// unknown elements, only the drawing.
pub fn svg_source(svg: &[u8]) -> learner::Result<String> {
    learner::render::parse_svg(svg).map(|tree| tree.to_string(&usvg::WriteOptions::default()))
}

/// What [`insert_item`] did with an item.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Inserted {
    /// Stored under this id.
    New(ItemId),
    /// An item with the same name is in the library; left unchanged.
    AlreadyPresent,
    /// The drawing cannot be used (a blank drawing has no style to measure); the reason, for
    /// the researcher. Nothing was stored.
    Unusable(String),
}

/// Stores `item` in `library`, with its features extracted here. An item the features cannot
/// describe is [`Inserted::Unusable`], not an error: an import goes on with the next item.
pub async fn insert_item(db: &Db, library: LibraryId, item: NewItem) -> Result<Inserted> {
    let NewItem {
        name,
        style,
        tags,
        image,
        cutout,
        svg,
    } = item;
    let prepared = tokio::task::spawn_blocking(move || -> Result<_> {
        let mut png = Vec::new();
        image
            .write_to(&mut Cursor::new(&mut png), image::ImageFormat::Png)
            .map_err(AppError::internal)?;
        let cutout = cutout
            .map(|c| {
                let mut bytes = Vec::new();
                c.write_to(&mut Cursor::new(&mut bytes), image::ImageFormat::Png)
                    .map(|()| bytes)
            })
            .transpose()
            .map_err(AppError::internal)?;
        let features = match learner::features::extract(image) {
            Ok(f) => f,
            Err(learner::Error::BlankImage) => {
                return Ok(Err(
                    "blank drawing (nothing but white on the canvas)".to_string()
                ));
            }
            Err(e) => return Ok(Err(format!("style features failed: {e}"))),
        };
        Ok(Ok((png, cutout, features.to_vec())))
    })
    .await
    .map_err(AppError::internal)??;
    let (png, cutout, features) = match prepared {
        Ok(p) => p,
        Err(reason) => return Ok(Inserted::Unusable(reason)),
    };
    let seq_row = sqlx::query(
        "SELECT CAST(COALESCE(MAX(seq), 0) AS BIGINT) AS m FROM items WHERE library_id = $1",
    )
    .bind(library.0)
    .fetch_one(&db.pool)
    .await?;
    let seq: i64 = seq_row.try_get("m")?;
    let id = ItemId::generate();
    let result = sqlx::query(
        "INSERT INTO items (id, library_id, seq, name, style, tags, png, features, svg, cutout) \
         VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10) ON CONFLICT DO NOTHING",
    )
    .bind(id.0)
    .bind(library.0)
    .bind(seq + 1)
    .bind(&name)
    .bind(style)
    .bind(serde_json::to_string(&tags).map_err(AppError::internal)?)
    .bind(png)
    .bind(serde_json::to_string(&features).map_err(AppError::internal)?)
    .bind(svg)
    .bind(cutout)
    .execute(&mut *db.write_conn().await?)
    .await?;
    Ok(if result.rows_affected() == 1 {
        Inserted::New(id)
    } else {
        Inserted::AlreadyPresent
    })
}

/// One stored item, without its image bytes.
#[derive(Debug, Clone, serde::Serialize)]
pub struct ItemInfo {
    /// Id.
    pub id: ItemId,
    /// Name in the library.
    pub name: String,
    /// Style label.
    pub style: Option<String>,
}

/// The items of a library in stable (import) order.
pub async fn list_items(db: &Db, library: LibraryId) -> Result<Vec<ItemInfo>> {
    let rows = sqlx::query("SELECT id, name, style FROM items WHERE library_id = $1 ORDER BY seq")
        .bind(library.0)
        .fetch_all(&db.pool)
        .await?;
    rows.iter()
        .map(|r| {
            Ok(ItemInfo {
                id: ItemId(r.try_get("id")?),
                name: r.try_get("name")?,
                style: r.try_get("style")?,
            })
        })
        .collect()
}

/// The features of the items of a library, by id.
pub async fn item_features(db: &Db, library: LibraryId) -> Result<HashMap<ItemId, Vec<f64>>> {
    let rows = sqlx::query("SELECT id, features FROM items WHERE library_id = $1")
        .bind(library.0)
        .fetch_all(&db.pool)
        .await?;
    let mut out = HashMap::new();
    for r in rows {
        let text: String = r.try_get("features")?;
        let v: Vec<f64> = serde_json::from_str(&text).map_err(AppError::internal)?;
        out.insert(ItemId(r.try_get("id")?), v);
    }
    Ok(out)
}

/// The PNG of an item.
pub async fn item_png(db: &Db, id: ItemId) -> Result<Vec<u8>> {
    let row = sqlx::query("SELECT png FROM items WHERE id = $1")
        .bind(id.0)
        .fetch_optional(&db.pool)
        .await?
        .ok_or(AppError::NotFound("item"))?;
    Ok(row.try_get("png")?)
}
