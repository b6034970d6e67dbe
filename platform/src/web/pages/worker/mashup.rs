//! A worker's mash-up task (§5.7.3): the canvas (`mashup.js`) with the task text, configured
//! with the assignment's own endpoints (`crate::web::api` `/mashup/…`) and the study's fixed
//! background, if any. Nothing on the page names the worker's condition.

use askama::Template;
use axum::response::Response;

use crate::error::Result;
use crate::studies::mashup::MashupSettings;
use crate::web::pages::mashup::{BackgroundChoice, background_choices};
use crate::web::pages::render;

#[derive(Template)]
#[template(path = "mashup_task.html")]
struct MashupTaskPage {
    token: String,
    sandbox: bool,
    task: String,
    library: String,
    background: Option<String>,
    min_pieces: u32,
    min_searches: u32,
    backgrounds: Vec<BackgroundChoice>,
}

impl MashupTaskPage {
    /// A worker submits the composition; it is not theirs to export (`mashup_canvas.html`).
    fn has_exports(&self) -> bool {
        false
    }
}

/// The task page of an active mash-up assignment.
pub(super) fn render_task(
    token: &str,
    sandbox: bool,
    library: String,
    m: MashupSettings,
) -> Result<Response> {
    render(&MashupTaskPage {
        token: token.to_string(),
        sandbox,
        task: m.task,
        library,
        background: m.background,
        min_pieces: m.min_pieces,
        min_searches: m.min_searches,
        backgrounds: background_choices(),
    })
}
