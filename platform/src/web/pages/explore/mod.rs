//! The admin's Explore pages (Garces et al. 2016 §6.5): choose a library, a metric and the
//! semantic labels to explore, build the taxonomy as a background job (the page follows its
//! progress through `explore.js`), see the representative styles, and open one as a balanced
//! grid whose nodes that hide images open a pop-up listing them.

mod forms;
mod grid_page;

use askama::Template;
use axum::Router;
use axum::extract::State;
use axum::response::Response;
use axum::routing::{get, post};
use serde::Deserialize;

use super::{page, render};
use crate::AppState;
use crate::error::AppError;
use crate::explore::jobs::{self, Job, Kind};
use crate::explore::taxonomy::TaxonomyResult;
use crate::explore::{LabelCount, label_counts, resolve};
use crate::search::source;
use crate::store::ids::ExplorationId;
use crate::studies::library;
use crate::web::admin::Admin;
use crate::web::extract::{ApiPath, ApiQuery};

/// The pages' routes.
pub(super) fn routes() -> Router<AppState> {
    Router::new()
        .route("/admin/explore", get(explore_page))
        .route("/admin/explore/taxonomy", post(forms::build_taxonomy))
        .route("/admin/explore/map", post(forms::build_map))
        .route("/admin/explore/jobs/{job}", get(job_page))
        .route(
            "/admin/explore/jobs/{job}/styles/{style}",
            get(grid_page::grid_page),
        )
}

/// An option of a drop-down.
struct Choice {
    value: String,
    label: String,
    selected: bool,
}

/// A label checkbox.
struct LabelBox {
    label: String,
    count: usize,
}

/// A stored exploration in the list.
struct JobLink {
    url: String,
    text: String,
}

#[derive(Template)]
#[template(path = "explore.html")]
struct ExplorePage {
    csrf: String,
    library: String,
    libraries: Vec<Choice>,
    models: Vec<Choice>,
    labels: Vec<LabelBox>,
    kappa: usize,
    tau: usize,
    jobs: Vec<JobLink>,
    error: Option<String>,
}

#[derive(Debug, Default, Deserialize)]
struct ExploreForm {
    library: Option<String>,
    model: Option<String>,
}

async fn explore_page(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    form: std::result::Result<ApiQuery<ExploreForm>, AppError>,
) -> Response {
    page(
        async {
            let admin = admin?;
            let ApiQuery(form) = form?;
            let names = library::library_names(&state.db).await?;
            let chosen = form
                .library
                .clone()
                .filter(|l| !l.trim().is_empty())
                .or_else(|| names.first().cloned());
            let defaults = learner::explore::TaxonomyParams::default();
            let mut p = ExplorePage {
                csrf: admin.csrf,
                library: chosen.clone().unwrap_or_default(),
                libraries: names
                    .iter()
                    .map(|n| Choice {
                        value: n.clone(),
                        label: n.clone(),
                        selected: Some(n) == chosen.as_ref(),
                    })
                    .collect(),
                models: Vec::new(),
                labels: Vec::new(),
                kappa: defaults.kappa,
                tau: defaults.tau,
                jobs: Vec::new(),
                error: None,
            };
            let Some(name) = chosen else {
                p.error = Some("There is no library yet: import one first.".into());
                return render(&p);
            };
            let model = form.model.clone().unwrap_or_default();
            let library = match resolve(&state.db, &name, Some(&model)).await {
                Ok((library, _)) => library,
                Err(e @ (AppError::BadRequest(_) | AppError::Conflict(_))) => {
                    p.error = Some(e.public_message());
                    source::library_by_name(&state.db, &name).await?
                }
                Err(e) => return Err(e),
            };
            p.models = vec![
                Choice {
                    value: String::new(),
                    label: "newest trained model".into(),
                    selected: model.is_empty(),
                },
                Choice {
                    value: "uniform".into(),
                    label: "uniform weights".into(),
                    selected: model == "uniform",
                },
            ];
            for m in source::models_for(&state.db, library).await? {
                p.models.push(Choice {
                    value: m.id.to_string(),
                    label: format!("model {} ({})", m.id, m.study),
                    selected: model == m.id.to_string(),
                });
            }
            p.labels = label_counts(&state.db, library)
                .await?
                .into_iter()
                .map(|LabelCount { label, count }| LabelBox { label, count })
                .collect();
            for kind in [Kind::Taxonomy, Kind::Map] {
                for j in jobs::recent(&state.db, library, kind, 20).await? {
                    let what = match kind {
                        Kind::Taxonomy => describe(&j),
                        Kind::Map => describe_map(&j),
                    };
                    p.jobs.push(JobLink {
                        url: format!("/admin/explore/jobs/{}", j.id),
                        text: format!("{what} · {}", j.status),
                    });
                }
            }
            render(&p)
        }
        .await,
    )
}

/// `labels a, b · κ 20 · τ 2 · model 12` for a job's parameters.
fn describe(j: &Job) -> String {
    let labels: Vec<&str> = j.params["labels"]
        .as_array()
        .map(|a| a.iter().filter_map(|v| v.as_str()).collect())
        .unwrap_or_default();
    format!(
        "{} · κ {} · τ {} · {}",
        if labels.is_empty() {
            "all labels".to_owned()
        } else {
            labels.join(", ")
        },
        j.params["kappa"],
        j.params["tau"],
        j.model
            .map_or_else(|| "uniform weights".to_owned(), |m| format!("model {m}"))
    )
}

/// `labels a, b · 100 per label · perplexity 30 · model 12` for a map's parameters.
fn describe_map(j: &Job) -> String {
    let labels: Vec<&str> = j.params["labels"]
        .as_array()
        .map(|a| a.iter().filter_map(|v| v.as_str()).collect())
        .unwrap_or_default();
    format!(
        "style map of {} · {} · perplexity {} · {}",
        if labels.is_empty() {
            "all labels".to_owned()
        } else {
            labels.join(", ")
        },
        j.params["per_label"]
            .as_u64()
            .map_or_else(|| "every item".to_owned(), |k| format!("{k} per label")),
        j.params["perplexity"],
        j.model
            .map_or_else(|| "uniform weights".to_owned(), |m| format!("model {m}"))
    )
}

/// A representative style as the page shows it.
struct StyleCard {
    url: String,
    thumbnail: String,
    name: String,
    count: usize,
    labels: String,
}

#[derive(Template)]
#[template(path = "explore_job.html")]
struct JobPage {
    id: ExplorationId,
    library: String,
    /// The Explore page of the library.
    back: String,
    title: String,
    status: String,
    stage: String,
    done: i64,
    total: i64,
    error: Option<String>,
    summary: Option<String>,
    styles: Vec<StyleCard>,
    /// A style map (drawn by `explore_map.js`) rather than a taxonomy.
    is_map: bool,
}

async fn job_page(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    id: std::result::Result<ApiPath<ExplorationId>, AppError>,
) -> Response {
    page(
        async {
            admin?;
            let ApiPath(id) = id?;
            // A map's points are drawn through its view API, never parsed for this page.
            let mut job = jobs::load_status(&state.db, id).await?;
            if job.kind != "map" && job.status == "done" {
                job = jobs::load(&state.db, id).await?;
            }
            let library = source::library_name(&state.db, job.library).await?;
            let mut p = JobPage {
                id,
                title: describe(&job),
                back: format!(
                    "/admin/explore?{}",
                    form_urlencoded::Serializer::new(String::new())
                        .append_pair("library", &library)
                        .finish()
                ),
                library,
                status: job.status.clone(),
                stage: job.stage.clone(),
                done: job.done,
                total: job.total,
                error: job.error.clone(),
                summary: None,
                styles: Vec::new(),
                is_map: job.kind == "map",
            };
            if p.is_map {
                p.title = describe_map(&job);
            } else if let Some(result) = &job.result {
                let r: TaxonomyResult =
                    serde_json::from_value(result.clone()).map_err(AppError::internal)?;
                p.summary = Some(format!(
                    "{} representative styles over {} items ({} in branches too small to keep){}.",
                    r.representatives.len(),
                    r.items,
                    r.unassigned,
                    r.kmeans_centres.map_or_else(String::new, |c| format!(
                        "; Ward ran on {c} k-means centres"
                    ))
                ));
                p.styles = r
                    .representatives
                    .iter()
                    .enumerate()
                    .map(|(k, s)| StyleCard {
                        url: format!("/admin/explore/jobs/{id}/styles/{k}"),
                        thumbnail: format!("/media/items/{}.png", s.id),
                        name: s.name.clone(),
                        count: s.count,
                        labels: s
                            .labels
                            .iter()
                            .map(|l| format!("{} {}", l.count, l.label))
                            .collect::<Vec<_>>()
                            .join(", "),
                    })
                    .collect();
            }
            render(&p)
        }
        .await,
    )
}
