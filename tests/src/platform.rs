//! Helpers for the platform tests: a fresh database per test (SQLite file or a new PostgreSQL
//! database on the server named by `TEST_POSTGRES_URL`), the real `platform` binary serving on
//! `127.0.0.1:0`, a small style-labelled library, and simulated workers over HTTP.

use std::collections::HashMap;
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Output, Stdio};
use std::sync::mpsc;
use std::time::Duration;

use rand::Rng;
use serde_json::{Value, json};

use crate::{binary, fixture};

/// Declares the same async scenario as a SQLite test and a PostgreSQL test (skipped, passing,
/// when `TEST_POSTGRES_URL` is unset; `scripts/test` always sets it).
#[macro_export]
macro_rules! both_databases {
    ($scenario:ident, $sqlite:ident, $postgres:ident) => {
        #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
        async fn $sqlite() {
            $scenario($crate::platform::sqlite_db()).await;
        }

        #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
        async fn $postgres() {
            if let Some(db) = $crate::platform::postgres_db().await {
                $scenario(db).await;
            }
        }
    };
}

/// The styles of the fixture set.
pub const STYLES: &[&str] = &["emojione-monotone", "fluent-emoji", "noto", "twemoji"];

/// A database for one test; the SQLite file or PostgreSQL database is dropped with it.
pub struct TestDb {
    /// Its URL.
    pub url: String,
    /// Which backend.
    pub postgres: bool,
    _dir: Option<tempfile::TempDir>,
}

/// A new SQLite database file in a temporary folder.
pub fn sqlite_db() -> TestDb {
    let dir = tempfile::tempdir().expect("temp dir");
    let url = format!("sqlite://{}", dir.path().join("platform.db").display());
    TestDb {
        url,
        postgres: false,
        _dir: Some(dir),
    }
}

/// A new, empty PostgreSQL database, or `None` (locally) when `TEST_POSTGRES_URL` is unset.
/// In CI (`CI=true`) a missing `TEST_POSTGRES_URL` fails the test.
pub async fn postgres_db() -> Option<TestDb> {
    let Some(admin_url) = std::env::var("TEST_POSTGRES_URL")
        .ok()
        .filter(|u| !u.is_empty())
    else {
        if std::env::var("CI").is_ok_and(|v| v == "true" || v == "1") {
            panic!(
                "TEST_POSTGRES_URL is not set: CI must run the PostgreSQL platform tests \
                 (scripts/test starts a throw-away cluster and sets it)"
            );
        }
        eprintln!("TEST_POSTGRES_URL is not set: skipping the PostgreSQL half of this test");
        return None;
    };
    let name = format!("t_{:016x}", rand::rng().random::<u64>());
    sqlx::any::install_default_drivers();
    let mut conn = <sqlx::AnyConnection as sqlx::Connection>::connect(&admin_url)
        .await
        .expect("connect to TEST_POSTGRES_URL");
    sqlx::Executor::execute(
        &mut conn,
        sqlx::AssertSqlSafe(format!("CREATE DATABASE {name}")),
    )
    .await
    .expect("create test database");
    let (head, _) = admin_url
        .rsplit_once('/')
        .expect("TEST_POSTGRES_URL has a database path");
    Some(TestDb {
        url: format!("{head}/{name}"),
        postgres: true,
        _dir: None,
    })
}

/// Both backends that are available: SQLite always, PostgreSQL when configured.
pub async fn all_dbs() -> Vec<TestDb> {
    let mut v = vec![sqlite_db()];
    if let Some(pg) = postgres_db().await {
        v.push(pg);
    }
    v
}

/// Runs `platform ARGS` and returns its output (panics with stderr when it fails).
pub fn platform_ok(args: &[&str], env: &[(&str, &str)]) -> String {
    let out = platform_cmd(args, env);
    assert!(
        out.status.success(),
        "platform {args:?} failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Runs `platform ARGS`.
pub fn platform_cmd(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(binary("platform", "platform"));
    cmd.args(args);
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.output().expect("run platform")
}

/// A copy of `per_style` concepts of each fixture style, with a `labels.csv`.
pub fn small_library(per_style: usize) -> tempfile::TempDir {
    let dir = tempfile::tempdir().expect("temp dir");
    let labels = std::fs::read_to_string(fixture("style/labels.csv")).expect("labels.csv");
    let mut out = String::from("file,style,keywords\n");
    let mut counts: HashMap<String, usize> = HashMap::new();
    for line in labels.lines().skip(1) {
        let mut cols = line.split(',');
        let (Some(file), Some(style)) = (cols.next(), cols.next()) else {
            continue;
        };
        let n = counts.entry(style.to_string()).or_default();
        if *n >= per_style {
            continue;
        }
        *n += 1;
        let target = dir.path().join(file);
        std::fs::create_dir_all(target.parent().expect("parent")).expect("mkdir");
        std::fs::copy(fixture(&format!("style/{file}")), &target).expect("copy fixture");
        out.push_str(&format!("{file},{style},\n"));
    }
    std::fs::write(dir.path().join("labels.csv"), out).expect("write labels");
    dir
}

/// Study settings for tests.
#[derive(Debug, Clone)]
pub struct StudyOpts {
    /// Questions per HIT.
    pub questions: u32,
    /// Controls per HIT.
    pub controls: u32,
    /// Main tuples.
    pub tuples: u32,
    /// Replication R.
    pub replication: u32,
    /// Extra settings JSON merged in.
    pub extra: Value,
}

impl Default for StudyOpts {
    fn default() -> Self {
        Self {
            questions: 12,
            controls: 3,
            tuples: 200,
            replication: 1,
            extra: json!({}),
        }
    }
}

/// The admin password the tests use.
pub const ADMIN_PASSWORD: &str = "correct horse battery staple";

/// Imports the folder `dir` as the library `name` (its items labelled by `labels`, if given)
/// with `platform library import`; returns what the command printed.
pub fn import_named(db_url: &str, name: &str, dir: &Path, labels: Option<&Path>) -> String {
    let dir = dir.to_string_lossy().into_owned();
    let labels = labels.map(|l| l.to_string_lossy().into_owned());
    let mut args = vec![
        "library",
        "import",
        "--database-url",
        db_url,
        "--name",
        name,
    ];
    if let Some(labels) = &labels {
        args.extend(["--labels", labels.as_str()]);
    }
    args.push(&dir);
    platform_ok(&args, &[])
}

/// Imports the library folder `dir` (its items, labelled by `dir/labels.csv`) as `fx`.
pub fn import_library(db: &TestDb, dir: &Path) {
    import_named(&db.url, "fx", dir, Some(&dir.join("labels.csv")));
}

/// Creates the admin account (password [`ADMIN_PASSWORD`]) with `platform admin create`.
pub fn create_admin(db_url: &str) {
    platform_ok(
        &["admin", "create", "--database-url", db_url],
        &[("PLATFORM_ADMIN_PASSWORD", ADMIN_PASSWORD)],
    );
}

/// Imports a small library, creates a study and an admin; returns the study id.
pub fn setup_study(db: &TestDb, opts: &StudyOpts) -> i64 {
    let lib = small_library(6);
    import_library(db, lib.path());
    let mut settings = json!({
        "questions_per_hit": opts.questions,
        "controls_per_hit": opts.controls,
        "tuples": opts.tuples,
        "replication": opts.replication,
        "training_questions": 2,
        "reasons_probability": 0.1,
    });
    if let (Some(s), Some(extra)) = (settings.as_object_mut(), opts.extra.as_object()) {
        for (k, v) in extra {
            s.insert(k.clone(), v.clone());
        }
    }
    let settings_file = lib.path().join("settings.json");
    std::fs::write(&settings_file, settings.to_string()).expect("write settings");
    let out = platform_ok(
        &[
            "study",
            "create",
            "--database-url",
            &db.url,
            "--name",
            "test study",
            "--library",
            "fx",
            "--settings",
            &settings_file.to_string_lossy(),
        ],
        &[],
    );
    create_admin(&db.url);
    out.split_whitespace()
        .nth(1)
        .and_then(|id| id.trim_end_matches(':').parse().ok())
        .unwrap_or_else(|| panic!("no study id in {out:?}"))
}

/// A running `platform serve`; killed when dropped.
pub struct Server {
    child: Child,
    /// `http://127.0.0.1:PORT`.
    pub base: String,
    /// The database URL it serves.
    pub db_url: String,
}

impl Server {
    /// Starts `platform serve` on a free loopback port and waits until it listens.
    pub fn start(db_url: &str) -> Self {
        Self::start_with(db_url, &[])
    }

    /// Like [`Server::start`] with extra arguments.
    pub fn start_with(db_url: &str, extra: &[&str]) -> Self {
        let mut child = Command::new(binary("platform", "platform"))
            .args(["serve", "--bind", "127.0.0.1:0", "--database-url", db_url])
            .args(extra)
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("spawn platform serve");
        let stdout = child.stdout.take().expect("stdout");
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                let Ok(line) = line else { break };
                if let Some(addr) = line.strip_prefix("listening on ") {
                    let _ = tx.send(addr.to_string());
                }
            }
        });
        let base = rx
            .recv_timeout(Duration::from_secs(60))
            .expect("platform serve did not report its address");
        Self {
            child,
            base,
            db_url: db_url.to_string(),
        }
    }

    /// SIGKILL, no shutdown.
    pub fn kill9(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }

    /// `base + path`.
    pub fn url(&self, path: &str) -> String {
        format!("{}{path}", self.base)
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.kill9();
    }
}

/// An HTTP client without cookies or redirects (tests look at raw responses).
pub fn client() -> reqwest::Client {
    reqwest::Client::builder()
        .redirect(reqwest::redirect::Policy::none())
        .timeout(Duration::from_secs(60))
        .build()
        .expect("client")
}

/// Item id → style label, read from the database (what an honest worker "sees").
pub async fn item_styles(db_url: &str) -> HashMap<i64, String> {
    sqlx::any::install_default_drivers();
    let pool = sqlx::AnyPool::connect(db_url).await.expect("connect");
    let rows: Vec<(i64, Option<String>)> = sqlx::query_as("SELECT id, style FROM items")
        .fetch_all(&pool)
        .await
        .expect("items");
    pool.close().await;
    rows.into_iter()
        .map(|(id, s)| (id, s.unwrap_or_default()))
        .collect()
}

/// Runs one SQL query returning a single integer.
pub async fn scalar(db_url: &str, sql: &'static str) -> i64 {
    sqlx::any::install_default_drivers();
    let pool = sqlx::AnyPool::connect(db_url).await.expect("connect");
    let (v,): (i64,) = sqlx::query_as(sql).fetch_one(&pool).await.expect(sql);
    pool.close().await;
    v
}

/// How a simulated worker answers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Behaviour {
    /// Sees style: picks the option of the reference's style when exactly one has it, else
    /// the per-tuple "truth" with probability 0.8.
    Honest,
    /// Random clicks (but passes training by retrying with the feedback).
    Spammer,
}

/// The honest (or random) choice for a question view.
pub fn choose(q: &Value, styles: &HashMap<i64, String>, who: Behaviour) -> i64 {
    let id = |k: &str| q[k]["id"].as_i64().expect("item id");
    let (r, l, rt) = (id("reference"), id("left"), id("right"));
    let mut rng = rand::rng();
    if who == Behaviour::Spammer {
        return if rng.random_bool(0.5) { l } else { rt };
    }
    let s = |i: i64| styles.get(&i).cloned().unwrap_or_default();
    match (s(l) == s(r), s(rt) == s(r)) {
        (true, false) => l,
        (false, true) => rt,
        _ => {
            let truth = l.min(rt);
            if rng.random_bool(0.8) {
                truth
            } else {
                l.max(rt)
            }
        }
    }
}

/// Sends a JSON request and returns (status, body).
pub async fn send(req: reqwest::RequestBuilder) -> (u16, Value) {
    let resp = req.send().await.expect("request");
    let status = resp.status().as_u16();
    let text = resp.text().await.expect("body");
    let body = serde_json::from_str(&text).unwrap_or(Value::String(text));
    (status, body)
}

/// Starts a direct-link worker; returns the assignment token.
pub async fn start_worker(c: &reqwest::Client, base: &str, study: i64, worker: &str) -> String {
    let (status, body) = send(
        c.post(format!("{base}/api/v1/studies/{study}/start"))
            .json(&json!({"source": "direct", "worker_id": worker})),
    )
    .await;
    assert_eq!(status, 200, "start: {body}");
    body["token"].as_str().expect("token").to_string()
}

/// Passes the training (using the feedback to correct wrong answers).
pub async fn pass_training(
    c: &reqwest::Client,
    base: &str,
    token: &str,
    styles: &HashMap<i64, String>,
    who: Behaviour,
) -> Value {
    for _ in 0..5 {
        let (_, st) = send(c.get(format!("{base}/api/v1/assignments/{token}"))).await;
        if st["status"] != "training" {
            return st;
        }
        let answers: Vec<Value> = st["training"]
            .as_array()
            .expect("training questions")
            .iter()
            .map(|q| json!({"position": q["position"], "choice": choose(q, styles, who)}))
            .collect();
        let (status, result) = send(
            c.post(format!("{base}/api/v1/assignments/{token}/training"))
                .json(&json!({"answers": answers})),
        )
        .await;
        assert_eq!(status, 200, "training: {result}");
        if result["passed"] == true {
            break;
        }
    }
    send(c.get(format!("{base}/api/v1/assignments/{token}")))
        .await
        .1
}

/// Answers every remaining question; returns the final state.
pub async fn answer_all(
    c: &reqwest::Client,
    base: &str,
    token: &str,
    styles: &HashMap<i64, String>,
    who: Behaviour,
) -> Value {
    loop {
        let (status, st) = send(c.get(format!("{base}/api/v1/assignments/{token}"))).await;
        assert_eq!(status, 200, "state: {st}");
        let Some(q) = st.get("question").filter(|q| !q.is_null()) else {
            return st;
        };
        let choice = choose(q, styles, who);
        let (status, ack) = send(
            c.post(format!("{base}/api/v1/assignments/{token}/answers"))
                .json(&json!({"position": q["position"], "choice": choice, "elapsed_ms": 1200})),
        )
        .await;
        assert_eq!(status, 200, "answer: {ack}");
        if ack["ask_reasons"] == true {
            let (status, body) = send(
                c.post(format!("{base}/api/v1/assignments/{token}/reasons")).json(
                    &json!({"position": q["position"], "reasons": ["colour_palette"], "text": "colours"}),
                ),
            )
            .await;
            assert_eq!(status, 200, "reasons: {body}");
        }
    }
}

/// GET `url` with the admin session `cookie`; asserts 200 and returns the body.
pub async fn admin_text(c: &reqwest::Client, url: &str, cookie: &str) -> String {
    let resp = c
        .get(url)
        .header("cookie", cookie)
        .send()
        .await
        .expect("admin GET");
    assert_eq!(resp.status().as_u16(), 200, "GET {url}");
    resp.text().await.expect("body")
}

/// Logs in as the test admin; returns (cookie header value, CSRF token).
pub async fn admin_login(c: &reqwest::Client, base: &str) -> (String, String) {
    let resp = c
        .post(format!("{base}/admin/login"))
        .form(&[("username", "admin"), ("password", ADMIN_PASSWORD)])
        .send()
        .await
        .expect("login");
    assert_eq!(resp.status().as_u16(), 303, "login should redirect");
    let cookie = resp
        .headers()
        .get("set-cookie")
        .and_then(|v| v.to_str().ok())
        .expect("session cookie")
        .split(';')
        .next()
        .expect("cookie pair")
        .to_string();
    let (status, session) = send(
        c.get(format!("{base}/api/v1/admin/session"))
            .header("cookie", &cookie),
    )
    .await;
    assert_eq!(status, 200, "session: {session}");
    (cookie, session["csrf"].as_str().expect("csrf").to_string())
}
