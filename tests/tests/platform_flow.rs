//! The worker flow, quality control, exports and replication over real HTTP against the real
//! `platform` binary, on SQLite and on PostgreSQL (`TEST_POSTGRES_URL`).

use std::collections::{HashMap, HashSet};

use e2e::both_databases;
use e2e::platform::*;
use serde_json::{Value, json};

/// Every question object a worker receives has exactly the same four keys, so a hidden control
/// cannot be told apart; no `expected` answer appears outside training feedback.
fn assert_no_control_leak(v: &Value) {
    match v {
        Value::Object(m) => {
            assert!(!m.contains_key("expected"), "expected answer leaked: {v}");
            for key in ["kind", "tuple_id", "slot_id", "control"] {
                if key == "kind" {
                    // `kind` only tags handback / start outcome variants.
                    if let Some(k) = m.get("kind") {
                        assert!(
                            ["mturk_form", "redirect", "code", "started", "preview"]
                                .contains(&k.as_str().unwrap_or("")),
                            "unexpected kind {k}"
                        );
                    }
                    continue;
                }
                assert!(!m.contains_key(key), "{key} leaked: {v}");
            }
            if m.contains_key("reference") {
                let mut keys: Vec<&str> = m.keys().map(String::as_str).collect();
                keys.sort_unstable();
                assert_eq!(keys, ["left", "position", "reference", "right"]);
            }
            m.values().for_each(assert_no_control_leak);
        }
        Value::Array(a) => a.iter().for_each(assert_no_control_leak),
        Value::String(s) => assert!(!s.contains("control"), "'control' in {s}"),
        _ => {}
    }
}

async fn worker_flow(db: TestDb) {
    let study = setup_study(&db, &StudyOpts::default());
    let server = Server::start(&db.url);
    let styles = item_styles(&db.url).await;
    let c = client();
    let base = &server.base;

    let token = start_worker(&c, base, study, "worker-1").await;
    let (_, again) = send(
        c.post(format!("{base}/api/v1/studies/{study}/start"))
            .json(&json!({"source": "direct", "worker_id": "worker-1"})),
    )
    .await;
    assert_eq!(again["token"], token.as_str(), "a second start resumes");
    assert_eq!(again["resumed"], true);

    // Training: a wrong attempt gets feedback and another try.
    let (_, st) = send(c.get(format!("{base}/api/v1/assignments/{token}"))).await;
    assert_eq!(st["status"], "training");
    assert_no_control_leak(&st);
    let training = st["training"].as_array().expect("training").clone();
    assert_eq!(training.len(), 2);
    let wrong: Vec<Value> = training
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
        c.post(format!("{base}/api/v1/assignments/{token}/training"))
            .json(&json!({"answers": wrong})),
    )
    .await;
    assert_eq!(status, 200, "{result}");
    assert_eq!(result["passed"], false);
    assert_eq!(result["attempts"], 1);
    assert!(
        result["feedback"]
            .as_array()
            .expect("feedback")
            .iter()
            .all(|f| f["correct"] == false)
    );
    let st = pass_training(&c, base, &token, &styles, Behaviour::Honest).await;
    assert_eq!(st["status"], "active", "{st}");
    assert_eq!(st["total"], 12);
    assert_eq!(st["training_attempts"], 2);

    // Answer five, reload: resume at the next unanswered question.
    let mut answered = Vec::new();
    for _ in 0..5 {
        let (_, st) = send(c.get(format!("{base}/api/v1/assignments/{token}"))).await;
        assert_no_control_leak(&st);
        let q = st["question"].clone();
        let choice = choose(&q, &styles, Behaviour::Honest);
        let (status, ack) = send(
            c.post(format!("{base}/api/v1/assignments/{token}/answers"))
                .json(&json!({"position": q["position"], "choice": choice})),
        )
        .await;
        assert_eq!(status, 200, "{ack}");
        assert_no_control_leak(&ack);
        assert_eq!(ack["duplicate"], false);
        answered.push((q.clone(), choice));
    }
    let (_, st) = send(c.get(format!("{base}/api/v1/assignments/{token}"))).await;
    assert_eq!(st["answered"], 5);
    let answered_positions: HashSet<i64> = answered
        .iter()
        .map(|(q, _)| q["position"].as_i64().expect("position"))
        .collect();
    assert!(!answered_positions.contains(&st["question"]["position"].as_i64().expect("next")));

    // Idempotent: the same answer again is a duplicate; a different one a conflict.
    let (q, choice) = &answered[0];
    let (status, ack) = send(
        c.post(format!("{base}/api/v1/assignments/{token}/answers"))
            .json(&json!({"position": q["position"], "choice": choice})),
    )
    .await;
    assert_eq!((status, ack["duplicate"].clone()), (200, json!(true)));
    let other = if q["left"]["id"] == *choice {
        &q["right"]["id"]
    } else {
        &q["left"]["id"]
    };
    let (status, _) = send(
        c.post(format!("{base}/api/v1/assignments/{token}/answers"))
            .json(&json!({"position": q["position"], "choice": other})),
    )
    .await;
    assert_eq!(status, 409);
    // An item that is not an option is refused.
    let (status, _) = send(
        c.post(format!("{base}/api/v1/assignments/{token}/answers"))
            .json(&json!({"position": st["question"]["position"], "choice": 1})),
    )
    .await;
    assert_eq!(status, 400);

    let done = answer_all(&c, base, &token, &styles, Behaviour::Honest).await;
    assert_eq!(done["status"], "completed", "{done}");
    assert_no_control_leak(&done);
    let code = done["completion_code"].as_str().expect("completion code");
    assert_eq!(code.len(), 12);
    assert_eq!(done["handback"]["kind"], "code");

    // The requester can check a submitted code; a made-up one is not valid.
    let (cookie, csrf) = admin_login(&c, base).await;
    for (given, valid) in [(code, true), ("ABCDEF123456", false)] {
        let (status, check) = send(
            c.get(format!("{base}/api/v1/admin/studies/{study}/codes/{given}"))
                .header("cookie", &cookie),
        )
        .await;
        assert_eq!(
            (status, check["valid"].clone()),
            (200, json!(valid)),
            "{check}"
        );
    }

    // Exports through the admin API and the CLI.
    let resp = c
        .get(format!(
            "{base}/api/v1/admin/studies/{study}/export/triplets.csv"
        ))
        .header("cookie", &cookie)
        .send()
        .await
        .expect("export");
    assert_eq!(resp.status().as_u16(), 200);
    let csv = resp.text().await.expect("csv");
    let mut lines = csv.lines();
    assert_eq!(lines.next(), Some("a,b,c,q,worker,tuple_id,worker_id"));
    let rows: Vec<&str> = lines.collect();
    assert_eq!(rows.len(), 9, "12 questions minus 3 controls:\n{csv}");
    for row in &rows {
        let cols: Vec<&str> = row.split(',').collect();
        assert_eq!(cols.len(), 7);
        assert!(
            cols[0].ends_with(".svg") && cols[1].ends_with(".svg") && cols[2].ends_with(".svg")
        );
        assert!(cols[3] == "0" || cols[3] == "1");
        // The worker by the id of the study link (`participant`), as the study page shows it.
        assert_eq!((cols[4], cols[6]), ("worker-1", "worker-1"));
    }
    // Curated controls by item name (unknown names are a clear 400).
    let first: Vec<&str> = rows[0].split(',').collect();
    let (status, body) = send(
        c.post(format!("{base}/api/v1/admin/studies/{study}/curated"))
            .header("cookie", &cookie)
            .header("x-csrf-token", &csrf)
            .json(&json!({"kind": "control", "a": first[0], "b": first[1], "c": first[2]})),
    )
    .await;
    assert_eq!(status, 200, "{body}");
    let (status, body) = send(
        c.post(format!("{base}/api/v1/admin/studies/{study}/curated"))
            .header("cookie", &cookie)
            .header("x-csrf-token", &csrf)
            .json(&json!({"kind": "control", "a": "nope.svg", "b": first[1], "c": first[2]})),
    )
    .await;
    assert_eq!(status, 400, "{body}");
    let dir = tempfile::tempdir().expect("tmp");
    let out = dir.path().to_string_lossy().into_owned();
    platform_ok(
        &[
            "export",
            &study.to_string(),
            "--database-url",
            &db.url,
            "--out",
            &out,
        ],
        &[],
    );
    let cli_csv = std::fs::read_to_string(dir.path().join("triplets.csv")).expect("triplets.csv");
    assert_eq!(cli_csv, csv, "CLI and API exports agree");
    let manifest: Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("manifest.json")).expect("manifest"),
    )
    .expect("manifest json");
    assert_eq!(manifest["items"].as_array().map(Vec::len), Some(24));
    assert!(manifest["columns"]["triplets.csv"]["q"].is_string());
    for f in [
        "reasons.csv",
        "workers.csv",
        "assignments.csv",
        "mturk_decisions.csv",
        "external_question.xml",
    ] {
        assert!(dir.path().join(f).exists(), "{f} missing");
    }
    // An abandoned assignment expires: its unanswered slots are freed, further answers refused.
    let token2 = start_worker(&c, base, study, "worker-2").await;
    pass_training(&c, base, &token2, &styles, Behaviour::Honest).await;
    let (_, st2) = send(c.get(format!("{base}/api/v1/assignments/{token2}"))).await;
    let q2 = st2["question"].clone();
    let choice2 = choose(&q2, &styles, Behaviour::Honest);
    let (status, _) = send(
        c.post(format!("{base}/api/v1/assignments/{token2}/answers"))
            .json(&json!({"position": q2["position"], "choice": choice2})),
    )
    .await;
    assert_eq!(status, 200);
    let (status, released) = send(
        c.post(format!(
            "{base}/api/v1/admin/studies/{study}/release-abandoned"
        ))
        .header("cookie", &cookie)
        .header("x-csrf-token", &csrf)
        .json(&json!({"older_than_minutes": 0})),
    )
    .await;
    assert_eq!(
        (status, released["released"].clone()),
        (200, json!(1)),
        "{released}"
    );
    let (_, st2) = send(c.get(format!("{base}/api/v1/assignments/{token2}"))).await;
    assert_eq!(st2["status"], "abandoned");
    assert!(
        st2["question"].is_null(),
        "an expired assignment offers no question"
    );
    let claimed = scalar(
        &db.url,
        "SELECT CAST(COUNT(*) AS BIGINT) FROM slots WHERE assignment_id IS NOT NULL",
    )
    .await;
    let held = scalar(
        &db.url,
        "SELECT CAST(COUNT(*) AS BIGINT) FROM questions WHERE slot_id IS NOT NULL",
    )
    .await;
    assert_eq!(claimed, held);
    assert!(
        (9..=10).contains(&claimed),
        "worker-1's 9 + at most 1 answered by worker-2: {claimed}"
    );
    let (status, _) = send(
        c.post(format!("{base}/api/v1/assignments/{token2}/answers"))
            .json(&json!({"position": q2["position"], "choice": choice2})),
    )
    .await;
    assert_eq!(status, 409, "no answers after expiry");

    let status = platform_ok(
        &[
            "study",
            "status",
            &study.to_string(),
            "--database-url",
            &db.url,
        ],
        &[],
    );
    let status: Value = serde_json::from_str(&status).expect("status json");
    assert_eq!(status["completed"], 1);
    assert_eq!(status["approved"], 1);
}
both_databases!(worker_flow, worker_flow_sqlite, worker_flow_postgres);

async fn quality_control(db: TestDb) {
    // 20 hidden controls per HIT: a random clicker passes the ≥ 2-errors rule with
    // probability (1 + 20) / 2²⁰ ≈ 2·10⁻⁵ (with 12 it was 13 / 2¹² ≈ 0.3% per spammer, and a
    // CI run of both backends with three spammers each failed about once in 50).
    let opts = StudyOpts {
        questions: 24,
        controls: 20,
        tuples: 400,
        ..StudyOpts::default()
    };
    let study = setup_study(&db, &opts);
    let server = Server::start(&db.url);
    let styles = item_styles(&db.url).await;
    let base = server.base.clone();
    let mut tasks = Vec::new();
    for i in 0..9 {
        let (base, styles) = (base.clone(), styles.clone());
        tasks.push(tokio::spawn(async move {
            let c = client();
            let who = if i % 3 == 2 {
                Behaviour::Spammer
            } else {
                Behaviour::Honest
            };
            let token = start_worker(&c, &base, study, &format!("qc-{i}")).await;
            // Spammers that got through the training (they retry with the feedback).
            pass_training(&c, &base, &token, &styles, Behaviour::Honest).await;
            let done = answer_all(&c, &base, &token, &styles, who).await;
            assert_eq!(done["status"], "completed");
            (token, who)
        }));
    }
    let mut results = Vec::new();
    for t in tasks {
        results.push(t.await.expect("worker task"));
    }
    let c = client();
    let (cookie, csrf) = admin_login(&c, &base).await;
    let (status, workers) = send(
        c.get(format!("{base}/api/v1/admin/studies/{study}/workers"))
            .header("cookie", &cookie),
    )
    .await;
    assert_eq!(status, 200);
    let workers = workers.as_array().expect("workers").clone();
    assert_eq!(workers.len(), 9);
    let honest = workers
        .iter()
        .filter(|w| w["decision"] == "approved")
        .count();
    let rejected: Vec<&Value> = workers
        .iter()
        .filter(|w| w["decision"] == "rejected")
        .collect();
    assert_eq!(
        (honest, rejected.len()),
        (6, 3),
        "spammers rejected, honest kept: {workers:?}"
    );
    for w in &rejected {
        assert!(w["control_errors"].as_i64().expect("errors") >= 2);
    }

    // Dry run with a threshold above the number of controls: would approve the spammers,
    // changes nothing.
    let (status, dry) = send(
        c.post(format!("{base}/api/v1/admin/studies/{study}/qc"))
            .header("cookie", &cookie)
            .header("x-csrf-token", &csrf)
            .json(&json!({"threshold": opts.controls + 1, "dry_run": true})),
    )
    .await;
    assert_eq!(status, 200, "{dry}");
    assert_eq!(
        dry.as_array()
            .expect("outcomes")
            .iter()
            .filter(|o| o["changes"] == true)
            .count(),
        3
    );
    let (_, dash) = send(
        c.get(format!("{base}/api/v1/admin/studies/{study}/dashboard"))
            .header("cookie", &cookie),
    )
    .await;
    assert_eq!(dash["rejected"], 3, "dry run must not change decisions");
    assert!((dash["rejection_rate"].as_f64().expect("rate") - 1.0 / 3.0).abs() < 1e-9);

    // Override one spammer; the audit trail records who did it.
    let target = rejected[0]["assignment"].as_i64().expect("assignment");
    let (status, _) = send(
        c.post(format!(
            "{base}/api/v1/admin/studies/{study}/assignments/{target}/decision"
        ))
        .header("cookie", &cookie)
        .header("x-csrf-token", &csrf)
        .json(&json!({"decision": "approved"})),
    )
    .await;
    assert_eq!(status, 200);
    // Re-applying the rule keeps the override.
    let (status, _) = send(
        c.post(format!("{base}/api/v1/admin/studies/{study}/qc"))
            .header("cookie", &cookie)
            .header("x-csrf-token", &csrf)
            .json(&json!({"dry_run": false})),
    )
    .await;
    assert_eq!(status, 200);
    let (_, audit) = send(
        c.get(format!("{base}/api/v1/admin/studies/{study}/audit"))
            .header("cookie", &cookie),
    )
    .await;
    let audit = audit.as_array().expect("audit").clone();
    assert_eq!(audit.len(), 10, "9 rule decisions + 1 override: {audit:?}");
    assert!(
        audit
            .iter()
            .any(|d| d["actor"] == "admin:admin" && d["rule"] == "override")
    );
    assert!(
        audit
            .iter()
            .filter(|d| d["actor"] == "rule")
            .all(|d| d["rule"] == "control_errors>=2")
    );

    // Rejected HITs are excluded from triplets.csv (24 − 20 = 4 main questions per HIT).
    let csv = c
        .get(format!(
            "{base}/api/v1/admin/studies/{study}/export/triplets.csv"
        ))
        .header("cookie", &cookie)
        .send()
        .await
        .expect("export")
        .text()
        .await
        .expect("csv");
    let main_questions = (opts.questions - opts.controls) as usize;
    assert_eq!(csv.lines().count() - 1, 7 * main_questions);
    let with_rejected = c
        .get(format!(
            "{base}/api/v1/admin/studies/{study}/export/triplets.csv?include_rejected=true&include_controls=true"
        ))
        .header("cookie", &cookie)
        .send()
        .await
        .expect("export")
        .text()
        .await
        .expect("csv");
    assert_eq!(with_rejected.lines().count() - 1, 9 * 24);
}
both_databases!(
    quality_control,
    quality_control_sqlite,
    quality_control_postgres
);

async fn replication(db: TestDb) {
    let opts = StudyOpts {
        questions: 8,
        controls: 0,
        tuples: 15,
        replication: 3,
        ..StudyOpts::default()
    };
    let study = setup_study(&db, &opts);
    // Main tuples are numbered in seq order (a HIT claims consecutive seqs, so its claims share
    // index pages).
    let offsets = scalar(
        &db.url,
        "SELECT CAST(COUNT(DISTINCT id - seq) AS BIGINT) FROM tuples WHERE kind = 'main'",
    )
    .await;
    assert_eq!(offsets, 1, "main tuple ids are consecutive in seq order");
    let server = Server::start(&db.url);
    let styles = item_styles(&db.url).await;
    let base = server.base.clone();
    let mut tasks = Vec::new();
    for i in 0..10 {
        let (base, styles) = (base.clone(), styles.clone());
        tasks.push(tokio::spawn(async move {
            let c = client();
            let token = start_worker(&c, &base, study, &format!("rep-{i}")).await;
            let st = pass_training_allowing_full(&c, &base, &token, &styles).await;
            if st["status"] == "active" {
                answer_all(&c, &base, &token, &styles, Behaviour::Honest).await;
            }
        }));
    }
    for t in tasks {
        t.await.expect("worker task");
    }
    // Demand (10 x 8) exceeds supply (15 x 3): every slot is claimed at most once, by distinct
    // workers per tuple, and nearly all are filled.
    let claimed = scalar(
        &db.url,
        "SELECT CAST(COUNT(*) AS BIGINT) FROM slots WHERE assignment_id IS NOT NULL",
    )
    .await;
    let distinct_pairs = scalar(
        &db.url,
        "SELECT CAST(COUNT(*) AS BIGINT) FROM (SELECT DISTINCT tuple_id, worker_id FROM slots WHERE worker_id IS NOT NULL) x",
    )
    .await;
    let questions = scalar(
        &db.url,
        "SELECT CAST(COUNT(*) AS BIGINT) FROM questions WHERE slot_id IS NOT NULL",
    )
    .await;
    let distinct_slots = scalar(
        &db.url,
        "SELECT CAST(COUNT(DISTINCT slot_id) AS BIGINT) FROM questions",
    )
    .await;
    let over = scalar(
        &db.url,
        "SELECT CAST(COUNT(*) AS BIGINT) FROM (SELECT tuple_id FROM slots WHERE assignment_id IS NOT NULL GROUP BY tuple_id HAVING COUNT(*) > 3) x",
    )
    .await;
    assert_eq!(over, 0, "no tuple answered by more than R workers");
    assert_eq!(claimed, distinct_pairs, "a worker holds one slot per tuple");
    assert_eq!(questions, claimed);
    assert_eq!(distinct_slots, claimed, "a slot is in one question only");
    assert!((40..=45).contains(&claimed), "claimed {claimed} of 45");
    let answers = scalar(
        &db.url,
        "SELECT CAST(COUNT(*) AS BIGINT) FROM questions WHERE choice IS NOT NULL",
    )
    .await;
    assert_eq!(answers, claimed, "every claimed slot answered exactly once");

    let c = client();
    let (cookie, _) = admin_login(&c, &base).await;
    let (_, dash) = send(
        c.get(format!("{base}/api/v1/admin/studies/{study}/dashboard"))
            .header("cookie", &cookie),
    )
    .await;
    assert!(
        dash["replicated_tuples"].as_i64().expect("replicated") >= 10,
        "{dash}"
    );
    assert!(dash["noise_ceiling"].as_f64().is_some());
    let csv = c
        .get(format!(
            "{base}/api/v1/admin/studies/{study}/export/triplets.csv"
        ))
        .header("cookie", &cookie)
        .send()
        .await
        .expect("export")
        .text()
        .await
        .expect("csv");
    let mut per_tuple: HashMap<String, HashSet<String>> = HashMap::new();
    for line in csv.lines().skip(1) {
        let cols: Vec<&str> = line.split(',').collect();
        assert!(
            per_tuple
                .entry(cols[5].into())
                .or_default()
                .insert(cols[4].into())
        );
    }
    assert!(per_tuple.values().all(|w| w.len() <= 3));
}
both_databases!(replication, replication_sqlite, replication_postgres);

/// Like `pass_training`, but a full study (409 "no more questions") is an acceptable outcome.
async fn pass_training_allowing_full(
    c: &reqwest::Client,
    base: &str,
    token: &str,
    styles: &HashMap<i64, String>,
) -> Value {
    let (_, st) = send(c.get(format!("{base}/api/v1/assignments/{token}"))).await;
    let answers: Vec<Value> = st["training"]
        .as_array()
        .expect("training")
        .iter()
        .map(|q| json!({"position": q["position"], "choice": choose(q, styles, Behaviour::Honest)}))
        .collect();
    let (status, body) = send(
        c.post(format!("{base}/api/v1/assignments/{token}/training"))
            .json(&json!({"answers": answers})),
    )
    .await;
    assert!(status == 200 || status == 409, "{status} {body}");
    send(c.get(format!("{base}/api/v1/assignments/{token}")))
        .await
        .1
}

/// Every (position, right choice) of the HIT behind `token`, read from the database (the test
/// plays a worker who answers all questions at once).
async fn hit_answers(db_url: &str, token: &str) -> Vec<(i64, i64)> {
    sqlx::any::install_default_drivers();
    let pool = sqlx::AnyPool::connect(db_url).await.expect("connect");
    let rows: Vec<(i64, i64)> = sqlx::query_as(
        "SELECT q.position, t.b FROM questions q JOIN tuples t ON t.id = q.tuple_id \
         JOIN assignments a ON a.id = q.assignment_id WHERE a.token = $1 ORDER BY q.position",
    )
    .bind(token)
    .fetch_all(&pool)
    .await
    .expect("questions");
    pool.close().await;
    rows
}

/// Sends all `answers` concurrently; returns each (status, ack).
async fn answer_concurrently(
    c: &reqwest::Client,
    base: &str,
    token: &str,
    answers: &[(i64, i64)],
) -> Vec<(u16, Value)> {
    let sends: Vec<_> = answers
        .iter()
        .map(|&(position, choice)| {
            let req = c
                .post(format!("{base}/api/v1/assignments/{token}/answers"))
                .json(&json!({"position": position, "choice": choice}));
            tokio::spawn(send(req))
        })
        .collect();
    let mut acks = Vec::new();
    for s in sends {
        acks.push(s.await.expect("join"));
    }
    acks
}

/// A study without training: `start` creates the assignment and its HIT in one transaction;
/// all answers sent at once (so they share group commits) complete the HIT exactly once, every
/// ack saying where to go next; re-sending them is acknowledged as duplicates, a different
/// choice is refused; a full study refuses a start without leaving an assignment behind.
async fn concurrent_answers(db: TestDb) {
    let opts = StudyOpts {
        tuples: 20,
        extra: json!({"training_questions": 0}),
        ..StudyOpts::default()
    };
    let study = setup_study(&db, &opts);
    let server = Server::start(&db.url);
    let c = client();
    let base = &server.base;

    let token = start_worker(&c, base, study, "w-concurrent").await;
    let (_, st) = send(c.get(format!("{base}/api/v1/assignments/{token}"))).await;
    assert_eq!(
        st["status"], "active",
        "no training: the HIT is allocated at start: {st}"
    );
    assert_eq!(st["total"], 12);
    let answers = hit_answers(&db.url, &token).await;
    assert_eq!(answers.len(), 12);

    let acks = answer_concurrently(&c, base, &token, &answers).await;
    for (status, ack) in &acks {
        assert_eq!(*status, 200, "{ack}");
        assert_eq!(ack["duplicate"], false, "{ack}");
        assert_no_control_leak(ack);
        // An ack that is not the last one points at a question that was open when it was
        // written, never at its own.
        if ack["completed"] == false {
            assert!(ack["next_position"].is_i64(), "{ack}");
        }
    }
    let finished = acks.iter().filter(|(_, a)| a["completed"] == true).count();
    assert!(finished >= 1, "no ack completed the HIT: {acks:?}");
    let (_, st) = send(c.get(format!("{base}/api/v1/assignments/{token}"))).await;
    assert_eq!(st["status"], "completed", "{st}");
    assert_eq!(st["answered"], 12);
    assert!(st["completion_code"].is_string(), "{st}");
    let decisions = scalar(&db.url, "SELECT CAST(COUNT(*) AS BIGINT) FROM decisions").await;
    assert_eq!(decisions, 1, "the control rule ran exactly once");

    for (status, ack) in answer_concurrently(&c, base, &token, &answers).await {
        assert_eq!(status, 200, "{ack}");
        assert_eq!(ack["duplicate"], true, "{ack}");
        assert_eq!(ack["completed"], true, "{ack}");
    }
    let (position, b) = answers[0];
    let (status, body) = send(
        c.post(format!("{base}/api/v1/assignments/{token}/answers"))
            .json(&json!({"position": position, "choice": b + 1_000_000})),
    )
    .await;
    assert_eq!(status, 400, "not one of the options: {body}");

    // 20 tuples, 9 per HIT: the second HIT takes 9, the third the last 2, the fourth finds
    // the study full.
    start_worker(&c, base, study, "w-second").await;
    start_worker(&c, base, study, "w-third").await;
    let before = scalar(&db.url, "SELECT CAST(COUNT(*) AS BIGINT) FROM assignments").await;
    let (status, body) = send(
        c.post(format!("{base}/api/v1/studies/{study}/start"))
            .json(&json!({"source": "direct", "worker_id": "w-fourth"})),
    )
    .await;
    assert_eq!(status, 409, "{body}");
    let after = scalar(&db.url, "SELECT CAST(COUNT(*) AS BIGINT) FROM assignments").await;
    assert_eq!(before, after, "a refused start leaves no assignment");
}
both_databases!(
    concurrent_answers,
    concurrent_answers_sqlite,
    concurrent_answers_postgres
);
