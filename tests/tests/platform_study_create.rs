//! Creating a large study on a live server (issue 16, major 5): the tuple pool is written in
//! bounded chunks, so worker starts on the server's answer path keep going while it is built;
//! a study is not open to workers until its pool is complete.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use e2e::both_databases;
use e2e::platform::*;
use serde_json::json;

/// Styles of the synthetic library: a hue family each, so automatic controls exist.
const SYNTH_STYLES: [&str; 4] = ["red", "green", "blue", "grey"];

/// A library folder of `per_style` × 4 flat SVG drawings with a `labels.csv`: 64 items make
/// 124,992 distinct triplets (n·(n−1)·(n−2)/2), enough for a 100,000-tuple study.
fn synthetic_library(per_style: usize) -> tempfile::TempDir {
    let dir = tempfile::tempdir().expect("temp dir");
    let mut labels = String::from("file,style,keywords\n");
    for (s, style) in SYNTH_STYLES.iter().enumerate() {
        for i in 0..per_style {
            let shade = 40 + (i * 200 / per_style.max(1)) as u8;
            let (r, g, b) = match s {
                0 => (shade, 20, 30),
                1 => (20, shade, 40),
                2 => (30, 40, shade),
                _ => (shade, shade, shade),
            };
            let shape = if i % 2 == 0 {
                format!(r#"<circle cx="50" cy="50" r="{}"/>"#, 20 + i % 25)
            } else {
                format!(
                    r#"<rect x="{0}" y="{0}" width="50" height="40"/>"#,
                    5 + i % 30
                )
            };
            let file = format!("{style}-{i}.svg");
            std::fs::write(
                dir.path().join(&file),
                format!(
                    concat!(
                        r#"<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 100 100">"#,
                        r##"<g fill="#{:02x}{:02x}{:02x}" stroke="#000" stroke-width="{}">"##,
                        "{}</g></svg>"
                    ),
                    r,
                    g,
                    b,
                    s + 1,
                    shape
                ),
            )
            .expect("write svg");
            labels.push_str(&format!("{file},{style},\n"));
        }
    }
    std::fs::write(dir.path().join("labels.csv"), labels).expect("labels");
    dir
}

/// Imports the synthetic library as `synth`, creates a small open study over it (no training,
/// so a start allocates its HIT at once) and the admin; returns the study id.
fn setup_live_study(db: &TestDb) -> i64 {
    let lib = synthetic_library(16);
    let path = lib.path().to_string_lossy().into_owned();
    let labels = lib.path().join("labels.csv").to_string_lossy().into_owned();
    platform_ok(
        &[
            "library",
            "import",
            "--database-url",
            &db.url,
            "--name",
            "synth",
            "--labels",
            &labels,
            &path,
        ],
        &[],
    );
    let settings = lib.path().join("settings.json");
    std::fs::write(
        &settings,
        json!({"questions_per_hit": 12, "controls_per_hit": 2, "tuples": 20000,
               "replication": 3, "training_questions": 0, "reasons_probability": 0.0})
        .to_string(),
    )
    .expect("settings");
    let out = platform_ok(
        &[
            "study",
            "create",
            "--database-url",
            &db.url,
            "--name",
            "live",
            "--library",
            "synth",
            "--settings",
            &settings.to_string_lossy(),
        ],
        &[],
    );
    create_admin(&db.url);
    out.split_whitespace()
        .nth(1)
        .and_then(|id| id.trim_end_matches(':').parse().ok())
        .unwrap_or_else(|| panic!("no study id in {out:?}"))
}

/// Starts new workers on `study` one after another (with a short pause) until `stop`; returns
/// each start's latency.
async fn keep_starting(base: String, study: i64, who: usize, stop: Arc<AtomicBool>) -> Vec<f64> {
    let c = client();
    let mut latencies = Vec::new();
    let mut n = 0;
    while !stop.load(Ordering::Relaxed) {
        n += 1;
        let t = Instant::now();
        let sent = c
            .post(format!("{base}/api/v1/studies/{study}/start"))
            .json(&json!({"source": "direct", "worker_id": format!("w{who}-{n}")}))
            .send()
            .await;
        // A start that times out (60 s) counts with its time, for the assertion to report.
        latencies.push(t.elapsed().as_secs_f64());
        if let Ok(resp) = sent {
            let status = resp.status().as_u16();
            let body = resp.text().await.unwrap_or_default();
            assert_eq!(status, 200, "start during the creation: {body}");
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    latencies
}

/// A 100,000-tuple × 10 study (1.1 million rows) is created through the API while workers
/// keep starting on another study of the same server: every start stays under 1 s (on SQLite
/// it waited ~31 s behind the single write transaction that built the whole pool), the new
/// study refuses workers until its pool is complete, and then takes them. On PostgreSQL, whose
/// writers do not queue behind each other, with 20,000 tuples: its foreign-key checks make a
/// slot cost ~30 µs there, and the full size would take a minute for little more to learn.
async fn large_creation_leaves_starts_fast(db: TestDb) {
    let tuples: i64 = if db.postgres { 20_000 } else { 100_000 };
    let live = setup_live_study(&db);
    let server = Server::start(&db.url);
    let base = server.base.clone();
    let c = client();
    let (cookie, csrf) = admin_login(&c, &base).await;
    // Warm-up: the first start of a server opens connections and prepares statements.
    for i in 0..3 {
        start_worker(&c, &base, live, &format!("warm-{i}")).await;
    }

    let stop = Arc::new(AtomicBool::new(false));
    let starters: Vec<_> = (0..3)
        .map(|who| tokio::spawn(keep_starting(base.clone(), live, who, stop.clone())))
        .collect();
    tokio::time::sleep(Duration::from_millis(300)).await;

    let t = Instant::now();
    let (status, created) = send(
        c.post(format!("{base}/api/v1/admin/studies"))
            .header("cookie", &cookie)
            .header("x-csrf-token", &csrf)
            .json(&json!({"name": "large", "library": "synth",
                          "settings": {"tuples": tuples, "replication": 10}})),
    )
    .await;
    assert!(status == 200 || status == 202, "create: {status} {created}");
    let large = created["id"].as_i64().expect("study id");
    // A start while the pool is written: refused, unless the pool was complete by then (the
    // state read after the attempt says which).
    let mut early_start: Option<(u16, serde_json::Value)> = None;
    let mut state = created.clone();
    while state["status"] == "creating" {
        assert!(
            t.elapsed() < Duration::from_secs(120),
            "the pool is still being written after 2 minutes: {state}"
        );
        let done = state["rows_done"].as_i64().expect("rows_done");
        let total = state["rows_total"].as_i64().expect("rows_total");
        // The tuples and their 10 slots each, plus the controls and practice triplets.
        assert!(
            (0..=total).contains(&done) && (tuples * 11..tuples * 11 + 1000).contains(&total),
            "progress: {state}"
        );
        let attempted = early_start.is_none();
        if attempted {
            early_start = Some(
                send(
                    c.post(format!("{base}/api/v1/studies/{large}/start"))
                        .json(&json!({"source": "direct", "worker_id": "early"})),
                )
                .await,
            );
        }
        tokio::time::sleep(Duration::from_millis(250)).await;
        let (status, body) = send(
            c.get(format!("{base}/api/v1/admin/studies/{large}"))
                .header("cookie", &cookie),
        )
        .await;
        assert_eq!(status, 200, "{body}");
        state = body;
        if attempted && state["status"] == "creating" {
            let (status, body) = early_start.as_ref().expect("attempted");
            assert_eq!(*status, 409, "a start while the pool is written: {body}");
            assert!(
                body["error"]
                    .as_str()
                    .unwrap_or_default()
                    .contains("being prepared"),
                "{body}"
            );
        }
    }
    let creation = t.elapsed().as_secs_f64();
    // A little more load after the pool is complete, then stop.
    tokio::time::sleep(Duration::from_millis(200)).await;
    stop.store(true, Ordering::Relaxed);
    let mut latencies: Vec<f64> = Vec::new();
    for s in starters {
        latencies.extend(s.await.expect("starter"));
    }
    latencies.sort_by(f64::total_cmp);
    let worst = latencies.last().copied().unwrap_or(0.0);
    let median = latencies[latencies.len() / 2];
    eprintln!(
        "{} pool: {tuples} x 10 created in {creation:.1} s; {} worker starts meanwhile, median \
         {:.0} ms, worst {:.0} ms",
        if db.postgres { "PostgreSQL" } else { "SQLite" },
        latencies.len(),
        median * 1000.0,
        worst * 1000.0
    );
    assert!(
        latencies.len() >= 20,
        "too few starts to say anything: {}",
        latencies.len()
    );
    assert!(
        worst < 1.0,
        "a worker start took {worst:.2} s while the study was created ({creation:.1} s)"
    );
    assert_eq!(state["status"], "ready", "{state}");
    // The complete study takes workers.
    start_worker(&c, &base, large, "after").await;
    assert_eq!(
        scalar(
            &db.url,
            "SELECT CAST(COUNT(*) AS BIGINT) FROM slots s JOIN studies t ON t.id = s.study_id \
             WHERE t.name = 'large'"
        )
        .await,
        tuples * 10
    );
}

both_databases!(
    large_creation_leaves_starts_fast,
    large_creation_leaves_worker_starts_under_a_second_sqlite,
    large_creation_leaves_worker_starts_under_a_second_postgres
);

/// Imports the synthetic library as `name`, with style labels or without.
fn import_synthetic(db: &TestDb, name: &str, labelled: bool) {
    let lib = synthetic_library(16);
    let path = lib.path().to_string_lossy().into_owned();
    let labels = lib.path().join("labels.csv").to_string_lossy().into_owned();
    let mut args = vec![
        "library",
        "import",
        "--database-url",
        &db.url,
        "--name",
        name,
    ];
    if labelled {
        args.extend(["--labels", labels.as_str()]);
    }
    args.push(&path);
    platform_ok(&args, &[]);
}

/// Runs `platform study create` with `settings` over `library`; returns (study id, stderr).
fn cli_create(db: &TestDb, library: &str, settings: serde_json::Value) -> (i64, String) {
    let dir = tempfile::tempdir().expect("temp dir");
    let file = dir.path().join("settings.json");
    std::fs::write(&file, settings.to_string()).expect("settings");
    let out = platform_cmd(
        &[
            "study",
            "create",
            "--database-url",
            &db.url,
            "--name",
            "cli study",
            "--library",
            library,
            "--settings",
            &file.to_string_lossy(),
        ],
        &[],
    );
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "study create: {stdout}\n{stderr}");
    let id = stdout
        .split_whitespace()
        .nth(1)
        .and_then(|id| id.trim_end_matches(':').parse().ok())
        .unwrap_or_else(|| panic!("no study id in {stdout:?}"));
    (id, stderr)
}

/// The text of a page (any status).
async fn page(c: &reqwest::Client, url: &str, cookie: Option<&str>) -> (u16, String) {
    let mut req = c.get(url);
    if let Some(cookie) = cookie {
        req = req.header("cookie", cookie);
    }
    let resp = req.send().await.expect("GET");
    let status = resp.status().as_u16();
    (status, resp.text().await.expect("body"))
}

/// The start page says how many questions a HIT holds now — the settings' number, fewer when
/// the study has fewer free tuples or no controls, nothing about practice when it has none,
/// and that the study is full when it is — and a start gets exactly that many. A library
/// without style labels gives no controls and no practice triplets: the command line, the API
/// and the study page say so.
async fn start_page_counts_what_a_hit_holds(db: TestDb) {
    import_synthetic(&db, "plain", false);
    import_synthetic(&db, "synth", true);
    create_admin(&db.url);
    let shape = json!({"questions_per_hit": 12, "controls_per_hit": 3, "tuples": 5,
                       "training_questions": 2, "replication": 1});
    let (plain, stderr) = cli_create(&db, "plain", shape.clone());
    assert!(
        stderr.contains("warning: study") && stderr.contains("No hidden control questions"),
        "{stderr}"
    );
    assert!(stderr.contains("No practice questions"), "{stderr}");
    assert!(stderr.contains("0 style labels"), "{stderr}");
    let (labelled, stderr) = cli_create(&db, "synth", shape.clone());
    assert!(!stderr.contains("warning"), "{stderr}");

    let server = Server::start(&db.url);
    let base = server.base.as_str();
    let c = client();
    let (cookie, csrf) = admin_login(&c, base).await;

    // The API: the creation's response and the study's state carry the warnings.
    let (status, created) = send(
        c.post(format!("{base}/api/v1/admin/studies"))
            .header("cookie", &cookie)
            .header("x-csrf-token", &csrf)
            .json(&json!({"name": "plain api", "library": "plain", "settings": shape})),
    )
    .await;
    assert_eq!(status, 200, "{created}");
    assert_eq!(created["status"], "ready", "{created}");
    let warnings = created["warnings"].as_array().expect("warnings");
    assert_eq!(warnings.len(), 2, "{created}");
    let (status, detail) = send(
        c.get(format!("{base}/api/v1/admin/studies/{plain}"))
            .header("cookie", &cookie),
    )
    .await;
    assert_eq!(status, 200, "{detail}");
    assert_eq!(
        detail["warnings"].as_array().map(Vec::len),
        Some(2),
        "{detail}"
    );
    let (status, detail) = send(
        c.get(format!("{base}/api/v1/admin/studies/{labelled}"))
            .header("cookie", &cookie),
    )
    .await;
    assert_eq!(status, 200, "{detail}");
    assert_eq!(detail["warnings"], json!([]), "{detail}");
    let (_, study_page) = page(&c, &format!("{base}/admin/studies/{plain}"), Some(&cookie)).await;
    assert!(
        study_page.contains("id=\"pool-warnings\"")
            && study_page.contains("No hidden control questions")
            && study_page.contains("No practice questions"),
        "the study page shows the warnings"
    );

    // No controls, no practice: 5 free tuples make a HIT of 5 questions, started at once.
    let (status, start) = page(&c, &format!("{base}/s/{plain}?participant=p1"), None).await;
    assert_eq!(status, 200);
    assert!(start.contains("You will answer 5 questions."), "{start}");
    assert!(
        !start.contains("practice"),
        "no practice questions: {start}"
    );
    let token = start_worker(&c, base, plain, "p1").await;
    let (_, state) = send(c.get(format!("{base}/api/v1/assignments/{token}"))).await;
    assert_eq!(state["status"], "active", "{state}");
    assert_eq!(state["total"], 5, "{state}");
    let (_, info) = send(c.get(format!("{base}/api/v1/studies/{plain}"))).await;
    assert_eq!(info["hit_questions"], 0, "every tuple is taken: {info}");
    // Nothing is left: the page says so and offers no start.
    let (_, full) = page(&c, &format!("{base}/s/{plain}?participant=p2"), None).await;
    assert!(full.contains("id=\"study-full\""), "{full}");
    assert!(!full.contains("id=\"start-form\""), "{full}");

    // With controls and practice: 5 tuples and 3 controls, after 2 practice questions.
    let (_, start) = page(&c, &format!("{base}/s/{labelled}?participant=q1"), None).await;
    assert!(
        start.contains("You will answer 8 questions, after 2 practice questions"),
        "{start}"
    );
    let (_, info) = send(c.get(format!("{base}/api/v1/studies/{labelled}"))).await;
    assert_eq!(
        (
            info["hit_questions"].clone(),
            info["practice_questions"].clone()
        ),
        (json!(8), json!(2)),
        "{info}"
    );
    let styles = item_styles(&db.url).await;
    let token = start_worker(&c, base, labelled, "q1").await;
    let state = pass_training(&c, base, &token, &styles, Behaviour::Honest).await;
    assert_eq!(state["status"], "active", "{state}");
    assert_eq!(state["total"], 8, "{state}");
}

both_databases!(
    start_page_counts_what_a_hit_holds,
    the_start_page_counts_what_a_hit_holds_and_warns_of_a_pool_without_controls_sqlite,
    the_start_page_counts_what_a_hit_holds_and_warns_of_a_pool_without_controls_postgres
);

/// Sizes a study cannot hold are refused with the numbers, by the API, the command line and
/// the form's own bounds, and nothing is stored.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn oversized_studies_are_refused_with_their_size() {
    let db = sqlite_db();
    import_synthetic(&db, "synth", true);
    create_admin(&db.url);
    let out = platform_cmd(
        &[
            "study",
            "create",
            "--database-url",
            &db.url,
            "--name",
            "huge",
            "--library",
            "synth",
            "--tuples",
            "1000000",
            "--replication",
            "100",
        ],
        &[],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        stderr.contains("1000000 × 100 = 100000000 slots") && stderr.contains("20000000"),
        "{stderr}"
    );

    let server = Server::start(&db.url);
    let base = server.base.as_str();
    let c = client();
    let (cookie, csrf) = admin_login(&c, base).await;
    for (settings, says) in [
        (
            json!({"tuples": 1_000_000, "replication": 100}),
            "100000000 slots",
        ),
        (
            json!({"tuples": 200_000, "replication": 1}),
            "more than the 124992 distinct triplets the library's 64 items make",
        ),
    ] {
        let (status, body) = send(
            c.post(format!("{base}/api/v1/admin/studies"))
                .header("cookie", &cookie)
                .header("x-csrf-token", &csrf)
                .json(&json!({"name": "huge", "library": "synth", "settings": settings})),
        )
        .await;
        assert_eq!(status, 400, "{settings}: {body}");
        assert!(
            body["error"].as_str().unwrap_or_default().contains(says),
            "{settings}: {body}"
        );
    }
    let (_, list) = send(
        c.get(format!("{base}/api/v1/admin/studies"))
            .header("cookie", &cookie),
    )
    .await;
    assert_eq!(list, json!([]), "nothing was stored");
    let (_, index) = page(&c, &format!("{base}/admin"), Some(&cookie)).await;
    for bound in [
        r#"name="tuples" type="number" value="1000" min="1" max="1000000""#,
        r#"name="replication" type="number" value="1" min="1" max="100""#,
        r#"name="controls_per_hit" type="number" value="5" min="0" max="499""#,
    ] {
        assert!(index.contains(bound), "the form bounds its fields: {bound}");
    }
    assert!(
        index.contains("at most 20000000 slots"),
        "the form states the limit"
    );
}

/// The `study create` process is killed while it writes a large pool: the half-written study
/// never takes a worker, and once its creation has had no progress for two minutes (simulated
/// here by moving its last progress back) a server starting marks it failed, deletes its rows
/// and says so on the study page and in the API.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_creation_killed_midway_leaves_a_failed_study_nobody_can_join() {
    let db = sqlite_db();
    import_synthetic(&db, "synth", true);
    create_admin(&db.url);
    let mut cli = std::process::Command::new(e2e::binary("platform", "platform"))
        .args([
            "study",
            "create",
            "--database-url",
            &db.url,
            "--name",
            "doomed",
            "--library",
            "synth",
            "--tuples",
            "100000",
            "--replication",
            "10",
        ])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("spawn study create");
    let t = Instant::now();
    loop {
        assert!(
            t.elapsed() < Duration::from_secs(60),
            "no chunk was written"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
        let exists = scalar(
            &db.url,
            "SELECT CAST(COUNT(*) AS BIGINT) FROM studies WHERE status = 'creating' \
             AND pool_done > 10000",
        )
        .await;
        if exists == 1 {
            break;
        }
        assert!(
            cli.try_wait().expect("wait").is_none(),
            "the creation finished before it could be killed"
        );
    }
    cli.kill().expect("kill");
    cli.wait().expect("reap");
    let id = scalar(&db.url, "SELECT id FROM studies WHERE name = 'doomed'").await;
    let written = scalar(
        &db.url,
        "SELECT CAST(COUNT(*) AS BIGINT) FROM slots s JOIN studies t ON t.id = s.study_id \
         WHERE t.name = 'doomed'",
    )
    .await;
    assert!(
        written > 0 && written < 1_000_000,
        "a half-written pool: {written}"
    );

    let c = client();
    {
        // Recent progress: the server cannot tell it from a slow creation, and waits.
        let server = Server::start(&db.url);
        let (status, body) = send(
            c.post(format!("{}/api/v1/studies/{id}/start", server.base))
                .json(&json!({"source": "direct", "worker_id": "early"})),
        )
        .await;
        assert_eq!(status, 409, "{body}");
        assert!(
            body["error"]
                .as_str()
                .unwrap_or_default()
                .contains("being prepared"),
            "{body}"
        );
        let (status, start) = page(&c, &server.url(&format!("/s/{id}?participant=x")), None).await;
        assert_eq!(status, 409);
        assert!(start.contains("being prepared"), "{start}");
    }
    // Two minutes and more without progress.
    sqlx::any::install_default_drivers();
    let pool = sqlx::AnyPool::connect(&db.url).await.expect("connect");
    sqlx::query("UPDATE studies SET pool_beat = pool_beat - 600000 WHERE name = 'doomed'")
        .execute(&pool)
        .await
        .expect("age the creation");
    pool.close().await;

    let server = Server::start(&db.url);
    let base = server.base.as_str();
    let (cookie, _) = admin_login(&c, base).await;
    let t = Instant::now();
    let detail = loop {
        let (status, detail) = send(
            c.get(format!("{base}/api/v1/admin/studies/{id}"))
                .header("cookie", &cookie),
        )
        .await;
        assert_eq!(status, 200, "{detail}");
        if detail["status"] == "failed" && detail["rows_done"] == 0 {
            break detail;
        }
        assert!(
            t.elapsed() < Duration::from_secs(60),
            "not failed and cleaned up: {detail}"
        );
        tokio::time::sleep(Duration::from_millis(200)).await;
    };
    assert!(
        detail["error"]
            .as_str()
            .unwrap_or_default()
            .contains("creation stopped"),
        "{detail}"
    );
    assert_eq!(
        scalar(
            &db.url,
            "SELECT CAST(COUNT(*) AS BIGINT) FROM tuples t JOIN studies s ON s.id = t.study_id \
             WHERE s.name = 'doomed'"
        )
        .await
            + scalar(
                &db.url,
                "SELECT CAST(COUNT(*) AS BIGINT) FROM slots t JOIN studies s ON s.id = t.study_id \
                 WHERE s.name = 'doomed'"
            )
            .await,
        0,
        "its rows are deleted"
    );
    let (status, body) = send(
        c.post(format!("{base}/api/v1/studies/{id}/start"))
            .json(&json!({"source": "direct", "worker_id": "late"})),
    )
    .await;
    assert_eq!(status, 409, "{body}");
    assert!(
        body["error"]
            .as_str()
            .unwrap_or_default()
            .contains("could not be set up"),
        "{body}"
    );
    let (_, study_page) = page(&c, &format!("{base}/admin/studies/{id}"), Some(&cookie)).await;
    assert!(
        study_page.contains("This study could not be created.")
            && study_page.contains("creation stopped"),
        "the study page says so"
    );
    let (_, index) = page(&c, &format!("{base}/admin"), Some(&cookie)).await;
    assert!(
        index.contains("<strong>failed</strong>"),
        "the list says so"
    );
}
