//! The worker flow over JSON: a study's public description, start (or MTurk preview), the
//! assignment's state, training, answers, the reasons questionnaire and giving up. No session:
//! the assignment's token in the path is the worker's credential.

use axum::Json;
use axum::extract::State;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::OkBody;
use crate::AppState;
use crate::error::{AppError, ErrorBody, Result};
use crate::flow::{
    self, AnswerAck, AnswerRequest, AssignmentState, ReasonsRequest, StartOutcome, StartRequest,
    TrainingAnswer, TrainingResult,
};
use crate::store::ids::StudyId;
use crate::studies::study::{self, MturkMode};
use crate::web::extract::{ApiJson, ApiPath};

/// What a worker may know about a study.
#[derive(Debug, Serialize, ToSchema)]
pub struct StudyInfo {
    /// Id.
    pub id: StudyId,
    /// Name.
    pub name: String,
    /// Description.
    pub description: String,
    /// Questions per HIT.
    pub questions_per_hit: u32,
    /// Training questions.
    pub training_questions: u32,
    /// Questions a HIT started now holds, controls included: `questions_per_hit`, or fewer
    /// when the study has fewer tuples with a free slot or fewer controls left (0: none left).
    pub hit_questions: usize,
    /// Practice questions of a training attempt started now (0: no training).
    pub practice_questions: usize,
    /// MTurk mode.
    pub mturk_mode: MturkMode,
}

/// Public description of a study.
#[utoipa::path(get, path = "/api/v1/studies/{study}", params(("study" = i64, Path)),
    responses((status = 200, body = StudyInfo),
              (status = 404, description = "No such study (or a malformed id)", body = ErrorBody)))]
pub(super) async fn study_info(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
) -> Result<Json<StudyInfo>> {
    let s = study::load(&state.db, id).await?;
    let outlook = flow::outlook(&state.db, &s).await?;
    Ok(Json(StudyInfo {
        id: s.id,
        name: s.name,
        description: s.settings.description.clone(),
        questions_per_hit: s.settings.questions_per_hit,
        training_questions: s.settings.training_questions,
        hit_questions: outlook.questions,
        practice_questions: outlook.practice,
        mturk_mode: s.settings.mturk_mode,
    }))
}

/// Starts or resumes an assignment (an MTurk preview creates nothing). `worker_id` is required
/// but in an MTurk preview (`assignment_id` `ASSIGNMENT_ID_NOT_AVAILABLE`, which has no
/// workerId); MTurk needs `turk_submit_to` of the study's MTurk site, Prolific its study and
/// session ids.
#[utoipa::path(post, path = "/api/v1/studies/{study}/start", params(("study" = i64, Path)),
    request_body = StartRequest,
    responses((status = 200, body = StartOutcome),
              (status = 400, description = "An invalid or missing field (the message names it), \
                  or a HIT from the other MTurk site", body = ErrorBody),
              (status = 403, description = "The worker is blocked or excluded", body = ErrorBody),
              (status = 404, description = "No such study (or a malformed id)", body = ErrorBody),
              (status = 409, description = "No free slot left, the study's tuple pool is still \
                  being written (or its creation failed), or the settings changed while \
                  starting (retry)", body = ErrorBody)))]
pub(super) async fn start(
    State(state): State<AppState>,
    ApiPath(id): ApiPath<StudyId>,
    ApiJson(req): ApiJson<StartRequest>,
) -> Result<Json<StartOutcome>> {
    let s = study::load(&state.db, id).await?;
    Ok(Json(flow::start(&state.db, &s, req).await?))
}

/// The assignment's state: the single source of truth for resuming.
#[utoipa::path(get, path = "/api/v1/assignments/{token}", params(("token" = String, Path)),
    responses((status = 200, body = AssignmentState),
              (status = 404, description = "No assignment has this token", body = ErrorBody)))]
pub(super) async fn assignment_state(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
) -> Result<Json<AssignmentState>> {
    let a = flow::by_token(&state.db, &token).await?;
    let s = flow::study_of(&state.db, &a).await?;
    Ok(Json(flow::state(&state.db, &s, &a).await?))
}

/// Most training answers one attempt may carry (a study has at most 20 training questions).
const MAX_TRAINING_ANSWERS: usize = 100;

/// A training attempt.
#[derive(Debug, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct TrainingRequest {
    /// One answer per training question.
    #[schema(max_items = 100)]
    pub answers: Vec<TrainingAnswer>,
}

/// Submits a training attempt; feedback per question.
#[utoipa::path(post, path = "/api/v1/assignments/{token}/training", params(("token" = String, Path)),
    request_body = TrainingRequest,
    responses((status = 200, body = TrainingResult),
              (status = 400, description = "Not one answer per training question, or an invalid \
                  field", body = ErrorBody),
              (status = 404, description = "No assignment has this token", body = ErrorBody),
              (status = 409, description = "The training is over", body = ErrorBody)))]
pub(super) async fn training(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
    ApiJson(req): ApiJson<TrainingRequest>,
) -> Result<Json<TrainingResult>> {
    if req.answers.len() > MAX_TRAINING_ANSWERS {
        return Err(AppError::BadRequest(format!(
            "answers: at most {MAX_TRAINING_ANSWERS}"
        )));
    }
    let a = flow::by_token(&state.db, &token).await?;
    let s = flow::study_of(&state.db, &a).await?;
    Ok(Json(
        flow::submit_training(&state.db, &s, &a, &req.answers).await?,
    ))
}

/// Gives up the training (screen-out code, not a rejection).
#[utoipa::path(post, path = "/api/v1/assignments/{token}/give-up", params(("token" = String, Path)),
    responses((status = 200, body = AssignmentState),
              (status = 404, description = "No assignment has this token", body = ErrorBody),
              (status = 409, description = "The training is over", body = ErrorBody)))]
pub(super) async fn give_up(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
) -> Result<Json<AssignmentState>> {
    let a = flow::by_token(&state.db, &token).await?;
    flow::give_up(&state.db, &a).await?;
    let a = flow::by_token(&state.db, &token).await?;
    let s = flow::study_of(&state.db, &a).await?;
    Ok(Json(flow::state(&state.db, &s, &a).await?))
}

/// Stores an answer durably before acknowledging it; idempotent.
#[utoipa::path(post, path = "/api/v1/assignments/{token}/answers", params(("token" = String, Path)),
    request_body = AnswerRequest,
    responses((status = 200, body = AnswerAck),
              (status = 400, description = "The choice is not one of the question's two options, \
                  or an invalid field", body = ErrorBody),
              (status = 404, description = "No assignment has this token, or it has no question at \
                  this position", body = ErrorBody),
              (status = 409, description = "The assignment is not answering questions, the \
                  question was answered differently, or the study is a mash-up study (its HIT \
                  ends with /mashup/submit)", body = ErrorBody)))]
pub(super) async fn answer(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
    ApiJson(req): ApiJson<AnswerRequest>,
) -> Result<Json<AnswerAck>> {
    // A mash-up HIT's one question stands for the composition: only a checked submission
    // answers it (refused with 409 in the answer's own read, see `AnsweredBy`).
    Ok(Json(
        flow::answer(&state.db, &token, &req, flow::AnsweredBy::Question).await?,
    ))
}

/// Stores the "why did you choose?" questionnaire of a question.
#[utoipa::path(post, path = "/api/v1/assignments/{token}/reasons", params(("token" = String, Path)),
    request_body = ReasonsRequest,
    responses((status = 200, body = OkBody),
              (status = 400, description = "The question has no questionnaire, or an invalid \
                  field", body = ErrorBody),
              (status = 404, description = "No assignment has this token, or it has no question at \
                  this position", body = ErrorBody),
              (status = 409, description = "The question is not answered yet", body = ErrorBody)))]
pub(super) async fn reasons(
    State(state): State<AppState>,
    ApiPath(token): ApiPath<String>,
    ApiJson(req): ApiJson<ReasonsRequest>,
) -> Result<Json<OkBody>> {
    let a = flow::by_token(&state.db, &token).await?;
    flow::submit_reasons(&state.db, &a, &req).await?;
    Ok(Json(OkBody { ok: true }))
}
