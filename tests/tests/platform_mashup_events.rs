//! The mash-up study's canvas events beyond adds and removes (§5.7.3) over real HTTP against
//! the real `platform` binary, on SQLite and PostgreSQL: undo, redo, layer and background
//! changes are stored in order with the adds and removes, every malformed or impossible event
//! is a 400 that stores nothing, a task with a fixed background refuses another, and the
//! study's export holds every search and event (`mashup_searches.csv`, `mashup_events.csv`).
//! The same events posted by the real page in Chromium are in `mashup_edits_in_chromium`.

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
    platform_ok(
        &["admin", "create", "--database-url", &db.url],
        &[("PLATFORM_ADMIN_PASSWORD", ADMIN_PASSWORD)],
    );
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

/// A worker's edits in real Chromium are posted as events and exported in the order made:
/// two pieces dragged on, the second sent one layer down (the Down button), the cat
/// photograph chosen, the Undo button, Ctrl+Shift+Z, Ctrl+Z, Ctrl+Y, and the Delete key on the
/// selected piece; the submitted composition is the canvas the edits left.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn mashup_edits_in_chromium() {
    use crate::platform_mashup_browser::{
        click, document, drag, ids_shown, on_canvas, result_centre, until,
    };
    use e2e::browser::*;
    use fantoccini::Locator;

    let profile = tempfile::tempdir().expect("profile dir");
    let Some((driver, c)) = browser(profile.path(), Viewport::Desktop).await else {
        return;
    };
    let db = sqlite_db();
    import_library(&db, small_library(3).path());
    let study = create_study(&db, "zoo", &[]);
    platform_ok(
        &["admin", "create", "--database-url", &db.url],
        &[("PLATFORM_ADMIN_PASSWORD", ADMIN_PASSWORD)],
    );
    let server = Server::start(&db.url);
    let http = client();
    let base = server.url("");
    let base = base.trim_end_matches('/');
    let token = start_worker(&http, base, study, "painter").await;
    c.goto(&server.url(&format!("/a/{token}")))
        .await
        .expect("task page");
    let seq =
        |n: usize| format!("return document.getElementById('mashup').dataset.searchSeq === '{n}';");
    until(&c, "the first results", &seq(1)).await;
    let first = ids_shown(&c).await;
    drag(
        &c,
        result_centre(&c, 0).await,
        on_canvas(&c, 250.0, 300.0).await,
    )
    .await;
    until(&c, "the re-search", &seq(2)).await;
    let second = ids_shown(&c).await;
    drag(
        &c,
        result_centre(&c, 2).await,
        on_canvas(&c, 550.0, 300.0).await,
    )
    .await;
    until(&c, "the second re-search", &seq(3)).await;
    let (a, b) = (first[0], second[2]);
    let items = |doc: &Value| -> Vec<i64> {
        doc["pieces"]
            .as_array()
            .expect("pieces")
            .iter()
            .map(|p| p["item"].as_i64().unwrap())
            .collect()
    };
    assert_eq!(items(&document(&c).await), vec![a, b]);

    click(&c, "mashup-down").await; // b (selected: the latest add) below a
    assert_eq!(items(&document(&c).await), vec![b, a]);
    // The order of the canvas's items changed: the page searches again (top-most first).
    until(&c, "the search after the layer change", &seq(4)).await;
    c.find(Locator::Id("mashup-background"))
        .await
        .expect("background")
        .select_by_value("cat")
        .await
        .expect("choose cat");
    assert_eq!(document(&c).await["background"], "cat");
    click(&c, "mashup-undo").await;
    assert_eq!(document(&c).await["background"], "blank");
    // Keys go to the canvas; then a click on b selects it for the Delete key.
    let canvas = c.find(Locator::Id("mashup-canvas")).await.expect("canvas");
    canvas
        .send_keys("\u{E009}\u{E008}z")
        .await
        .expect("ctrl+shift+z");
    assert_eq!(
        document(&c).await["background"],
        "cat",
        "Ctrl+Shift+Z redoes"
    );
    canvas.send_keys("\u{E009}z").await.expect("ctrl+z");
    assert_eq!(document(&c).await["background"], "blank", "Ctrl+Z undoes");
    canvas.send_keys("\u{E009}y").await.expect("ctrl+y");
    assert_eq!(document(&c).await["background"], "cat", "Ctrl+Y redoes");
    let (x, y) = on_canvas(&c, 550.0, 300.0).await;
    drag(&c, (x, y), (x, y)).await;
    assert_eq!(
        attr(&c, "#mashup", "data-selected").await,
        "0",
        "b is selected"
    );
    canvas.send_keys("\u{E017}").await.expect("delete");
    assert_eq!(items(&document(&c).await), vec![a]);
    until(&c, "the search after the delete", &seq(5)).await;
    // Every event answered: 5 searches, 2 adds, layer, background, 4 undo/redo, remove.
    until(
        &c,
        "the events",
        "return document.getElementById('mashup').dataset.logged === '14';",
    )
    .await;
    let violations = csp_violations(&c, &driver).await;
    assert!(violations.is_empty(), "{violations:?}");

    let (cookie, _) = admin_login(&http, base).await;
    let csv = export(
        &http,
        base,
        &cookie,
        study,
        "mashup_events.csv?include_incomplete=true",
    )
    .await;
    let events = csv_rows(&csv);
    let names = library_names(&db.url).await;
    let (na, nb) = (names[&a].as_str(), names[&b].as_str());
    let both = format!("{nb};{na}");
    let got: Vec<Vec<&str>> = events
        .iter()
        .map(|e| {
            [
                "event",
                "item",
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
    let want: Vec<Vec<&str>> = vec![
        vec!["add", na, "1", "", "", "", ""],
        vec!["add", nb, "3", "", "", "", ""],
        vec!["layer", nb, "", "1", "0", "", ""],
        vec!["background", "", "", "", "", "", "cat"],
        vec!["undo", "", "", "", "", both.as_str(), "blank"],
        vec!["redo", "", "", "", "", both.as_str(), "cat"],
        vec!["undo", "", "", "", "", both.as_str(), "blank"],
        vec!["redo", "", "", "", "", both.as_str(), "cat"],
        vec!["remove", nb, "", "", "", "", ""],
    ];
    assert_eq!(got, want, "{csv}");

    mark(&c).await;
    click(&c, "mashup-submit").await;
    wait_navigated(&c).await;
    let stored = scalar(
        &db.url,
        "SELECT CAST(COUNT(*) AS BIGINT) FROM mashup_submissions",
    )
    .await;
    assert_eq!(stored, 1);
}

/// Item id → name, as stored.
async fn library_names(db_url: &str) -> HashMap<i64, String> {
    use sqlx::Row;
    sqlx::any::install_default_drivers();
    let pool = sqlx::AnyPool::connect(db_url).await.expect("connect");
    let rows = sqlx::query("SELECT id, name FROM items")
        .fetch_all(&pool)
        .await
        .expect("items");
    pool.close().await;
    rows.iter().map(|r| (r.get("id"), r.get("name"))).collect()
}
