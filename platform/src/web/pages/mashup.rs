//! The admin's mash-up canvas (Garces et al. 2014 §5.7.3): search a library, drag results onto
//! an HTML5 canvas, arrange them, and export or save the composition. The page is a shell: the
//! script `mashup.js` does the work through the JSON API, configured by the root element's
//! `data-*` attributes (so a worker page can reuse it with other endpoints).

use askama::Template;
use axum::Router;
use axum::extract::State;
use axum::response::Response;
use axum::routing::get;
use serde::Deserialize;

use super::{page, render};
use crate::AppState;
use crate::error::AppError;
use crate::mashup::backgrounds::BACKGROUNDS;
use crate::search::MAX_NEAR;
use crate::store::ids::ItemId;
use crate::studies::library;
use crate::web::admin::Admin;
use crate::web::assets;
use crate::web::extract::ApiQuery;

/// The page's routes.
pub(super) fn routes() -> Router<AppState> {
    Router::new().route("/admin/mashup", get(mashup_page))
}

#[derive(Debug, Default, Deserialize)]
struct MashupForm {
    library: Option<String>,
    /// An item to start the canvas with (the Explore pages' "Use in mash-up"); its library is
    /// chosen.
    item: Option<ItemId>,
}

/// A background of the drop-down, with its image URL (empty for blank).
pub(super) struct BackgroundChoice {
    pub(super) name: &'static str,
    pub(super) label: &'static str,
    pub(super) url: String,
}

/// Every background, as the canvas's drop-down offers them.
pub(super) fn background_choices() -> Vec<BackgroundChoice> {
    BACKGROUNDS
        .iter()
        .map(|b| BackgroundChoice {
            name: b.name,
            label: b.label,
            url: b.asset_name().map(|a| assets::url(&a)).unwrap_or_default(),
        })
        .collect()
}

#[derive(Template)]
#[template(path = "mashup.html")]
struct MashupPage {
    libraries: Vec<(String, bool)>,
    library: String,
    backgrounds: Vec<BackgroundChoice>,
    csrf: String,
    max_near: usize,
    script: String,
    /// The item placed on the canvas when the page opens (empty: none).
    start_item: String,
}

impl MashupPage {
    /// The admin exports compositions as PNG and SVG (`mashup_canvas.html`).
    fn has_exports(&self) -> bool {
        true
    }
}

async fn mashup_page(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    form: std::result::Result<ApiQuery<MashupForm>, AppError>,
) -> Response {
    page(
        async {
            let admin = admin?;
            let ApiQuery(form) = form?;
            let names = library::library_names(&state.db).await?;
            let item_library = match form.item {
                Some(id) => Some(crate::mashup::store::item_library_name(&state.db, id).await?),
                None => None,
            };
            let chosen = item_library
                .or(form.library)
                .filter(|l| names.contains(l))
                .or_else(|| names.first().cloned())
                .unwrap_or_default();
            render(&MashupPage {
                libraries: names.iter().map(|n| (n.clone(), *n == chosen)).collect(),
                library: chosen,
                backgrounds: background_choices(),
                csrf: admin.csrf,
                max_near: MAX_NEAR,
                script: assets::url("mashup.js"),
                start_item: form.item.map(|i| i.to_string()).unwrap_or_default(),
            })
        }
        .await,
    )
}
