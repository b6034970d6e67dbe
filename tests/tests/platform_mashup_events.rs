//! The mash-up study's canvas events beyond adds and removes (§5.7.3) over real HTTP against
//! the real `platform` binary, on SQLite and PostgreSQL: undo, redo, layer and background
//! changes are stored in order with the adds and removes, every malformed or impossible event
//! is a 400 that stores nothing, a task with a fixed background refuses another, and the
//! study's export holds every search and event (`mashup_searches.csv`, `mashup_events.csv`).
//! The same events posted by the real page in Chromium: `platform_mashup_events_browser`.

use std::collections::HashMap;

use e2e::both_databases;
use e2e::platform::*;
use serde_json::{Value, json};

/// Creates a mash-up study over the imported library `fx`; returns its id.
pub(crate) fn create_study(db: &TestDb, name: &str, extra: &[&str]) -> i64 {
    let mut args = vec![
        "study",
        "create",
        "--database-url",
        &db.url,
        "--name",
        name,
        "--library",
        "fx",
        "--kind",
        "mashup",
        "--task",
        "A zoo",
        "--min-pieces",
        "1",
        "--tuples",
        "2",
    ];
    args.extend_from_slice(extra);
    let out = platform_ok(&args, &[]);
    out.split_whitespace()
        .nth(1)
        .and_then(|id| id.trim_end_matches(':').parse().ok())
        .unwrap_or_else(|| panic!("no study id in {out:?}"))
}

/// A CSV export as rows of named cells.
pub(crate) fn csv_rows(text: &str) -> Vec<HashMap<String, String>> {
    let mut r = csv::Reader::from_reader(text.as_bytes());
    let names: Vec<String> = r
        .headers()
        .expect("header")
        .iter()
        .map(str::to_string)
        .collect();
    r.records()
        .map(|rec| {
            let rec = rec.expect("record");
            names
                .iter()
                .cloned()
                .zip(rec.iter().map(str::to_string))
                .collect()
        })
        .collect()
}

/// An export file of `study` (admin session `cookie`).
pub(crate) async fn export(
    c: &reqwest::Client,
    base: &str,
    cookie: &str,
    study: i64,
    file: &str,
) -> String {
    admin_text(
        c,
        &format!("{base}/api/v1/admin/studies/{study}/export/{file}"),
        cookie,
    )
    .await
}

async fn canvas_events(db: TestDb) {
    import_library(&db, small_library(3).path());
    let study = create_study(&db, "zoo", &[]);
    let fixed = create_study(&db, "farm", &["--background", "grass"]);
    create_admin(&db.url);
    let server = Server::start(&db.url);
    let base = server.url("");
    let base = base.trim_end_matches('/');
    let c = client();
    let api = |token: &str, path: &str| format!("{base}/api/v1/assignments/{token}/mashup{path}");
    let post = |token: &str, event: Value| c.post(api(token, "/events")).json(&event);

    let token = start_worker(&c, base, study, "keeper").await;
    let (status, list) = send(c.get(api(&token, "/search?q="))).await;
    assert_eq!(status, 200, "{list}");
    let results = list["results"].as_array().expect("results");
    let id = |i: usize| results[i]["id"].as_i64().expect("id");
    let name = |i: usize| results[i]["name"].as_str().expect("name").to_string();
    let (x, y, never) = (id(0), id(1), id(5));

    // What the page posts for: add x, add y, y to the bottom, the cat photograph, an undo (of
    // the background), a redo, delete x.
    let good = [
        json!({"event": "add", "item": x, "search_seq": 1, "position": 1}),
        json!({"event": "add", "item": y, "search_seq": 1, "position": 2}),
        json!({"event": "layer", "item": y, "from": 1, "to": 0}),
        json!({"event": "background", "background": "cat"}),
        json!({"event": "undo", "items": [y, x], "background": "blank"}),
        json!({"event": "redo", "items": [y, x], "background": "cat"}),
        json!({"event": "remove", "item": x}),
    ];
    for event in &good {
        let (status, body) = send(post(&token, event.clone())).await;
        assert_eq!(status, 200, "{event}: {body}");
    }

    // Malformed or impossible events: 400 with a message, nothing stored.
    let many: Vec<i64> = vec![x; 201];
    for (event, why) in [
        (json!({"event": "teleport", "item": x}), "unknown event"),
        (json!({"item": x}), "no event"),
        (
            json!({"event": "undo", "items": [x]}),
            "undo without background",
        ),
        (
            json!({"event": "redo", "items": [x], "background": "cat", "at": 3}),
            "unknown field",
        ),
        (
            json!({"event": "undo", "items": [x, never], "background": "cat"}),
            "undo to an item never added",
        ),
        (
            json!({"event": "redo", "items": many, "background": "cat"}),
            "201 pieces",
        ),
        (
            json!({"event": "undo", "items": [], "background": "moon"}),
            "unknown background",
        ),
        (
            json!({"event": "layer", "item": y, "from": 0, "to": 0}),
            "layer to itself",
        ),
        (
            json!({"event": "layer", "item": y, "from": 0, "to": 200}),
            "layer out of range",
        ),
        (
            json!({"event": "layer", "item": y, "from": -1, "to": 0}),
            "negative layer",
        ),
        (
            json!({"event": "layer", "item": never, "from": 0, "to": 1}),
            "layer of an item never added",
        ),
        (
            json!({"event": "layer", "item": y, "from": "top", "to": 1}),
            "layer as text",
        ),
        (
            json!({"event": "background", "background": "moon"}),
            "unknown background",
        ),
        (json!({"event": "background"}), "no background"),
    ] {
        let (status, body) = send(post(&token, event.clone())).await;
        assert_eq!(status, 400, "{why}: {event} → {body}");
        assert!(
            body["error"].as_str().is_some_and(|e| !e.is_empty()),
            "{why}: {body}"
        );
    }
    let stored = scalar(
        &db.url,
        "SELECT CAST(COUNT(*) AS BIGINT) FROM mashup_events",
    )
    .await;
    assert_eq!(stored, good.len() as i64, "a refused event was stored");

    // A task with a fixed background refuses any other (the page hides the drop-down).
    let farmer = start_worker(&c, base, fixed, "farmer").await;
    let (status, _) = send(c.get(api(&farmer, "/search"))).await;
    assert_eq!(status, 200);
    let (status, body) = send(post(
        &farmer,
        json!({"event": "background", "background": "cat"}),
    ))
    .await;
    assert_eq!(status, 400, "{body}");
    let (status, body) = send(post(
        &farmer,
        json!({"event": "background", "background": "grass"}),
    ))
    .await;
    assert_eq!(status, 200, "{body}");

    // Submit (y on the cat), then the export holds the search and every event, in order.
    let doc = json!({"document": {"version": 1, "width": 800, "height": 600, "background": "cat",
        "pieces": [{"item": y, "x": 400, "y": 300, "scale": 1.0, "rotation": 0.0}]}});
    let (status, st) = send(c.post(api(&token, "/submit")).json(&doc)).await;
    assert_eq!(status, 200, "{st}");
    let (cookie, _) = admin_login(&c, base).await;
    let searches = csv_rows(&export(&c, base, &cookie, study, "mashup_searches.csv").await);
    assert_eq!(searches.len(), 1, "{searches:?}");
    let names: Vec<String> = (0..results.len()).map(name).collect();
    assert_eq!(searches[0]["results"], names.join(";"));
    assert_eq!(searches[0]["worker_id"], "keeper");
    assert!(["A", "B"].contains(&searches[0]["condition"].as_str()));
    let events = csv_rows(&export(&c, base, &cookie, study, "mashup_events.csv").await);
    let got: Vec<Vec<&str>> = events
        .iter()
        .map(|e| {
            [
                "seq",
                "event",
                "item",
                "search_seq",
                "position",
                "layer_from",
                "layer_to",
                "items",
                "background",
            ]
            .iter()
            .map(|k| e[*k].as_str())
            .collect()
        })
        .collect();
    let (nx, ny) = (name(0), name(1));
    let both = format!("{ny};{nx}");
    let want: Vec<Vec<&str>> = vec![
        vec!["1", "add", nx.as_str(), "1", "1", "", "", "", ""],
        vec!["2", "add", ny.as_str(), "1", "2", "", "", "", ""],
        vec!["3", "layer", ny.as_str(), "", "", "1", "0", "", ""],
        vec!["4", "background", "", "", "", "", "", "", "cat"],
        vec!["5", "undo", "", "", "", "", "", both.as_str(), "blank"],
        vec!["6", "redo", "", "", "", "", "", both.as_str(), "cat"],
        vec!["7", "remove", nx.as_str(), "", "", "", "", "", ""],
    ];
    assert_eq!(got, want);
    assert!(
        events
            .iter()
            .all(|e| e["worker_id"] == "keeper" && e["created_at_utc"].ends_with('Z'))
    );
    // The other study's export is its own: the farmer's HIT is not submitted, so only with
    // include_incomplete.
    let farm = csv_rows(&export(&c, base, &cookie, fixed, "mashup_events.csv").await);
    assert!(farm.is_empty(), "{farm:?}");
    let farm = export(
        &c,
        base,
        &cookie,
        fixed,
        "mashup_events.csv?include_incomplete=true",
    )
    .await;
    let farm = csv_rows(&farm);
    assert_eq!(farm.len(), 1);
    assert_eq!(
        (farm[0]["event"].as_str(), farm[0]["background"].as_str()),
        ("background", "grass")
    );
    // The manifest describes the new columns and counts the rows.
    let manifest: Value =
        serde_json::from_str(&export(&c, base, &cookie, study, "manifest.json").await)
            .expect("json");
    assert!(manifest["columns"]["mashup_events.csv"]["layer_from"].is_string());
    assert_eq!(manifest["counts"]["mashup_events"], 7);
    assert_eq!(manifest["counts"]["mashup_searches"], 1);
}

both_databases!(canvas_events, canvas_events_sqlite, canvas_events_postgres);
