//! The worker pages: the start page (instructions, worked example, informed consent; MTurk,
//! Prolific and direct links), the practice questions, the questions, the reasons
//! questionnaire and the end page, on top of the same [`crate::flow`] functions as the JSON
//! API. Every page fits a phone (360–430 px wide; `platform/static/style.css`).

use axum::Router;
use axum::routing::{get, post};

use crate::AppState;

mod done;
mod iconset;
mod mashup;
mod start;
mod task;

/// The worker pages' routes.
pub(super) fn routes() -> Router<AppState> {
    Router::new()
        .route("/s/{study}", get(start::start_page))
        .route("/s/{study}/start", post(start::start_submit))
        .route("/s/{study}/decline", post(start::decline_submit))
        .route("/a/{token}", get(task::assignment_page))
        .route("/a/{token}/training", post(task::training_submit))
        .route("/a/{token}/give-up", post(task::give_up_submit))
        .route("/a/{token}/answer", post(task::answer_submit))
        .route("/a/{token}/reasons", post(task::reasons_submit))
        .route("/a/{token}/iconset", post(iconset::iconset_submit))
}
