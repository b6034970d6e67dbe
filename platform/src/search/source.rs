//! What a search index is built from: a library's stored items (their 169 features, name, style
//! label and keywords) and, when one is chosen, a trained model of a study over that library.

use learner::metric::Model;
use learner::search::{ItemText, keywords::name_from_id};
use learner::table::FeatureTable;
use sqlx::Row;

use crate::error::{AppError, Result};
use crate::store::db::Db;
use crate::store::ids::{ItemId, LibraryId, ModelId};

/// A library's items as the search engine reads them, in import order.
pub struct LibraryItems {
    /// Ids, by row of `table`.
    pub ids: Vec<ItemId>,
    /// Names (the learner's item ids), by row.
    pub names: Vec<String>,
    /// Style labels, by row.
    pub styles: Vec<Option<String>>,
    /// The features, one row per item, in the catalogue's column order.
    pub table: FeatureTable,
    /// The words of each item: its name's words, its keywords, its style as the category.
    pub texts: Vec<ItemText>,
}

/// What identifies the state of a library's items: a stored index is stale once it differs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct LibraryVersion {
    /// Items.
    pub items: i64,
    /// The largest import sequence number (items are only added).
    pub last_seq: i64,
    /// Items at `last_seq` (normally one; two imports at the same moment can share it).
    pub at_last: i64,
}

/// The library named `name`.
pub async fn library_by_name(db: &Db, name: &str) -> Result<LibraryId> {
    let row = sqlx::query("SELECT id FROM libraries WHERE name = $1")
        .bind(name)
        .fetch_optional(&db.pool)
        .await?
        .ok_or(AppError::NotFound("library"))?;
    Ok(LibraryId(row.try_get("id")?))
}

/// The name of library `id` (the search API names libraries).
pub async fn library_name(db: &Db, id: LibraryId) -> Result<String> {
    let row = sqlx::query("SELECT name FROM libraries WHERE id = $1")
        .bind(id.0)
        .fetch_optional(&db.pool)
        .await?
        .ok_or(AppError::NotFound("library"))?;
    Ok(row.try_get("name")?)
}

/// The current [`LibraryVersion`] of a library (a read of the whole library's index).
pub async fn version(db: &Db, library: LibraryId) -> Result<LibraryVersion> {
    let row = sqlx::query(
        "SELECT COUNT(*) AS n, COALESCE(MAX(seq), -1) AS last FROM items WHERE library_id = $1",
    )
    .bind(library.0)
    .fetch_one(&db.pool)
    .await?;
    let (items, last_seq): (i64, i64) = (row.try_get("n")?, row.try_get("last")?);
    let at_last = tail(db, library, last_seq).await?.0;
    Ok(LibraryVersion {
        items,
        last_seq,
        at_last,
    })
}

/// Whether the library is still at `known`: no item has been imported since (items are only
/// added, each at a sequence number at least the largest so far). One short range read of the
/// `(library_id, seq)` index, whatever the library's size, so every search can afford it.
pub async fn unchanged(db: &Db, library: LibraryId, known: &LibraryVersion) -> Result<bool> {
    let (n, last) = tail(db, library, known.last_seq).await?;
    Ok(n == known.at_last && last == known.last_seq)
}

/// Items at or after sequence number `from`, and the largest sequence number among them.
async fn tail(db: &Db, library: LibraryId, from: i64) -> Result<(i64, i64)> {
    let row = sqlx::query(
        "SELECT COUNT(*) AS n, COALESCE(MAX(seq), -1) AS last FROM items \
         WHERE library_id = $1 AND seq >= $2",
    )
    .bind(library.0)
    .bind(from)
    .fetch_one(&db.pool)
    .await?;
    Ok((row.try_get("n")?, row.try_get("last")?))
}

/// Reads every item of a library for indexing.
pub async fn library_items(db: &Db, library: LibraryId) -> Result<LibraryItems> {
    let rows = sqlx::query(
        "SELECT id, name, style, tags, features FROM items WHERE library_id = $1 ORDER BY seq",
    )
    .bind(library.0)
    .fetch_all(&db.pool)
    .await?;
    let names_of_columns: Vec<String> = learner::features::catalogue()
        .into_iter()
        .map(|f| f.name.to_string())
        .collect();
    let dim = names_of_columns.len();
    let mut ids = Vec::with_capacity(rows.len());
    let mut names = Vec::with_capacity(rows.len());
    let mut styles = Vec::with_capacity(rows.len());
    let mut texts = Vec::with_capacity(rows.len());
    let mut values = Vec::with_capacity(rows.len() * dim);
    for r in &rows {
        let name: String = r.try_get("name")?;
        let features: Vec<f64> = serde_json::from_str(&r.try_get::<String, _>("features")?)
            .map_err(AppError::internal)?;
        if features.len() != dim {
            return Err(AppError::Internal(format!(
                "item {name} has {} features, expected {dim}",
                features.len()
            )));
        }
        values.extend(features);
        let tags: Vec<String> =
            serde_json::from_str(&r.try_get::<String, _>("tags")?).map_err(AppError::internal)?;
        let style: Option<String> = r.try_get("style")?;
        texts.push(ItemText {
            name: name_from_id(&name),
            tags: Vec::new(),
            keywords: tags,
            category: style.clone(),
        });
        ids.push(ItemId(r.try_get("id")?));
        styles.push(style);
        names.push(name);
    }
    let table =
        FeatureTable::new(names_of_columns, names.clone(), values).map_err(AppError::internal)?;
    Ok(LibraryItems {
        ids,
        names,
        styles,
        table,
        texts,
    })
}

/// A trained model a search may use.
#[derive(Debug, Clone, serde::Serialize, utoipa::ToSchema)]
pub struct ModelChoice {
    /// The model.
    pub id: ModelId,
    /// The study it was trained on.
    pub study: String,
    /// When it finished (Unix ms).
    pub finished_at: Option<i64>,
}

/// The finished models of the studies over `library`, newest first.
pub async fn models_for(db: &Db, library: LibraryId) -> Result<Vec<ModelChoice>> {
    sqlx::query(
        "SELECT m.id, s.name, m.finished_at FROM models m JOIN studies s ON s.id = m.study_id \
         WHERE s.library_id = $1 AND m.status = 'done' ORDER BY m.finished_at DESC, m.id DESC",
    )
    .bind(library.0)
    .fetch_all(&db.pool)
    .await?
    .iter()
    .map(|r| {
        Ok(ModelChoice {
            id: ModelId(r.try_get("id")?),
            study: r.try_get("name")?,
            finished_at: r.try_get("finished_at")?,
        })
    })
    .collect()
}

/// The stored `model.json` of a model of a study over `library`.
pub async fn model(db: &Db, library: LibraryId, id: ModelId) -> Result<Model> {
    let row = sqlx::query(
        "SELECT s.library_id, m.status FROM models m JOIN studies s ON s.id = m.study_id \
         WHERE m.id = $1",
    )
    .bind(id.0)
    .fetch_optional(&db.pool)
    .await?
    .ok_or(AppError::NotFound("model"))?;
    if row.try_get::<i64, _>("library_id")? != library.0 {
        return Err(AppError::BadRequest(format!(
            "model {id} was trained on a study over another library"
        )));
    }
    let status: String = row.try_get("status")?;
    if status != "done" {
        return Err(AppError::Conflict(format!(
            "model {id} is {status}, not trained: choose a finished model"
        )));
    }
    let row =
        sqlx::query("SELECT bytes FROM model_files WHERE model_id = $1 AND name = 'model.json'")
            .bind(id.0)
            .fetch_optional(&db.pool)
            .await?
            .ok_or_else(|| AppError::Internal(format!("model {id} has no model.json")))?;
    serde_json::from_slice(&row.try_get::<Vec<u8>, _>("bytes")?).map_err(AppError::internal)
}
