//! Style exploration in the platform (issue 18, Garces et al. 2016 §6.5) on SQLite and
//! PostgreSQL through the real server: a taxonomy job goes from queued to done, its result is
//! stored and reused for the same parameters, and equals `learner::explore::taxonomy` run here
//! on the stored features; a job left running by a dead server shows failed and restarts; a
//! branch's balanced grid holds every member once; bad requests are 4xx answers that store
//! nothing; anonymous requests are refused. In Chromium: build from the page, open a branch
//! and a hidden-image pop-up, with no CSP violation.

use std::collections::HashMap;
use std::time::Duration;

use e2e::both_databases;
use e2e::platform::*;
use serde_json::{Value, json};

mod browser;
mod map;
mod phone;

both_databases!(explore_a_library, explore_sqlite, explore_postgres);

/// Items per style imported (48 in all).
const PER_STYLE: usize = 12;

/// The first [`PER_STYLE`] drawings of each fixture style with their style labels, as
/// `clipart`, and the admin.
pub(super) fn import(db: &TestDb) {
    let dir = tempfile::tempdir().expect("temp dir");
    let labels = std::fs::read_to_string(e2e::fixture("style/labels.csv")).expect("labels.csv");
    let mut out = String::from("file,style,keywords\n");
    let mut counts: HashMap<String, usize> = HashMap::new();
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
    }
    let labels_file = dir.path().join("labels.csv");
    std::fs::write(&labels_file, out).expect("labels");
    let printed = import_named(&db.url, "clipart", dir.path(), Some(&labels_file));
    assert!(printed.contains("48"), "{printed}");
    create_admin(&db.url);
}

async fn pool(db_url: &str) -> sqlx::AnyPool {
    sqlx::any::install_default_drivers();
    sqlx::AnyPool::connect(db_url).await.expect("connect")
}

/// The representative styles `learner::explore::taxonomy` finds for the stored items of
/// `labels` under uniform weights, as (representative name, sorted member names).
async fn reference(
    db_url: &str,
    labels: &[&str],
    kappa: usize,
    tau: usize,
) -> Vec<(String, Vec<String>)> {
    let pool = pool(db_url).await;
    let rows: Vec<(String, String, String)> =
        sqlx::query_as("SELECT name, style, features FROM items ORDER BY seq")
            .fetch_all(&pool)
            .await
            .expect("items");
    pool.close().await;
    let columns: Vec<String> = learner::features::catalogue()
        .into_iter()
        .map(|f| f.name.to_string())
        .collect();
    let mut values = Vec::new();
    for r in &rows {
        let f: Vec<f64> = serde_json::from_str(&r.2).expect("features");
        values.extend(f);
    }
    let names: Vec<String> = rows.iter().map(|r| r.0.clone()).collect();
    let table = learner::table::FeatureTable::new(columns, names, values).expect("table");
    let weighting = learner::search::Weighting::uniform(&table);
    let matrix = learner::search::StyleMatrix::build(&table, &weighting).expect("matrix");
    let item_labels: HashMap<String, String> =
        rows.iter().map(|r| (r.0.clone(), r.1.clone())).collect();
    let keep: Vec<String> = labels.iter().map(|l| l.to_string()).collect();
    let library = learner::explore::StyleLibrary::from_matrix(
        &table,
        &matrix,
        Some(&item_labels),
        Some(&keep),
    )
    .expect("library");
    let params = learner::explore::TaxonomyParams {
        kappa,
        tau,
        ..Default::default()
    };
    let required: Vec<u32> = (0..labels.len() as u32).collect();
    let t = learner::explore::taxonomy(&library, &required, &params, &mut |_, _, _| {})
        .expect("taxonomy");
    t.representatives
        .iter()
        .map(|&r| {
            let node = &t.nodes[r];
            let mut members: Vec<String> = node
                .members
                .iter()
                .map(|&i| library.ids()[i].clone())
                .collect();
            members.sort();
            (library.ids()[node.representative].clone(), members)
        })
        .collect()
}

/// Polls the job until it is done or failed (at most 2 minutes).
pub(super) async fn wait_done(c: &reqwest::Client, base: &str, cookie: &str, id: i64) -> Value {
    for _ in 0..1200 {
        let (status, job) = send(
            c.get(format!("{base}/api/v1/admin/explore/jobs/{id}"))
                .header("cookie", cookie),
        )
        .await;
        assert_eq!(status, 200, "{job}");
        if job["status"] == "done" || job["status"] == "failed" {
            return job;
        }
        assert!(
            job["status"] == "queued" || job["status"] == "running",
            "{job}"
        );
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    panic!("job {id} did not end");
}

async fn explore_a_library(db: TestDb) {
    import(&db);
    let server = Server::start(&db.url);
    let base = server.base.clone();
    let c = client();
    let start_url = format!("{base}/api/v1/admin/explore/taxonomy");

    // Admins only.
    let (status, _) = send(c.post(&start_url).json(&json!({"library": "clipart"}))).await;
    assert_eq!(status, 401);
    let page = c
        .get(format!("{base}/admin/explore"))
        .send()
        .await
        .expect("page");
    assert_eq!(page.status().as_u16(), 303, "anonymous explore page");
    assert_eq!(page.headers()["location"], "/admin/login");
    let (cookie, csrf) = admin_login(&c, &base).await;
    let start = |body: Value| {
        let req = c
            .post(&start_url)
            .header("cookie", &cookie)
            .header("x-csrf-token", &csrf)
            .json(&body);
        async move { send(req).await }
    };

    // The page offers the labels with their counts.
    let html = admin_text(&c, &format!("{base}/admin/explore"), &cookie).await;
    for style in STYLES {
        assert!(
            html.contains(&format!(
                "value=\"{style}\"> {style} <span class=\"muted\">({PER_STYLE})"
            )),
            "{style} checkbox with its count"
        );
    }

    // Bad requests: clear 4xx answers, nothing stored.
    let cases = [
        (
            json!({"library": "clipart", "labels": ["noto", "dinosaur"]}),
            400,
            "dinosaur",
        ),
        (
            json!({"library": "clipart", "labels": ["noto"], "kappa": 12}),
            400,
            "prune every branch",
        ),
        (
            json!({"library": "clipart", "labels": ["noto", "twemoji"], "tau": 12}),
            400,
            "12 of them `noto`",
        ),
        (
            json!({"library": "clipart", "model": "12345"}),
            404,
            "model",
        ),
        (
            json!({"library": "clipart", "model": "newest"}),
            400,
            "model",
        ),
        (json!({"library": "nowhere"}), 404, "library"),
        (json!({"library": "clipart", "kappa": -1}), 400, ""),
        (
            json!({"library": "clipart", "colour": "red"}),
            400,
            "colour",
        ),
    ];
    for (body, want, message) in cases {
        let (status, answer) = start(body.clone()).await;
        assert_eq!(status, want, "{body} → {answer}");
        assert!(
            answer["error"]
                .as_str()
                .is_some_and(|e| e.contains(message)),
            "{body} → {answer}"
        );
    }
    let (status, _) = send(
        c.post(&start_url)
            .header("cookie", &cookie)
            .json(&json!({"library": "clipart"})),
    )
    .await;
    assert_eq!(status, 403, "no CSRF header");
    assert_eq!(
        scalar(&db.url, "SELECT COUNT(*) FROM explorations").await,
        0
    );

    // A job: queued, then done with its result stored.
    let good = json!({"library": "clipart", "model": "uniform", "labels": ["twemoji", "noto"], "kappa": 3, "tau": 1});
    let (status, started) = start(good.clone()).await;
    assert_eq!(status, 202, "{started}");
    assert_eq!(started["started"], true);
    let id = started["id"].as_i64().expect("id");
    let job = wait_done(&c, &base, &cookie, id).await;
    assert_eq!(job["status"], "done", "{job}");
    assert_eq!(
        job["params"],
        json!({"labels": ["noto", "twemoji"], "kappa": 3, "tau": 1})
    );
    assert_eq!(job["model"], Value::Null);
    assert_eq!(
        scalar(
            &db.url,
            "SELECT COUNT(*) FROM explorations WHERE status = 'done' AND result IS NOT NULL"
        )
        .await,
        1
    );
    let result = &job["result"];
    assert_eq!(result["items"], 2 * PER_STYLE);

    // The same as the learner's taxonomy on the stored features.
    let expected = reference(&db.url, &["noto", "twemoji"], 3, 1).await;
    let names: HashMap<i64, String> = {
        let pool = pool(&db.url).await;
        let rows: Vec<(i64, String)> = sqlx::query_as("SELECT id, name FROM items")
            .fetch_all(&pool)
            .await
            .expect("names");
        pool.close().await;
        rows.into_iter().collect()
    };
    let got: Vec<(String, Vec<String>)> = result["representatives"]
        .as_array()
        .expect("representatives")
        .iter()
        .map(|r| {
            let mut members: Vec<String> = r["members"]
                .as_array()
                .expect("members")
                .iter()
                .map(|m| names[&m.as_i64().expect("id")].clone())
                .collect();
            members.sort();
            assert_eq!(r["count"], members.len());
            assert_eq!(
                names[&r["id"].as_i64().expect("id")],
                r["name"].as_str().expect("name")
            );
            let per_label: u64 = r["labels"]
                .as_array()
                .expect("labels")
                .iter()
                .map(|l| l["count"].as_u64().expect("n"))
                .sum();
            assert_eq!(per_label as usize, members.len());
            (r["name"].as_str().expect("name").to_string(), members)
        })
        .collect();
    assert!(!got.is_empty());
    assert_eq!(got, expected);

    // Identical parameters reuse the stored job.
    let (status, again) = start(good.clone()).await;
    assert_eq!(status, 202);
    assert_eq!(again, json!({"id": id, "started": false}));
    assert_eq!(
        scalar(&db.url, "SELECT COUNT(*) FROM explorations").await,
        1
    );

    // A branch on the balanced grid: ⌊√n⌋² nodes, every member once, shown or hidden.
    let grid_url =
        |k: usize, q: &str| format!("{base}/api/v1/admin/explore/jobs/{id}/styles/{k}/grid{q}");
    let first = &result["representatives"][0];
    let n = first["count"].as_u64().expect("count") as usize;
    let (status, grid) = send(c.get(grid_url(0, "")).header("cookie", &cookie)).await;
    assert_eq!(status, 200, "{grid}");
    let side = (n as f64).sqrt().floor() as usize;
    assert_eq!(
        (grid["rows"].as_u64(), grid["cols"].as_u64()),
        (Some(side as u64), Some(side as u64))
    );
    let mut seen: Vec<i64> = Vec::new();
    for cell in grid["cells"].as_array().expect("cells") {
        seen.extend(cell["shown"].as_i64());
        seen.extend(
            cell["hidden"]
                .as_array()
                .expect("hidden")
                .iter()
                .map(|h| h.as_i64().expect("id")),
        );
    }
    seen.sort();
    let mut members: Vec<i64> = first["members"]
        .as_array()
        .expect("members")
        .iter()
        .map(|m| m.as_i64().expect("id"))
        .collect();
    members.sort();
    assert_eq!(seen, members, "every member once");
    let shown = grid["cells"]
        .as_array()
        .expect("cells")
        .iter()
        .filter(|c| c["shown"].is_i64())
        .count();
    assert_eq!(shown, side * side, "every node shows an item");
    for (q, want) in [
        (format!("?rows={n}&cols=2"), 400),
        ("?rows=2".to_string(), 400),
        ("?rows=0&cols=1".to_string(), 400),
    ] {
        let (status, body) = send(c.get(grid_url(0, &q)).header("cookie", &cookie)).await;
        assert_eq!(status, want, "{q}: {body}");
    }
    let (status, _) = send(c.get(grid_url(999, "")).header("cookie", &cookie)).await;
    assert_eq!(status, 404);
    let (status, _) = send(
        c.get(format!("{base}/api/v1/admin/explore/jobs/1"))
            .header("cookie", &cookie),
    )
    .await;
    assert_eq!(status, 404);

    // The pages: the representatives, and the grid with a pop-up per node that hides images.
    let page = admin_text(&c, &format!("{base}/admin/explore/jobs/{id}"), &cookie).await;
    assert!(
        page.contains("representative styles over 24 items"),
        "{page}"
    );
    assert_eq!(page.matches("class=\"style-link\"").count(), got.len());
    let page = admin_text(
        &c,
        &format!("{base}/admin/explore/jobs/{id}/styles/0?rows=2&cols=2"),
        &cookie,
    )
    .await;
    assert_eq!(
        page.matches("<dialog").count(),
        page.matches("has-hidden").count()
    );
    assert!(
        page.contains(&format!("{n} members on 2 × 2 nodes")),
        "{page}"
    );
    let resp = c
        .get(format!(
            "{base}/admin/explore/jobs/{id}/styles/0?rows=99&cols=99"
        ))
        .header("cookie", &cookie)
        .send()
        .await
        .expect("grid page");
    assert_eq!(resp.status().as_u16(), 400);

    // A job left running by a server that stopped: shown failed, and asking again restarts it.
    let pool = pool(&db.url).await;
    sqlx::query(
        "UPDATE explorations SET status = 'running', heartbeat_at = 0, result = NULL WHERE id = $1",
    )
    .bind(id)
    .execute(&pool)
    .await
    .expect("stale");
    pool.close().await;
    let (_, job) = send(
        c.get(format!("{base}/api/v1/admin/explore/jobs/{id}"))
            .header("cookie", &cookie),
    )
    .await;
    assert_eq!(job["status"], "failed", "{job}");
    assert!(
        job["error"].as_str().is_some_and(|e| e.contains("stopped")),
        "{job}"
    );
    let (status, restarted) = start(good.clone()).await;
    assert_eq!(status, 202);
    assert_eq!(restarted["started"], true);
    let new_id = restarted["id"].as_i64().expect("id");
    assert_ne!(new_id, id);
    let job = wait_done(&c, &base, &cookie, new_id).await;
    assert_eq!(job["result"]["representatives"], result["representatives"]);

    map::style_map(&db, &c, &base, &cookie, &csrf, id).await;
}
