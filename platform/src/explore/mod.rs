//! Style exploration in the platform (Garces et al. 2016, "Style-Based Exploration of
//! Illustration Datasets", §6.5): the representative styles of a library's items of a few
//! semantic labels (the taxonomy, §6.5.1), a branch laid out on the balanced grid, as stored
//! background jobs. The algorithms are `learner::explore`; the style space is the search
//! index's (`crate::search`), so an exploration and a search under the same model agree.
//!
//! An item's semantic label is its style label (`items.style`, the search's category); items
//! without one are `unlabelled`.

pub mod grid;
pub mod jobs;
pub mod map;
pub mod taxonomy;

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};
use sqlx::Row;
use utoipa::ToSchema;

use crate::error::{AppError, Result};
use crate::search::source;
use crate::store::db::Db;
use crate::store::ids::{LibraryId, ModelId};

/// The label of items with no style label.
pub const UNLABELLED: &str = learner::explore::library::UNLABELLED;

/// Longest library name or label accepted.
pub const MAX_TEXT_CHARS: usize = 200;

/// Most labels one exploration may require.
pub const MAX_LABELS: usize = 50;

/// A semantic label of a library and how many items carry it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
pub struct LabelCount {
    /// The label.
    pub label: String,
    /// Items carrying it.
    pub count: usize,
}

/// The labels of a library's items with their counts, by label.
pub async fn label_counts(db: &Db, library: LibraryId) -> Result<Vec<LabelCount>> {
    let rows =
        sqlx::query("SELECT style, COUNT(*) AS n FROM items WHERE library_id = $1 GROUP BY style")
            .bind(library.0)
            .fetch_all(&db.pool)
            .await?;
    let mut counts: BTreeMap<String, usize> = BTreeMap::new();
    for r in &rows {
        let style: Option<String> = r.try_get("style")?;
        let n: i64 = r.try_get("n")?;
        *counts
            .entry(style.unwrap_or_else(|| UNLABELLED.into()))
            .or_default() += n as usize;
    }
    Ok(counts
        .into_iter()
        .map(|(label, count)| LabelCount { label, count })
        .collect())
}

/// A checked text field: trimmed, no control characters, at most [`MAX_TEXT_CHARS`].
pub(crate) fn text(name: &str, value: &str) -> Result<String> {
    let v = value.trim();
    if v.chars().any(char::is_control) {
        return Err(AppError::BadRequest(format!(
            "{name}: control characters are not allowed"
        )));
    }
    if v.chars().count() > MAX_TEXT_CHARS {
        return Err(AppError::BadRequest(format!(
            "{name}: at most {MAX_TEXT_CHARS} characters"
        )));
    }
    Ok(v.to_owned())
}

/// The library named `name` and the model a request chose: `uniform`, a model id, or
/// empty/omitted for the newest finished model over the library (uniform weights without one).
/// A model of a study over another library, or not finished, is refused.
pub async fn resolve(
    db: &Db,
    library: &str,
    model: Option<&str>,
) -> Result<(LibraryId, Option<ModelId>)> {
    let name = text("library", library)?;
    if name.is_empty() {
        return Err(AppError::BadRequest("library: required".into()));
    }
    let model = text("model", model.unwrap_or(""))?;
    let id = source::library_by_name(db, &name).await?;
    let model = match model.as_str() {
        "" => source::models_for(db, id).await?.first().map(|m| m.id),
        "uniform" => None,
        v => {
            let m: ModelId = v.parse().map_err(|_| {
                AppError::BadRequest(format!(
                    "model: a model id or \"uniform\", not {:?}",
                    v.chars().take(40).collect::<String>()
                ))
            })?;
            // Checks it is a finished model of a study over this library.
            source::model(db, id, m).await?;
            Some(m)
        }
    };
    Ok((id, model))
}
