//! The admin's style search page: keywords, a style label and a metric, results as thumbnails;
//! "More like this" on a result orders the library by style distance to it (Garces et al.
//! 2014, Fig. 5.12). A bad request keeps the form and says what is wrong above the results.

use askama::Template;
use axum::Router;
use axum::extract::State;
use axum::response::Response;
use axum::routing::get;
use serde::Deserialize;

use super::{page, render};
use crate::AppState;
use crate::error::AppError;
use crate::search::{self, SearchAnswer, SearchOrder, SearchRequest};
use crate::studies::library;
use crate::web::admin::Admin;
use crate::web::extract::ApiQuery;

/// The page's routes.
pub(super) fn routes() -> Router<AppState> {
    Router::new().route("/admin/search", get(search_page))
}

/// The form as the browser sends it (every field optional; the first library by default).
#[derive(Debug, Default, Deserialize)]
pub(super) struct SearchForm {
    pub library: Option<String>,
    pub model: Option<String>,
    pub q: Option<String>,
    pub category: Option<String>,
    pub near: Option<String>,
    pub limit: Option<u32>,
}

/// One thumbnail.
struct ResultCard {
    url: String,
    name: String,
    style: String,
    /// `d = 0.123`, or the cluster in the diversity order.
    detail: String,
    more_like_this: String,
}

/// An option of a drop-down.
struct Choice {
    value: String,
    label: String,
    selected: bool,
}

#[derive(Template)]
#[template(path = "search.html")]
pub(super) struct SearchPage {
    /// The library searched (the upload form's hidden field).
    library: String,
    /// The metric chosen (the upload form's hidden field).
    model: String,
    /// The session's CSRF token (the upload form posts).
    pub csrf: String,
    /// An uploaded drawing the results are ordered by: its name and a `data:` PNG thumbnail.
    pub example: Option<(String, String)>,
    libraries: Vec<Choice>,
    models: Vec<Choice>,
    categories: Vec<Choice>,
    q: String,
    near: String,
    /// Images of the reference items of a "more like this" search.
    references: Vec<String>,
    error: Option<String>,
    summary: Option<String>,
    uniform: bool,
    results: Vec<ResultCard>,
}

/// `?a=b&c=d` with each value percent-encoded.
fn query_string(pairs: &[(&str, &str)]) -> String {
    let mut out = form_urlencoded::Serializer::new(String::new());
    for (k, v) in pairs.iter().filter(|(_, v)| !v.is_empty()) {
        out.append_pair(k, v);
    }
    format!("/admin/search?{}", out.finish())
}

async fn search_page(
    State(state): State<AppState>,
    admin: std::result::Result<Admin, AppError>,
    form: std::result::Result<ApiQuery<SearchForm>, AppError>,
) -> Response {
    page(
        async {
            let admin = admin?;
            let ApiQuery(form) = form?;
            let names = library::library_names(&state.db).await?;
            let library = form
                .library
                .clone()
                .filter(|l| !l.trim().is_empty())
                .or_else(|| names.first().cloned());
            let Some(library) = library else {
                return render(&SearchPage {
                    library: String::new(),
                    model: String::new(),
                    csrf: admin.csrf,
                    example: None,
                    libraries: Vec::new(),
                    models: Vec::new(),
                    categories: Vec::new(),
                    q: String::new(),
                    near: String::new(),
                    references: Vec::new(),
                    error: Some(
                        "There is no library yet: import one with `platform library import` or \
                         upload items on the studies page."
                            .into(),
                    ),
                    summary: None,
                    uniform: false,
                    results: Vec::new(),
                });
            };
            let request = SearchRequest {
                library: library.clone(),
                model: form.model.clone(),
                q: form.q.clone(),
                category: form.category.clone(),
                near: form.near.clone(),
                limit: form.limit,
            };
            // A request error is shown on the page with the form kept; anything else is an
            // error page.
            let (answer, error) = match search::run(&state, &request).await {
                Ok(a) => (Some(a), None),
                Err(e @ (AppError::BadRequest(_) | AppError::Conflict(_))) => {
                    (None, Some(e.public_message()))
                }
                Err(e) => return Err(e),
            };
            let model = form.model.clone().unwrap_or_default();
            let category = form.category.clone().unwrap_or_default();
            let mut page = page_of(&library, &names, &model, &category, &form, answer, error);
            page.csrf = admin.csrf;
            render(&page)
        }
        .await,
    )
}

/// The page for a search's answer (or its error); `csrf` and `example` are left empty.
pub(super) fn page_of(
    library: &str,
    names: &[String],
    model: &str,
    category: &str,
    form: &SearchForm,
    answer: Option<SearchAnswer>,
    error: Option<String>,
) -> SearchPage {
    let choice = |value: String, label: String, selected: bool| Choice {
        value,
        label,
        selected,
    };
    let libraries = names
        .iter()
        .map(|n| choice(n.clone(), n.clone(), n == library))
        .collect();
    let mut models = vec![
        choice(
            String::new(),
            "newest trained model".into(),
            model.is_empty(),
        ),
        choice(
            "uniform".into(),
            "uniform weights".into(),
            model == "uniform",
        ),
    ];
    let mut categories = vec![choice(String::new(), "any".into(), category.is_empty())];
    let q = form.q.clone().unwrap_or_default();
    let near = form.near.clone().unwrap_or_default();
    let Some(answer) = answer else {
        return SearchPage {
            library: library.into(),
            model: model.into(),
            csrf: String::new(),
            example: None,
            libraries,
            models,
            categories,
            q,
            near,
            references: Vec::new(),
            error,
            summary: None,
            uniform: false,
            results: Vec::new(),
        };
    };
    for m in &answer.models {
        let id = m.id.to_string();
        let selected = model == id;
        models.push(choice(
            id.clone(),
            format!("model {id} ({})", m.study),
            selected,
        ));
    }
    for c in &answer.categories {
        categories.push(choice(c.clone(), c.clone(), c == category));
    }
    let metric = match answer.model {
        Some(id) => format!("model {id}"),
        None => "uniform weights".into(),
    };
    let summary = format!(
        "{} of {} matching items, {} ({}).",
        answer.results.len(),
        answer.matched,
        match answer.order {
            SearchOrder::Style => "nearest in style first",
            SearchOrder::Diversity => "dealt across the library's style clusters",
            SearchOrder::Random => "in random order",
        },
        metric
    );
    let model_value = answer.model.map(|m| m.to_string()).unwrap_or_else(|| {
        if model == "uniform" {
            "uniform".into()
        } else {
            String::new()
        }
    });
    let results = answer
        .results
        .iter()
        .map(|r| ResultCard {
            url: r.url.clone(),
            name: r.name.clone(),
            style: r.style.clone().unwrap_or_default(),
            detail: match (r.distance, r.cluster) {
                (Some(d), _) => format!("d = {d:.3}"),
                (None, Some(c)) => format!("cluster {}", c + 1),
                (None, None) => String::new(),
            },
            more_like_this: query_string(&[
                ("library", library),
                ("model", &model_value),
                ("q", form.q.as_deref().unwrap_or("")),
                ("category", category),
                ("near", &r.id.to_string()),
            ]),
        })
        .collect();
    // The search succeeded, so every id in `near` is an item of the library.
    let references = near
        .split(',')
        .map(str::trim)
        .filter(|id| !id.is_empty())
        .map(|id| format!("/media/items/{id}.png"))
        .collect();
    SearchPage {
        library: library.into(),
        model: model.into(),
        csrf: String::new(),
        example: None,
        libraries,
        models,
        categories,
        q,
        near,
        references,
        error,
        summary: Some(summary),
        uniform: answer.uniform,
        results,
    }
}
