//! A worker's submitted composition (§5.7.3): the quality check of a mash-up HIT is the
//! study's minimum numbers of pieces and searches and the validity of the document, whose
//! every piece must have a logged, server-checked position (`log::positions`). The composition is stored in `compositions` (migration 0012) and linked
//! to the assignment in `mashup_submissions` (migration 0015), in one transaction.

use sqlx::Row;

use super::MashupSettings;
use super::log::{self, Canvas, positions, replay};
use crate::error::{AppError, Result};
use crate::mashup::Document;
use crate::store::db::{Db, now_ms};
use crate::store::ids::{AssignmentId, CompositionId, ItemId, LibraryId};

/// Checks `doc` (already [`Document::validate`]d) against the study's minimums and the log
/// (`canvas`), and returns its pieces' logged positions.
pub fn check(
    settings: &MashupSettings,
    doc: &Document,
    searches: i64,
    canvas: &Canvas,
) -> Result<Vec<i64>> {
    if let Some(fixed) = &settings.background
        && &doc.background != fixed
    {
        return Err(AppError::BadRequest(format!(
            "document: the background is {fixed:?} in this task, not {:?}",
            doc.background
        )));
    }
    if doc.pieces.len() < settings.min_pieces as usize {
        return Err(AppError::BadRequest(format!(
            "document: {} pieces; this task needs at least {}",
            doc.pieces.len(),
            settings.min_pieces
        )));
    }
    if searches < i64::from(settings.min_searches) {
        return Err(AppError::BadRequest(format!(
            "{searches} searches made; this task needs at least {}",
            settings.min_searches
        )));
    }
    let items: Vec<ItemId> = doc.pieces.iter().map(|p| p.item).collect();
    positions(&items, canvas)
}

/// Stores the submission of `assignment` after [`check`]ing it against the log; a second
/// submission is a 409.
pub async fn submit(
    db: &Db,
    assignment: AssignmentId,
    library: LibraryId,
    settings: &MashupSettings,
    doc: &Document,
) -> Result<CompositionId> {
    let canvas = replay(&log::events(db, assignment).await?);
    let searches = log::search_count(db, assignment).await?;
    check(settings, doc, searches, &canvas)?;
    let id = CompositionId::generate();
    let now = now_ms();
    let mut tx = db.begin_write().await?;
    log::lock_row(&mut tx, db.backend, log::Locked::Assignment, assignment.0).await?;
    let done = sqlx::query("SELECT assignment_id FROM mashup_submissions WHERE assignment_id = $1")
        .bind(assignment.0)
        .fetch_optional(&mut *tx)
        .await?;
    if done.is_some() {
        return Err(AppError::Conflict(
            "this task's composition was already submitted".into(),
        ));
    }
    sqlx::query(
        "INSERT INTO compositions (id, library_id, name, document, created_at, updated_at) \
         VALUES ($1, $2, $3, $4, $5, $6)",
    )
    .bind(id.0)
    .bind(library.0)
    .bind(format!("mash-up assignment {assignment}"))
    .bind(doc.to_json()?)
    .bind(now)
    .bind(now)
    .execute(&mut *tx)
    .await?;
    sqlx::query(
        "INSERT INTO mashup_submissions (assignment_id, composition_id, submitted_at) \
         VALUES ($1, $2, $3)",
    )
    .bind(assignment.0)
    .bind(id.0)
    .bind(now)
    .execute(&mut *tx)
    .await?;
    tx.commit().await?;
    Ok(id)
}

/// The composition `assignment` submitted, if any.
pub async fn submitted_composition(
    db: &Db,
    assignment: AssignmentId,
) -> Result<Option<CompositionId>> {
    let row = sqlx::query("SELECT composition_id FROM mashup_submissions WHERE assignment_id = $1")
        .bind(assignment.0)
        .fetch_optional(&db.pool)
        .await?;
    row.map(|r| Ok(CompositionId(r.try_get("composition_id")?)))
        .transpose()
}
