//! Built search indexes, kept in memory per (library, model) and rebuilt when the library has
//! gained items. A cache only: every index can be rebuilt from the database, so servers can
//! still be killed or multiplied.

use std::collections::HashMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use learner::search::{SearchIndex, SearchParams, Weighting};
use tokio::sync::Mutex;

use super::source::{self, LibraryVersion};
use crate::error::{AppError, Result};
use crate::store::db::{Db, now_ms};
use crate::store::ids::{ItemId, LibraryId, ModelId};

/// Indexes kept at once; the least recently used goes first. An index of the paper's 200,000
/// items takes tens of MB (`docs/search.md`).
pub const CAPACITY: usize = 4;

/// Which index: a library under a model, or under uniform weights (`model: None`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Key {
    /// The library.
    pub library: LibraryId,
    /// The model, or `None` for uniform weights.
    pub model: Option<ModelId>,
}

/// One built index with what the pages show of its items.
#[derive(Debug)]
pub struct Built {
    /// What it was built for.
    pub key: Key,
    /// The library's state when it was built.
    pub version: LibraryVersion,
    /// The engine's index; its ids are the items' names.
    pub index: SearchIndex,
    /// Item ids, by row of the index.
    pub ids: Vec<ItemId>,
    /// The row of each item id (the inverse of `ids`).
    rows: HashMap<ItemId, usize>,
    /// Style labels, by row.
    pub styles: Vec<Option<String>>,
    /// The distinct style labels (the category facet), sorted.
    pub categories: Vec<String>,
    /// Seconds the build took.
    pub seconds: f64,
    last_used: AtomicU64,
}

impl Built {
    /// The row of an item of this library.
    pub fn row_of(&self, id: ItemId) -> Option<usize> {
        self.rows.get(&id).copied()
    }
}

/// The cache.
#[derive(Debug, Default)]
pub struct IndexCache {
    entries: Mutex<Vec<Arc<Built>>>,
}

impl IndexCache {
    /// The index for `key`, built (once, however many requests ask at the same time) when
    /// missing or older than the library.
    pub async fn get(&self, db: &Db, key: Key) -> Result<Arc<Built>> {
        // Every search asks: the cached index, if nothing was imported since its build (one
        // short index read, not a count of the whole library).
        let cached = {
            let entries = self.entries.lock().await;
            entries.iter().find(|e| e.key == key).cloned()
        };
        if let Some(e) = cached
            && source::unchanged(db, key.library, &e.version).await?
        {
            e.last_used.store(now_ms() as u64, Ordering::Relaxed);
            return Ok(e);
        }
        // Held across the build: a second request for the same index waits for this one
        // instead of building it again (builds are rare: once per library change and model).
        let mut entries = self.entries.lock().await;
        let version = source::version(db, key.library).await?;
        if let Some(e) = entries
            .iter()
            .find(|e| e.key == key && e.version == version)
        {
            e.last_used.store(now_ms() as u64, Ordering::Relaxed);
            return Ok(e.clone());
        }
        if version.items == 0 {
            return Err(AppError::Conflict(
                "this library has no items yet: import or upload some first".into(),
            ));
        }
        let items = source::library_items(db, key.library).await?;
        let model = match key.model {
            Some(id) => Some(source::model(db, key.library, id).await?),
            None => None,
        };
        let built = tokio::task::spawn_blocking(move || {
            let started = Instant::now();
            let weighting = match &model {
                Some(m) => Weighting::from_model(m, &items.table).map_err(|e| {
                    AppError::Conflict(format!(
                        "the model does not fit this library's features ({e}); retrain it"
                    ))
                })?,
                None => Weighting::uniform(&items.table),
            };
            let index = SearchIndex::build(
                &items.table,
                items.texts,
                &weighting,
                &SearchParams::default(),
                None,
                &mut |_| {},
            )
            .map_err(AppError::internal)?;
            let mut categories: Vec<String> = items.styles.iter().flatten().cloned().collect();
            categories.sort();
            categories.dedup();
            Ok::<_, AppError>(Built {
                key,
                version,
                index,
                rows: items
                    .ids
                    .iter()
                    .enumerate()
                    .map(|(row, &id)| (id, row))
                    .collect(),
                ids: items.ids,
                styles: items.styles,
                categories,
                seconds: started.elapsed().as_secs_f64(),
                last_used: AtomicU64::new(now_ms() as u64),
            })
        })
        .await
        .map_err(AppError::internal)??;
        let built = Arc::new(built);
        entries.retain(|e| e.key != key);
        entries.push(built.clone());
        if entries.len() > CAPACITY
            && let Some(oldest) = entries
                .iter()
                .enumerate()
                .min_by_key(|(_, e)| e.last_used.load(Ordering::Relaxed))
                .map(|(i, _)| i)
        {
            entries.remove(oldest);
        }
        Ok(built)
    }
}
