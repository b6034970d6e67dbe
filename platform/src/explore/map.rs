//! The style map (§5.7.1 of Garces et al. 2014; the map view of §6.5): t-SNE of a library's
//! items of some labels (every item, or k-means representatives per label) as a stored job, and
//! a level-of-detail view of it — for a viewport, at most one thumbnail per screen cell (chosen
//! here, never in the browser) and dots for the rest — so that 200,000 points stay smooth.

use std::sync::Arc;

use learner::explore::TsneParams;
use learner::explore::map::{MapParams, style_map};
use serde::{Deserialize, Serialize};
use utoipa::{IntoParams, ToSchema};

use super::jobs::{self, Job, JobKey, Kind, Progress};
use super::taxonomy::{check_labels, style_library};
use super::{MAX_LABELS, label_counts, resolve, text};
use crate::AppState;
use crate::error::{AppError, Result};
use crate::search::cache::{Built, Key};
use crate::store::ids::{ExplorationId, ItemId};

/// Most thumbnails of one view.
pub const MAX_THUMBNAILS: usize = 2_000;
/// Most dots of one view (a stride through the viewport's other points).
pub const MAX_DOTS: usize = 50_000;

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

/// A viewport of the map, in map coordinates, cut into `cols × rows` screen cells.
#[derive(Debug, Clone, Copy, Deserialize, IntoParams)]
#[into_params(parameter_in = Query)]
pub struct ViewQuery {
    /// Left edge.
    pub x0: f64,
    /// Right edge (> x0).
    pub x1: f64,
    /// Top edge.
    pub y0: f64,
    /// Bottom edge (> y0).
    pub y1: f64,
    /// Screen cells across (1–200; cols·rows at most 2,000).
    #[param(minimum = 1, maximum = 200)]
    pub cols: usize,
    /// Screen cells down (1–200).
    #[param(minimum = 1, maximum = 200)]
    pub rows: usize,
}

/// A thumbnail drawn.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct MapThumbnail {
    /// The item.
    pub id: ItemId,
    /// Its x.
    pub x: f32,
    /// Its y.
    pub y: f32,
    /// Its image.
    pub url: String,
}

/// What to draw in a viewport.
#[derive(Debug, Clone, Serialize, ToSchema)]
pub struct MapView {
    /// Points of the whole map.
    pub total: usize,
    /// Points in the viewport.
    pub in_view: usize,
    /// The bounds of the whole map `[x0, y0, x1, y1]`.
    pub bounds: [f32; 4],
    /// One per occupied screen cell: the cell's first item in map order.
    pub thumbnails: Vec<MapThumbnail>,
    /// The viewport's other points `[x, y]` (a stride through them beyond 50,000).
    pub dots: Vec<[f32; 2]>,
}

/// What to draw of a finished map `job` in `q`'s viewport.
pub fn view(job: &Job, q: &ViewQuery) -> Result<MapView> {
    if job.kind != "map" {
        return Err(AppError::NotFound("style map"));
    }
    let Some(result) = &job.result else {
        return Err(AppError::Conflict(format!(
            "exploration {} is {}: wait until it is done",
            job.id, job.status
        )));
    };
    let finite = [q.x0, q.x1, q.y0, q.y1].iter().all(|v| v.is_finite());
    if !finite || q.x1 <= q.x0 || q.y1 <= q.y0 {
        return Err(AppError::BadRequest(
            "x0 < x1 and y0 < y1, finite numbers".into(),
        ));
    }
    if !(1..=200).contains(&q.cols)
        || !(1..=200).contains(&q.rows)
        || q.cols * q.rows > MAX_THUMBNAILS
    {
        return Err(AppError::BadRequest(format!(
            "cols and rows: 1–200 each, cols·rows at most {MAX_THUMBNAILS}"
        )));
    }
    let map: MapResult = serde_json::from_value(result.clone()).map_err(AppError::internal)?;
    let n = map.items.len();
    let mut bounds = [
        f32::INFINITY,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NEG_INFINITY,
    ];
    for (&x, &y) in map.x.iter().zip(&map.y) {
        bounds[0] = bounds[0].min(x);
        bounds[1] = bounds[1].min(y);
        bounds[2] = bounds[2].max(x);
        bounds[3] = bounds[3].max(y);
    }
    let mut taken = vec![false; q.cols * q.rows];
    let (mut thumbnails, mut rest) = (Vec::new(), Vec::new());
    for ((&id, &mx), &my) in map.items.iter().zip(&map.x).zip(&map.y) {
        let (x, y) = (f64::from(mx), f64::from(my));
        if x < q.x0 || x >= q.x1 || y < q.y0 || y >= q.y1 {
            continue;
        }
        let cx = (((x - q.x0) / (q.x1 - q.x0)) * q.cols as f64) as usize;
        let cy = (((y - q.y0) / (q.y1 - q.y0)) * q.rows as f64) as usize;
        let cell = cy.min(q.rows - 1) * q.cols + cx.min(q.cols - 1);
        if taken[cell] {
            rest.push([mx, my]);
        } else {
            taken[cell] = true;
            thumbnails.push(MapThumbnail {
                id,
                x: mx,
                y: my,
                url: format!("/media/items/{id}.png"),
            });
        }
    }
    let in_view = thumbnails.len() + rest.len();
    let stride = rest.len().div_ceil(MAX_DOTS).max(1);
    Ok(MapView {
        total: n,
        in_view,
        bounds,
        thumbnails,
        dots: rest.into_iter().step_by(stride).collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::store::ids::LibraryId;

    fn job(points: &[(i64, f32, f32)]) -> Job {
        let result = MapResult {
            items: points.iter().map(|p| ItemId(p.0)).collect(),
            x: points.iter().map(|p| p.1).collect(),
            y: points.iter().map(|p| p.2).collect(),
            kl_divergence: 0.0,
        };
        Job {
            id: ExplorationId(1),
            library: LibraryId(1),
            model: None,
            kind: "map".into(),
            params: serde_json::Value::Null,
            status: "done".into(),
            stage: "done".into(),
            done: 1,
            total: 1,
            error: None,
            created_at: 0,
            finished_at: Some(0),
            result: Some(serde_json::to_value(result).expect("JSON")),
        }
    }

    fn q(x0: f64, x1: f64, y0: f64, y1: f64, cols: usize, rows: usize) -> ViewQuery {
        ViewQuery {
            x0,
            x1,
            y0,
            y1,
            cols,
            rows,
        }
    }

    #[test]
    fn one_thumbnail_per_occupied_cell_the_rest_as_dots() {
        // Cells of a 2 × 2 view over [0, 2)²: items 1 and 2 share the top-left cell.
        let j = job(&[
            (1, 0.1, 0.1),
            (2, 0.9, 0.2),
            (3, 1.5, 0.5),
            (4, 1.5, 1.5),
            (5, 5.0, 5.0),
        ]);
        let v = view(&j, &q(0.0, 2.0, 0.0, 2.0, 2, 2)).expect("view");
        assert_eq!((v.total, v.in_view), (5, 4));
        let ids: Vec<i64> = v.thumbnails.iter().map(|t| t.id.0).collect();
        assert_eq!(ids, vec![1, 3, 4]);
        assert_eq!(v.dots, vec![[0.9, 0.2]]);
        assert_eq!(v.bounds, [0.1, 0.1, 5.0, 5.0]);
        // One cell: one thumbnail, every other point in view a dot.
        let v = view(&j, &q(-10.0, 10.0, -10.0, 10.0, 1, 1)).expect("view");
        assert_eq!((v.thumbnails.len(), v.dots.len()), (1, 4));
    }

    #[test]
    fn bad_viewports_are_refused() {
        let j = job(&[(1, 0.0, 0.0)]);
        for bad in [
            q(1.0, 0.0, 0.0, 1.0, 1, 1),
            q(0.0, 1.0, 0.0, f64::NAN, 1, 1),
            q(0.0, 1.0, 0.0, 1.0, 0, 1),
            q(0.0, 1.0, 0.0, 1.0, 50, 41),
        ] {
            assert!(matches!(view(&j, &bad), Err(AppError::BadRequest(_))));
        }
        let mut taxonomy = j.clone();
        taxonomy.kind = "taxonomy".into();
        assert!(matches!(
            view(&taxonomy, &q(0.0, 1.0, 0.0, 1.0, 1, 1)),
            Err(AppError::NotFound(_))
        ));
    }
}
