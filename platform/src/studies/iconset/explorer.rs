//! Condition A's explorer (Garces et al. 2016 §6.5–6.6): the style taxonomy of the study's
//! labels (§6.5.1, `crate::explore::taxonomy`) and every representative style's branch on the
//! balanced grid (§6.5.2, `crate::explore::grid`), computed once when the study is created and
//! stored in `iconset_explorers`, so that a worker's HIT never waits on a computation and every
//! worker in condition A sees the same explorer.

use std::sync::Arc;

use learner::explore::TaxonomyParams;
use serde::{Deserialize, Serialize};
use sqlx::Row;
use utoipa::ToSchema;

use super::IconsetSettings;
use crate::error::{AppError, Result};
use crate::explore::grid::{BranchGrid, arrange};
use crate::explore::jobs::Progress;
use crate::explore::{LabelCount, taxonomy};
use crate::search::IndexCache;
use crate::search::cache::{Built, Key};
use crate::store::db::{Db, now_ms};
use crate::store::ids::{ItemId, LibraryId, StudyId};

/// Largest side of a branch's grid on the worker's page: a larger branch keeps the rest of its
/// members as hidden images of the nodes (§6.5.2), so a phone still shows the whole grid.
pub const MAX_SIDE: usize = 8;

/// One representative style with its branch on the grid.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct ExplorerStyle {
    /// The representative item (the member nearest the branch's mean).
    pub id: ItemId,
    /// Items in the branch.
    pub count: usize,
    /// Items of each label in the branch.
    pub labels: Vec<LabelCount>,
    /// The branch on the balanced grid; every member is shown or hidden behind a node.
    pub grid: BranchGrid,
}

/// The explorer of an icon-set study.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct Explorer {
    /// Items of the study's labels clustered.
    pub items: usize,
    /// Items in no kept branch (not reachable from the explorer).
    pub unassigned: usize,
    /// The representative styles, the largest first.
    pub styles: Vec<ExplorerStyle>,
}

impl Explorer {
    /// Whether `item` is shown or hidden in some branch.
    pub fn contains(&self, item: ItemId) -> bool {
        self.styles.iter().any(|s| {
            s.grid
                .cells
                .iter()
                .any(|c| c.shown == Some(item) || c.hidden.contains(&item))
        })
    }
}

/// The grid's shape for a branch of `n` members: the largest square with at most `n` nodes,
/// at most [`MAX_SIDE`] on a side.
pub fn shape(n: usize) -> (usize, usize) {
    let (side, _) = crate::explore::grid::default_shape(n);
    (side.min(MAX_SIDE), side.min(MAX_SIDE))
}

/// Checks `settings` against the library (labels, counts, κ/τ, the model) and computes the
/// explorer under the study's model (blocking work off the async runtime).
pub async fn compute(
    db: &Db,
    cache: &IndexCache,
    library: LibraryId,
    settings: &IconsetSettings,
) -> Result<Explorer> {
    settings.check_library(db, library).await?;
    if let Some(m) = settings.model {
        // A finished model of a study over this library.
        crate::search::source::model(db, library, m).await?;
    }
    let built = cache
        .get(
            db,
            Key {
                library,
                model: settings.model,
            },
        )
        .await?;
    let s = settings.clone();
    tokio::task::spawn_blocking(move || build(&built, &s))
        .await
        .map_err(AppError::internal)?
}

fn build(built: &Arc<Built>, s: &IconsetSettings) -> Result<Explorer> {
    let params = TaxonomyParams {
        kappa: s.kappa,
        tau: s.tau,
        ..TaxonomyParams::default()
    };
    let t = taxonomy::compute(built, &s.labels, &params, &Progress::default())?;
    let styles = t
        .representatives
        .iter()
        .map(|r| {
            let (rows, cols) = shape(r.members.len());
            Ok(ExplorerStyle {
                id: r.id,
                count: r.count,
                labels: r.labels.clone(),
                grid: arrange(built, &r.members, rows, cols)?,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(Explorer {
        items: t.items,
        unassigned: t.unassigned,
        styles,
    })
}

/// Stores the explorer of `study`.
pub async fn store(db: &Db, study: StudyId, explorer: &Explorer) -> Result<()> {
    let json = serde_json::to_string(explorer).map_err(AppError::internal)?;
    let mut tx = db.begin_write().await?;
    sqlx::query("INSERT INTO iconset_explorers (study_id, result, created_at) VALUES ($1, $2, $3)")
        .bind(study.0)
        .bind(json)
        .bind(now_ms())
        .execute(&mut *tx)
        .await?;
    tx.commit().await?;
    Ok(())
}

/// The stored explorer of `study`.
pub async fn load(db: &Db, study: StudyId) -> Result<Explorer> {
    let row = sqlx::query("SELECT result FROM iconset_explorers WHERE study_id = $1")
        .bind(study.0)
        .fetch_optional(&db.pool)
        .await?
        .ok_or_else(|| {
            AppError::Conflict(format!("study {study} has no explorer: it was not created"))
        })?;
    serde_json::from_str(&row.try_get::<String, _>("result")?).map_err(AppError::internal)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grids_are_at_most_eight_by_eight() {
        assert_eq!(shape(1), (1, 1));
        assert_eq!(shape(10), (3, 3));
        assert_eq!(shape(64), (8, 8));
        assert_eq!(shape(1000), (8, 8));
    }
}
