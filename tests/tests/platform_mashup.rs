//! The mash-up canvas's JSON API and media (issue 17, §5.7.3) through the real server on SQLite
//! and PostgreSQL: SVG sources stored on import and served, compositions saved, listed, loaded,
//! updated and deleted, rendered to SVG (vector pieces, one group each) and PNG (the pieces'
//! pixels where they are), and every bad request a clear 4xx.

use e2e::both_databases;
use e2e::platform::*;
use serde_json::{Value, json};

both_databases!(compositions_round_trip, mashup_sqlite, mashup_postgres);

/// Imports three SVG drawings and one photograph as `clipart`, one SVG as `other`; creates the
/// admin.
fn import(db: &TestDb) {
    let dir = tempfile::tempdir().expect("temp dir");
    for file in ["noto/dog-face.svg", "noto/cat-face.svg", "noto/fish.svg"] {
        let target = dir.path().join(file.replace('/', "-"));
        std::fs::copy(e2e::fixture(&format!("style/{file}")), &target).expect("copy");
    }
    std::fs::copy(
        e2e::fixture("photos/coffee.jpg"),
        dir.path().join("coffee.jpg"),
    )
    .expect("copy");
    let printed = import_named(&db.url, "clipart", dir.path(), None);
    assert!(printed.contains('4'), "{printed}");
    let other = tempfile::tempdir().expect("temp dir");
    std::fs::copy(
        e2e::fixture("style/noto/bird.svg"),
        other.path().join("bird.svg"),
    )
    .expect("copy");
    import_named(&db.url, "other", other.path(), None);
    create_admin(&db.url);
}

/// (id, name, library, has an SVG) of every item.
async fn items(db_url: &str) -> Vec<(i64, String, String, bool)> {
    sqlx::any::install_default_drivers();
    let pool = sqlx::AnyPool::connect(db_url).await.expect("connect");
    let rows: Vec<(i64, String, String, i64)> = sqlx::query_as(
        "SELECT i.id, i.name, l.name, CASE WHEN i.svg IS NULL THEN 0 ELSE 1 END \
         FROM items i JOIN libraries l ON l.id = i.library_id ORDER BY i.name",
    )
    .fetch_all(&pool)
    .await
    .expect("items");
    pool.close().await;
    rows.into_iter()
        .map(|(id, name, lib, svg)| (id, name, lib, svg == 1))
        .collect()
}

fn piece(item: i64, x: f64, y: f64) -> Value {
    json!({"item": item, "x": x, "y": y, "scale": 1.0, "rotation": 0.0})
}

async fn compositions_round_trip(db: TestDb) {
    import(&db);
    let all = items(&db.url).await;
    let id_of = |name: &str| all.iter().find(|i| i.1.contains(name)).expect(name).0;
    let (dog, cat, coffee, bird) = (id_of("dog"), id_of("cat"), id_of("coffee"), id_of("bird"));
    // SVG sources are kept for drawings, not for photographs.
    for (_, name, _, svg) in &all {
        assert_eq!(*svg, name.ends_with(".svg"), "{name}");
    }
    let server = Server::start(&db.url);
    let c = client();
    let url = |p: &str| server.url(p);

    // Media: the SVG is served (usvg-normalised: it parses), a photograph has none.
    let resp = c
        .get(url(&format!("/media/items/{dog}.svg")))
        .send()
        .await
        .expect("svg");
    assert_eq!(resp.status().as_u16(), 200);
    assert_eq!(resp.headers()["content-type"], "image/svg+xml");
    let text = resp.text().await.expect("text");
    usvg::Tree::from_str(&text, &usvg::Options::default()).expect("the stored SVG parses");
    assert!(!text.contains("<script"));
    let resp = c
        .get(url(&format!("/media/items/{coffee}.svg")))
        .send()
        .await
        .expect("svg");
    assert_eq!(resp.status().as_u16(), 404);

    // Anonymous: 401 from the API, the page redirects to the login.
    let (status, _) = send(c.get(url("/api/v1/admin/compositions?library=clipart"))).await;
    assert_eq!(status, 401);
    let page = c.get(url("/admin/mashup")).send().await.expect("page");
    assert_eq!(page.status().as_u16(), 303);
    assert_eq!(page.headers()["location"], "/admin/login");

    let (cookie, csrf) = admin_login(&c, &server.base).await;
    let post = |path: &str, body: Value| {
        c.post(url(path))
            .header("cookie", &cookie)
            .header("x-csrf-token", &csrf)
            .json(&body)
    };
    let page = c
        .get(url("/admin/mashup"))
        .header("cookie", &cookie)
        .send()
        .await
        .expect("page");
    assert_eq!(page.status().as_u16(), 200);
    let html = page.text().await.expect("html");
    assert!(html.contains("data-library=\"clipart\"") && html.contains("mashup.js?v="));
    for background in [
        "blank",
        "grass",
        "gravel",
        "brick",
        "space",
        "rocket",
        "astronaut",
        "coffee",
        "cat",
        "camera",
        "coins",
    ] {
        assert!(
            html.contains(&format!("<option value=\"{background}\" data-url=\"")),
            "{background}"
        );
    }

    // Save, list, load.
    let doc = json!({"version": 1, "width": 400, "height": 300, "background": "blank",
        "pieces": [piece(dog, 100.0, 150.0), piece(coffee, 300.0, 150.0)]});
    let (status, saved) = send(post(
        "/api/v1/admin/compositions",
        json!({"library": "clipart", "name": "scene", "document": doc}),
    ))
    .await;
    assert_eq!(status, 201, "{saved}");
    let id = saved["id"].as_i64().expect("id");
    assert_eq!(saved["document"], doc);
    let (status, listed) = send(
        c.get(url("/api/v1/admin/compositions?library=clipart"))
            .header("cookie", &cookie),
    )
    .await;
    assert_eq!(status, 200, "{listed}");
    assert_eq!(listed["compositions"][0]["id"], id);
    assert_eq!(listed["compositions"][0]["pieces"], 2);
    let (_, other_list) = send(
        c.get(url("/api/v1/admin/compositions?library=other"))
            .header("cookie", &cookie),
    )
    .await;
    assert_eq!(other_list["compositions"], json!([]));
    let (status, loaded) = send(
        c.get(url(&format!("/api/v1/admin/compositions/{id}")))
            .header("cookie", &cookie),
    )
    .await;
    assert_eq!(status, 200);
    assert_eq!(loaded["document"], doc);
    assert_eq!(loaded["library"], "clipart");

    // Update: the same dog twice (ids must not collide in the SVG), a cat, a grass background.
    let mut doc2 = doc.clone();
    doc2["background"] = json!("grass");
    doc2["pieces"] = json!([
        piece(dog, 80.0, 80.0),
        piece(dog, 200.0, 150.0),
        piece(cat, 320.0, 220.0)
    ]);
    let (status, updated) = send(
        c.put(url(&format!("/api/v1/admin/compositions/{id}")))
            .header("cookie", &cookie)
            .header("x-csrf-token", &csrf)
            .json(&json!({"name": "scene 2", "document": doc2})),
    )
    .await;
    assert_eq!(status, 200, "{updated}");
    assert_eq!(updated["name"], "scene 2");
    assert_eq!(updated["document"], doc2);

    // Export of the stored composition: the SVG parses and has three vector pieces with
    // distinct ids; the PNG is 400×300 with the pieces' pixels on grass.
    let resp = c
        .get(url(&format!(
            "/api/v1/admin/compositions/{id}/export?format=svg"
        )))
        .header("cookie", &cookie)
        .send()
        .await
        .expect("svg");
    assert_eq!(resp.status().as_u16(), 200);
    assert_eq!(resp.headers()["content-type"], "image/svg+xml");
    let svg = resp.text().await.expect("svg text");
    usvg::Tree::from_str(&svg, &usvg::Options::default()).expect("export parses");
    let xml = usvg::roxmltree::Document::parse(&svg).expect("xml");
    let groups: Vec<_> = xml
        .descendants()
        .filter(|n| n.attribute("class") == Some("piece"))
        .collect();
    assert_eq!(groups.len(), 3);
    assert!(
        groups
            .iter()
            .all(|g| g.descendants().any(|n| n.has_tag_name("path")))
    );
    let mut ids: Vec<&str> = xml
        .descendants()
        .filter_map(|n| n.attribute("id"))
        .collect();
    let n = ids.len();
    ids.sort_unstable();
    ids.dedup();
    assert_eq!(ids.len(), n, "duplicate ids");
    let (status, png) = render(
        &c,
        &cookie,
        &csrf,
        &server,
        "png",
        json!({"library": "clipart", "document": doc}),
    )
    .await;
    assert_eq!(status, 200);
    let img = image::load_from_memory(&png)
        .expect("PNG decodes")
        .to_rgb8();
    assert_eq!(img.dimensions(), (400, 300));
    assert_ne!(
        img.get_pixel(100, 150).0,
        [255, 255, 255],
        "the dog is drawn"
    );
    assert_eq!(
        img.get_pixel(200, 20).0,
        [255, 255, 255],
        "blank background elsewhere"
    );
    assert_eq!(img.get_pixel(5, 295).0, [255, 255, 255]);

    // Bad input: each a clear 4xx with the reason.
    let cases: Vec<(Value, u16, &str)> = vec![
        (
            json!({"library": "clipart", "name": "x", "document": {"version": 1}}),
            400,
            "width",
        ),
        (
            json!({"library": "clipart", "name": "", "document": doc}),
            400,
            "name",
        ),
        (
            json!({"library": "nope", "name": "x", "document": doc}),
            404,
            "library",
        ),
        (
            json!({"library": "clipart", "name": "x", "document": with(&doc, "background", json!("lava"))}),
            400,
            "background",
        ),
        (
            json!({"library": "clipart", "name": "x", "document": with(&doc, "width", json!(5000))}),
            400,
            "width",
        ),
        (
            json!({"library": "clipart", "name": "x", "document": with(&doc, "pieces", json!([piece(bird, 1.0, 1.0)]))}),
            400,
            "not in this library",
        ),
        (
            json!({"library": "clipart", "name": "x", "document": with(&doc, "pieces", json!([piece(123_456_789, 1.0, 1.0)]))}),
            400,
            "not in this library",
        ),
        (
            json!({"library": "clipart", "name": "x", "document": with(&doc, "pieces", json!([{"item": dog, "x": 1, "y": 1, "scale": 0, "rotation": 0}]))}),
            400,
            "scale",
        ),
        (
            json!({"library": "clipart", "name": "x", "document": doc, "extra": 1}),
            400,
            "extra",
        ),
    ];
    for (body, want, reason) in cases {
        let (status, answer) = send(post("/api/v1/admin/compositions", body.clone())).await;
        assert_eq!(status, want, "{body}: {answer}");
        assert!(
            answer["error"].as_str().unwrap_or("").contains(reason),
            "{reason}: {answer}"
        );
    }
    let many: Vec<Value> = (0..201).map(|_| piece(dog, 1.0, 1.0)).collect();
    let (status, answer) = send(post(
        "/api/v1/admin/compositions",
        json!({"library": "clipart", "name": "x", "document": with(&doc, "pieces", json!(many))}),
    ))
    .await;
    assert_eq!(status, 400, "{answer}");
    let (status, _) = send(
        c.post(url("/api/v1/admin/compositions"))
            .header("cookie", &cookie)
            .header("x-csrf-token", &csrf)
            .header("content-type", "application/json")
            .body("{\"library\": "),
    )
    .await;
    assert_eq!(status, 400, "malformed JSON");
    let huge = format!(
        "{{\"library\":\"clipart\",\"name\":\"{}\"}}",
        "x".repeat(300 * 1024)
    );
    let (status, _) = send(
        c.post(url("/api/v1/admin/compositions"))
            .header("cookie", &cookie)
            .header("x-csrf-token", &csrf)
            .header("content-type", "application/json")
            .body(huge),
    )
    .await;
    assert_eq!(status, 413, "oversized body");
    // A large but valid document (200 pieces, ~13 KB) is over nothing.
    let full: Vec<Value> = (0..200).map(|i| piece(dog, f64::from(i), 1.5)).collect();
    let (status, answer) = send(post("/api/v1/admin/compositions",
        json!({"library": "clipart", "name": "full", "document": with(&doc, "pieces", json!(full))}))).await;
    assert_eq!(status, 201, "{answer}");
    let (status, _) = send(
        c.post(url("/api/v1/admin/compositions"))
            .header("cookie", &cookie)
            .json(&json!({"library": "clipart", "name": "x", "document": doc})),
    )
    .await;
    assert_eq!(status, 403, "no CSRF token");
    let (status, _) = render(
        &c,
        &cookie,
        &csrf,
        &server,
        "gif",
        json!({"library": "clipart", "document": doc}),
    )
    .await;
    assert_eq!(status, 400, "unknown format");

    // Delete: gone, and a second delete is a 404.
    for want in [204, 404] {
        let (status, _) = send(
            c.delete(url(&format!("/api/v1/admin/compositions/{id}")))
                .header("cookie", &cookie)
                .header("x-csrf-token", &csrf),
        )
        .await;
        assert_eq!(status, want);
    }
    let (status, _) = send(
        c.get(url(&format!("/api/v1/admin/compositions/{id}")))
            .header("cookie", &cookie),
    )
    .await;
    assert_eq!(status, 404);
}

fn with(doc: &Value, key: &str, value: Value) -> Value {
    let mut d = doc.clone();
    d[key] = value;
    d
}

async fn render(
    c: &reqwest::Client,
    cookie: &str,
    csrf: &str,
    server: &Server,
    format: &str,
    body: Value,
) -> (u16, Vec<u8>) {
    let resp = c
        .post(server.url(&format!(
            "/api/v1/admin/compositions/render?format={format}"
        )))
        .header("cookie", cookie)
        .header("x-csrf-token", csrf)
        .json(&body)
        .send()
        .await
        .expect("render");
    let status = resp.status().as_u16();
    (status, resp.bytes().await.expect("bytes").to_vec())
}
