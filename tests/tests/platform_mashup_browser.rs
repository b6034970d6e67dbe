//! The mash-up canvas in real Chromium (issue 17, §5.7.3): search, drag two results onto the
//! canvas, move, resize and rotate one (checked on the document the page exposes in
//! `data-document`), the results re-sorted by style to the canvas after an add (the order the
//! API gives for those items), undo, export PNG and SVG, save and load after a reload.
//! Screenshots are kept under `target/e2e-artifacts/platform-mashup/`.

use std::time::Duration;

use e2e::browser::*;
use e2e::platform::*;
use e2e::workspace_root;
use fantoccini::actions::{InputSource, MOUSE_BUTTON_LEFT, MouseActions, PointerAction};
use fantoccini::{Client, Locator};
use serde_json::{Value, json};

/// Six drawings of four styles as `clipart`, and the admin.
pub(crate) fn import(db: &TestDb) {
    let dir = tempfile::tempdir().expect("temp dir");
    for file in [
        "noto/dog-face.svg",
        "noto/cat-face.svg",
        "twemoji/dog-face.svg",
        "twemoji/cat-face.svg",
        "fluent-emoji/dog-face.svg",
        "emojione-monotone/dog-face.svg",
    ] {
        let target = dir.path().join(file.replace('/', "-"));
        std::fs::copy(e2e::fixture(&format!("style/{file}")), &target).expect("copy");
    }
    import_named(&db.url, "clipart", dir.path(), None);
    create_admin(&db.url);
}

/// Runs `script` until it returns true (up to 20 s).
pub(crate) async fn until(c: &Client, what: &str, script: &str) {
    for _ in 0..800 {
        if c.execute(script, vec![])
            .await
            .ok()
            .and_then(|v| v.as_bool())
            == Some(true)
        {
            return;
        }
        tokio::time::sleep(Duration::from_millis(25)).await;
    }
    panic!("timed out waiting for {what}");
}

pub(crate) async fn document(c: &Client) -> Value {
    let text = attr(c, "#mashup", "data-document").await;
    serde_json::from_str(&text).expect("data-document is JSON")
}

/// Viewport coordinates of canvas point (x, y).
pub(crate) async fn on_canvas(c: &Client, x: f64, y: f64) -> (f64, f64) {
    let v = c
        .execute(
            "const c = document.getElementById('mashup-canvas'), r = c.getBoundingClientRect();\
             return [r.left + arguments[0] * r.width / c.width, r.top + arguments[1] * r.height / c.height];",
            vec![json!(x), json!(y)],
        )
        .await
        .expect("canvas rect");
    (v[0].as_f64().expect("x"), v[1].as_f64().expect("y"))
}

/// A left-button drag from one viewport point to another.
pub(crate) async fn drag(c: &Client, from: (f64, f64), to: (f64, f64)) {
    let actions = MouseActions::new("mouse".into())
        .then(PointerAction::MoveTo {
            duration: None,
            x: from.0.round(),
            y: from.1.round(),
        })
        .then(PointerAction::Down {
            button: MOUSE_BUTTON_LEFT,
        })
        .then(PointerAction::MoveTo {
            duration: Some(Duration::from_millis(50)),
            x: ((from.0 + to.0) / 2.0).round(),
            y: ((from.1 + to.1) / 2.0).round(),
        })
        .then(PointerAction::MoveTo {
            duration: Some(Duration::from_millis(50)),
            x: to.0.round(),
            y: to.1.round(),
        })
        .then(PointerAction::Up {
            button: MOUSE_BUTTON_LEFT,
        });
    c.perform_actions(actions).await.expect("drag");
    c.release_actions().await.expect("release");
}

/// Viewport centre of the result at `index` (0-based).
pub(crate) async fn result_centre(c: &Client, index: usize) -> (f64, f64) {
    let v = c
        .execute(
            "const r = document.querySelectorAll('.mashup-result')[arguments[0]].getBoundingClientRect();\
             return [r.left + r.width / 2, r.top + r.height / 2];",
            vec![json!(index)],
        )
        .await
        .expect("result rect");
    (v[0].as_f64().expect("x"), v[1].as_f64().expect("y"))
}

pub(crate) async fn ids_shown(c: &Client) -> Vec<i64> {
    attr(c, "#mashup-results", "data-ids")
        .await
        .split(',')
        .filter_map(|s| s.parse().ok())
        .collect()
}

pub(crate) async fn click(c: &Client, id: &str) {
    c.find(Locator::Id(id))
        .await
        .expect(id)
        .click()
        .await
        .expect("click");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn compose_export_save_and_load_in_chromium() {
    let profile = tempfile::tempdir().expect("profile dir");
    let Some((driver, c)) = browser(profile.path(), Viewport::Desktop).await else {
        return;
    };
    let artifacts = workspace_root().join("target/e2e-artifacts/platform-mashup");
    std::fs::create_dir_all(&artifacts).expect("artifacts dir");
    let db = sqlite_db();
    import(&db);
    let server = Server::start(&db.url);
    let http = client();
    let (cookie, csrf) = admin_login(&http, &server.base).await;

    // Log in through the page, then open the canvas: the first results are the diversity order.
    c.goto(&server.url("/admin/login"))
        .await
        .expect("login page");
    c.find(Locator::Id("username"))
        .await
        .expect("user")
        .send_keys("admin")
        .await
        .expect("type");
    c.find(Locator::Id("password"))
        .await
        .expect("pass")
        .send_keys(ADMIN_PASSWORD)
        .await
        .expect("type");
    click(&c, "login").await;
    c.wait()
        .for_element(Locator::Id("studies"))
        .await
        .expect("studies");
    c.goto(&server.url("/admin/mashup"))
        .await
        .expect("mashup page");
    until(
        &c,
        "the first results",
        "return document.getElementById('mashup').dataset.searchSeq === '1';",
    )
    .await;
    let first = ids_shown(&c).await;
    assert_eq!(first.len(), 6, "{first:?}");
    assert!(
        c.find(Locator::Id("uniform-notice"))
            .await
            .expect("notice")
            .is_displayed()
            .await
            .expect("shown")
    );

    // Drag the first result onto the canvas: one piece where it was dropped; the results are
    // re-sorted by style to it, exactly as the API orders them.
    let to = on_canvas(&c, 250.0, 300.0).await;
    drag(&c, result_centre(&c, 0).await, to).await;
    until(
        &c,
        "the re-sort",
        "return document.getElementById('mashup').dataset.searchSeq === '2';",
    )
    .await;
    let doc = document(&c).await;
    assert_eq!(doc["pieces"].as_array().map(Vec::len), Some(1), "{doc}");
    assert_eq!(doc["pieces"][0]["item"], first[0]);
    assert!(
        (doc["pieces"][0]["x"].as_f64().expect("x") - 250.0).abs() <= 3.0,
        "{doc}"
    );
    let (_, expected) = send(
        http.get(server.url(&format!(
            "/api/v1/admin/search?library=clipart&limit=48&near={}",
            first[0]
        )))
        .header("cookie", &cookie),
    )
    .await;
    let expected: Vec<i64> = expected["results"]
        .as_array()
        .expect("results")
        .iter()
        .map(|r| r["id"].as_i64().expect("id"))
        .collect();
    let after_add = ids_shown(&c).await;
    assert_eq!(after_add, expected, "style order to the canvas");
    assert_ne!(after_add, first);

    // A second piece.
    let second = after_add[0];
    let to = on_canvas(&c, 550.0, 300.0).await;
    drag(&c, result_centre(&c, 0).await, to).await;
    until(
        &c,
        "the second re-sort",
        "return document.getElementById('mashup').dataset.searchSeq === '3';",
    )
    .await;
    let doc = document(&c).await;
    assert_eq!(doc["pieces"][1]["item"], second, "{doc}");

    // Move the second piece by (+60, −40) canvas pixels.
    let from = on_canvas(&c, 550.0, 300.0).await;
    let to = on_canvas(&c, 610.0, 260.0).await;
    drag(&c, from, to).await;
    let doc = document(&c).await;
    let (x, y) = (
        doc["pieces"][1]["x"].as_f64().expect("x"),
        doc["pieces"][1]["y"].as_f64().expect("y"),
    );
    assert!(
        (x - 610.0).abs() <= 3.0 && (y - 260.0).abs() <= 3.0,
        "{doc}"
    );

    // Resize: the square handle at the bottom-right corner, dragged outwards to 1.5× the
    // distance from the centre.
    let half = 80.0; // 160 px square at scale 1, the fixture drawings are square
    let from = on_canvas(&c, x + half, y + half).await;
    let to = on_canvas(&c, x + 1.5 * half, y + 1.5 * half).await;
    drag(&c, from, to).await;
    let doc = document(&c).await;
    let scale = doc["pieces"][1]["scale"].as_f64().expect("scale");
    assert!((scale - 1.5).abs() < 0.06, "{doc}");

    // Rotate: the round handle above the piece, dragged to its right: a quarter turn.
    let r = c.execute("const c = document.getElementById('mashup-canvas'); return 9 * c.width / c.getBoundingClientRect().width;", vec![])
        .await.expect("r").as_f64().expect("r");
    let from = on_canvas(&c, x, y - half * scale - 3.0 * r).await;
    let to = on_canvas(&c, x + 150.0, y).await;
    drag(&c, from, to).await;
    let doc = document(&c).await;
    let rotation = doc["pieces"][1]["rotation"].as_f64().expect("rotation");
    assert!((rotation - 90.0).abs() < 3.0, "{doc}");
    shot(&c, &artifacts, "01-two-pieces-1280.png").await;

    // Undo takes the rotation back; redo (Ctrl+Shift+Z) is checked through the button.
    click(&c, "mashup-undo").await;
    let doc = document(&c).await;
    assert_eq!(doc["pieces"][1]["rotation"].as_f64(), Some(0.0), "{doc}");
    assert!((doc["pieces"][1]["scale"].as_f64().expect("scale") - scale).abs() < 1e-9);
    click(&c, "mashup-redo").await;
    assert!(
        (document(&c).await["pieces"][1]["rotation"]
            .as_f64()
            .expect("r")
            - rotation)
            .abs()
            < 1e-9
    );
    click(&c, "mashup-undo").await;
    let doc = document(&c).await;

    // Export: both downloads are made from the server's render of the document shown; the
    // same render, fetched here, decodes with the two pieces.
    click(&c, "mashup-export-png").await;
    until(
        &c,
        "the PNG export",
        "return (document.getElementById('mashup').dataset.lastExport || '').startsWith('png:');",
    )
    .await;
    click(&c, "mashup-export-svg").await;
    until(
        &c,
        "the SVG export",
        "return (document.getElementById('mashup').dataset.lastExport || '').startsWith('svg:');",
    )
    .await;
    let render = |format: &str| {
        http.post(server.url(&format!(
            "/api/v1/admin/compositions/render?format={format}"
        )))
        .header("cookie", &cookie)
        .header("x-csrf-token", &csrf)
        .json(&json!({"library": "clipart", "document": doc}))
        .send()
    };
    let png = render("png")
        .await
        .expect("png")
        .bytes()
        .await
        .expect("bytes");
    let img = image::load_from_memory(&png)
        .expect("PNG decodes")
        .to_rgb8();
    assert_eq!(img.dimensions(), (800, 600));
    for p in doc["pieces"].as_array().expect("pieces") {
        let (px, py) = (
            p["x"].as_f64().expect("x") as u32,
            p["y"].as_f64().expect("y") as u32,
        );
        let changed = (px - 20..px + 20)
            .step_by(4)
            .any(|x| img.get_pixel(x, py).0 != [255, 255, 255]);
        assert!(changed, "no piece drawn at ({px}, {py})");
    }
    assert_eq!(img.get_pixel(5, 5).0, [255, 255, 255], "blank background");
    let svg = render("svg")
        .await
        .expect("svg")
        .text()
        .await
        .expect("text");
    usvg::Tree::from_str(&svg, &usvg::Options::default()).expect("SVG parses");
    assert_eq!(svg.matches("class=\"piece\"").count(), 2);

    // Save, reload the page, load it back.
    c.find(Locator::Id("mashup-name"))
        .await
        .expect("name")
        .send_keys("two dogs")
        .await
        .expect("type");
    click(&c, "mashup-save-button").await;
    until(
        &c,
        "the save",
        "return !!document.getElementById('mashup').dataset.compositionId;",
    )
    .await;
    let saved = attr(&c, "#mashup", "data-composition-id").await;
    c.goto(&server.url("/admin/mashup")).await.expect("reload");
    until(
        &c,
        "the saved list",
        &format!("return !!document.querySelector('#mashup-saved option[value=\"{saved}\"]');"),
    )
    .await;
    c.find(Locator::Id("mashup-saved"))
        .await
        .expect("saved")
        .select_by_value(&saved)
        .await
        .expect("choose");
    click(&c, "mashup-load").await;
    until(&c, "the load", "return JSON.parse(document.getElementById('mashup').dataset.document).pieces.length === 2;").await;
    assert_eq!(document(&c).await, doc);
    shot(&c, &artifacts, "02-loaded-1100.png").await;
    // A phone's width: the results above the canvas, the canvas within the screen.
    c.set_window_size(390, 844).await.expect("phone width");
    let fits = c
        .execute(
            "const c = document.getElementById('mashup-canvas').getBoundingClientRect();\
             const r = document.getElementById('mashup-results').getBoundingClientRect();\
             return c.right <= document.documentElement.clientWidth + 1 && r.bottom <= c.top;",
            vec![],
        )
        .await
        .expect("layout");
    assert_eq!(fits, json!(true), "phone layout");
    shot(&c, &artifacts, "03-phone-390.png").await;

    let violations = csp_violations(&c, &driver).await;
    assert!(violations.is_empty(), "{violations:?}");
    c.close().await.expect("close");
}
