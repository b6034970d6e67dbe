//! The level-of-detail view of a finished style map: for a viewport, at most one thumbnail per
//! screen cell (chosen here, never in the browser) and dots for the rest. A finished map never
//! changes, so the server keeps the last few it parsed ([`MapCache`]): a pan or zoom over
//! 200,000 points is then one pass over three arrays, not a read and parse of the stored result.

use std::sync::{Arc, Mutex};

use serde::Serialize;
use utoipa::{IntoParams, ToSchema};

use super::MapResult;
use crate::error::{AppError, Result};
use crate::explore::jobs::{self, Job};
use crate::store::db::Db;
use crate::store::ids::{ExplorationId, ItemId};

/// Most thumbnails of one view.
pub const MAX_THUMBNAILS: usize = 2_000;
/// Most dots of one view (a stride through the viewport's other points).
pub const MAX_DOTS: usize = 50_000;
/// Parsed maps a server keeps (about 12 bytes per point: 2.4 MB for 200,000 points).
pub const CACHED_MAPS: usize = 8;

/// A viewport of the map, in map coordinates, cut into `cols × rows` screen cells.
#[derive(Debug, Clone, Copy, serde::Deserialize, IntoParams)]
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

/// A finished map, parsed, with its bounds.
#[derive(Debug)]
pub struct MapIndex {
    map: MapResult,
    bounds: [f32; 4],
}

impl MapIndex {
    /// Parses the result of a finished map `job` (a 404 for another kind, a 409 while it runs).
    pub fn of_job(job: &Job) -> Result<Self> {
        if job.kind != "map" {
            return Err(AppError::NotFound("style map"));
        }
        let Some(result) = &job.result else {
            return Err(not_done(job));
        };
        let map: MapResult = serde_json::from_value(result.clone()).map_err(AppError::internal)?;
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
        Ok(Self { map, bounds })
    }

    /// What to draw in `q`'s viewport.
    pub fn view(&self, q: &ViewQuery) -> Result<MapView> {
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
        let map = &self.map;
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
            total: map.items.len(),
            in_view,
            bounds: self.bounds,
            thumbnails,
            dots: rest.into_iter().step_by(stride).collect(),
        })
    }
}

/// The 409 for a map that is not done.
fn not_done(job: &Job) -> AppError {
    AppError::Conflict(format!(
        "exploration {} is {}: wait until it is done",
        job.id, job.status
    ))
}

/// The last [`CACHED_MAPS`] finished maps a server parsed, most recently used last.
#[derive(Debug, Default)]
pub struct MapCache {
    entries: Mutex<Vec<(ExplorationId, Arc<MapIndex>)>>,
}

impl MapCache {
    /// The parsed map `id`: from the cache, or read (its status first, so that a running or
    /// missing map costs no read of a result) and kept.
    pub async fn get(&self, db: &Db, id: ExplorationId) -> Result<Arc<MapIndex>> {
        if let Some(index) = self.touch(id) {
            return Ok(index);
        }
        let status = jobs::load_status(db, id).await?;
        if status.kind != "map" {
            return Err(AppError::NotFound("style map"));
        }
        if status.status != "done" {
            return Err(not_done(&status));
        }
        let job = jobs::load(db, id).await?;
        let index = Arc::new(MapIndex::of_job(&job)?);
        let mut entries = self.entries.lock().map_err(|_| poisoned())?;
        entries.retain(|(k, _)| *k != id);
        if entries.len() >= CACHED_MAPS {
            entries.remove(0);
        }
        entries.push((id, index.clone()));
        Ok(index)
    }

    /// The cached map `id`, moved to the most recently used place.
    fn touch(&self, id: ExplorationId) -> Option<Arc<MapIndex>> {
        let mut entries = self.entries.lock().ok()?;
        let at = entries.iter().position(|(k, _)| *k == id)?;
        let entry = entries.remove(at);
        let index = entry.1.clone();
        entries.push(entry);
        Some(index)
    }

    /// Ids of the cached maps, least recently used first.
    pub fn cached(&self) -> Vec<ExplorationId> {
        self.entries
            .lock()
            .map(|e| e.iter().map(|(k, _)| *k).collect())
            .unwrap_or_default()
    }
}

fn poisoned() -> AppError {
    AppError::internal("the map cache's lock was poisoned by a panic")
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
        let v = MapIndex::of_job(&j)
            .expect("map")
            .view(&q(0.0, 2.0, 0.0, 2.0, 2, 2))
            .expect("view");
        assert_eq!((v.total, v.in_view), (5, 4));
        let ids: Vec<i64> = v.thumbnails.iter().map(|t| t.id.0).collect();
        assert_eq!(ids, vec![1, 3, 4]);
        assert_eq!(v.dots, vec![[0.9, 0.2]]);
        assert_eq!(v.bounds, [0.1, 0.1, 5.0, 5.0]);
        // One cell: one thumbnail, every other point in view a dot.
        let v = MapIndex::of_job(&j)
            .expect("map")
            .view(&q(-10.0, 10.0, -10.0, 10.0, 1, 1))
            .expect("view");
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
            let index = MapIndex::of_job(&j).expect("map");
            assert!(matches!(index.view(&bad), Err(AppError::BadRequest(_))));
        }
        let mut taxonomy = j.clone();
        taxonomy.kind = "taxonomy".into();
        assert!(matches!(
            MapIndex::of_job(&taxonomy),
            Err(AppError::NotFound(_))
        ));
    }
}

#[cfg(test)]
mod cache_tests;
