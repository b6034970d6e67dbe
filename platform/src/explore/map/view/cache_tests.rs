//! [`MapCache`] against real SQLite and PostgreSQL: what it refuses, that it serves a map it
//! parsed without reading the database again, and its least-recently-used eviction.

use super::*;
use crate::store::db::now_ms;

/// Stores an exploration of `kind` with `status` and `result` (raw JSON text or NULL).
async fn store(db: &Db, id: i64, kind: &str, status: &str, result: Option<String>) {
    let now = now_ms();
    sqlx::query(
        "INSERT INTO explorations (id, library_id, model_id, kind, params, library_items, \
         status, progress_done, progress_total, stage, result, created_at, heartbeat_at) \
         VALUES ($1, 1, NULL, $2, '{}', 3, $3, 0, 0, $3, $4, $5, $5)",
    )
    .bind(id)
    .bind(kind)
    .bind(status)
    .bind(result)
    .bind(now)
    .execute(&db.pool)
    .await
    .expect("insert exploration");
}

fn map_json(points: &[(i64, f32, f32)]) -> String {
    serde_json::to_string(&MapResult {
        items: points.iter().map(|p| ItemId(p.0)).collect(),
        x: points.iter().map(|p| p.1).collect(),
        y: points.iter().map(|p| p.2).collect(),
        kl_divergence: 0.5,
    })
    .expect("JSON")
}

/// The stored maps' points have x in {-3, 0, 1}: one column per unit over [-3.5, 2.5), each
/// point in the middle of its column.
fn whole(cols: usize) -> ViewQuery {
    ViewQuery {
        x0: -3.5,
        x1: 2.5,
        y0: -1.0,
        y1: 5.0,
        cols,
        rows: 1,
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_map_cache_refuses_unfinished_maps_and_serves_a_parsed_one_without_the_database() {
    for (db, _dir) in crate::flow::tests::databases().await {
        sqlx::query("INSERT INTO libraries (id, name, created_at) VALUES (1, 'lib', 0)")
            .execute(&db.pool)
            .await
            .expect("library");
        store(&db, 10, "map", "running", None).await;
        store(&db, 11, "taxonomy", "done", Some("{}".into())).await;
        let last = 20 + CACHED_MAPS as i64;
        for id in 20..=last {
            let points = [(id, 0.0, 0.0), (id + 100, 1.0, 2.0), (id + 200, -3.0, 4.0)];
            store(&db, id, "map", "done", Some(map_json(&points))).await;
        }
        let cache = MapCache::default();
        let get = |id: i64| cache.get(&db, ExplorationId(id));
        assert!(matches!(get(10).await, Err(AppError::Conflict(_))));
        assert!(matches!(get(11).await, Err(AppError::NotFound(_))));
        assert!(matches!(get(99).await, Err(AppError::NotFound(_))));
        assert!(cache.cached().is_empty(), "nothing unfinished is kept");

        let v = get(20)
            .await
            .expect("map 20")
            .view(&whole(3))
            .expect("view");
        assert_eq!((v.total, v.in_view, v.thumbnails.len()), (3, 3, 3));
        assert_eq!(v.bounds, [-3.0, 0.0, 1.0, 4.0]);
        // Served again once its row is gone: parsed once, never read again.
        sqlx::query("DELETE FROM explorations WHERE id = 20")
            .execute(&db.pool)
            .await
            .expect("delete");
        let again = get(20).await.expect("cached map 20").view(&whole(1));
        let again = again.expect("view");
        assert_eq!((again.thumbnails.len(), again.dots.len()), (1, 2));
        assert_eq!(
            again.thumbnails[0].id,
            ItemId(20),
            "first item in map order"
        );

        // The least recently used map goes first: 20 is the oldest once 21.. are read, and
        // reading 21 again moves it past the others.
        for id in 21..last {
            get(id).await.expect("map");
        }
        get(21).await.expect("map 21");
        get(last).await.expect("one more map than the cache holds");
        let kept: Vec<i64> = cache.cached().iter().map(|k| k.0).collect();
        assert_eq!(kept.len(), CACHED_MAPS);
        assert!(
            !kept.contains(&20),
            "the least recently used map went: {kept:?}"
        );
        assert!(kept.contains(&21), "a map read again stays: {kept:?}");
        assert_eq!(kept.last(), Some(&last));
        assert!(matches!(get(20).await, Err(AppError::NotFound(_))));
    }
}
