//! The mash-up study's worker endpoints (§5.7.3), scoped by the assignment's token like the
//! rest of the worker flow: the task, the search, the event log and the submission. Nothing a
//! worker receives names their condition: both conditions answer the same request with the
//! same fields (no order, model or distance), condition A ordered by style to the canvas
//! (`near`, or across the style clusters when the canvas is empty), condition B in a seeded
//! random order of the same matches.

use axum::Json;
use axum::extract::State;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::OkBody;
use crate::AppState;
use crate::error::{AppError, ErrorBody, Result};
use crate::flow::{self, AnswerRequest, Assignment, AssignmentState};
use crate::mashup::{Document, store};
use crate::search::{self, SearchRequest};
use crate::store::ids::ItemId;
use crate::studies::kind::StudyKind;
use crate::studies::mashup::log::{self, Event};
use crate::studies::mashup::{Condition, MashupSettings, shuffle_seed, submit};
use crate::studies::study::Study;
use crate::web::extract::{ApiJson, ApiPath, ApiQuery};

/// Most canvas items one search is ordered by (as the admin canvas, `data-max-near`).
const MAX_NEAR: usize = 20;

/// A worker's mash-up task.
#[derive(Debug, Serialize, ToSchema)]
pub struct MashupTask {
    /// What to compose.
    pub task: String,
    /// The fixed background, if the task has one.
    pub background: Option<String>,
    /// Pieces the composition must have.
    pub min_pieces: u32,
    /// Searches to make before submitting.
    pub min_searches: u32,
    /// The library the pieces come from (its name).
    pub library: String,
    /// Searches made so far.
    pub searches: i64,
    /// The assignment's status (`active`, `completed`, …).
    pub status: String,
}

/// A worker's search.
#[derive(Debug, Deserialize, utoipa::IntoParams)]
#[serde(deny_unknown_fields)]
#[into_params(parameter_in = Query)]
pub struct WorkerSearchQuery {
    /// Keywords.
    #[param(max_length = 200)]
    pub q: Option<String>,
    /// Only items with this style label.
    #[param(max_length = 200)]
    pub category: Option<String>,
    /// Comma-separated ids of the items on the canvas (items of the study's library).
    pub near: Option<String>,
    /// Results wanted (1–200, default 48).
    #[param(minimum = 1, maximum = 200)]
    pub limit: Option<u32>,
}

/// One result a worker sees.
#[derive(Debug, Serialize, ToSchema)]
pub struct WorkerResult {
    /// The item.
    pub id: ItemId,
    /// Its name.
    pub name: String,
    /// Its image.
    pub url: String,
}

/// A search's answer, logged under `seq`.
#[derive(Debug, Serialize, ToSchema)]
pub struct WorkerSearchAnswer {
    /// The search's number in this assignment (events name it as `search_seq`).
    pub seq: i64,
    /// Items matching the keywords and category.
    pub matched: usize,
    /// The results, in the order to show them (positions count from 1).
    pub results: Vec<WorkerResult>,
    /// The library's style labels, for the category filter.
    pub categories: Vec<String>,
}

/// A submitted composition.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct MashupSubmission {
    /// The canvas.
    pub document: Document,
}

/// The assignment of `token` with its mash-up study and task; 404 for another kind of study.
async fn mashup_of(state: &AppState, token: &str) -> Result<(Assignment, Study, MashupSettings)> {
    let a = flow::by_token(&state.db, token).await?;
    let s = flow::study_of(&state.db, &a).await?;
    match (s.kind, s.settings.mashup.clone()) {
        (StudyKind::Mashup, Some(m)) => Ok((a, s, m)),
        _ => Err(AppError::NotFound("mash-up task")),
    }
}

fn active(a: &Assignment) -> Result<()> {
    if a.status == "active" {
        Ok(())
    } else {
        Err(AppError::Conflict(format!(
            "the assignment is {}, not composing",
            a.status
        )))
    }
}

/// The worker's task.
#[utoipa::path(get, path = "/api/v1/assignments/{token}/mashup", params(("token" = String, Path)),
    responses((status = 200, body = MashupTask),
              (status = 404, description = "No assignment has this token, or its study is not a \
                  mash-up study", body = ErrorBody)))]
pub(super) async fn mashup_task(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
) -> Result<Json<MashupTask>> {
    let (a, s, m) = mashup_of(&state, &token).await?;
    let library = crate::search::source::library_name(&state.db, s.library).await?;
    Ok(Json(MashupTask {
        task: m.task,
        background: m.background,
        min_pieces: m.min_pieces,
        min_searches: m.min_searches,
        library,
        searches: log::search_count(&state.db, a.id).await?,
        status: a.status,
    }))
}

/// Searches the library for the worker's canvas and logs the list returned.
#[utoipa::path(get, path = "/api/v1/assignments/{token}/mashup/search",
    params(("token" = String, Path), WorkerSearchQuery),
    responses((status = 200, body = WorkerSearchAnswer),
              (status = 400, description = "A bad field, or a canvas item not in the study's \
                  library", body = ErrorBody),
              (status = 404, description = "No assignment has this token, or its study is not a \
                  mash-up study", body = ErrorBody),
              (status = 409, description = "The assignment is not composing, or the library \
                  cannot be searched", body = ErrorBody)))]
pub(super) async fn mashup_search(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
    ApiQuery(query): ApiQuery<WorkerSearchQuery>,
) -> Result<Json<WorkerSearchAnswer>> {
    let (a, s, _) = mashup_of(&state, &token).await?;
    active(&a)?;
    let condition = log::assign_condition(&state.db, s.id, s.settings.seed, a.id).await?;
    // The canvas items, as the page sends them. They are not checked against the log: the
    // page searches again as soon as a piece lands, concurrently with logging its add, and
    // ordering condition A by any item of the library harms nothing (the search refuses items
    // of other libraries; condition B ignores them).
    let mut near: Vec<ItemId> = Vec::new();
    if let Some(text) = query.near.as_deref().filter(|t| !t.trim().is_empty()) {
        for part in text.split(',').map(str::trim) {
            let id: ItemId = part
                .parse()
                .map_err(|_| AppError::BadRequest("near: item ids separated by commas".into()))?;
            if !near.contains(&id) {
                near.push(id);
            }
        }
        near.truncate(MAX_NEAR);
    }
    let library = crate::search::source::library_name(&state.db, s.library).await?;
    let q = query.q.as_deref().map(str::trim).filter(|q| !q.is_empty());
    let category = query
        .category
        .as_deref()
        .map(str::trim)
        .filter(|c| !c.is_empty());
    let mut req = SearchRequest {
        library,
        model: None,
        q: q.map(str::to_string),
        category: category.map(str::to_string),
        near: None,
        limit: query.limit,
    };
    let answer = match condition {
        Condition::A => {
            if !near.is_empty() {
                let ids: Vec<String> = near.iter().map(ToString::to_string).collect();
                req.near = Some(ids.join(","));
            }
            search::run(&state, &req).await?
        }
        Condition::B => {
            let seed = shuffle_seed(s.settings.seed, a.id, q.unwrap_or(""), category);
            search::run_shuffled(&state, &req, seed).await?
        }
    };
    let ids: Vec<ItemId> = answer.results.iter().map(|r| r.id).collect();
    let seq = log::record_search(&state.db, a.id, q.unwrap_or(""), category, &ids).await?;
    Ok(Json(WorkerSearchAnswer {
        seq,
        matched: answer.matched,
        results: answer
            .results
            .into_iter()
            .map(|r| WorkerResult {
                id: r.id,
                name: r.name,
                url: r.url,
            })
            .collect(),
        categories: answer.categories,
    }))
}

/// Logs a canvas event: a search shown (checked against the server's log), a piece added from
/// a result list (accepted only when that list had that item at that position), a piece
/// removed, an undo or redo, a layer change, a background change (`studies::mashup::events`).
#[utoipa::path(post, path = "/api/v1/assignments/{token}/mashup/events",
    params(("token" = String, Path)), request_body = Event,
    responses((status = 200, body = OkBody),
              (status = 400, description = "An unknown event or field, an unknown search, a \
                  position that does not hold the item, an item never added from a result list, \
                  a layer out of range, or a background that is not the canvas's (or not the \
                  task's fixed one)", body = ErrorBody),
              (status = 404, description = "No assignment has this token, or its study is not a \
                  mash-up study", body = ErrorBody),
              (status = 409, description = "The assignment is not composing", body = ErrorBody)))]
pub(super) async fn mashup_event(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
    ApiJson(event): ApiJson<Event>,
) -> Result<Json<OkBody>> {
    let (a, _, m) = mashup_of(&state, &token).await?;
    active(&a)?;
    log::check_background(&event, m.background.as_deref())?;
    log::record_event(&state.db, a.id, &event).await?;
    Ok(Json(OkBody { ok: true }))
}

/// Submits the composition: checked against the task (background, minimum pieces and
/// searches) and the log (every piece added from a result list), stored, and the HIT completed
/// through the shared flow (completion code, MTurk/Prolific hand-back).
#[utoipa::path(post, path = "/api/v1/assignments/{token}/mashup/submit",
    params(("token" = String, Path)), request_body = MashupSubmission,
    responses((status = 200, body = AssignmentState),
              (status = 400, description = "A bad document, too few pieces or searches, another \
                  background than the task's, or a piece not added from a result list",
                  body = ErrorBody),
              (status = 404, description = "No assignment has this token, or its study is not a \
                  mash-up study", body = ErrorBody),
              (status = 409, description = "The assignment is not composing (already submitted)",
                  body = ErrorBody)))]
pub(super) async fn mashup_submit(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
    ApiJson(body): ApiJson<MashupSubmission>,
) -> Result<Json<AssignmentState>> {
    let (a, s, m) = mashup_of(&state, &token).await?;
    active(&a)?;
    let doc = body.document;
    doc.validate()?;
    store::check_items(&state.db, s.library, &doc).await?;
    match submit::submit(&state.db, a.id, s.library, &m, &doc).await {
        Ok(_) => {}
        // Stored before a failure to complete: complete now.
        Err(AppError::Conflict(_)) => {}
        Err(e) => return Err(e),
    }
    // The HIT's one question stands for the composition task: answering it completes the HIT
    // through the shared answer path (QC, completion code, hand-back).
    let view = flow::state(&state.db, &s, &a).await?;
    if let Some(q) = view.question {
        let req = AnswerRequest {
            position: q.position,
            choice: q.left.id,
            elapsed_ms: None,
        };
        flow::answer(&state.db, &token, &req, flow::AnsweredBy::ComposedScene).await?;
    }
    let a = flow::by_token(&state.db, &token).await?;
    Ok(Json(flow::state(&state.db, &s, &a).await?))
}
