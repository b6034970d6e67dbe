//! The icon-set study's worker endpoints (Garces et al. 2016 §6.6), scoped by the assignment's
//! token like the rest of the worker flow: the task with the tray, condition A's explorer,
//! condition B's search, the tray's events and the submission. Nothing a worker receives names
//! their condition; the task says which of the two interfaces the page shows. The worker page
//! (`crate::web::pages::worker::iconset`) calls the same functions.

use std::sync::Arc;

use axum::Json;
use axum::extract::State;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use crate::AppState;
use crate::error::{AppError, ErrorBody, Result};
use crate::flow::{self, AnswerRequest, Assignment, AssignmentState};
use crate::search::cache::{Built, Key};
use crate::search::{self, SearchRequest};
use crate::store::ids::ItemId;
use crate::studies::iconset::explorer::{self, Explorer};
use crate::studies::iconset::log::{self, Action, Tray};
use crate::studies::iconset::{Condition, IconsetSettings};
use crate::studies::kind::StudyKind;
use crate::studies::study::Study;
use crate::web::extract::{ApiJson, ApiPath, ApiQuery};

/// Results of one search when the request does not say (a few screens of thumbnails).
const DEFAULT_LIMIT: u32 = 48;

/// Which interface the worker's page shows (the condition, unnamed).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, ToSchema)]
#[serde(rename_all = "lowercase")]
pub enum Interface {
    /// The representative styles and a style's balanced grid.
    Explorer,
    /// The search ordered by style.
    Search,
}

impl From<Condition> for Interface {
    fn from(c: Condition) -> Self {
        match c {
            Condition::A => Self::Explorer,
            Condition::B => Self::Search,
        }
    }
}

/// A worker's icon-set task.
#[derive(Debug, Serialize, ToSchema)]
pub struct IconsetTask {
    /// What to do.
    pub task: String,
    /// The slots of each set, in order.
    pub labels: Vec<String>,
    /// The interface the page shows.
    pub interface: Interface,
    /// The tray as the server logged it.
    pub tray: Tray,
    /// The set being made (from 1); `null` when every set is finished.
    pub current: Option<usize>,
    /// The assignment's status (`active`, `completed`, …).
    pub status: String,
}

/// A search of condition B.
#[derive(Debug, Deserialize, utoipa::IntoParams)]
#[serde(deny_unknown_fields)]
#[into_params(parameter_in = Query)]
pub struct IconSearchQuery {
    /// Keywords.
    #[param(max_length = 200)]
    pub q: Option<String>,
    /// The label searched (one of the task's).
    #[param(max_length = 200)]
    pub label: String,
    /// Results wanted (1–200, default 48).
    #[param(minimum = 1, maximum = 200)]
    pub limit: Option<u32>,
}

/// One icon a worker sees.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct Icon {
    /// The item.
    pub id: ItemId,
    /// Its name.
    pub name: String,
    /// Its image.
    pub url: String,
}

/// A search's answer.
#[derive(Debug, Serialize, ToSchema)]
pub struct IconSearchAnswer {
    /// Items of the label matching the keywords.
    pub matched: usize,
    /// The results, most like the current set's icons first.
    pub results: Vec<Icon>,
}

/// The assignment of `token` with its icon-set study and settings; 404 for another kind.
pub(crate) async fn iconset_of(
    state: &AppState,
    token: &str,
) -> Result<(Assignment, Study, IconsetSettings)> {
    let a = flow::by_token(&state.db, token).await?;
    let s = flow::study_of(&state.db, &a).await?;
    match (s.kind, s.settings.iconset.clone()) {
        (StudyKind::Iconset, Some(i)) => Ok((a, s, i)),
        _ => Err(AppError::NotFound("icon-set task")),
    }
}

fn active(a: &Assignment) -> Result<()> {
    if a.status == "active" {
        Ok(())
    } else {
        Err(AppError::Conflict(format!(
            "the assignment is {}, not making icon sets",
            a.status
        )))
    }
}

/// The condition of an active assignment (drawn, and set 1 started, on the first call); the
/// stored one, if any, of another.
pub(crate) async fn condition(state: &AppState, a: &Assignment, s: &Study) -> Result<Condition> {
    if a.status == "active" {
        return log::start(&state.db, s.id, s.settings.seed, a.id).await;
    }
    log::condition_of(&state.db, a.id)
        .await?
        .ok_or_else(|| AppError::Conflict(format!("the assignment is {}", a.status)))
}

/// Condition B's search: the task label's items matching the keywords, ordered by style to the
/// icons of the current set (with none, dealt across the style clusters), logged.
pub(crate) async fn run_search(
    state: &AppState,
    a: &Assignment,
    s: &Study,
    settings: &IconsetSettings,
    q: Option<&str>,
    label: &str,
    limit: Option<u32>,
) -> Result<IconSearchAnswer> {
    active(a)?;
    if condition(state, a, s).await? != Condition::B {
        return Err(AppError::Conflict("this task has no search".into()));
    }
    let label = label.trim();
    if settings.slot(label).is_none() {
        return Err(AppError::BadRequest(format!(
            "label: one of {}",
            settings.labels.join(", ")
        )));
    }
    let tray = log::tray(&state.db, settings, a.id).await?;
    let near: Vec<String> = tray
        .current()
        .map(|c| {
            tray.sets[c]
                .slots
                .iter()
                .flatten()
                .map(ToString::to_string)
                .collect()
        })
        .unwrap_or_default();
    let req = SearchRequest {
        library: crate::search::source::library_name(&state.db, s.library).await?,
        model: Some(
            settings
                .model
                .map_or_else(|| "uniform".to_string(), |m| m.to_string()),
        ),
        q: q.map(str::to_string),
        category: Some(label.to_string()),
        near: (!near.is_empty()).then(|| near.join(",")),
        limit: Some(limit.unwrap_or(DEFAULT_LIMIT)),
    };
    let answer = search::run(state, &req).await?;
    let ids: Vec<ItemId> = answer.results.iter().map(|r| r.id).collect();
    log::record_search(
        &state.db,
        settings,
        a.id,
        q.unwrap_or("").trim(),
        label,
        &ids,
    )
    .await?;
    Ok(IconSearchAnswer {
        matched: answer.matched,
        results: answer
            .results
            .into_iter()
            .map(|r| Icon {
                id: r.id,
                name: r.name,
                url: r.url,
            })
            .collect(),
    })
}

/// Condition A's explorer, as stored when the study was created.
pub(crate) async fn load_explorer(state: &AppState, a: &Assignment, s: &Study) -> Result<Explorer> {
    if condition(state, a, s).await? != Condition::A {
        return Err(AppError::Conflict("this task has no explorer".into()));
    }
    explorer::load(&state.db, s.id).await
}

/// The study's search index when `action` finishes a set (its spread is measured in it).
pub(crate) async fn index_for(
    state: &AppState,
    s: &Study,
    settings: &IconsetSettings,
    action: &Action,
) -> Result<Option<Arc<Built>>> {
    if *action != Action::Finish {
        return Ok(None);
    }
    let key = Key {
        library: s.library,
        model: settings.model,
    };
    Ok(Some(state.search.get(&state.db, key).await?))
}

/// Completes the HIT after every set is finished, through the shared answer path (QC,
/// completion code, MTurk/Prolific hand-back).
pub(crate) async fn submit_tray(
    state: &AppState,
    token: &str,
    a: &Assignment,
    s: &Study,
    settings: &IconsetSettings,
) -> Result<()> {
    active(a)?;
    condition(state, a, s).await?;
    let tray = log::tray(&state.db, settings, a.id).await?;
    if let Some(c) = tray.current() {
        return Err(AppError::BadRequest(format!(
            "set {} of {} is not finished",
            c + 1,
            settings.sets
        )));
    }
    let view = flow::state(&state.db, s, a).await?;
    if let Some(q) = view.question {
        let req = AnswerRequest {
            position: q.position,
            choice: q.left.id,
            elapsed_ms: None,
        };
        flow::answer(&state.db, token, &req, flow::AnsweredBy::IconSets).await?;
    }
    Ok(())
}

/// The worker's task and tray.
#[utoipa::path(get, path = "/api/v1/assignments/{token}/iconset", params(("token" = String, Path)),
    responses((status = 200, body = IconsetTask),
              (status = 404, description = "No assignment has this token, or its study is not an \
                  icon-set study", body = ErrorBody),
              (status = 409, description = "The assignment ended before it began the task",
                  body = ErrorBody)))]
pub(super) async fn iconset_task(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
) -> Result<Json<IconsetTask>> {
    let (a, s, i) = iconset_of(&state, &token).await?;
    let c = condition(&state, &a, &s).await?;
    let tray = log::tray(&state.db, &i, a.id).await?;
    Ok(Json(IconsetTask {
        task: i.task(),
        labels: i.labels.clone(),
        interface: c.into(),
        current: tray.current().map(|c| c + 1),
        tray,
        status: a.status,
    }))
}

/// The explorer: the representative styles of the task's labels, each with its branch on the
/// balanced grid (every member shown or hidden behind a node).
#[utoipa::path(get, path = "/api/v1/assignments/{token}/iconset/explorer",
    params(("token" = String, Path)),
    responses((status = 200, body = Explorer),
              (status = 404, description = "No assignment has this token, or its study is not an \
                  icon-set study", body = ErrorBody),
              (status = 409, description = "This task has no explorer, or the assignment ended \
                  before it began the task", body = ErrorBody)))]
pub(super) async fn iconset_explorer(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
) -> Result<Json<Explorer>> {
    let (a, s, _) = iconset_of(&state, &token).await?;
    Ok(Json(load_explorer(&state, &a, &s).await?))
}

/// Searches the icons of one label, ordered by style to the current set's icons, and logs it.
#[utoipa::path(get, path = "/api/v1/assignments/{token}/iconset/search",
    params(("token" = String, Path), IconSearchQuery),
    responses((status = 200, body = IconSearchAnswer),
              (status = 400, description = "A bad field, or a label not of the task",
                  body = ErrorBody),
              (status = 404, description = "No assignment has this token, or its study is not an \
                  icon-set study", body = ErrorBody),
              (status = 409, description = "This task has no search, or the assignment is not \
                  making icon sets", body = ErrorBody)))]
pub(super) async fn iconset_search(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
    ApiQuery(query): ApiQuery<IconSearchQuery>,
) -> Result<Json<IconSearchAnswer>> {
    let (a, s, i) = iconset_of(&state, &token).await?;
    let q = query.q.as_deref().filter(|q| !q.trim().is_empty());
    Ok(Json(
        run_search(&state, &a, &s, &i, q, &query.label, query.limit).await?,
    ))
}

/// Puts an icon into the current set (the slot of its label), takes one out (a deletion), or
/// finishes the current set; returns the tray after it.
#[utoipa::path(post, path = "/api/v1/assignments/{token}/iconset/events",
    params(("token" = String, Path)), request_body = Action,
    responses((status = 200, body = Tray),
              (status = 400, description = "An unknown event or field, an item not of the \
                  library or of no task label, an icon already used, a slot filled or empty, \
                  a set not full", body = ErrorBody),
              (status = 404, description = "No assignment has this token, or its study is not an \
                  icon-set study", body = ErrorBody),
              (status = 409, description = "The assignment is not making icon sets, or every \
                  set is finished", body = ErrorBody)))]
pub(super) async fn iconset_event(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
    ApiJson(action): ApiJson<Action>,
) -> Result<Json<Tray>> {
    let (a, s, i) = iconset_of(&state, &token).await?;
    active(&a)?;
    condition(&state, &a, &s).await?;
    let index = index_for(&state, &s, &i, &action).await?;
    Ok(Json(
        log::act(&state.db, s.library, &i, a.id, &action, index.as_deref()).await?,
    ))
}

/// Submits the tray once every set is finished: the HIT is completed through the shared flow.
#[utoipa::path(post, path = "/api/v1/assignments/{token}/iconset/submit",
    params(("token" = String, Path)),
    responses((status = 200, body = AssignmentState),
              (status = 400, description = "A set is not finished", body = ErrorBody),
              (status = 404, description = "No assignment has this token, or its study is not an \
                  icon-set study", body = ErrorBody),
              (status = 409, description = "The assignment is not making icon sets (already \
                  submitted)", body = ErrorBody)))]
pub(super) async fn iconset_submit(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
) -> Result<Json<AssignmentState>> {
    let (a, s, i) = iconset_of(&state, &token).await?;
    submit_tray(&state, &token, &a, &s, &i).await?;
    let a = flow::by_token(&state.db, &token).await?;
    Ok(Json(flow::state(&state.db, &s, &a).await?))
}
