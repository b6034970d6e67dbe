//! A worker's canvas edits in real Chromium (§5.7.3): the page posts every add, layer change,
//! background change, undo, redo and delete as an event, in the order made, and the study's
//! export (`mashup_events.csv`) lists them so.

use std::collections::HashMap;

use e2e::platform::*;
use serde_json::Value;

use crate::platform_mashup_events::{create_study, csv_rows, export};

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
    create_admin(&db.url);
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
