//! Libraries of clip art: import from folders / Iconify JSON (through `learner::input`), or one
//! validated upload at a time. Each item is stored rendered (400x400 PNG, what workers see) with
//! its 169 features and an optional style label (used to build control questions).

use std::collections::HashMap;
use std::io::Cursor;
use std::path::{Path, PathBuf};

use image::RgbImage;
use sqlx::Row;

use crate::db::{Db, now_ms};
use crate::error::{AppError, Result};
use crate::ids::{ItemId, LibraryId};

/// Largest accepted upload, in bytes.
pub const MAX_UPLOAD_BYTES: usize = 5 * 1024 * 1024;
/// Largest accepted raster upload side, in pixels.
pub const MAX_UPLOAD_SIDE: u32 = 4096;

/// What an import did.
#[derive(Debug, Default, Clone, serde::Serialize)]
pub struct ImportReport {
    /// The library imported into.
    pub library: Option<LibraryId>,
    /// Items stored.
    pub imported: usize,
    /// Items already present (same name), left unchanged.
    pub existing: usize,
    /// Inputs that could not be used, with the reason.
    pub skipped: Vec<(String, String)>,
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

/// A rendered item ready to store.
#[derive(Debug, Clone)]
pub struct NewItem {
    /// Stable name inside the library (learner item id).
    pub name: String,
    /// Style label, if known.
    pub style: Option<String>,
    /// Keywords.
    pub tags: Vec<String>,
    /// 400x400 rendering.
    pub image: RgbImage,
}

/// Stores `item` in `library` (features extracted here). Returns `None` when an item with the
/// same name exists.
pub async fn insert_item(db: &Db, library: LibraryId, item: NewItem) -> Result<Option<ItemId>> {
    let NewItem {
        name,
        style,
        tags,
        image,
    } = item;
    let (png, features) = tokio::task::spawn_blocking(move || -> Result<(Vec<u8>, Vec<f64>)> {
        let mut png = Vec::new();
        image
            .write_to(&mut Cursor::new(&mut png), image::ImageFormat::Png)
            .map_err(AppError::internal)?;
        let features = learner::features::extract(image)
            .map_err(|e| AppError::BadRequest(format!("feature extraction failed: {e}")))?;
        Ok((png, features.to_vec()))
    })
    .await
    .map_err(AppError::internal)??;
    let seq_row = sqlx::query(
        "SELECT CAST(COALESCE(MAX(seq), 0) AS BIGINT) AS m FROM items WHERE library_id = $1",
    )
    .bind(library.0)
    .fetch_one(&db.pool)
    .await?;
    let seq: i64 = seq_row.try_get("m")?;
    let id = ItemId::generate();
    let result = sqlx::query(
        "INSERT INTO items (id, library_id, seq, name, style, tags, png, features) \
         VALUES ($1, $2, $3, $4, $5, $6, $7, $8) ON CONFLICT DO NOTHING",
    )
    .bind(id.0)
    .bind(library.0)
    .bind(seq + 1)
    .bind(&name)
    .bind(style)
    .bind(serde_json::to_string(&tags).map_err(AppError::internal)?)
    .bind(png)
    .bind(serde_json::to_string(&features).map_err(AppError::internal)?)
    .execute(&mut *db.write_conn().await?)
    .await?;
    Ok((result.rows_affected() == 1).then_some(id))
}

/// Reads the `file,style` columns of a labels CSV (the fixture's `labels.csv`).
pub fn read_styles(path: &Path) -> Result<HashMap<String, String>> {
    let mut reader = csv::Reader::from_path(path)
        .map_err(|e| AppError::BadRequest(format!("{}: {e}", path.display())))?;
    let headers = reader
        .headers()
        .map_err(|e| AppError::BadRequest(format!("{}: {e}", path.display())))?
        .clone();
    let file_col = headers.iter().position(|h| h.trim() == "file");
    let style_col = headers.iter().position(|h| h.trim() == "style");
    let (Some(file_col), Some(style_col)) = (file_col, style_col) else {
        return Err(AppError::BadRequest(format!(
            "{}: needs 'file' and 'style' columns",
            path.display()
        )));
    };
    let mut styles = HashMap::new();
    for record in reader.records() {
        let record =
            record.map_err(|e| AppError::BadRequest(format!("{}: {e}", path.display())))?;
        if let (Some(f), Some(s)) = (record.get(file_col), record.get(style_col))
            && !s.trim().is_empty()
        {
            styles.insert(f.trim().to_string(), s.trim().to_string());
        }
    }
    Ok(styles)
}

/// Imports SVG/raster folders and Iconify JSON files into the library `name`. `labels` is an
/// optional CSV with `file,style,keywords` columns (tags and style labels by item id).
pub async fn import_paths(
    db: &Db,
    name: &str,
    paths: &[PathBuf],
    labels: Option<&Path>,
) -> Result<ImportReport> {
    let library = ensure_library(db, name).await?;
    let styles = match labels {
        Some(p) => read_styles(p)?,
        None => HashMap::new(),
    };
    let paths = paths.to_vec();
    let labels = labels.map(Path::to_path_buf);
    let discovery =
        tokio::task::spawn_blocking(move || learner::input::discover(&paths, labels.as_deref()))
            .await
            .map_err(AppError::internal)?
            .map_err(|e| AppError::BadRequest(e.to_string()))?;
    let mut report = ImportReport {
        library: Some(library),
        skipped: discovery
            .errors
            .iter()
            .map(|e| (e.location.clone(), e.error.to_string()))
            .collect(),
        ..ImportReport::default()
    };
    for item in discovery.items {
        let id = item.id.clone();
        let rendered = tokio::task::spawn_blocking(move || item.render().map(|img| (item, img)))
            .await
            .map_err(AppError::internal)?;
        match rendered {
            Ok((item, image)) => {
                let new = NewItem {
                    style: styles.get(&item.id).cloned(),
                    name: item.id,
                    tags: item.tags,
                    image,
                };
                match insert_item(db, library, new).await? {
                    Some(_) => report.imported += 1,
                    None => report.existing += 1,
                }
            }
            Err(e) => report.skipped.push((id, e.to_string())),
        }
    }
    Ok(report)
}

/// Validates one uploaded file (by name and content) and renders it. SVG must parse and render;
/// rasters must be PNG/JPEG within [`MAX_UPLOAD_SIDE`]; everything within [`MAX_UPLOAD_BYTES`].
pub fn validate_upload(filename: &str, bytes: &[u8]) -> Result<RgbImage> {
    if bytes.is_empty() {
        return Err(AppError::BadRequest(format!("{filename}: empty file")));
    }
    if bytes.len() > MAX_UPLOAD_BYTES {
        return Err(AppError::TooLarge(format!(
            "{filename}: {} bytes, the limit is {MAX_UPLOAD_BYTES}",
            bytes.len()
        )));
    }
    let lower = filename.to_ascii_lowercase();
    if lower.ends_with(".svg") {
        learner::render::render_svg(bytes)
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
        learner::render::render_raster(bytes)
            .map_err(|e| AppError::BadRequest(format!("{filename}: not a readable image: {e}")))
    } else {
        Err(AppError::BadRequest(format!(
            "{filename}: unsupported type (use .svg, .png, .jpg)"
        )))
    }
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
            validate_upload("a.svg", ok).map(|i| i.width()).ok(),
            Some(400)
        );
    }
}
