//! The style map (§5.7.1 of Garces et al. 2014; the map view of §6.5): t-SNE of a library's
//! items of some labels (every item, or k-means representatives per label) as a stored job, and
//! a level-of-detail view of it — for a viewport, at most one thumbnail per screen cell (chosen
//! here, never in the browser) and dots for the rest — so that 200,000 points stay smooth.

mod view;

use std::sync::Arc;

use learner::explore::TsneParams;
use learner::explore::map::{MapParams, style_map};
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::jobs::{self, JobKey, Kind, Progress};
use super::taxonomy::{check_labels, style_library};
use super::{MAX_LABELS, label_counts, resolve, text};
use crate::AppState;
use crate::error::{AppError, Result};
use crate::search::cache::{Built, Key};
use crate::store::ids::{ExplorationId, ItemId};

pub use view::{MAX_DOTS, MAX_THUMBNAILS, MapCache, MapIndex, MapThumbnail, MapView, ViewQuery};

/// A style map request.
#[derive(Debug, Clone, Default, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct MapRequest {
    /// The library (its name).
    #[schema(max_length = 200)]
    pub library: String,
    /// `uniform`, a model id, or omitted: the newest trained model over the library.
    pub model: Option<String>,
    /// The labels whose items are mapped (empty: every item).
    #[serde(default)]
    pub labels: Vec<String>,
    /// Representatives per label (k-means, 100 in the paper); omitted: every item.
    pub per_label: Option<usize>,
    /// t-SNE perplexity (default 30).
    pub perplexity: Option<f64>,
}

/// A finished map: parallel arrays, by mapped item.
#[derive(Debug, Clone, Serialize, Deserialize, ToSchema)]
pub struct MapResult {
    /// The mapped items.
    pub items: Vec<ItemId>,
    /// Their x.
    pub x: Vec<f32>,
    /// Their y.
    pub y: Vec<f32>,
    /// The t-SNE's final KL divergence.
    pub kl_divergence: f64,
}

/// Checks `req`, then returns the stored map job for it or starts one (`true`).
pub async fn start(state: &AppState, req: &MapRequest) -> Result<(ExplorationId, bool)> {
    let (library, model) = resolve(&state.db, &req.library, req.model.as_deref()).await?;
    if req.labels.len() > MAX_LABELS {
        return Err(AppError::BadRequest(format!(
            "labels: at most {MAX_LABELS}"
        )));
    }
    let mut labels = req
        .labels
        .iter()
        .map(|l| text("labels", l))
        .collect::<Result<Vec<_>>>()?;
    labels.retain(|l| !l.is_empty());
    labels.sort();
    labels.dedup();
    let tsne = TsneParams {
        perplexity: req.perplexity.unwrap_or(TsneParams::default().perplexity),
        ..TsneParams::default()
    };
    tsne.validate()
        .map_err(|e| AppError::BadRequest(e.to_string()))?;
    if req.per_label == Some(0) {
        return Err(AppError::BadRequest("per_label: at least 1".into()));
    }
    let counts = label_counts(&state.db, library).await?;
    let items = check_labels(&counts, &labels)?;
    let chosen = counts
        .iter()
        .filter(|c| labels.is_empty() || labels.contains(&c.label));
    let points: usize = match req.per_label {
        None => items,
        Some(k) => chosen.map(|c| c.count.min(k)).sum(),
    };
    let needed = tsne.neighbours() + 1;
    if points < needed {
        let e = learner::Error::TsneTooFewPoints {
            n: points,
            perplexity: tsne.perplexity,
            needed,
        };
        return Err(AppError::BadRequest(e.to_string()));
    }
    let params = MapParams {
        per_label: req.per_label,
        tsne,
    };
    let key = JobKey {
        library,
        model,
        kind: Kind::Map,
        params: serde_json::json!({
            "labels": labels,
            "per_label": req.per_label,
            "perplexity": params.tsne.perplexity,
        })
        .to_string(),
        library_items: counts.iter().map(|c| c.count as i64).sum(),
    };
    let (id, new) = jobs::find_or_create(&state.db, &key).await?;
    if new {
        let cache = state.search.clone();
        let db = state.db.clone();
        jobs::spawn(
            state.clone(),
            id,
            async move { cache.get(&db, Key { library, model }).await },
            move |built: Arc<Built>, progress: &Progress| {
                let (library, rows) = style_library(&built, &labels)?;
                let map = style_map(&library, &params, &mut |done, total| {
                    progress.set("t-SNE", done, total);
                })
                .map_err(|e| AppError::BadRequest(e.to_string()))?;
                let result = MapResult {
                    items: map.items.iter().map(|&i| built.ids[rows[i]]).collect(),
                    x: map.positions.iter().map(|p| p[0]).collect(),
                    y: map.positions.iter().map(|p| p[1]).collect(),
                    kl_divergence: map.info.kl_divergence,
                };
                serde_json::to_value(result).map_err(AppError::internal)
            },
        );
    }
    Ok((id, new))
}
