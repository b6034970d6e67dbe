//! The mash-up canvas's keyboard shortcuts and layer buttons in real Chromium, on
//! `/admin/mashup` (§5.7.3): Top / Up / Down / Bottom reorder the pieces (and the saved
//! document's order follows, through save and update), Ctrl+Z undoes, Ctrl+Shift+Z and Ctrl+Y
//! redo, Delete and Backspace remove the selected piece (and nothing without a selection),
//! undo puts the selection back on the piece that moved, and keys typed into a text field
//! leave the canvas alone.

use e2e::browser::*;
use e2e::platform::*;
use fantoccini::{Client, Locator};
use serde_json::Value;

use crate::platform_mashup_browser::{
    click, document, drag, ids_shown, import, on_canvas, result_centre, until,
};

/// The items of the pieces, bottom to top.
async fn order(c: &Client) -> Vec<i64> {
    document(c).await["pieces"]
        .as_array()
        .expect("pieces")
        .iter()
        .map(|p| p["item"].as_i64().expect("item"))
        .collect()
}

async fn selected(c: &Client) -> i64 {
    attr(c, "#mashup", "data-selected")
        .await
        .parse()
        .expect("index")
}

/// Types `keys` (WebDriver key codes) into the element `id`.
async fn keys(c: &Client, id: &str, keys: &str) {
    c.find(Locator::Id(id))
        .await
        .expect(id)
        .send_keys(keys)
        .await
        .expect("keys");
}

const CTRL: &str = "\u{E009}";
const SHIFT: &str = "\u{E008}";
const DELETE: &str = "\u{E017}";
const BACKSPACE: &str = "\u{E003}";

/// Clicks canvas point (x, y) without moving: selects the piece there, or nothing.
async fn tap(c: &Client, x: f64, y: f64) {
    let at = on_canvas(c, x, y).await;
    drag(c, at, at).await;
}

/// Saves the canvas under its name and returns the stored document's item order.
async fn saved_order(
    c: &Client,
    http: &reqwest::Client,
    server: &Server,
    cookie: &str,
) -> Vec<i64> {
    c.execute(
        "document.getElementById('mashup-status').textContent = '';",
        vec![],
    )
    .await
    .expect("clear status");
    click(c, "mashup-save-button").await;
    until(
        c,
        "the save",
        "return document.getElementById('mashup-status').textContent.startsWith('Saved');",
    )
    .await;
    let id = attr(c, "#mashup", "data-composition-id").await;
    let (status, body) = send(
        http.get(server.url(&format!("/api/v1/admin/compositions/{id}")))
            .header("cookie", cookie),
    )
    .await;
    assert_eq!(status, 200, "{body}");
    body["document"]["pieces"]
        .as_array()
        .expect("pieces")
        .iter()
        .map(|p: &Value| p["item"].as_i64().expect("item"))
        .collect()
}

/// The value of the input `id`.
async fn value(c: &Client, id: &str) -> String {
    c.find(Locator::Id(id))
        .await
        .expect(id)
        .prop("value")
        .await
        .expect("value")
        .unwrap_or_default()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn keyboard_and_layers_in_chromium() {
    let profile = tempfile::tempdir().expect("profile dir");
    let Some((driver, c)) = browser(profile.path(), Viewport::Desktop).await else {
        return;
    };
    let db = sqlite_db();
    import(&db);
    let server = Server::start(&db.url);
    let http = client();
    let (cookie, _) = admin_login(&http, &server.base).await;
    c.goto(&server.url("/admin/login"))
        .await
        .expect("login page");
    keys(&c, "username", "admin").await;
    keys(&c, "password", ADMIN_PASSWORD).await;
    click(&c, "login").await;
    c.wait()
        .for_element(Locator::Id("studies"))
        .await
        .expect("studies");
    c.goto(&server.url("/admin/mashup"))
        .await
        .expect("mashup page");
    let seq =
        |n: usize| format!("return document.getElementById('mashup').dataset.searchSeq === '{n}';");
    until(&c, "the first results", &seq(1)).await;

    // Three pieces side by side: A, B, C from bottom to top.
    let xs = [150.0, 400.0, 650.0];
    let mut items = Vec::new();
    for (n, x) in xs.iter().enumerate() {
        // The first result not on the canvas yet (an item is nearest in style to itself).
        let shown = ids_shown(&c).await;
        let i = shown
            .iter()
            .position(|id| !items.contains(id))
            .expect("a new item");
        let item = shown[i];
        drag(
            &c,
            result_centre(&c, i).await,
            on_canvas(&c, *x, 300.0).await,
        )
        .await;
        until(&c, "the re-search", &seq(n + 2)).await;
        items.push(item);
    }
    let [a, b, cc] = [items[0], items[1], items[2]];
    assert_eq!(order(&c).await, vec![a, b, cc]);
    assert_eq!(selected(&c).await, 2, "the latest add is selected");

    // The layer buttons move the selected piece and keep it selected.
    tap(&c, xs[0], 300.0).await;
    assert_eq!(selected(&c).await, 0);
    for (button, want, at) in [
        ("mashup-up", vec![b, a, cc], 1),
        ("mashup-top", vec![b, cc, a], 2),
        ("mashup-bottom", vec![a, b, cc], 0),
        ("mashup-down", vec![a, b, cc], 0), // already at the bottom: nothing changes
    ] {
        click(&c, button).await;
        assert_eq!(order(&c).await, want, "{button}");
        assert_eq!(selected(&c).await, at, "{button}");
    }
    click(&c, "mashup-top").await;
    assert_eq!(order(&c).await, vec![b, cc, a]);

    // Keys on the canvas: undo selects the piece that moved back, redo returns it.
    keys(&c, "mashup-canvas", &format!("{CTRL}z")).await;
    assert_eq!(order(&c).await, vec![a, b, cc], "Ctrl+Z");
    assert_eq!(
        selected(&c).await,
        0,
        "the undone move's piece (A) is selected"
    );
    keys(&c, "mashup-canvas", &format!("{CTRL}{SHIFT}z")).await;
    assert_eq!(order(&c).await, vec![b, cc, a], "Ctrl+Shift+Z");
    assert_eq!(selected(&c).await, 2);
    keys(&c, "mashup-canvas", &format!("{CTRL}z")).await;
    keys(&c, "mashup-canvas", &format!("{CTRL}y")).await;
    assert_eq!(order(&c).await, vec![b, cc, a], "Ctrl+Y");

    // Delete removes the selected piece (A); undo brings it back, selected, so Backspace
    // removes A again, not whatever has its index.
    keys(&c, "mashup-canvas", DELETE).await;
    assert_eq!(order(&c).await, vec![b, cc], "Delete");
    assert_eq!(selected(&c).await, -1);
    keys(&c, "mashup-canvas", &format!("{CTRL}z")).await;
    assert_eq!(order(&c).await, vec![b, cc, a]);
    assert_eq!(selected(&c).await, 2);
    keys(&c, "mashup-canvas", BACKSPACE).await;
    assert_eq!(order(&c).await, vec![b, cc], "Backspace");
    keys(&c, "mashup-canvas", DELETE).await;
    assert_eq!(order(&c).await, vec![b, cc], "Delete without a selection");
    keys(&c, "mashup-canvas", &format!("{CTRL}z")).await;
    assert_eq!(order(&c).await, vec![b, cc, a]);

    // Keys typed into a field edit the field, not the canvas.
    keys(&c, "mashup-name", "layers").await;
    keys(&c, "mashup-name", &format!("{BACKSPACE}{DELETE}")).await;
    assert_eq!(value(&c, "mashup-name").await, "layer");
    keys(&c, "mashup-name", &format!("{CTRL}z")).await;
    assert_eq!(order(&c).await, vec![b, cc, a], "keys in a text field");
    assert_eq!(selected(&c).await, 2);
    c.find(Locator::Id("mashup-name"))
        .await
        .expect("name")
        .clear()
        .await
        .expect("clear");
    keys(&c, "mashup-name", "layers").await;

    // The saved document keeps the order; a layer change then an update saves the new one.
    assert_eq!(
        saved_order(&c, &http, &server, &cookie).await,
        vec![b, cc, a]
    );
    tap(&c, xs[0], 300.0).await; // A, on top
    click(&c, "mashup-down").await;
    assert_eq!(order(&c).await, vec![b, a, cc]);
    assert_eq!(
        saved_order(&c, &http, &server, &cookie).await,
        vec![b, a, cc]
    );

    let violations = csp_violations(&c, &driver).await;
    assert!(violations.is_empty(), "{violations:?}");
}
