//! A representative style's members on the balanced grid; a node that hides images opens a
//! pop-up (`<dialog>`) listing them.

use askama::Template;
use axum::extract::State;
use axum::response::Response;
use serde::Deserialize;

use super::super::{page, render};
use super::forms::number;
use crate::AppState;
use crate::error::AppError;
use crate::explore::grid::{self, BranchGrid};
use crate::explore::jobs;
use crate::store::ids::ExplorationId;
use crate::web::admin::Admin;
use crate::web::extract::{ApiPath, ApiQuery};

/// One node of the grid page.
struct GridCell {
    /// The shown item's image, if any.
    thumbnail: Option<String>,
    /// The shown item's id.
    item: String,
    /// The hidden images: (item id, image).
    hidden: Vec<(String, String)>,
    /// The pop-up's id.
    dialog: String,
}

#[derive(Template)]
#[template(path = "explore_grid.html")]
struct GridPage {
    job: ExplorationId,
    /// The library's name (the items' drag data carry it).
    library: String,
    style: usize,
    grid: Option<BranchGrid>,
    /// The nodes, by row.
    cells: Vec<Vec<GridCell>>,
    rows: String,
    cols: String,
    error: Option<String>,
}

#[derive(Debug, Default, Deserialize)]
pub(super) struct GridForm {
    rows: Option<String>,
    cols: Option<String>,
}

pub(super) async fn grid_page(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    path: std::result::Result<ApiPath<(ExplorationId, usize)>, AppError>,
    form: std::result::Result<ApiQuery<GridForm>, AppError>,
) -> Response {
    page(
        async {
            admin?;
            let ApiPath((id, style)) = path?;
            let ApiQuery(form) = form?;
            let job = jobs::load(&state.db, id).await?;
            grid::branch(&job, style)?;
            let shape = (
                number("rows", form.rows.as_deref())?,
                number("cols", form.cols.as_deref())?,
            );
            let (grid, error) = match grid::layout(&state, &job, style, shape).await {
                Ok(g) => (Some(g), None),
                Err(e @ AppError::BadRequest(_)) => (None, Some(e.public_message())),
                Err(e) => return Err(e),
            };
            let image = |id: &crate::store::ids::ItemId| format!("/media/items/{id}.png");
            let cells = grid
                .iter()
                .flat_map(|g| g.cells.iter())
                .enumerate()
                .map(|(k, c)| GridCell {
                    thumbnail: c.shown.as_ref().map(image),
                    item: c.shown.map(|i| i.to_string()).unwrap_or_default(),
                    hidden: c.hidden.iter().map(|h| (h.to_string(), image(h))).collect(),
                    dialog: format!("hidden-{k}"),
                })
                .collect::<Vec<_>>();
            let cols = grid.as_ref().map_or(1, |g| g.cols.max(1));
            let mut by_row: Vec<Vec<GridCell>> = Vec::new();
            for (k, c) in cells.into_iter().enumerate() {
                if k % cols == 0 {
                    by_row.push(Vec::new());
                }
                if let Some(last) = by_row.last_mut() {
                    last.push(c);
                }
            }
            let shown = |v: Option<usize>| v.map(|v| v.to_string()).unwrap_or_default();
            let failed = error.is_some();
            let library = crate::search::source::library_name(&state.db, job.library).await?;
            let mut response = render(&GridPage {
                job: id,
                library,
                style,
                rows: grid
                    .as_ref()
                    .map_or_else(|| shown(shape.0), |g| g.rows.to_string()),
                cols: grid
                    .as_ref()
                    .map_or_else(|| shown(shape.1), |g| g.cols.to_string()),
                grid,
                cells: by_row,
                error,
            })?;
            // A shape the branch cannot fill is the request's fault: the form stays, with a 400.
            if failed {
                *response.status_mut() = axum::http::StatusCode::BAD_REQUEST;
            }
            Ok(response)
        }
        .await,
    )
}
