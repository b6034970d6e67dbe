//! The JSON API holds to its OpenAPI document (`/api/v1/openapi.json`), on the real server:
//! the document is valid OpenAPI 3.1 to an independent validator; schemathesis, with an admin
//! session, finds no 5xx, no response off its schema, no undocumented status or content type,
//! and no request the schema forbids accepted; and the contract's fixes one by one (object
//! bodies, integer ranges, whole numbers, the worker id of a start, enumerations, shared
//! statuses). Also the HTML pages for worker URLs that do not exist, and the favicon.
//!
//! schemathesis and openapi-spec-validator come from pip (`scripts/test` installs the pinned
//! versions). Without them the tests that need them skip with a message, except in CI
//! (`CI=true`), where they fail.

use std::collections::BTreeSet;
use std::io::Read;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use e2e::both_databases;
use e2e::platform::*;
use serde_json::{Value, json};

/// Whether `program args…` runs and exits 0; in CI a missing tool fails the test, elsewhere it
/// is skipped with a message (returns false).
fn tool(what: &str, program: &str, args: &[&str]) -> bool {
    let ok = Command::new(program)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        if std::env::var("CI").is_ok_and(|v| v == "true" || v == "1") {
            panic!("{what} is not installed: CI must run it (scripts/test installs it with pip)");
        }
        eprintln!("{what} is not installed (pip install, see scripts/test): skipping");
    }
    ok
}

async fn document(server: &Server) -> Value {
    let (status, doc) = send(client().get(server.url("/api/v1/openapi.json"))).await;
    assert_eq!(status, 200, "{doc}");
    doc
}

/// A logged-in admin's JSON requests.
struct Admin {
    c: reqwest::Client,
    base: String,
    cookie: String,
    csrf: String,
}

impl Admin {
    async fn login(server: &Server) -> Self {
        let c = client();
        let (cookie, csrf) = admin_login(&c, &server.base).await;
        Self {
            c,
            base: server.base.clone(),
            cookie,
            csrf,
        }
    }

    async fn get(&self, path: &str) -> (u16, Value) {
        send(
            self.c
                .get(format!("{}{path}", self.base))
                .header("cookie", &self.cookie),
        )
        .await
    }

    /// A state-changing request with a raw JSON body.
    async fn write(&self, method: reqwest::Method, path: &str, body: &str) -> (u16, Value) {
        send(
            self.c
                .request(method, format!("{}{path}", self.base))
                .header("cookie", &self.cookie)
                .header("x-csrf-token", &self.csrf)
                .header("content-type", "application/json")
                .body(body.to_string()),
        )
        .await
    }

    async fn post(&self, path: &str, body: &str) -> (u16, Value) {
        self.write(reqwest::Method::POST, path, body).await
    }

    async fn patch(&self, path: &str, body: &str) -> (u16, Value) {
        self.write(reqwest::Method::PATCH, path, body).await
    }
}

/// A study with one completed HIT (answers to train on, a decision to override), one worker
/// answering and one in training; returns their tokens (done, active, training).
async fn study_with_workers(server: &Server, study: i64) -> (String, String, String) {
    let c = client();
    let styles = item_styles(&server.db_url).await;
    let done = start_worker(&c, &server.base, study, "w-done").await;
    pass_training(&c, &server.base, &done, &styles, Behaviour::Honest).await;
    let end = answer_all(&c, &server.base, &done, &styles, Behaviour::Honest).await;
    assert_eq!(end["status"], "completed", "{end}");
    let active = start_worker(&c, &server.base, study, "w-active").await;
    pass_training(&c, &server.base, &active, &styles, Behaviour::Honest).await;
    let training = start_worker(&c, &server.base, study, "w-training").await;
    (done, active, training)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_document_is_valid_openapi_3_1() {
    let db = sqlite_db();
    setup_study(&db, &StudyOpts::default());
    let server = Server::start(&db.url);
    let doc = document(&server).await;
    assert_eq!(doc["openapi"], "3.1.0");

    // The dashboard's pairs are named objects (tuples were `items` arrays, which OpenAPI 3.1
    // tools refuse, then `prefixItems`, which they read differently).
    let schemas = &doc["components"]["schemas"];
    let dashboard = &schemas["Dashboard"]["properties"];
    assert_eq!(
        dashboard["control_error_histogram"]["items"]["$ref"],
        "#/components/schemas/ErrorCount"
    );
    assert_eq!(
        dashboard["answers_per_hour"]["items"]["$ref"],
        "#/components/schemas/HourCount"
    );
    assert!(
        !doc.to_string().contains("prefixItems"),
        "no tuple left in the document"
    );

    // An independent validator reads the whole document.
    if !tool(
        "openapi-spec-validator",
        "python3",
        &["-c", "import openapi_spec_validator"],
    ) {
        return;
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("openapi.json");
    std::fs::write(&path, doc.to_string()).expect("write document");
    let out = Command::new("python3")
        .args([
            "-c",
            "import json, sys\n\
             from openapi_spec_validator import OpenAPIV31SpecValidator\n\
             errors = list(OpenAPIV31SpecValidator(json.load(open(sys.argv[1]))).iter_errors())\n\
             for e in errors: print(e)\n\
             sys.exit(1 if errors else 0)",
        ])
        .arg(&path)
        .output()
        .expect("run openapi-spec-validator");
    assert!(
        out.status.success(),
        "openapi-spec-validator: {}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn admin_authentication_is_described_and_enforced() {
    let db = sqlite_db();
    let study = setup_study(&db, &StudyOpts::default());
    let server = Server::start(&db.url);
    let doc = document(&server).await;
    let schemes = &doc["components"]["securitySchemes"];
    assert_eq!(
        schemes["session"],
        json!({"type": "apiKey", "in": "cookie", "name": "platform_session",
               "description": schemes["session"]["description"]})
    );
    assert_eq!(schemes["csrf"]["in"], "header");
    assert_eq!(schemes["csrf"]["name"], "x-csrf-token");
    let admin = Admin::login(&server).await;
    let c = client();
    let mut checked = 0;
    for (path, item) in doc["paths"].as_object().expect("paths") {
        for (method, op) in item.as_object().expect("operations") {
            let admin_op = path.starts_with("/api/v1/admin/");
            let expected = match (admin_op, method.as_str()) {
                (false, _) => Value::Null,
                (true, "get") => json!([{"session": []}]),
                (true, _) => json!([{"session": [], "csrf": []}]),
            };
            assert_eq!(op["security"], expected, "{method} {path}");
            if !admin_op {
                continue;
            }
            // What the document says is what the server does: no cookie 401, no CSRF 403.
            let url = server.url(&path.replace("{study}", &study.to_string()));
            let method: reqwest::Method = method.to_uppercase().parse().expect("method");
            let anonymous = c
                .request(method.clone(), &url)
                .header("content-type", "application/json")
                .body("{}");
            assert_eq!(
                send(anonymous).await.0,
                401,
                "{method} {path} without a session"
            );
            assert!(op["responses"]["401"].is_object(), "{method} {path}");
            if method != reqwest::Method::GET {
                let no_csrf = c
                    .request(method.clone(), &url)
                    .header("cookie", &admin.cookie)
                    .header("content-type", "application/json")
                    .body("{}");
                assert_eq!(send(no_csrf).await.0, 403, "{method} {path} without CSRF");
                assert!(op["responses"]["403"].is_object(), "{method} {path}");
            }
            checked += 1;
        }
    }
    assert!(checked >= 17, "only {checked} admin operations");
}

/// The statuses every operation of a kind answers are in the document: 415 without a JSON
/// content type, 404 for unknown or malformed ids, 503, 400/413 for bodies.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn shared_statuses_are_documented() {
    let db = sqlite_db();
    let study = setup_study(&db, &StudyOpts::default());
    let server = Server::start(&db.url);
    let doc = document(&server).await;
    let admin = Admin::login(&server).await;
    let mut with_body = 0;
    for (path, item) in doc["paths"].as_object().expect("paths") {
        for (method, op) in item.as_object().expect("operations") {
            let documented: BTreeSet<&str> = op["responses"]
                .as_object()
                .expect("responses")
                .keys()
                .map(String::as_str)
                .collect();
            let must: &[&str] = match (op["requestBody"].is_object(), path.contains('{')) {
                (true, true) => &["400", "404", "413", "415", "503"],
                (true, false) => &["400", "413", "415", "503"],
                (false, true) => &["404", "503"],
                (false, false) => &["503"],
            };
            for status in must {
                assert!(
                    documented.contains(status),
                    "{method} {path}: {status} not documented ({documented:?})"
                );
            }
            if !op["requestBody"].is_object() {
                continue;
            }
            // The server does answer 415 to a body without a content type …
            with_body += 1;
            let url = server.url(
                &path
                    .replace("{study}", &study.to_string())
                    .replace("{token}", "0123456789abcdef0123456789abcdef")
                    .replace("{assignment}", "1")
                    .replace("{id}", "1"),
            );
            let method: reqwest::Method = method.to_uppercase().parse().expect("method");
            let req = admin
                .c
                .request(method.clone(), &url)
                .header("cookie", &admin.cookie)
                .header("x-csrf-token", &admin.csrf)
                .body("{}");
            let (status, body) = send(req).await;
            assert_eq!(status, 415, "{method} {path}: {body}");
        }
    }
    assert!(with_body >= 10, "only {with_body} operations with a body");
    // … and 404 to a malformed id.
    let (status, _) = admin.get("/api/v1/admin/studies/abc/dashboard").await;
    assert_eq!(status, 404);
}

/// What the schema forbids is refused with a 400, what it allows is accepted.
async fn contract(db: TestDb) {
    let study = setup_study(&db, &StudyOpts::default());
    let server = Server::start(&db.url);
    let (_done, active, _training) = study_with_workers(&server, study).await;
    let admin = Admin::login(&server).await;
    let s = format!("/api/v1/admin/studies/{study}");
    let before = admin.get(&format!("{s}/settings")).await.1;

    // A JSON array where an object is expected, at the top or inside.
    let (status, body) = admin.patch(&format!("{s}/settings"), "[null, null]").await;
    assert_eq!(status, 400, "PATCH settings with an array: {body}");
    let (status, body) = admin.post(&format!("{s}/models"), "[null, null]").await;
    assert_eq!(status, 400, "POST models with an array: {body}");
    let (_, models) = admin.get(&format!("{s}/models")).await;
    assert_eq!(models, json!([]), "no training was started");
    let (status, body) = admin
        .post(
            "/api/v1/admin/studies",
            r#"{"name": "n", "library": "fx", "settings": []}"#,
        )
        .await;
    assert_eq!(status, 400, "settings as an array: {body}");
    assert!(
        body["error"]
            .as_str()
            .unwrap_or_default()
            .contains("settings"),
        "the message names the field: {body}"
    );
    let c = client();
    let (status, body) = send(
        c.post(server.url(&format!("/api/v1/studies/{study}/start")))
            .json(&json!({"worker_id": "w-new", "demographics": [null, null]})),
    )
    .await;
    assert_eq!(status, 400, "demographics as an array: {body}");

    // Integers beyond their documented range.
    for (path, body) in [
        (
            format!("{s}/qc"),
            r#"{"threshold": 2147483648, "dry_run": true}"#,
        ),
        (format!("{s}/qc"), r#"{"threshold": 501, "dry_run": true}"#),
        (
            format!("{s}/release-abandoned"),
            r#"{"older_than_minutes": 4294967295}"#,
        ),
        (format!("{s}/models"), r#"{"folds": 101}"#),
    ] {
        let (status, reply) = admin.post(&path, body).await;
        assert_eq!(status, 400, "POST {path} {body}: {reply}");
    }
    for body in [
        r#"{"reject_at_control_errors": 2147483648}"#,
        r#"{"reject_at_control_errors": 501}"#,
    ] {
        let (status, reply) = admin.patch(&format!("{s}/settings"), body).await;
        assert_eq!(status, 400, "PATCH settings {body}: {reply}");
    }
    let (status, reply) = admin
        .post(
            "/api/v1/admin/studies",
            r#"{"name": "n", "library": "fx", "settings": {"seed": 9007199254740992}}"#,
        )
        .await;
    assert_eq!(status, 400, "seed beyond 2^53: {reply}");
    assert_eq!(
        admin.get(&format!("{s}/settings")).await.1,
        before,
        "nothing was applied"
    );

    // Whole numbers written as floats are integers.
    let (status, reply) = admin
        .post(
            &format!("{s}/release-abandoned"),
            r#"{"older_than_minutes": 1470.0}"#,
        )
        .await;
    assert_eq!(status, 200, "{reply}");
    let (status, reply) = admin
        .patch(
            &format!("{s}/settings"),
            r#"{"reject_at_control_errors": 3.0}"#,
        )
        .await;
    assert_eq!(status, 200, "{reply}");
    assert_eq!(reply["settings"]["reject_at_control_errors"], 3);
    let (_, state) = send(c.get(server.url(&format!("/api/v1/assignments/{active}")))).await;
    let q = &state["question"];
    let body = format!(
        r#"{{"position": {}.0, "choice": {}.0, "elapsed_ms": 1500.0}}"#,
        q["position"], q["left"]["id"]
    );
    let (status, ack) = send(
        c.post(server.url(&format!("/api/v1/assignments/{active}/answers")))
            .header("content-type", "application/json")
            .body(body.clone()),
    )
    .await;
    assert_eq!(status, 200, "{body}: {ack}");

    // Enumerations: the document lists the values, the server takes those and no other.
    let doc = document(&server).await;
    let schemas = &doc["components"]["schemas"];
    assert_eq!(
        schemas["CuratedKind"]["enum"],
        json!(["control", "training"])
    );
    assert_eq!(schemas["Decision"]["enum"], json!(["approved", "rejected"]));
    assert!(
        schemas["ReasonCode"]["enum"]
            .as_array()
            .is_some_and(|codes| codes.contains(&json!("colour_palette"))),
        "{}",
        schemas["ReasonCode"]
    );
    let (status, reply) = admin
        .post(
            &format!("{s}/curated"),
            r#"{"kind": "bonus", "a": "x", "b": "y", "c": "z"}"#,
        )
        .await;
    assert_eq!(status, 400, "{reply}");

    // `worker_id` may be left out in an MTurk preview only, as the schema says.
    let start = server.url(&format!("/api/v1/studies/{study}/start"));
    let shape = &schemas["StartRequest"]["allOf"][1]["anyOf"];
    assert_eq!(shape[0]["required"], json!(["worker_id"]), "{shape}");
    assert_eq!(
        shape[1]["properties"]["assignment_id"]["enum"],
        json!(["ASSIGNMENT_ID_NOT_AVAILABLE"])
    );
    let (status, reply) = send(c.post(&start).json(&json!({
        "assignment_id": "ASSIGNMENT_ID_NOT_AVAILABLE",
        "turk_submit_to": "https://workersandbox.mturk.com",
    })))
    .await;
    assert_eq!(
        (status, &reply["kind"]),
        (200, &json!("preview")),
        "{reply}"
    );
    let (status, reply) = send(c.post(&start).json(&json!({"source": "direct"}))).await;
    assert_eq!(status, 400, "{reply}");
    assert!(
        reply["error"]
            .as_str()
            .unwrap_or_default()
            .contains("worker_id"),
        "{reply}"
    );
    // A field the schema constrains is checked whatever the source.
    let (status, reply) = send(c.post(&start).json(&json!({
        "source": "direct", "worker_id": "w-other", "turk_submit_to": "https://example.org",
    })))
    .await;
    assert_eq!(status, 400, "{reply}");
}

both_databases!(contract, contract_sqlite, contract_postgres);

/// The dashboard's histogram and hourly counts are named objects, in the API and the CLI.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn dashboard_pairs_are_named() {
    let db = sqlite_db();
    let study = setup_study(&db, &StudyOpts::default());
    let server = Server::start(&db.url);
    study_with_workers(&server, study).await;
    let admin = Admin::login(&server).await;
    let (status, d) = admin
        .get(&format!("/api/v1/admin/studies/{study}/dashboard"))
        .await;
    assert_eq!(status, 200, "{d}");
    let bin = &d["control_error_histogram"][0];
    assert!(bin["errors"].is_i64() && bin["count"] == 1, "{d}");
    let hour = &d["answers_per_hour"][0];
    assert!(
        hour["hour"].as_i64().is_some_and(|h| h % 3_600_000 == 0),
        "{d}"
    );
    assert!(hour["count"].as_i64().is_some_and(|n| n >= 12), "{d}");
    let out = platform_ok(
        &[
            "study",
            "status",
            "--database-url",
            &db.url,
            &study.to_string(),
        ],
        &[],
    );
    let cli: Value = serde_json::from_str(&out).expect("status JSON");
    assert_eq!(cli["control_error_histogram"], d["control_error_histogram"]);
    assert_eq!(cli["answers_per_hour"], d["answers_per_hour"]);
}

/// Browsers get an HTML page for worker URLs that do not exist; `/api/` keeps JSON.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn missing_pages_are_html_and_there_is_a_favicon() {
    let db = sqlite_db();
    let study = setup_study(&db, &StudyOpts::default());
    let server = Server::start(&db.url);
    let c = client();
    for path in [
        "/a/unknown-token",
        "/s/999",
        "/s/not-a-number",
        "/nope",
        "/admin/studies/not-a-number",
        "/media/items/1.png",
    ] {
        let resp = c.get(server.url(path)).send().await.expect("GET");
        assert_eq!(resp.status().as_u16(), 404, "{path}");
        let kind = resp.headers()["content-type"]
            .to_str()
            .unwrap_or_default()
            .to_string();
        let csp = resp.headers().get("content-security-policy").is_some();
        let html = resp.text().await.expect("body");
        assert!(kind.starts_with("text/html"), "{path}: {kind}: {html}");
        assert!(csp, "{path}: the page has the CSP");
        assert!(
            html.contains("<h1>") && html.contains("not found"),
            "{path}: {html}"
        );
    }
    // The address of a form, opened as a page.
    let resp = c
        .get(server.url("/a/unknown-token/answer"))
        .send()
        .await
        .expect("GET");
    assert_eq!(resp.status().as_u16(), 405);
    assert_eq!(resp.headers()["allow"], "POST");
    let kind = resp.headers()["content-type"]
        .to_str()
        .unwrap_or_default()
        .to_string();
    assert!(kind.starts_with("text/html"), "{kind}");
    // A malformed form post to a worker page: an error page, not JSON.
    let resp = c
        .post(server.url("/a/unknown-token/answer"))
        .header("content-type", "text/plain")
        .body("x")
        .send()
        .await
        .expect("POST");
    let status = resp.status().as_u16();
    let kind = resp.headers()["content-type"]
        .to_str()
        .unwrap_or_default()
        .to_string();
    assert!(
        (400..500).contains(&status) && kind.starts_with("text/html"),
        "{status} {kind}"
    );
    for path in [
        "/api/v1/nope",
        "/api/v1/studies/not-a-number",
        "/api/v1/assignments/x",
    ] {
        let resp = c.get(server.url(path)).send().await.expect("GET");
        assert_eq!(resp.status().as_u16(), 404, "{path}");
        let kind = resp.headers()["content-type"]
            .to_str()
            .unwrap_or_default()
            .to_string();
        assert_eq!(kind, "application/json", "{path}");
    }
    let resp = c
        .get(server.url("/favicon.ico"))
        .send()
        .await
        .expect("favicon");
    assert_eq!(resp.status().as_u16(), 200);
    assert_eq!(resp.headers()["content-type"], "image/x-icon");
    let icon = resp.bytes().await.expect("icon");
    assert_eq!(&icon[..4], &[0, 0, 1, 0], "an ICO file");
    let page = c
        .get(server.url(&format!("/s/{study}?participant=p1")))
        .send()
        .await
        .expect("start page")
        .text()
        .await
        .expect("html");
    assert!(
        page.contains("<link rel=\"icon\" href=\"/static/favicon.ico?v="),
        "{page}"
    );
}

/// The fuzzer's configuration with the real ids of a study with workers in every state, so
/// requests reach the handlers' logic instead of stopping at a 404, and the admin session.
async fn schemathesis_config(server: &Server, study: i64) -> String {
    let (done, active, training) = study_with_workers(server, study).await;
    let admin = Admin::login(server).await;
    let session = admin
        .cookie
        .strip_prefix("platform_session=")
        .expect("session cookie")
        .to_string();
    let (_, workers) = admin
        .get(&format!("/api/v1/admin/studies/{study}/workers"))
        .await;
    let assignments: Vec<i64> = workers
        .as_array()
        .expect("workers")
        .iter()
        .filter_map(|w| w["assignment"].as_i64())
        .collect();
    sqlx::any::install_default_drivers();
    let pool = sqlx::AnyPool::connect(&server.db_url)
        .await
        .expect("connect");
    let items: Vec<(i64, String)> = sqlx::query_as("SELECT id, name FROM items")
        .fetch_all(&pool)
        .await
        .expect("items");
    pool.close().await;
    let item_ids: Vec<i64> = items.iter().map(|(id, _)| *id).collect();
    let names: Vec<&String> = items.iter().map(|(_, n)| n).collect();
    let positions: Vec<i64> = (0..12).collect();
    format!(
        r#"
# Fail on what would make the run test less than it seems: the admin session not accepted
# (every admin operation answering 401/403), a scheme of this file missing from the document,
# a pattern or reference of the document the fuzzer cannot use.
[warnings]
fail-on = ["missing_auth", "unused_openapi_auth", "unsupported_regex", "unresolvable_reference"]

[auth.openapi.session]
api_key = "{session}"

[auth.openapi.csrf]
api_key = "{csrf}"

[dictionaries.studies]
values = [{study}]

[dictionaries.tokens]
values = ["{done}", "{active}", "{training}"]

[dictionaries.assignments]
values = {assignments:?}

[dictionaries.items]
values = {item_ids:?}

[dictionaries.item_names]
values = {names:?}

[dictionaries.positions]
values = {positions:?}

[parameters]
"path.study" = {{ dictionary = "studies", probability = 0.8 }}
"path.token" = {{ dictionary = "tokens", probability = 0.9 }}
"path.assignment" = {{ dictionary = "assignments", probability = 0.8 }}
"body.choice" = {{ dictionary = "items", probability = 0.7 }}
"body.answers[*].choice" = {{ dictionary = "items", probability = 0.7 }}
"body.position" = {{ dictionary = "positions", probability = 0.7 }}
"body.answers[*].position" = {{ dictionary = "positions", probability = 0.7 }}
"body.a" = {{ dictionary = "item_names", probability = 0.7 }}
"body.b" = {{ dictionary = "item_names", probability = 0.7 }}
"body.c" = {{ dictionary = "item_names", probability = 0.7 }}
"#,
        csrf = admin.csrf,
    )
}

/// Longest the schemathesis run may take before the test fails (it takes ~30 s here with the
/// default 25 examples per operation).
fn schemathesis_deadline() -> Duration {
    Duration::from_secs(if std::env::var_os("SCHEMATHESIS_MAX_EXAMPLES").is_some() {
        3600
    } else {
        240
    })
}

/// schemathesis against the real server (SQLite) with an admin session: every check but
/// `positive_data_acceptance`, which counts a 400 for a well-formed request with an unknown
/// library or item name, a training answer count that does not match the study, or
/// `controls_per_hit` not below `questions_per_hit` as a failure; what the schema cannot say
/// is left to the handlers' own tests. Nothing is excluded: the API has no logout, and a
/// training it starts runs in the background (one at a time; the next is a 409).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn schemathesis_finds_nothing() {
    if !tool("schemathesis", "schemathesis", &["--version"]) {
        return;
    }
    let db = sqlite_db();
    let study = setup_study(&db, &StudyOpts::default());
    let server = Server::start(&db.url);
    let dir = tempfile::tempdir().expect("temp dir");
    let config = dir.path().join("schemathesis.toml");
    std::fs::write(&config, schemathesis_config(&server, study).await).expect("write config");
    let log = dir.path().join("schemathesis.log");
    // A longer or other run locally: SCHEMATHESIS_MAX_EXAMPLES=200 SCHEMATHESIS_SEED=7.
    let examples = std::env::var("SCHEMATHESIS_MAX_EXAMPLES").unwrap_or_else(|_| "25".into());
    let seed = std::env::var("SCHEMATHESIS_SEED").unwrap_or_else(|_| "1".into());
    let args = [
        "--config-file",
        &config.to_string_lossy(),
        "run",
        &server.url("/api/v1/openapi.json"),
        "--checks",
        "all",
        "--exclude-checks",
        "positive_data_acceptance",
        "--max-examples",
        &examples,
        "--seed",
        &seed,
        "--workers",
        "1",
        "--request-timeout",
        "30",
        "--generation-database",
        "none",
        "--no-color",
    ];
    eprintln!("schemathesis {}", args.join(" "));
    let started = Instant::now();
    let mut child = Command::new("schemathesis")
        .args(args)
        .current_dir(dir.path())
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&log).expect("log file"))
        .stderr(Stdio::inherit())
        .spawn()
        .expect("run schemathesis");
    let status = loop {
        if let Some(status) = child.try_wait().expect("wait for schemathesis") {
            break Some(status);
        }
        if started.elapsed() > schemathesis_deadline() {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        tokio::time::sleep(Duration::from_millis(200)).await;
    };
    let mut output = String::new();
    std::fs::File::open(&log)
        .and_then(|mut f| f.read_to_string(&mut output))
        .expect("read log");
    eprintln!("{output}");
    eprintln!("schemathesis took {:.1} s", started.elapsed().as_secs_f64());
    let status =
        status.unwrap_or_else(|| panic!("schemathesis ran past {:?}", schemathesis_deadline()));
    assert!(
        status.success(),
        "schemathesis found failures (output above)"
    );
    let operations: usize = document(&server).await["paths"]
        .as_object()
        .expect("paths")
        .values()
        .map(|item| item.as_object().map_or(0, |ops| ops.len()))
        .sum();
    assert!(
        output.contains(&format!("Tested: {operations}\n")),
        "all {operations} operations were tested (output above)"
    );
}
