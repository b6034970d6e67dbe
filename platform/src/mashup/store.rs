//! Saved compositions (table `compositions`, migration 0012) on SQLite and PostgreSQL, and the
//! check that a document uses only items of its library. Bound parameters only.

use serde::Serialize;
use sqlx::Row;
use utoipa::ToSchema;

use super::document::Document;
use crate::error::{AppError, Result};
use crate::store::db::{Db, now_ms};
use crate::store::ids::{CompositionId, ItemId, LibraryId};

/// Longest composition name, in characters.
pub const MAX_NAME_CHARS: usize = 200;

/// A stored composition.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct Composition {
    /// Its id.
    pub id: CompositionId,
    /// The library its pieces come from (name).
    pub library: String,
    /// Its name.
    pub name: String,
    /// The canvas.
    pub document: Document,
    /// Unix milliseconds.
    pub created_at: i64,
    /// Unix milliseconds.
    pub updated_at: i64,
}

/// A composition in a list (no document).
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct CompositionSummary {
    /// Its id.
    pub id: CompositionId,
    /// Its name.
    pub name: String,
    /// How many pieces it has.
    pub pieces: usize,
    /// Unix milliseconds.
    pub updated_at: i64,
}

/// A trimmed name of 1–200 characters without control characters.
pub fn check_name(name: &str) -> Result<String> {
    let name = name.trim();
    if name.is_empty() || name.chars().count() > MAX_NAME_CHARS {
        return Err(AppError::BadRequest(format!(
            "name: 1..={MAX_NAME_CHARS} characters"
        )));
    }
    if name.chars().any(char::is_control) {
        return Err(AppError::BadRequest(
            "name: control characters are not allowed".into(),
        ));
    }
    Ok(name.to_string())
}

/// Refuses (400) a document with an item that does not exist or belongs to another library,
/// naming the first such item.
pub async fn check_items(db: &Db, library: LibraryId, doc: &Document) -> Result<()> {
    let wanted = doc.items();
    if wanted.is_empty() {
        return Ok(());
    }
    // One query with one bound parameter per distinct item (at most 200).
    let placeholders: Vec<String> = (0..wanted.len()).map(|i| format!("${}", i + 2)).collect();
    let sql = format!(
        "SELECT id FROM items WHERE library_id = $1 AND id IN ({})",
        placeholders.join(", ")
    );
    // Safe: the text holds only generated `$n` placeholders; the ids are bound.
    let mut query = sqlx::query(sqlx::AssertSqlSafe(sql)).bind(library.0);
    for id in &wanted {
        query = query.bind(id.0);
    }
    let found: Vec<i64> = query
        .fetch_all(&db.pool)
        .await?
        .iter()
        .map(|r| r.try_get("id"))
        .collect::<std::result::Result<_, _>>()?;
    match wanted.iter().find(|id| !found.contains(&id.0)) {
        Some(missing) => Err(AppError::BadRequest(format!(
            "document: item {missing} is not in this library"
        ))),
        None => Ok(()),
    }
}

/// Stores a new composition (the caller has validated `doc` and run [`check_items`]).
pub async fn create(
    db: &Db,
    library: LibraryId,
    name: &str,
    doc: &Document,
) -> Result<CompositionId> {
    let id = CompositionId::generate();
    let now = now_ms();
    sqlx::query(
        "INSERT INTO compositions (id, library_id, name, document, created_at, updated_at) \
         VALUES ($1, $2, $3, $4, $5, $6)",
    )
    .bind(id.0)
    .bind(library.0)
    .bind(name)
    .bind(doc.to_json()?)
    .bind(now)
    .bind(now)
    .execute(&mut *db.write_conn().await?)
    .await?;
    Ok(id)
}

/// The compositions of a library, most recently changed first.
pub async fn list(db: &Db, library: LibraryId) -> Result<Vec<CompositionSummary>> {
    let rows = sqlx::query(
        "SELECT id, name, document, updated_at FROM compositions WHERE library_id = $1 \
         ORDER BY updated_at DESC, id",
    )
    .bind(library.0)
    .fetch_all(&db.pool)
    .await?;
    rows.iter()
        .map(|r| {
            let doc = stored_document(&r.try_get::<String, _>("document")?)?;
            Ok(CompositionSummary {
                id: CompositionId(r.try_get("id")?),
                name: r.try_get("name")?,
                pieces: doc.pieces.len(),
                updated_at: r.try_get("updated_at")?,
            })
        })
        .collect()
}

/// One composition (404 when there is none).
pub async fn get(db: &Db, id: CompositionId) -> Result<Composition> {
    let r = sqlx::query(
        "SELECT c.id, l.name AS library, c.name, c.document, c.created_at, c.updated_at \
         FROM compositions c JOIN libraries l ON l.id = c.library_id WHERE c.id = $1",
    )
    .bind(id.0)
    .fetch_optional(&db.pool)
    .await?
    .ok_or(AppError::NotFound("composition"))?;
    Ok(Composition {
        id: CompositionId(r.try_get("id")?),
        library: r.try_get("library")?,
        name: r.try_get("name")?,
        document: stored_document(&r.try_get::<String, _>("document")?)?,
        created_at: r.try_get("created_at")?,
        updated_at: r.try_get("updated_at")?,
    })
}

/// The library a composition belongs to (404 when there is no such composition).
pub async fn library_of(db: &Db, id: CompositionId) -> Result<LibraryId> {
    let r = sqlx::query("SELECT library_id FROM compositions WHERE id = $1")
        .bind(id.0)
        .fetch_optional(&db.pool)
        .await?
        .ok_or(AppError::NotFound("composition"))?;
    Ok(LibraryId(r.try_get("library_id")?))
}

/// Replaces a composition's name and document (404 when there is none).
pub async fn update(db: &Db, id: CompositionId, name: &str, doc: &Document) -> Result<()> {
    let done = sqlx::query(
        "UPDATE compositions SET name = $1, document = $2, updated_at = $3 WHERE id = $4",
    )
    .bind(name)
    .bind(doc.to_json()?)
    .bind(now_ms())
    .bind(id.0)
    .execute(&mut *db.write_conn().await?)
    .await?;
    if done.rows_affected() == 0 {
        return Err(AppError::NotFound("composition"));
    }
    Ok(())
}

/// Deletes a composition (404 when there is none).
pub async fn delete(db: &Db, id: CompositionId) -> Result<()> {
    let done = sqlx::query("DELETE FROM compositions WHERE id = $1")
        .bind(id.0)
        .execute(&mut *db.write_conn().await?)
        .await?;
    if done.rows_affected() == 0 {
        return Err(AppError::NotFound("composition"));
    }
    Ok(())
}

/// A stored document: it was valid when written, so a failure here is internal.
fn stored_document(json: &str) -> Result<Document> {
    serde_json::from_str(json).map_err(AppError::internal)
}

/// The stored SVG source of an item, `None` for a raster item (404 when there is no item).
pub async fn item_svg(db: &Db, id: ItemId) -> Result<Option<String>> {
    let r = sqlx::query("SELECT svg FROM items WHERE id = $1")
        .bind(id.0)
        .fetch_optional(&db.pool)
        .await?
        .ok_or(AppError::NotFound("item"))?;
    Ok(r.try_get("svg")?)
}

/// What the canvas draws a raster item from: its cut-out with the transparency kept
/// (migration 0017), or, for items imported before it, the opaque rendering (404 when there is
/// no item).
pub async fn item_cutout(db: &Db, id: ItemId) -> Result<Vec<u8>> {
    let r = sqlx::query("SELECT cutout, png FROM items WHERE id = $1")
        .bind(id.0)
        .fetch_optional(&db.pool)
        .await?
        .ok_or(AppError::NotFound("item"))?;
    match r.try_get::<Option<Vec<u8>>, _>("cutout")? {
        Some(c) => Ok(c),
        None => Ok(r.try_get("png")?),
    }
}

/// The name of the library of item `id` (404 for an unknown item).
pub async fn item_library_name(db: &Db, id: ItemId) -> Result<String> {
    let row = sqlx::query(
        "SELECT l.name FROM items i JOIN libraries l ON l.id = i.library_id WHERE i.id = $1",
    )
    .bind(id.0)
    .fetch_optional(&db.pool)
    .await?
    .ok_or(AppError::NotFound("item"))?;
    Ok(row.try_get("name")?)
}
