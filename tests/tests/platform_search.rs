//! Style search in the platform (issue 17), on SQLite and PostgreSQL, through the real server:
//! keywords (exact, prefix) and the style filter restrict, "more like this" orders by the
//! eq.-5.5 distance recomputed here from the stored features, the empty canvas deals across
//! style clusters, uniform weights are said so, and bad requests are clear 4xx answers. A
//! search by an uploaded drawing (`POST /api/v1/admin/search/example` and the page's form)
//! finds the item whose file was uploaded first, at distance ≈ 0.

use std::collections::HashMap;

use e2e::both_databases;
use e2e::platform::*;
use serde_json::Value;

both_databases!(search_a_library, search_sqlite, search_postgres);

/// Items per style imported (32 in all): enough for seven style clusters, quick to render.
const PER_STYLE: usize = 8;

/// A library of the first [`PER_STYLE`] drawings of each fixture style with their style labels
/// and keywords, imported as `clipart`; returns the keywords by item name.
fn import_library(db: &TestDb) -> HashMap<String, Vec<String>> {
    let dir = tempfile::tempdir().expect("temp dir");
    let labels = std::fs::read_to_string(e2e::fixture("style/labels.csv")).expect("labels.csv");
    let mut out = String::from("file,style,keywords\n");
    let mut counts: HashMap<String, usize> = HashMap::new();
    let mut keywords = HashMap::new();
    for line in labels.lines().skip(1) {
        let cols: Vec<&str> = line.split(',').collect();
        let (file, style, words) = (cols[0], cols[1], cols[3]);
        let n = counts.entry(style.to_string()).or_default();
        if *n >= PER_STYLE {
            continue;
        }
        *n += 1;
        let target = dir.path().join(file);
        std::fs::create_dir_all(target.parent().expect("parent")).expect("mkdir");
        std::fs::copy(e2e::fixture(&format!("style/{file}")), &target).expect("copy");
        out.push_str(&format!("{file},{style},{words}\n"));
        keywords.insert(
            file.to_string(),
            words.split(';').map(str::to_string).collect(),
        );
    }
    let labels_file = dir.path().join("labels.csv");
    std::fs::write(&labels_file, out).expect("labels");
    let printed = import_named(&db.url, "clipart", dir.path(), Some(&labels_file));
    assert!(printed.contains("32"), "{printed}");
    create_admin(&db.url);
    keywords
}

/// Every item's (name, style, raw features), by id, straight from the database.
async fn stored_items(db_url: &str) -> HashMap<i64, (String, String, Vec<f64>)> {
    sqlx::any::install_default_drivers();
    let pool = sqlx::AnyPool::connect(db_url).await.expect("connect");
    let rows: Vec<(i64, String, String, String)> =
        sqlx::query_as("SELECT id, name, style, features FROM items")
            .fetch_all(&pool)
            .await
            .expect("items");
    pool.close().await;
    rows.into_iter()
        .map(|(id, name, style, f)| (id, (name, style, serde_json::from_str(&f).expect("JSON"))))
        .collect()
}

/// Uniform weights (§5.6): every feature standardised over the library (population standard
/// deviation, 1 for a constant feature), `d(x, y) = ‖x̂ − ŷ‖`.
fn uniform_distances(items: &HashMap<i64, (String, String, Vec<f64>)>) -> impl Fn(i64, i64) -> f64 {
    let dim = items.values().next().expect("items").2.len();
    let n = items.len() as f64;
    let mean: Vec<f64> = (0..dim)
        .map(|k| items.values().map(|i| i.2[k]).sum::<f64>() / n)
        .collect();
    let scale: Vec<f64> = (0..dim)
        .map(|k| {
            let v = items
                .values()
                .map(|i| (i.2[k] - mean[k]).powi(2))
                .sum::<f64>()
                / n;
            if v.sqrt() > 1e-12 { v.sqrt() } else { 1.0 }
        })
        .collect();
    let features: HashMap<i64, Vec<f64>> = items.iter().map(|(id, i)| (*id, i.2.clone())).collect();
    move |a, b| {
        (0..dim)
            .map(|k| ((features[&a][k] - features[&b][k]) / scale[k]).powi(2))
            .sum::<f64>()
            .sqrt()
    }
}

async fn search_a_library(db: TestDb) {
    let keywords = import_library(&db);
    let items = stored_items(&db.url).await;
    let server = Server::start(&db.url);
    let base = server.base.clone();
    let c = client();
    let api = |query: &str| format!("{base}/api/v1/admin/search?{query}");

    // Admins only.
    let (status, _) = send(c.get(api("library=clipart&q=dog"))).await;
    assert_eq!(status, 401);
    let page = c
        .get(format!("{base}/admin/search"))
        .send()
        .await
        .expect("page");
    assert_eq!(page.status().as_u16(), 303, "anonymous search page");
    assert_eq!(page.headers()["location"], "/admin/login");
    let (cookie, csrf) = admin_login(&c, &base).await;
    let get = |query: String| {
        let req = c.get(api(&query)).header("cookie", &cookie);
        async move { send(req).await }
    };

    // Keywords: every item whose name or keywords hold "dog" is found; a prefix finds "puppy".
    let (status, body) = get("library=clipart&q=dog&limit=200".into()).await;
    assert_eq!(status, 200, "{body}");
    assert_eq!(body["uniform"], true, "no trained model: {body}");
    assert!(body["model"].is_null());
    assert_eq!(body["order"], "diversity");
    let found: Vec<&str> = results(&body)
        .iter()
        .map(|r| r["name"].as_str().unwrap())
        .collect();
    let dogs: Vec<&String> = keywords
        .iter()
        .filter(|(name, words)| name.contains("dog") || words.iter().any(|w| w == "dog"))
        .map(|(name, _)| name)
        .collect();
    assert!(!dogs.is_empty());
    for dog in &dogs {
        assert!(found.contains(&dog.as_str()), "{dog} not found: {found:?}");
    }
    assert_eq!(body["matched"].as_u64(), Some(found.len() as u64));
    assert!(
        found.len() < items.len(),
        "keywords must restrict: {found:?}"
    );
    let (_, body) = get("library=clipart&q=pupp&limit=200".into()).await;
    let found: Vec<&str> = results(&body)
        .iter()
        .map(|r| r["name"].as_str().unwrap())
        .collect();
    for (name, words) in &keywords {
        if words.iter().any(|w| w.starts_with("pupp")) {
            assert!(
                found.contains(&name.as_str()),
                "prefix missed {name}: {found:?}"
            );
        }
    }

    // The style filter keeps one style; the library's styles are offered.
    let (_, body) = get("library=clipart&category=noto&limit=200".into()).await;
    assert_eq!(results(&body).len(), PER_STYLE, "{body}");
    assert!(results(&body).iter().all(|r| r["style"] == "noto"));
    assert_eq!(body["categories"].as_array().map(Vec::len), Some(4));

    // The empty canvas: the whole library dealt across seven style clusters, the first seven
    // results from seven different clusters.
    let (_, body) = get("library=clipart&limit=200".into()).await;
    assert_eq!(results(&body).len(), items.len());
    let first: std::collections::HashSet<u64> = results(&body)[..7]
        .iter()
        .map(|r| {
            r["cluster"]
                .as_u64()
                .expect("cluster in the diversity order")
        })
        .collect();
    assert_eq!(first.len(), 7, "{body}");

    // "More like this": ordered by the eq.-5.5 distance (uniform weights) recomputed here, the
    // reference itself left out.
    let d = uniform_distances(&items);
    let reference = *items.keys().min().expect("an item");
    let (status, body) = get(format!("library=clipart&near={reference}&limit=200")).await;
    assert_eq!(status, 200, "{body}");
    assert_eq!(body["order"], "style");
    let hits = results(&body);
    assert_eq!(hits.len(), items.len() - 1);
    let mut expected: Vec<(i64, f64)> = items
        .keys()
        .filter(|&&id| id != reference)
        .map(|&id| (id, d(reference, id)))
        .collect();
    expected.sort_by(|a, b| a.1.total_cmp(&b.1));
    for (hit, (id, dist)) in hits.iter().zip(&expected) {
        let got = hit["distance"].as_f64().expect("distance");
        assert!(
            (got - dist).abs() <= 1e-4 * dist.max(1.0),
            "{got} vs {dist}"
        );
        // Ties aside (f32 storage), the same item at each rank.
        if hit["id"].as_i64() != Some(*id) {
            let theirs = d(reference, hit["id"].as_i64().expect("id"));
            assert!(
                (theirs - dist).abs() <= 1e-4 * dist.max(1.0),
                "rank differs"
            );
        }
    }

    // Bad requests: a clear 4xx naming the problem.
    for (query, status, says) in [
        ("q=dog", 400, "library"),
        ("library=nope&q=dog", 404, "library"),
        ("library=clipart&near=999", 400, "not in library"),
        ("library=clipart&near=12,dog", 400, "near"),
        ("library=clipart&limit=0", 400, "limit"),
        ("library=clipart&limit=201", 400, "limit"),
        ("library=clipart&model=abc", 400, "model"),
        ("library=clipart&model=12345", 404, "model"),
        ("library=clipart&q=%21%21%21", 400, "word"),
        ("library=clip%00art&q=dog", 400, "control characters"),
        ("library=clipart&q=do%00g", 400, "control characters"),
    ] {
        let (got, body) = get(query.into()).await;
        assert_eq!(got, status, "{query}: {body}");
        assert!(body.to_string().contains(says), "{query}: {body}");
    }
    let long = "x".repeat(201);
    let (got, _) = get(format!("library=clipart&q={long}")).await;
    assert_eq!(got, 400);

    // The page: thumbnails, the uniform-weights notice, "more like this" links, and an error
    // shown above the kept form.
    let html = admin_text(&c, &format!("{base}/admin/search?library=clipart"), &cookie).await;
    assert_eq!(
        html.matches("<li><img src=\"/media/items/").count(),
        items.len()
    );
    assert!(html.contains("id=\"uniform-notice\""));
    assert!(html.contains("More like this"));
    let html = admin_text(
        &c,
        &format!("{base}/admin/search?library=clipart&near={reference}"),
        &cookie,
    )
    .await;
    assert!(
        html.contains(&format!(
            "<p id=\"references\">More like <img src=\"/media/items/{reference}.png\""
        )),
        "the page shows what the results are like"
    );
    let html = admin_text(
        &c,
        &format!("{base}/admin/search?library=clipart&q=dog&near=999"),
        &cookie,
    )
    .await;
    assert!(html.contains("id=\"search-error\""), "{html}");
    assert!(
        html.contains("value=\"dog\""),
        "the form keeps the keywords"
    );

    search_by_drawing(&c, &base, &cookie, &csrf, &items, reference).await;
}

/// A hand-built multipart/form-data body: text fields, then one file (when given).
fn multipart(fields: &[(&str, &str)], file: Option<(&str, &[u8])>) -> (String, Vec<u8>) {
    let boundary = "----e2e-search-example-5c2a";
    let mut body = Vec::new();
    for (name, value) in fields {
        body.extend_from_slice(
            format!(
                "--{boundary}\r\nContent-Disposition: form-data; name=\"{name}\"\r\n\r\n{value}\r\n"
            )
            .as_bytes(),
        );
    }
    if let Some((filename, bytes)) = file {
        body.extend_from_slice(
            format!(
                "--{boundary}\r\nContent-Disposition: form-data; name=\"file\"; \
                 filename=\"{filename}\"\r\nContent-Type: application/octet-stream\r\n\r\n"
            )
            .as_bytes(),
        );
        body.extend_from_slice(bytes);
        body.extend_from_slice(b"\r\n");
    }
    body.extend_from_slice(format!("--{boundary}--\r\n").as_bytes());
    (format!("multipart/form-data; boundary={boundary}"), body)
}

/// Search by an uploaded drawing: an item's own file comes back first at distance ≈ 0 (it is
/// featurised as the import did), through the API and the page; bad files are 400s that say
/// why; anonymous requests are 401 and a request without the CSRF header 403.
async fn search_by_drawing(
    c: &reqwest::Client,
    base: &str,
    cookie: &str,
    csrf: &str,
    items: &HashMap<i64, (String, String, Vec<f64>)>,
    reference: i64,
) {
    let name = items[&reference].0.clone();
    let svg = std::fs::read(e2e::fixture(&format!("style/{name}"))).expect("fixture SVG");
    let api = format!("{base}/api/v1/admin/search/example");
    let post = |fields: &[(&str, &str)], file: Option<(&str, &[u8])>, csrf: Option<&str>| {
        let (content_type, body) = multipart(fields, file);
        let mut req = c
            .post(&api)
            .header("cookie", cookie)
            .header("content-type", content_type)
            .body(body);
        if let Some(csrf) = csrf {
            req = req.header("x-csrf-token", csrf);
        }
        async move { send(req).await }
    };
    let library = [("library", "clipart"), ("limit", "5")];

    let (status, body) = post(&library, Some(("mine.svg", &svg)), Some(csrf)).await;
    assert_eq!(status, 200, "{body}");
    assert_eq!(body["order"], "style");
    let hits = results(&body);
    assert_eq!(hits.len(), 5);
    assert_eq!(hits[0]["id"].as_i64(), Some(reference), "{body}");
    assert_eq!(hits[0]["name"], name.as_str());
    let d0 = hits[0]["distance"].as_f64().expect("distance");
    assert!(d0.abs() < 1e-4, "its own file is at distance {d0}");
    assert!(hits[1]["distance"].as_f64().expect("distance") > 1e-3);
    // Keywords restrict as in GET: none of the results lacks the word.
    let (status, body) = post(
        &[("library", "clipart"), ("q", "zzzzqqq")],
        Some(("mine.svg", &svg)),
        Some(csrf),
    )
    .await;
    assert_eq!(status, 200, "{body}");
    assert_eq!(body["matched"], 0);

    // Anonymous: 401; no CSRF header: 403.
    let (content_type, raw) = multipart(&library, Some(("mine.svg", &svg)));
    let anonymous = c.post(&api).header("content-type", content_type).body(raw);
    assert_eq!(send(anonymous).await.0, 401);
    assert_eq!(post(&library, Some(("mine.svg", &svg)), None).await.0, 403);

    // Bad files: 400 with the reason.
    let big = vec![b' '; 2 * 1024 * 1024 + 1];
    for (file, says) in [
        (Some(("empty.svg", &b""[..])), "empty file"),
        (Some(("notes.txt", &b"hello, world"[..])), "not an image"),
        (
            Some(("broken.svg", &b"<svg xmlns="[..])),
            "not a usable SVG",
        ),
        (
            Some(("broken.png", &b"\x89PNG\r\n\x1a\n\0\0"[..])),
            "not a readable image",
        ),
        (Some(("big.svg", &big[..])), "too big"),
        (None, "choose a drawing"),
    ] {
        let (status, body) = post(&library, file, Some(csrf)).await;
        assert_eq!(status, 400, "{says}: {body}");
        assert!(body["error"].to_string().contains(says), "{says}: {body}");
    }
    let (status, body) = post(&[("library", "nope")], Some(("mine.svg", &svg)), Some(csrf)).await;
    assert_eq!(status, 404, "{body}");

    // The page's form: the results, and the uploaded drawing shown as the reference.
    let (content_type, raw) = multipart(
        &[("csrf", csrf), ("library", "clipart")],
        Some(("mine.svg", &svg)),
    );
    let page = c
        .post(format!("{base}/admin/search/example"))
        .header("cookie", cookie)
        .header("content-type", content_type)
        .body(raw)
        .send()
        .await
        .expect("page");
    assert_eq!(page.status().as_u16(), 200);
    let html = page.text().await.expect("html");
    assert!(
        html.contains(
            "<p id=\"example-reference\">Like your drawing <img src=\"data:image/png;base64,"
        ),
        "{html}"
    );
    let first = html.find("<li><img src=\"/media/items/").expect("results");
    assert!(
        html[first..].starts_with(&format!("<li><img src=\"/media/items/{reference}.png\"")),
        "the uploaded item first"
    );
    let (content_type, raw) = multipart(
        &[("csrf", csrf), ("library", "clipart")],
        Some(("notes.txt", b"hello")),
    );
    let page = c
        .post(format!("{base}/admin/search/example"))
        .header("cookie", cookie)
        .header("content-type", content_type)
        .body(raw)
        .send()
        .await
        .expect("page");
    assert_eq!(page.status().as_u16(), 400);
    let html = page.text().await.expect("html");
    assert!(html.contains("id=\"search-error\"") && html.contains("not an image"));
}

fn results(body: &Value) -> &Vec<Value> {
    body["results"].as_array().expect("results")
}
