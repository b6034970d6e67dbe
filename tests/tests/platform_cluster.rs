//! No state that correctness depends on lives in process memory: two servers share one
//! PostgreSQL, and a server killed with SIGKILL under load loses no acknowledged answer.

use std::collections::{HashMap, HashSet};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use e2e::platform::*;
use serde_json::{Value, json};

/// Acknowledged answers: ((token, position), chosen item id).
type Acked = Arc<Mutex<Vec<((String, i64), i64)>>>;

/// (token, position) → chosen item id, for every answer stored in the database.
async fn stored_answers(db_url: &str) -> HashMap<(String, i64), i64> {
    sqlx::any::install_default_drivers();
    let pool = sqlx::AnyPool::connect(db_url).await.expect("connect");
    let rows: Vec<(String, i64, i64)> = sqlx::query_as(
        "SELECT a.token, q.position, CASE WHEN q.choice = 'b' THEN t.b ELSE t.c END \
         FROM questions q JOIN tuples t ON t.id = q.tuple_id JOIN assignments a ON a.id = q.assignment_id \
         WHERE q.choice IS NOT NULL",
    )
    .fetch_all(&pool)
    .await
    .expect("answers");
    pool.close().await;
    rows.into_iter().map(|(t, p, i)| ((t, p), i)).collect()
}

/// One worker answering until done or until the server stops answering; records every
/// acknowledged (non-duplicate) answer.
async fn worker_until_error(
    bases: Vec<String>,
    study: i64,
    name: String,
    styles: Arc<HashMap<i64, String>>,
    acked: Acked,
    count: Arc<AtomicUsize>,
) -> Option<String> {
    let c = client();
    let pick = |i: usize| bases[i % bases.len()].clone();
    let mut i = name.len();
    let (status, body) = send_opt(
        c.post(format!("{}/api/v1/studies/{study}/start", pick(i)))
            .json(&json!({"source": "direct", "worker_id": name})),
    )
    .await?;
    assert_eq!(status, 200, "{body}");
    let token = body["token"].as_str()?.to_string();
    i += 1;
    let (_, st) = send_opt(c.get(format!("{}/api/v1/assignments/{token}", pick(i)))).await?;
    let answers: Vec<Value> = st["training"]
        .as_array()?
        .iter()
        .map(
            |q| json!({"position": q["position"], "choice": choose(q, &styles, Behaviour::Honest)}),
        )
        .collect();
    i += 1;
    let (status, _) = send_opt(
        c.post(format!("{}/api/v1/assignments/{token}/training", pick(i)))
            .json(&json!({"answers": answers})),
    )
    .await?;
    if status != 200 {
        return Some(token);
    }
    loop {
        i += 1;
        let (status, st) =
            send_opt(c.get(format!("{}/api/v1/assignments/{token}", pick(i)))).await?;
        if status != 200 {
            return Some(token);
        }
        let Some(q) = st.get("question").filter(|q| !q.is_null()).cloned() else {
            return Some(token);
        };
        let choice = choose(&q, &styles, Behaviour::Honest);
        let position = q["position"].as_i64()?;
        i += 1;
        let (status, ack) = send_opt(
            c.post(format!("{}/api/v1/assignments/{token}/answers", pick(i)))
                .json(&json!({"position": position, "choice": choice})),
        )
        .await?;
        if status != 200 {
            return Some(token);
        }
        if ack["duplicate"] == false {
            acked
                .lock()
                .expect("lock")
                .push(((token.clone(), position), choice));
            count.fetch_add(1, Ordering::SeqCst);
        }
    }
}

/// Like `send`, but a connection failure is `None` instead of a panic.
async fn send_opt(req: reqwest::RequestBuilder) -> Option<(u16, Value)> {
    let resp = req.send().await.ok()?;
    let status = resp.status().as_u16();
    let text = resp.text().await.ok()?;
    Some((
        status,
        serde_json::from_str(&text).unwrap_or(Value::String(text)),
    ))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn two_servers_share_one_postgres() {
    let Some(db) = postgres_db().await else {
        return;
    };
    let study = setup_study(
        &db,
        &StudyOpts {
            questions: 10,
            controls: 2,
            tuples: 30,
            replication: 3,
            ..StudyOpts::default()
        },
    );
    let (s1, s2) = (Server::start(&db.url), Server::start(&db.url));
    let styles = Arc::new(item_styles(&db.url).await);
    let acked = Arc::new(Mutex::new(Vec::new()));
    let count = Arc::new(AtomicUsize::new(0));
    let mut tasks = Vec::new();
    for w in 0..14 {
        tasks.push(tokio::spawn(worker_until_error(
            vec![s1.base.clone(), s2.base.clone()],
            study,
            format!("cluster-{w}"),
            styles.clone(),
            acked.clone(),
            count.clone(),
        )));
    }
    for t in tasks {
        t.await.expect("worker");
    }
    let acked = acked.lock().expect("lock").clone();
    let stored = stored_answers(&db.url).await;
    assert_eq!(stored.len(), acked.len(), "no answer lost or duplicated");
    let keys: HashSet<&(String, i64)> = acked.iter().map(|(k, _)| k).collect();
    assert_eq!(
        keys.len(),
        acked.len(),
        "each position acknowledged once as new"
    );
    for (k, choice) in &acked {
        assert_eq!(stored.get(k), Some(choice), "{k:?}");
    }
    let over = scalar(
        &db.url,
        "SELECT CAST(COUNT(*) AS BIGINT) FROM (SELECT tuple_id FROM slots WHERE assignment_id IS NOT NULL GROUP BY tuple_id HAVING COUNT(*) > 3) x",
    )
    .await;
    assert_eq!(over, 0, "no replicated tuple over-filled");
    let claimed = scalar(
        &db.url,
        "SELECT CAST(COUNT(*) AS BIGINT) FROM slots WHERE assignment_id IS NOT NULL",
    )
    .await;
    let in_questions = scalar(
        &db.url,
        "SELECT CAST(COUNT(DISTINCT slot_id) AS BIGINT) FROM questions",
    )
    .await;
    assert_eq!(claimed, in_questions);
    assert!(
        claimed >= 80,
        "14 workers x 8 main questions > 90 slots; claimed {claimed}"
    );
}

async fn crash(db: TestDb) {
    let study = setup_study(
        &db,
        &StudyOpts {
            questions: 30,
            controls: 3,
            tuples: 400,
            ..StudyOpts::default()
        },
    );
    let server = Arc::new(Mutex::new(Server::start(&db.url)));
    let base = server.lock().expect("lock").base.clone();
    let styles = Arc::new(item_styles(&db.url).await);
    let acked = Arc::new(Mutex::new(Vec::new()));
    let count = Arc::new(AtomicUsize::new(0));
    let mut tasks = Vec::new();
    for w in 0..8 {
        tasks.push(tokio::spawn(worker_until_error(
            vec![base.clone()],
            study,
            format!("crash-{w}"),
            styles.clone(),
            acked.clone(),
            count.clone(),
        )));
    }
    // SIGKILL the server in the middle of the load.
    while count.load(Ordering::SeqCst) < 60 {
        tokio::time::sleep(std::time::Duration::from_millis(5)).await;
    }
    server.lock().expect("lock").kill9();
    let mut tokens = Vec::new();
    for t in tasks {
        if let Some(token) = t.await.expect("worker") {
            tokens.push(token);
        }
    }
    let acked = acked.lock().expect("lock").clone();
    assert!(acked.len() >= 60);
    let stored = stored_answers(&db.url).await;
    for (k, choice) in &acked {
        assert_eq!(
            stored.get(k),
            Some(choice),
            "acknowledged answer {k:?} lost in the crash"
        );
    }
    // Restart: every worker resumes at its next unanswered question and finishes.
    let restarted = Server::start(&db.url);
    let c = client();
    for token in tokens {
        let (_, st) = send(c.get(restarted.url(&format!("/api/v1/assignments/{token}")))).await;
        let answered = st["answered"].as_i64().unwrap_or(0) as usize;
        let mine = stored.keys().filter(|(t, _)| *t == token).count();
        assert_eq!(answered, mine, "resume sees exactly the stored answers");
        if st["status"] == "training" {
            pass_training(&c, &restarted.base, &token, &styles, Behaviour::Honest).await;
        }
        let done = answer_all(&c, &restarted.base, &token, &styles, Behaviour::Honest).await;
        assert_eq!(done["status"], "completed");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn kill_9_under_load_loses_no_acknowledged_answer_sqlite() {
    crash(sqlite_db()).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn kill_9_under_load_loses_no_acknowledged_answer_postgres() {
    if let Some(db) = postgres_db().await {
        crash(db).await;
    }
}
