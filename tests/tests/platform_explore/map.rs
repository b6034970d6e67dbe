//! The style map through the API: every item of the chosen labels placed once, jobs reused,
//! bad requests refused, and the view's level of detail (one thumbnail per occupied screen cell,
//! dots for the rest).

use e2e::platform::*;

use super::wait_done;
use serde_json::{Value, json};

/// The map checks, on a server over `db` with the fixture library and an admin session; `taxonomy_job`
/// is a finished taxonomy job (which has no map view).
pub(super) async fn style_map(
    db: &TestDb,
    c: &reqwest::Client,
    base: &str,
    cookie: &str,
    csrf: &str,
    taxonomy_job: i64,
) {
    let id = taxonomy_job;
    // The style map: every item of the labels placed once; the view draws one thumbnail per
    // occupied screen cell and dots for the rest.
    let map_url = format!("{base}/api/v1/admin/explore/map");
    let start_map = |body: Value| {
        let req = c
            .post(&map_url)
            .header("cookie", cookie)
            .header("x-csrf-token", csrf)
            .json(&body);
        async move { send(req).await }
    };
    let before = scalar(&db.url, "SELECT COUNT(*) FROM explorations").await;
    for (body, message) in [
        (
            json!({"library": "clipart", "labels": ["noto"], "perplexity": 30}),
            "perplexity",
        ),
        (
            json!({"library": "clipart", "labels": ["moon"], "perplexity": 3}),
            "moon",
        ),
        (json!({"library": "clipart", "per_label": 0}), "per_label"),
        (
            json!({"library": "clipart", "perplexity": -2}),
            "perplexity",
        ),
    ] {
        let (status, answer) = start_map(body.clone()).await;
        assert_eq!(status, 400, "{body} → {answer}");
        assert!(
            answer["error"]
                .as_str()
                .is_some_and(|e| e.contains(message)),
            "{body} → {answer}"
        );
    }
    assert_eq!(
        scalar(&db.url, "SELECT COUNT(*) FROM explorations").await,
        before
    );
    let map_body = json!({"library": "clipart", "model": "uniform", "labels": ["noto", "twemoji"], "perplexity": 5});
    let (status, started) = start_map(map_body.clone()).await;
    assert_eq!(status, 202, "{started}");
    let map_id = started["id"].as_i64().expect("id");
    let job = wait_done(c, base, cookie, map_id).await;
    assert_eq!(job["status"], "done", "{job}");
    let (status, again) = start_map(map_body).await;
    assert_eq!(
        (status, &again["id"], &again["started"]),
        (202, &json!(map_id), &json!(false))
    );
    let mut mapped: Vec<i64> = job["result"]["items"]
        .as_array()
        .expect("items")
        .iter()
        .map(|v| v.as_i64().expect("id"))
        .collect();
    mapped.sort();
    let mut expected_items: Vec<i64> = item_styles(&db.url)
        .await
        .into_iter()
        .filter(|(_, s)| s == "noto" || s == "twemoji")
        .map(|(id, _)| id)
        .collect();
    expected_items.sort();
    assert_eq!(mapped, expected_items);
    let view = |q: String| {
        let req = c
            .get(format!(
                "{base}/api/v1/admin/explore/jobs/{map_id}/view?{q}"
            ))
            .header("cookie", cookie);
        async move { send(req).await }
    };
    let (status, v) = view("x0=-1e9&x1=1e9&y0=-1e9&y1=1e9&cols=1&rows=1".into()).await;
    assert_eq!(status, 200, "{v}");
    assert_eq!(
        (v["total"].as_u64(), v["in_view"].as_u64()),
        (Some(24), Some(24))
    );
    assert_eq!(v["thumbnails"].as_array().expect("thumbnails").len(), 1);
    assert_eq!(v["dots"].as_array().expect("dots").len(), 23);
    let b: Vec<f64> = v["bounds"]
        .as_array()
        .expect("bounds")
        .iter()
        .map(|x| x.as_f64().expect("n"))
        .collect();
    let (status, fine) = view(format!(
        "x0={}&x1={}&y0={}&y1={}&cols=40&rows=40",
        b[0],
        b[2] + 1e-3,
        b[1],
        b[3] + 1e-3
    ))
    .await;
    assert_eq!(status, 200, "{fine}");
    let thumbs = fine["thumbnails"].as_array().expect("thumbnails").len();
    assert_eq!(thumbs + fine["dots"].as_array().expect("dots").len(), 24);
    assert!(thumbs > 1, "{fine}");
    // Half the map's width holds fewer points.
    let (_, half) = view(format!(
        "x0={}&x1={}&y0={}&y1={}&cols=40&rows=40",
        b[0],
        (b[0] + b[2]) / 2.0,
        b[1],
        b[3] + 1e-3
    ))
    .await;
    assert!(half["in_view"].as_u64() < Some(24), "{half}");
    for q in [
        "x0=1&x1=0&y0=0&y1=1&cols=1&rows=1",
        "x0=0&x1=1&y0=0&y1=1&cols=100&rows=100",
        "x0=0&x1=1&y0=0&y1=1&cols=0&rows=1",
    ] {
        let (status, body) = view(q.into()).await;
        assert_eq!(status, 400, "{q}: {body}");
    }
    let (status, _) = send(
        c.get(format!(
            "{base}/api/v1/admin/explore/jobs/{id}/view?x0=0&x1=1&y0=0&y1=1&cols=1&rows=1"
        ))
        .header("cookie", cookie),
    )
    .await;
    assert_eq!(status, 404, "a taxonomy has no map view");
}
