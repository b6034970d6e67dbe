//! The forms of a worker's row on the study page: block or unblock the worker (by their crowd
//! platform id; blocking ends their open HIT), and record a bonus. The approve/reject override
//! is in [`super::forms`].

use axum::extract::State;
use axum::response::{IntoResponse, Redirect, Response};
use serde::Deserialize;

use crate::AppState;
use crate::error::AppError;
use crate::store::ids::{AssignmentId, StudyId};
use crate::studies::bonus;
use crate::studies::study_edit;
use crate::web::admin::Admin;
use crate::web::extract::{ApiForm, ApiPath};

use super::super::page;
use super::forms::checked;
use super::{Submitted, form_error};

#[derive(Debug, Deserialize)]
pub(super) struct BlockForm {
    csrf: Option<String>,
    /// `block` or `unblock`.
    action: Option<String>,
}

pub(super) async fn admin_block(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    ApiPath((id, assignment)): ApiPath<(StudyId, AssignmentId)>,
    form: std::result::Result<ApiForm<BlockForm>, AppError>,
) -> Response {
    let (admin, f) = match checked(admin, form, |f| f.csrf.as_deref()) {
        Ok(x) => x,
        Err(e) => return page(Err(e)),
    };
    let run = async {
        let blocked = match f.action.as_deref() {
            Some("block") => true,
            Some("unblock") => false,
            _ => return Err(AppError::BadRequest("action: block or unblock".into())),
        };
        let actor = format!("admin:{}", admin.username);
        study_edit::block_worker_of(&state.db, id, assignment, blocked, &actor).await?;
        Ok(Redirect::to(&format!("/admin/studies/{id}#worker-{assignment}")).into_response())
    };
    match run.await {
        Ok(r) => r,
        Err(e) => {
            let submitted = Submitted::Block {
                assignment: assignment.0,
            };
            form_error(&state, &admin, id, submitted, e).await
        }
    }
}

#[derive(Debug, Deserialize)]
pub(super) struct BonusForm {
    csrf: Option<String>,
    amount: Option<String>,
    reason: Option<String>,
}

pub(super) async fn admin_bonus(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    ApiPath((id, assignment)): ApiPath<(StudyId, AssignmentId)>,
    form: std::result::Result<ApiForm<BonusForm>, AppError>,
) -> Response {
    let (admin, f) = match checked(admin, form, |f| f.csrf.as_deref()) {
        Ok(x) => x,
        Err(e) => return page(Err(e)),
    };
    let amount = f.amount.unwrap_or_default();
    let reason = f.reason.unwrap_or_default();
    let run = async {
        let cents = bonus::parse_amount(&amount)?;
        let actor = format!("admin:{}", admin.username);
        bonus::record(&state.db, id, assignment, cents, &reason, &actor).await?;
        Ok::<_, AppError>(
            Redirect::to(&format!("/admin/studies/{id}#worker-{assignment}")).into_response(),
        )
    };
    match run.await {
        Ok(r) => r,
        Err(e) => {
            let submitted = Submitted::Bonus {
                assignment: assignment.0,
                amount,
                reason,
            };
            form_error(&state, &admin, id, submitted, e).await
        }
    }
}
