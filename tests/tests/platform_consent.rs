//! Informed consent and the practice pool through the JSON API of the real server, on SQLite
//! and PostgreSQL: a study with a consent text starts nobody who has not agreed, records who
//! agreed to which version of the text and who declined (a declined worker gets the no-consent
//! hand-back and no HIT), and a failed practice attempt is followed by other practice triplets
//! with the right answers of the failed ones.

use e2e::both_databases;
use e2e::platform::*;
use serde_json::{Value, json};

const CONSENT: &str = "## Information\n\nYou compare pictures for about ten minutes.";

async fn consent_rows(db_url: &str) -> Vec<(String, String, Option<String>, Option<String>)> {
    sqlx::any::install_default_drivers();
    let pool = sqlx::AnyPool::connect(db_url).await.expect("connect");
    let rows: Vec<(String, String, Option<String>, Option<String>)> = sqlx::query_as(
        "SELECT w.external_id, a.status, a.consent, a.consent_version FROM assignments a \
         JOIN workers w ON w.id = a.worker_id ORDER BY w.external_id",
    )
    .fetch_all(&pool)
    .await
    .expect("assignments");
    pool.close().await;
    rows
}

async fn start(
    http: &reqwest::Client,
    server: &Server,
    study: i64,
    worker: &str,
    consent: Option<bool>,
) -> (u16, Value) {
    let mut req = json!({"source": "prolific", "worker_id": worker,
        "prolific_study_id": "S1", "prolific_session_id": format!("session-{worker}")});
    if let Some(c) = consent {
        req["consent"] = json!(c);
    }
    send(
        http.post(server.url(&format!("/api/v1/studies/{study}/start")))
            .json(&req),
    )
    .await
}

async fn consent_is_asked_and_recorded(db: TestDb) {
    let study = setup_study(
        &db,
        &StudyOpts {
            extra: json!({"consent": CONSENT, "prolific_noconsent_code": "NOCONSENT1"}),
            ..StudyOpts::default()
        },
    );
    let server = Server::start(&db.url);
    let http = client();

    // No answer to the consent form: refused, nothing stored.
    let (status, body) = start(&http, &server, study, "p-none", None).await;
    assert_eq!(status, 400, "{body}");
    assert!(
        body["error"].as_str().unwrap_or("").contains("consent"),
        "{body}"
    );
    assert!(consent_rows(&db.url).await.is_empty());

    // Agreed: started, with the version of the text agreed to.
    let (status, body) = start(&http, &server, study, "p-yes", Some(true)).await;
    assert_eq!(status, 200, "{body}");
    let token = body["token"].as_str().expect("token").to_string();
    let (_, st) = send(http.get(server.url(&format!("/api/v1/assignments/{token}")))).await;
    assert_eq!(st["status"], "training", "{st}");

    // Declined: an assignment without a HIT, sent back to Prolific with the no-consent code.
    let (status, body) = start(&http, &server, study, "p-no", Some(false)).await;
    assert_eq!(status, 200, "{body}");
    let declined = body["token"].as_str().expect("token").to_string();
    let (_, st) = send(http.get(server.url(&format!("/api/v1/assignments/{declined}")))).await;
    assert_eq!(st["status"], "declined", "{st}");
    assert_eq!(
        st["handback"]["url"], "https://app.prolific.com/submissions/complete?cc=NOCONSENT1",
        "{st}"
    );
    assert_eq!(st["total"], 0, "no HIT for a declined worker: {st}");
    // Declining again (a reload of the form) changes nothing; agreeing afterwards resumes the
    // recorded decision instead of starting a HIT.
    let (_, again) = start(&http, &server, study, "p-no", Some(true)).await;
    assert_eq!(again["resumed"], true, "{again}");

    let rows = consent_rows(&db.url).await;
    let version = rows
        .iter()
        .find(|r| r.0 == "p-yes")
        .and_then(|r| r.3.clone())
        .expect("a version for the agreed text");
    assert_eq!(version.len(), 12);
    assert_eq!(
        rows,
        vec![
            (
                "p-no".into(),
                "declined".into(),
                Some("declined".into()),
                Some(version.clone())
            ),
            (
                "p-yes".into(),
                "training".into(),
                Some("agreed".into()),
                Some(version.clone())
            ),
        ]
    );

    // The dashboard counts the declined worker; assignments.csv says who agreed to which text,
    // when (the ids of the export are the platform's: p-no, p-yes).
    let (cookie, _) = admin_login(&http, &server.base).await;
    let dashboard: Value = http
        .get(server.url(&format!("/api/v1/admin/studies/{study}/dashboard")))
        .header("cookie", &cookie)
        .send()
        .await
        .expect("dashboard")
        .json()
        .await
        .expect("json");
    assert_eq!(dashboard["declined"], 1, "{dashboard}");
    assert_eq!(dashboard["started"], 2, "{dashboard}");
    let csv = http
        .get(server.url(&format!(
            "/api/v1/admin/studies/{study}/export/assignments.csv?include_incomplete=true"
        )))
        .header("cookie", &cookie)
        .send()
        .await
        .expect("export")
        .text()
        .await
        .expect("csv");
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).expect(name);
    let mut consent: Vec<(String, String, String, bool)> = lines
        .map(|l| {
            let cells: Vec<&str> = l.split(',').collect();
            (
                cells[col("worker_id")].to_string(),
                cells[col("consent")].to_string(),
                cells[col("consent_version")].to_string(),
                cells[col("consent_at_utc")].ends_with('Z'),
            )
        })
        .collect();
    consent.sort();
    assert_eq!(
        consent,
        vec![
            ("p-no".into(), "declined".into(), version.clone(), true),
            ("p-yes".into(), "agreed".into(), version.clone(), true),
        ],
        "{csv}"
    );

    // The HTML start page shows the consent form with a required box, and the decline button.
    let page = http
        .get(server.url(&format!("/s/{study}?participant=html-1")))
        .send()
        .await
        .expect("start page")
        .text()
        .await
        .expect("html");
    assert!(
        page.contains("id=\"consent-agree\" required")
            || page.contains("required id=\"consent-agree\""),
        "{page}"
    );
    assert!(page.contains("<h2>Information</h2>"), "{page}");
    assert!(page.contains("id=\"decline\""), "{page}");
}

both_databases!(
    consent_is_asked_and_recorded,
    consent_is_asked_and_recorded_sqlite,
    consent_is_asked_and_recorded_postgres
);

async fn practice_retries_show_answers_and_other_triplets(db: TestDb) {
    let study = setup_study(&db, &StudyOpts::default());
    let server = Server::start(&db.url);
    let http = client();
    let styles = item_styles(&db.url).await;
    let token = start_worker(&http, &server.base, study, "practice-1").await;
    let (_, st) = send(http.get(server.url(&format!("/api/v1/assignments/{token}")))).await;
    let first = st["training"].clone();
    let wrong: Vec<Value> = first
        .as_array()
        .expect("practice questions")
        .iter()
        .map(|q| {
            let right = choose(q, &styles, Behaviour::Honest);
            let other = if q["left"]["id"] == right {
                &q["right"]["id"]
            } else {
                &q["left"]["id"]
            };
            json!({"position": q["position"], "choice": other})
        })
        .collect();
    let (status, result) = send(
        http.post(server.url(&format!("/api/v1/assignments/{token}/training")))
            .json(&json!({"answers": wrong})),
    )
    .await;
    assert_eq!(status, 200, "{result}");
    assert_eq!(result["passed"], false, "{result}");
    let (_, st) = send(http.get(server.url(&format!("/api/v1/assignments/{token}")))).await;
    let review = st["last_training_attempt"]
        .as_array()
        .expect("review")
        .clone();
    assert_eq!(review.len(), first.as_array().map_or(0, Vec::len), "{st}");
    for (r, q) in review.iter().zip(first.as_array().expect("questions")) {
        assert_eq!(r["question"]["reference"], q["reference"], "{r}");
        assert_eq!(r["correct"], false, "{r}");
        assert_eq!(
            r["expected"],
            json!(choose(q, &styles, Behaviour::Honest)),
            "{r}"
        );
    }
    let ids = |qs: &Value| -> Vec<Value> {
        qs.as_array()
            .expect("questions")
            .iter()
            .map(|q| json!([q["reference"]["id"], q["left"]["id"], q["right"]["id"]]))
            .collect()
    };
    assert_ne!(
        ids(&st["training"]),
        ids(&first),
        "a retry draws other practice triplets"
    );
    let st = pass_training(&http, &server.base, &token, &styles, Behaviour::Honest).await;
    assert_eq!(st["status"], "active", "{st}");
}

both_databases!(
    practice_retries_show_answers_and_other_triplets,
    practice_retries_show_answers_and_other_triplets_sqlite,
    practice_retries_show_answers_and_other_triplets_postgres
);
