//! Style search in the platform (Garces et al. 2014 §5.7.3): a library's items found by keyword
//! and style label, ordered by their mean style distance (eq. 5.5, under a trained model or
//! uniform weights) to reference items — the "more like this" item, later the canvas — or, with
//! no reference, dealt across style clusters so that the first screen shows the library's
//! variety. The engine is `learner::search`; this module chooses the index, checks the request
//! and names the results.

pub mod cache;
pub mod example;
pub mod source;

use learner::search::{Order, Query};
use serde::{Deserialize, Serialize};
use utoipa::{IntoParams, ToSchema};

use crate::AppState;
use crate::error::{AppError, Result};
use crate::store::ids::{ItemId, ModelId};
pub use cache::IndexCache;
use cache::Key;
pub use source::ModelChoice;

/// Longest keyword text or category accepted.
pub const MAX_TEXT_CHARS: usize = 200;
/// Most reference items of one search.
pub const MAX_NEAR: usize = 20;
/// Most results of one search.
pub const MAX_LIMIT: u32 = 200;
/// Results when the request does not say (a grid of 8 × 6 thumbnails).
pub const DEFAULT_LIMIT: u32 = 48;

/// A search, as a query string (`GET /api/v1/admin/search?library=icons&q=dog&near=12,34`).
#[derive(Debug, Clone, Default, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct SearchRequest {
    /// The library (its name).
    #[param(max_length = 200)]
    pub library: String,
    /// `uniform`, a model id, or omitted: the newest trained model of a study over the
    /// library, uniform weights when there is none.
    pub model: Option<String>,
    /// Keywords, matched in names and keywords (each word exactly, as a prefix or with a typo).
    #[param(max_length = 200)]
    pub q: Option<String>,
    /// Only items with this style label.
    #[param(max_length = 200)]
    pub category: Option<String>,
    /// Comma-separated item ids of the library: results ordered by mean style distance to them
    /// ("more like this"; the items on a canvas). Without: dealt across style clusters.
    pub near: Option<String>,
    /// Results wanted (1–200, default 48).
    #[param(minimum = 1, maximum = 200)]
    pub limit: Option<u32>,
}

/// How results are ordered.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, ToSchema)]
#[serde(rename_all = "lowercase")]
pub enum SearchOrder {
    /// By mean style distance to the reference items.
    Style,
    /// Dealt across the library's style clusters (no reference item).
    Diversity,
    /// In a seeded random order (condition B of the mash-up study, §5.7.3).
    Random,
}

/// One result.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct SearchResult {
    /// The item.
    pub id: ItemId,
    /// Its name in the library.
    pub name: String,
    /// Its style label.
    pub style: Option<String>,
    /// Its image.
    pub url: String,
    /// Mean style distance `d` (eq. 5.5) to the reference items (style order only).
    pub distance: Option<f64>,
    /// Its top-level style cluster, 0–6 (diversity order only).
    pub cluster: Option<u16>,
}

/// The answer to a search.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct SearchAnswer {
    /// The library searched.
    pub library: String,
    /// The model whose metric ordered the results; `null` with uniform weights.
    pub model: Option<ModelId>,
    /// True when no trained model was used (every feature weighs the same).
    pub uniform: bool,
    /// How the results are ordered.
    pub order: SearchOrder,
    /// Items matching the keywords and category (the whole library without either).
    pub matched: usize,
    /// The results, in the order to show them.
    pub results: Vec<SearchResult>,
    /// The finished models over this library, newest first.
    pub models: Vec<ModelChoice>,
    /// The library's style labels, for the category filter.
    pub categories: Vec<String>,
}

/// The request's model choice.
enum ModelWanted {
    Newest,
    Uniform,
    Id(ModelId),
}

/// Checks `req` and runs it.
pub async fn run(state: &AppState, req: &SearchRequest) -> Result<SearchAnswer> {
    run_with_examples(state, req, Vec::new()).await
}

/// [`run`], with the features of drawings that are not in the library (an upload, see
/// [`example`]) among the references: results are then ordered by mean style distance to them
/// and to the `near` items.
pub async fn run_with_examples(
    state: &AppState,
    req: &SearchRequest,
    examples: Vec<Vec<f64>>,
) -> Result<SearchAnswer> {
    run_ordered(state, req, examples, None).await
}

/// [`run`] with the keyword and category matches in the random order drawn from `seed`
/// (condition B of the mash-up study, §5.7.3); `near` must be empty.
pub async fn run_shuffled(
    state: &AppState,
    req: &SearchRequest,
    seed: u64,
) -> Result<SearchAnswer> {
    run_ordered(state, req, Vec::new(), Some(seed)).await
}

async fn run_ordered(
    state: &AppState,
    req: &SearchRequest,
    examples: Vec<Vec<f64>>,
    shuffle: Option<u64>,
) -> Result<SearchAnswer> {
    let text = |name: &str, value: &Option<String>| -> Result<Option<String>> {
        match value.as_deref().map(str::trim) {
            None | Some("") => Ok(None),
            Some(v) if v.chars().count() > MAX_TEXT_CHARS => Err(AppError::BadRequest(format!(
                "{name}: at most {MAX_TEXT_CHARS} characters"
            ))),
            Some(v) => Ok(Some(v.to_string())),
        }
    };
    // Control characters are refused before anything reaches the database (PostgreSQL
    // rejects a NUL in text) or the keyword parser.
    for (name, value) in [
        ("library", Some(&req.library)),
        ("model", req.model.as_ref()),
        ("q", req.q.as_ref()),
        ("category", req.category.as_ref()),
        ("near", req.near.as_ref()),
    ] {
        if value.is_some_and(|v| v.chars().any(char::is_control)) {
            return Err(AppError::BadRequest(format!(
                "{name}: control characters are not allowed"
            )));
        }
    }
    let keywords = text("q", &req.q)?;
    let category = text("category", &req.category)?;
    let limit = req.limit.unwrap_or(DEFAULT_LIMIT);
    if !(1..=MAX_LIMIT).contains(&limit) {
        return Err(AppError::BadRequest(format!("limit: 1..={MAX_LIMIT}")));
    }
    let near = parse_near(req.near.as_deref().unwrap_or(""))?;
    let wanted = match req.model.as_deref().map(str::trim) {
        None | Some("") => ModelWanted::Newest,
        Some("uniform") => ModelWanted::Uniform,
        Some(v) => ModelWanted::Id(v.parse().map_err(|_| {
            AppError::BadRequest(format!(
                "model: a model id or \"uniform\", not {:?}",
                v.chars().take(40).collect::<String>()
            ))
        })?),
    };
    if req.library.trim().is_empty() {
        return Err(AppError::BadRequest("library: required".into()));
    }
    if req.library.chars().count() > MAX_TEXT_CHARS {
        return Err(AppError::BadRequest(format!(
            "library: at most {MAX_TEXT_CHARS} characters"
        )));
    }

    let db = &state.db;
    let library = source::library_by_name(db, &req.library).await?;
    let models = source::models_for(db, library).await?;
    let model = match wanted {
        ModelWanted::Newest => models.first().map(|m| m.id),
        ModelWanted::Uniform => None,
        ModelWanted::Id(id) => Some(id),
    };
    let built = state.search.get(db, Key { library, model }).await?;
    let near_names = near
        .iter()
        .map(|&id| {
            built
                .row_of(id)
                .map(|row| built.index.ids()[row].clone())
                .ok_or_else(|| {
                    AppError::BadRequest(format!(
                        "near: item {id} is not in library {}",
                        req.library
                    ))
                })
        })
        .collect::<Result<Vec<_>>>()?;
    let diverse = near_names.is_empty() && examples.is_empty();
    let query = Query {
        keywords,
        category,
        near: near_names,
        examples,
        diverse: diverse && shuffle.is_none(),
        shuffle,
        limit: limit as usize,
    };
    // The engine's refusals (keywords with no searchable word…) are the request's fault.
    query
        .validate()
        .map_err(|e| AppError::BadRequest(e.to_string()))?;
    let found = {
        let built = built.clone();
        tokio::task::spawn_blocking(move || built.index.search(&query))
            .await
            .map_err(AppError::internal)?
            .map_err(|e| AppError::BadRequest(e.to_string()))?
    };
    let results = found
        .hits
        .iter()
        .map(|hit| {
            let row = hit.row as usize;
            let id = built.ids[row];
            SearchResult {
                id,
                name: hit.id.clone(),
                style: built.styles[row].clone(),
                url: format!("/media/items/{id}.png"),
                distance: hit.distance,
                cluster: hit.cluster.map(|c| c.top),
            }
        })
        .collect();
    Ok(SearchAnswer {
        library: req.library.clone(),
        model,
        uniform: model.is_none(),
        order: match found.order {
            Order::Style => SearchOrder::Style,
            Order::Diversity | Order::Relevance => SearchOrder::Diversity,
            Order::Random => SearchOrder::Random,
        },
        matched: found.matched,
        results,
        models,
        categories: built.categories.clone(),
    })
}

/// `12,34` → the ids, each once, at most [`MAX_NEAR`].
fn parse_near(text: &str) -> Result<Vec<ItemId>> {
    let mut ids: Vec<ItemId> = Vec::new();
    for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let id: ItemId = part.parse().map_err(|_| {
            AppError::BadRequest(format!(
                "near: item ids separated by commas, not {:?}",
                part.chars().take(40).collect::<String>()
            ))
        })?;
        if !ids.contains(&id) {
            ids.push(id);
        }
    }
    if ids.len() > MAX_NEAR {
        return Err(AppError::BadRequest(format!(
            "near: at most {MAX_NEAR} items"
        )));
    }
    Ok(ids)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn near_lists_are_parsed_checked_and_deduplicated() {
        assert_eq!(parse_near("").expect("empty"), vec![]);
        assert_eq!(
            parse_near(" 12, 34,12 ,").expect("ids"),
            vec![ItemId(12), ItemId(34)]
        );
        assert!(parse_near("12,dog").is_err());
        let many: Vec<String> = (1..=21).map(|i| i.to_string()).collect();
        assert!(parse_near(&many.join(",")).is_err());
        assert!(parse_near(&many[..20].join(",")).is_ok());
    }
}
