//! The end page: how the worker gets paid (or leaves) on their crowd platform.
//!
//! - Prolific: the completion code configured on Prolific in large type, and the redirect back
//!   to Prolific that Prolific participants expect (a few seconds later, with a link to go at
//!   once). The platform's own HMAC code is shown only as a reference, labelled as one.
//! - MTurk: the HIT is submitted to MTurk with the platform's code.
//! - Direct links: the platform's code, which the researcher checks.
//! - A worker who did not consent: asked to return the task (Prolific: the no-consent code when
//!   the study has one).

use askama::Template;
use axum::response::Response;

use crate::error::{AppError, Result};
use crate::flow::{AssignmentState, Handback, PROLIFIC_COMPLETE};
use crate::web::pages::render;

/// Seconds before the end page takes a Prolific participant back to Prolific.
const PROLIFIC_REDIRECT_SECONDS: u32 = 5;

#[derive(Template)]
#[template(path = "done.html")]
struct DonePage {
    sandbox: bool,
    /// `mturk`, `prolific` or `direct`.
    source: String,
    /// `completed`, `screened_out` or `declined`.
    status: String,
    /// The platform's own code (HMAC of the assignment), when there is one.
    code: Option<String>,
    /// The code Prolific expects (configured in the study's settings).
    prolific_code: Option<String>,
    /// Where the page sends the worker (Prolific's completion address).
    redirect: Option<String>,
    redirect_seconds: u32,
    mturk_action: Option<String>,
    mturk_assignment: String,
}

/// Renders the end page of a finished assignment.
pub(super) fn render_done(st: AssignmentState) -> Result<Response> {
    let code = st.completion_code.or(st.screenout_code);
    if code.is_none() && st.status != "declined" {
        return Err(AppError::Conflict("the assignment is not finished".into()));
    }
    let (mut mturk_action, mut mturk_assignment, mut redirect) = (None, String::new(), None);
    match st.handback {
        Some(Handback::MturkForm {
            action,
            assignment_id,
            ..
        }) => {
            mturk_action = Some(action);
            mturk_assignment = assignment_id;
        }
        Some(Handback::Redirect { url }) => redirect = Some(url),
        _ => {}
    }
    let prolific_code = redirect
        .as_deref()
        .and_then(|u| u.strip_prefix(PROLIFIC_COMPLETE))
        .and_then(|q| q.strip_prefix("?cc="))
        .map(str::to_string);
    render(&DonePage {
        sandbox: st.sandbox,
        source: st.source,
        status: st.status,
        code,
        prolific_code,
        redirect,
        redirect_seconds: PROLIFIC_REDIRECT_SECONDS,
        mturk_action,
        mturk_assignment,
    })
}
