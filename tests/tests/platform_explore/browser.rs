//! The Explore pages in Chromium: build a taxonomy from the page, open a branch and a
//! hidden-image pop-up, follow the mash-up link, drag a hidden image onto the mash-up canvas,
//! click and zoom the style map, with no CSP violation.
//!
//! WebDriver cannot drive a native HTML5 drag between pages, so the drags are the browser's own
//! `DragEvent`s dispatched with a `DataTransfer`: the pages' real handlers set and read it.

use std::time::Duration;

use e2e::browser::*;
use e2e::platform::*;
use fantoccini::Locator;
use serde_json::{Value, json};

use super::{import, wait_done};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn explore_in_chromium() {
    let profile = tempfile::tempdir().expect("profile dir");
    // Screenshots for a person to look at, as in platform_browser.rs.
    let artifacts = e2e::workspace_root().join("target/e2e-artifacts/platform-explore");
    std::fs::create_dir_all(&artifacts).expect("artifacts dir");
    let Some((driver, c)) = browser(profile.path(), Viewport::Desktop).await else {
        return;
    };
    let db = sqlite_db();
    import(&db);
    let server = Server::start(&db.url);
    c.goto(&server.url("/admin/login"))
        .await
        .expect("login page");
    for (id, text) in [("username", "admin"), ("password", ADMIN_PASSWORD)] {
        c.find(Locator::Id(id))
            .await
            .expect(id)
            .send_keys(text)
            .await
            .expect("type");
    }
    c.find(Locator::Id("login"))
        .await
        .expect("login")
        .click()
        .await
        .expect("click");
    c.wait()
        .for_element(Locator::Id("studies"))
        .await
        .expect("studies");

    c.goto(&server.url("/admin/explore?library=clipart&model=uniform"))
        .await
        .expect("explore page");
    for label in ["noto", "fluent-emoji"] {
        c.find(Locator::Css(&format!(
            "input[name=labels][value=\"{label}\"]"
        )))
        .await
        .expect(label)
        .click()
        .await
        .expect("check");
    }
    for (name, value) in [("kappa", "3"), ("tau", "1")] {
        let input = c
            .find(Locator::Css(&format!("input[name={name}]")))
            .await
            .expect(name);
        input.clear().await.expect("clear");
        input.send_keys(value).await.expect("type");
    }
    c.find(Locator::Id("build-taxonomy"))
        .await
        .expect("build")
        .click()
        .await
        .expect("click");
    // The job page follows the job and shows the representatives once it is done.
    c.wait()
        .at_most(Duration::from_secs(120))
        .for_element(Locator::Css("#styles .style-link"))
        .await
        .expect("representative styles");
    let summary = c
        .find(Locator::Id("job-summary"))
        .await
        .expect("summary")
        .text()
        .await
        .expect("text");
    assert!(summary.contains("over 24 items"), "{summary}");
    let href = attr(&c, "#styles .style-link", "href").await;
    c.find(Locator::Css("#styles .style-link"))
        .await
        .expect("link")
        .click()
        .await
        .expect("open branch");
    c.wait()
        .for_element(Locator::Id("grid"))
        .await
        .expect("grid");
    let cells = c
        .find_all(Locator::Css("#grid .explore-cell"))
        .await
        .expect("cells")
        .len();
    assert!(cells >= 1);
    shot(&c, &artifacts, "01-branch-grid.png").await;

    // A small grid hides images behind its nodes: one opens in a pop-up.
    let href = if href.starts_with("http") {
        href
    } else {
        server.url(&href)
    };
    c.goto(&format!("{href}?rows=2&cols=2"))
        .await
        .expect("small grid");
    c.wait()
        .for_element(Locator::Css(".has-hidden"))
        .await
        .expect("a node with hidden images");
    let hidden = attr(&c, ".has-hidden", "data-dialog").await;
    c.find(Locator::Css(".has-hidden"))
        .await
        .expect("node")
        .click()
        .await
        .expect("open");
    let open = c
        .execute(
            "return document.getElementById(arguments[0]).open",
            vec![json!(hidden)],
        )
        .await
        .expect("dialog state");
    assert_eq!(open, json!(true), "the pop-up is open");
    shot(&c, &artifacts, "02-hidden-images.png").await;
    let images = c
        .find_all(Locator::Css(&format!("#{hidden} img")))
        .await
        .expect("hidden images")
        .len();
    assert!(images >= 1);
    // Dragging a hidden image carries its item, its library and the canvas link.
    let dragged = c
        .execute(
            "const img = document.querySelector('#' + arguments[0] + ' img'), dt = new DataTransfer();\
             img.dispatchEvent(new DragEvent('dragstart', {dataTransfer: dt, bubbles: true, cancelable: true}));\
             return [img.dataset.dragItem, dt.getData('application/x-stylekit-item'), dt.getData('text/uri-list')];",
            vec![json!(hidden)],
        )
        .await
        .expect("drag a hidden image");
    let hidden_item: i64 = dragged[0].as_str().expect("id").parse().expect("item id");
    let payload: Value = serde_json::from_str(dragged[1].as_str().expect("drag data"))
        .expect("the drag data is JSON");
    assert_eq!(payload, json!({"item": hidden_item, "library": "clipart"}));
    assert!(
        dragged[2]
            .as_str()
            .is_some_and(|u| u.ends_with(&format!("/admin/mashup?item={hidden_item}"))),
        "{dragged}"
    );

    // "Use in mash-up" opens the canvas with that item placed on it.
    let link = attr(&c, ".use-mashup", "href").await;
    let item: i64 = link
        .rsplit('=')
        .next()
        .expect("item")
        .parse()
        .expect("item id");
    let link = if link.starts_with("http") {
        link
    } else {
        server.url(&link)
    };
    c.goto(&link).await.expect("mash-up page");
    let mut pieces = Value::Null;
    for _ in 0..400 {
        pieces = c
            .execute(
                "const m = document.getElementById('mashup'); return m && m.dataset.document ? JSON.parse(m.dataset.document).pieces : null",
                vec![],
            )
            .await
            .expect("document");
        if pieces.as_array().is_some_and(|p| !p.is_empty()) {
            break;
        }
        tokio::time::sleep(Duration::from_millis(25)).await;
    }
    assert_eq!(pieces.as_array().map(Vec::len), Some(1), "{pieces}");
    assert_eq!(pieces[0]["item"], json!(item));

    // The hidden image dropped on the canvas joins it where it was dropped; an item of another
    // library is refused with a message and the canvas stays as it was.
    let drop = "const m = document.getElementById('mashup-canvas'), r = m.getBoundingClientRect();\
        const dt = new DataTransfer(); dt.setData('application/x-stylekit-item', arguments[0]);\
        const at = {dataTransfer: dt, bubbles: true, cancelable: true, clientX: r.left + r.width / 4, clientY: r.top + r.height / 4};\
        const accepted = !m.dispatchEvent(new DragEvent('dragover', at));\
        m.dispatchEvent(new DragEvent('drop', at));\
        const e = document.getElementById('mashup-error');\
        return [accepted, JSON.parse(document.getElementById('mashup').dataset.document).pieces, e.hidden ? '' : e.textContent];";
    let other = json!({"item": hidden_item, "library": "another"}).to_string();
    let refused = c.execute(drop, vec![json!(other)]).await.expect("drop");
    assert_eq!(refused[1].as_array().map(Vec::len), Some(1), "{refused}");
    assert!(
        refused[2].as_str().is_some_and(|e| e.contains("another")),
        "{refused}"
    );
    let dropped = c
        .execute(drop, vec![json!(payload.to_string())])
        .await
        .expect("drop");
    assert_eq!(
        dropped[0],
        json!(true),
        "the canvas accepts the drag: {dropped}"
    );
    assert_eq!(dropped[2], json!(""), "the error is gone: {dropped}");
    let pieces = dropped[1].as_array().expect("pieces");
    assert_eq!(pieces.len(), 2, "{dropped}");
    assert_eq!(pieces[1]["item"], json!(hidden_item));
    let width: f64 = attr(&c, "#mashup-canvas", "width")
        .await
        .parse()
        .expect("width");
    let x = pieces[1]["x"].as_f64().expect("x");
    assert!(
        (x - width / 4.0).abs() <= 1.0,
        "dropped at a quarter: {x} of {width}"
    );

    // The style map: zooming in changes what is drawn (fewer items in view).
    let http = client();
    let (cookie, csrf) = admin_login(&http, &server.base).await;
    let (status, started) = send(
        http.post(server.url("/api/v1/admin/explore/map"))
            .header("cookie", &cookie)
            .header("x-csrf-token", &csrf)
            .json(&json!({"library": "clipart", "model": "uniform", "labels": ["noto", "fluent-emoji"], "perplexity": 5})),
    )
    .await;
    assert_eq!(status, 202, "{started}");
    let map_id = started["id"].as_i64().expect("id");
    wait_done(&http, &server.base, &cookie, map_id).await;
    c.goto(&server.url(&format!("/admin/explore/jobs/{map_id}")))
        .await
        .expect("map page");
    let drawn = "const m = document.getElementById('map'); return m && m.dataset.scale && Number(m.dataset.scale) > 1e-5 ? [Number(m.dataset.thumbnails), Number(m.dataset.dots), Number(m.dataset.scale)] : null";
    let mut first = Value::Null;
    for _ in 0..400 {
        first = c.execute(drawn, vec![]).await.expect("map state");
        if first.is_array() {
            break;
        }
        tokio::time::sleep(Duration::from_millis(25)).await;
    }
    assert!(first.is_array(), "the map was drawn");
    assert_eq!(
        first[0].as_f64().expect("n") + first[1].as_f64().expect("n"),
        24.0,
        "{first}"
    );
    // A click on a drawn thumbnail offers it to the mash-up canvas.
    let at = attr(&c, "#map", "data-first-thumbnail").await;
    let (sx, sy) = at.split_once(',').expect("x,y");
    c.execute(
        "const m = document.getElementById('map'), r = m.getBoundingClientRect();\
         const x = r.left + Number(arguments[0]) * r.width / m.width, y = r.top + Number(arguments[1]) * r.height / m.height;\
         for (const type of ['pointerdown', 'pointerup']) m.dispatchEvent(new PointerEvent(type, {pointerId: 7, clientX: x, clientY: y, bubbles: true}));",
        vec![json!(sx), json!(sy)],
    )
    .await
    .expect("click a thumbnail");
    let href = attr(&c, "#map-mashup", "href").await;
    assert!(href.contains("/admin/mashup?item="), "{href}");
    // The picked thumbnail drags like a grid image.
    let dragged = c
        .execute(
            "const img = document.querySelector('#map-selected img'), dt = new DataTransfer();\
             img.dispatchEvent(new DragEvent('dragstart', {dataTransfer: dt, bubbles: true, cancelable: true}));\
             return dt.getData('application/x-stylekit-item');",
            vec![],
        )
        .await
        .expect("drag the picked thumbnail");
    let payload: Value = serde_json::from_str(dragged.as_str().expect("drag data")).expect("JSON");
    assert_eq!(payload["library"], json!("clipart"));
    assert!(
        href.ends_with(&format!("item={}", payload["item"])),
        "{href} {payload}"
    );

    // Zoom in on that thumbnail: it stays under the cursor, so the view keeps drawing it.
    c.execute(
        "const m = document.getElementById('map'), r = m.getBoundingClientRect();\
         const x = r.left + Number(arguments[0]) * r.width / m.width, y = r.top + Number(arguments[1]) * r.height / m.height;\
         for (let i = 0; i < 2; i++) m.dispatchEvent(new WheelEvent('wheel', {deltaY: -400, clientX: x, clientY: y, bubbles: true, cancelable: true}));",
        vec![json!(sx), json!(sy)],
    )
    .await
    .expect("zoom");
    let mut zoomed = Value::Null;
    for _ in 0..400 {
        zoomed = c.execute(drawn, vec![]).await.expect("map state");
        if zoomed[2].as_f64() > first[2].as_f64() && zoomed[0] != first[0] {
            break;
        }
        tokio::time::sleep(Duration::from_millis(25)).await;
    }
    assert!(
        zoomed[2].as_f64() > first[2].as_f64(),
        "zoomed in: {first} → {zoomed}"
    );
    assert_ne!(
        zoomed[0], first[0],
        "the thumbnails drawn changed: {first} → {zoomed}"
    );
    assert!(
        zoomed[0].as_f64() >= Some(1.0),
        "the zoomed view still draws the thumbnail under the cursor: {zoomed}"
    );

    shot(&c, &artifacts, "03-map-zoomed.png").await;

    let violations = csp_violations(&c, &driver).await;
    assert!(violations.is_empty(), "{violations:?}");
    c.close().await.expect("close");
}
