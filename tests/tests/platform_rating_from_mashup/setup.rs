//! Setting up mash-up studies with submitted compositions over HTTP, and reading back what a
//! composition-rating study made from one holds.

use std::collections::HashMap;

use e2e::platform::*;
use serde_json::json;

/// The study id in `platform study create`'s "study ID: …" line.
pub(crate) fn created_id(stdout: &str) -> i64 {
    stdout
        .split_whitespace()
        .nth(1)
        .and_then(|id| id.trim_end_matches(':').parse().ok())
        .unwrap_or_else(|| panic!("no study id in {stdout:?}"))
}

/// `platform study create --database-url URL ARGS`.
pub(crate) fn create_study(db: &TestDb, args: &[&str]) -> std::process::Output {
    let mut all = vec!["study", "create", "--database-url", &db.url];
    all.extend_from_slice(args);
    platform_cmd(&all, &[])
}

/// A mash-up study over the library `fx` (fixed background `grass`, two pieces, one search).
pub(crate) fn mashup_study(db: &TestDb, name: &str, compositions: u32) -> i64 {
    let n = compositions.to_string();
    let out = create_study(
        db,
        &[
            "--name",
            name,
            "--library",
            "fx",
            "--kind",
            "mashup",
            "--task",
            "A farm in the morning",
            "--background",
            "grass",
            "--min-pieces",
            "2",
            "--tuples",
            &n,
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    created_id(&String::from_utf8_lossy(&out.stdout))
}

/// `workers` direct-link workers each search once and submit the first two results, placed
/// apart, as their composition (the study's balanced conditions alternate within pairs).
pub(crate) async fn submit_compositions(base: &str, study: i64, workers: usize, tag: &str) {
    let c = client();
    for w in 0..workers {
        let token = start_worker(&c, base, study, &format!("{tag}{w}")).await;
        let api = |path: &str| format!("{base}/api/v1/assignments/{token}/mashup{path}");
        let (status, list) = send(c.get(api("/search"))).await;
        assert_eq!(status, 200, "{list}");
        let results = list["results"].as_array().expect("results");
        let mut pieces = Vec::new();
        for position in [1usize, 2 + w % 3] {
            let item = results[position - 1]["id"].as_i64().expect("id");
            let (status, body) = send(c.post(api("/events")).json(&json!({
                "event": "add", "item": item, "search_seq": 1, "position": position
            })))
            .await;
            assert_eq!(status, 200, "{body}");
            pieces.push(
                json!({"item": item, "x": 200 + 300 * pieces.len(), "y": 300,
                               "scale": 1.0 + 0.2 * w as f64, "rotation": 10.0 * w as f64}),
            );
        }
        let doc = json!({"document": {"version": 1, "width": 800, "height": 600,
                                      "background": "grass", "pieces": pieces}});
        let (status, st) = send(c.post(api("/submit")).json(&doc)).await;
        assert_eq!(status, 200, "{st}");
    }
}

pub(crate) async fn rows(db_url: &str, sql: &str, study: i64) -> Vec<(String, i64, i64)> {
    sqlx::any::install_default_drivers();
    let pool = sqlx::AnyPool::connect(db_url).await.expect("connect");
    let out: Vec<(String, i64, i64)> = sqlx::query_as(sqlx::AssertSqlSafe(sql.to_string()))
        .bind(study)
        .fetch_all(&pool)
        .await
        .expect(sql);
    pool.close().await;
    out
}

/// Composition id → condition of mash-up study `study`.
pub(crate) async fn conditions(db_url: &str, study: i64) -> HashMap<i64, String> {
    rows(
        db_url,
        "SELECT c.condition, s.composition_id, c.seq FROM mashup_conditions c \
         JOIN mashup_submissions s ON s.assignment_id = c.assignment_id WHERE c.study_id = $1",
        study,
    )
    .await
    .into_iter()
    .map(|(condition, id, _)| (id, condition))
    .collect()
}

/// The main pairs of rating study `study` as (composition of b, composition of c), read back
/// from the rendered items' names.
pub(crate) async fn pairs(db_url: &str, study: i64) -> Vec<(i64, i64)> {
    let named = rows(
        db_url,
        "SELECT ib.name, t.c, t.b FROM tuples t JOIN items ib ON ib.id = t.b \
         WHERE t.study_id = $1 AND t.kind = 'main' ORDER BY t.seq",
        study,
    )
    .await;
    let c_names = rows(
        db_url,
        "SELECT ic.name, t.seq, t.a FROM tuples t JOIN items ic ON ic.id = t.c \
         WHERE t.study_id = $1 AND t.kind = 'main' ORDER BY t.seq",
        study,
    )
    .await;
    let composition = |name: &str| -> i64 {
        name.rsplit('-')
            .next()
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("{name}"))
    };
    named
        .iter()
        .zip(&c_names)
        .map(|((b, _, _), (c, _, _))| (composition(b), composition(c)))
        .collect()
}

pub(crate) fn mean_abs_diff(x: &image::RgbImage, y: &image::RgbImage) -> f64 {
    let total: u64 = x
        .as_raw()
        .iter()
        .zip(y.as_raw())
        .map(|(a, b)| u64::from(a.abs_diff(*b)))
        .sum();
    total as f64 / x.as_raw().len() as f64
}
