//! The mash-up study (§5.7.3) over real HTTP against the real `platform` binary, on SQLite and
//! PostgreSQL: created with `platform study create --kind mashup`, one HIT per worker in each
//! condition (A: results by style to the canvas; B: the same matches in a seeded random order),
//! every search and piece logged and checked against what the server returned, bad events and
//! submissions refused, and the report equal to `learner::stats` on the stored positions.

use std::collections::{BTreeSet, HashMap};

use e2e::both_databases;
use e2e::platform::*;
use serde_json::{Value, json};

fn ids(list: &Value) -> Vec<i64> {
    list["results"]
        .as_array()
        .expect("results")
        .iter()
        .map(|r| r["id"].as_i64().expect("id"))
        .collect()
}

async fn rows(db_url: &str, sql: &'static str) -> Vec<sqlx::any::AnyRow> {
    sqlx::any::install_default_drivers();
    let pool = sqlx::AnyPool::connect(db_url).await.expect("connect");
    let rows = sqlx::query(sql).fetch_all(&pool).await.expect(sql);
    pool.close().await;
    rows
}

/// The condition of each assignment token, as stored.
async fn conditions(db_url: &str) -> HashMap<String, String> {
    use sqlx::Row;
    rows(
        db_url,
        "SELECT a.token, c.condition FROM mashup_conditions c \
         JOIN assignments a ON a.id = c.assignment_id",
    )
    .await
    .iter()
    .map(|r| (r.get("token"), r.get("condition")))
    .collect()
}

/// Per token, the stored adds as (search_seq, item, position), and the stored result lists.
async fn stored_log(
    db_url: &str,
) -> (
    HashMap<String, Vec<(i64, i64, i64)>>,
    HashMap<(String, i64), Vec<i64>>,
) {
    use sqlx::Row;
    let mut adds: HashMap<String, Vec<(i64, i64, i64)>> = HashMap::new();
    for r in rows(
        db_url,
        "SELECT a.token, e.search_seq, e.item_id, e.position FROM mashup_events e \
         JOIN assignments a ON a.id = e.assignment_id WHERE e.event = 'add' ORDER BY e.seq",
    )
    .await
    {
        adds.entry(r.get("token")).or_default().push((
            r.get("search_seq"),
            r.get("item_id"),
            r.get("position"),
        ));
    }
    let mut lists = HashMap::new();
    for r in rows(
        db_url,
        "SELECT a.token, s.seq, s.results FROM mashup_searches s \
         JOIN assignments a ON a.id = s.assignment_id",
    )
    .await
    {
        let list: Vec<i64> =
            serde_json::from_str(&r.get::<String, _>("results")).expect("results json");
        lists.insert((r.get("token"), r.get("seq")), list);
    }
    (adds, lists)
}

fn composition(items: &[i64], background: &str) -> Value {
    let pieces: Vec<Value> = items
        .iter()
        .enumerate()
        .map(|(i, id)| json!({"item": id, "x": 100 + 80 * i, "y": 300, "scale": 1.0, "rotation": 0.0}))
        .collect();
    json!({"document": {"version": 1, "width": 800, "height": 600, "background": background,
                        "pieces": pieces}})
}

async fn mashup_study(db: TestDb) {
    let lib = small_library(6);
    import_library(&db, lib.path());
    let create = |extra: &[&str]| {
        let mut args = vec![
            "study",
            "create",
            "--database-url",
            &db.url,
            "--name",
            "farm",
            "--library",
            "fx",
        ];
        args.extend_from_slice(extra);
        platform_cmd(&args, &[])
    };
    // Bad creations: a clear message, no study.
    for (extra, needle) in [
        (&["--kind", "mashup"][..], "--task"),
        (
            &["--kind", "mashup", "--task", "x", "--background", "moon"][..],
            "background",
        ),
        (
            &["--kind", "mashup", "--task", "x", "--min-pieces", "0"][..],
            "min_pieces",
        ),
        (&["--kind", "mashup", "--task", "  "][..], "task"),
        (
            &[
                "--kind",
                "mashup",
                "--task",
                "x",
                "--questions-per-hit",
                "3",
            ][..],
            "questions_per_hit",
        ),
        (&["--task", "x"][..], "--kind mashup"),
    ] {
        let out = create(extra);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && err.contains(needle),
            "{extra:?}: {err}"
        );
    }
    assert_eq!(
        scalar(&db.url, "SELECT CAST(COUNT(*) AS BIGINT) FROM studies").await,
        0
    );
    let out = create(&[
        "--kind",
        "mashup",
        "--task",
        "A farm in the morning",
        "--background",
        "grass",
        "--min-pieces",
        "2",
        "--min-searches",
        "1",
        "--tuples",
        "4",
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("4 main tuples, 4 slots, 0 controls, 0 training"),
        "{stdout}"
    );
    let study: i64 = stdout
        .split_whitespace()
        .nth(1)
        .and_then(|id| id.trim_end_matches(':').parse().ok())
        .expect("study id");
    create_admin(&db.url);
    let server = Server::start(&db.url);
    let base = server.url("");
    let base = base.trim_end_matches('/');
    let c = client();
    let api = |token: &str, path: &str| format!("{base}/api/v1/assignments/{token}/mashup{path}");

    // Four workers; each first sees the task and makes a search with an empty canvas.
    let mut tokens = Vec::new();
    let mut first = HashMap::new();
    for w in 0..4 {
        let token = start_worker(&c, base, study, &format!("m{w}")).await;
        let (status, task) = send(c.get(api(&token, ""))).await;
        assert_eq!(status, 200, "{task}");
        assert_eq!(task["task"], "A farm in the morning");
        assert_eq!(task["background"], "grass");
        assert_eq!(
            (task["min_pieces"].as_i64(), task["searches"].as_i64()),
            (Some(2), Some(0))
        );
        assert_eq!(task["status"], "active");
        let body = task.to_string();
        assert!(
            !body.contains("\"A\"") && !body.contains("condition"),
            "{body}"
        );
        let (status, list) = send(c.get(api(&token, "/search"))).await;
        assert_eq!(status, 200, "{list}");
        assert_eq!(list["seq"], 1);
        assert_eq!(list["matched"], 24);
        let keys: BTreeSet<&str> = list
            .as_object()
            .unwrap()
            .keys()
            .map(String::as_str)
            .collect();
        assert_eq!(
            keys,
            BTreeSet::from(["categories", "matched", "results", "seq"])
        );
        first.insert(token.clone(), ids(&list));
        tokens.push(token);
    }
    let cond = conditions(&db.url).await;
    assert_eq!(cond.len(), 4);
    assert_eq!(cond.values().filter(|c| *c == "A").count(), 2, "{cond:?}");
    let wa = tokens.iter().find(|t| cond[*t] == "A").unwrap().clone();
    let wb = tokens.iter().find(|t| cond[*t] == "B").unwrap().clone();
    let all_items: BTreeSet<i64> = first[&wa].iter().copied().collect();
    assert_eq!(all_items.len(), 24);

    let (cookie, _) = admin_login(&c, base).await;
    let style_order = |near: i64| {
        let (c, cookie) = (c.clone(), cookie.clone());
        let url = format!("{base}/api/v1/admin/search?library=fx&near={near}&limit=48");
        async move {
            let (status, body) = send(c.get(url).header("cookie", cookie)).await;
            assert_eq!(status, 200, "{body}");
            ids(&body)
        }
    };
    let add = |token: &str, item: i64, search_seq: i64, position: i64| {
        c.post(api(token, "/events")).json(
            &json!({"event": "add", "item": item, "search_seq": search_seq, "position": position}),
        )
    };

    // Condition A: a piece from position 3; the next list is the style order to it.
    let a1 = first[&wa][2];
    let (status, body) = send(add(&wa, a1, 1, 3)).await;
    assert_eq!(status, 200, "{body}");
    let (status, list) = send(c.get(api(&wa, &format!("/search?near={a1}")))).await;
    assert_eq!(status, 200, "{list}");
    assert_eq!(list["seq"], 2);
    let a_list = ids(&list);
    assert_eq!(
        a_list,
        style_order(a1).await,
        "condition A is not the style order"
    );
    let a2 = a_list[5];
    assert_eq!(send(add(&wa, a2, 2, 6)).await.0, 200);

    // Condition B: the same matches in an order that is not the style order, the same again
    // for the same query.
    let b1 = first[&wb][0];
    assert_eq!(send(add(&wb, b1, 1, 1)).await.0, 200);
    let (status, list) = send(c.get(api(&wb, &format!("/search?near={b1}")))).await;
    assert_eq!(status, 200, "{list}");
    assert_eq!(list["seq"], 2);
    let b_list = ids(&list);
    assert_eq!(b_list.iter().copied().collect::<BTreeSet<_>>(), all_items);
    let style = style_order(b1).await;
    assert_ne!(
        b_list
            .iter()
            .filter(|&&i| i != b1)
            .copied()
            .collect::<Vec<_>>(),
        style
    );
    assert_ne!(b_list, first[&wa], "B shows A's empty-canvas order");
    let (_, again) = send(c.get(api(&wb, &format!("/search?near={b1}")))).await;
    assert_eq!(again["seq"], 3);
    assert_eq!(
        ids(&again),
        b_list,
        "condition B's order is not reproducible"
    );
    assert_eq!(ids(&again), first[&wb], "B's order depends on the canvas");
    let b2 = b_list[9];
    assert_eq!(send(add(&wb, b2, 3, 10)).await.0, 200);

    // Bad events: 4xx, nothing stored.
    let other = b_list[0];
    for (event, why) in [
        (
            json!({"event": "add", "item": b2, "search_seq": 3, "position": 11}),
            "wrong position",
        ),
        (
            json!({"event": "add", "item": other, "search_seq": 3, "position": 10}),
            "wrong item",
        ),
        (
            json!({"event": "add", "item": b2, "search_seq": 99, "position": 10}),
            "unknown search",
        ),
        (
            json!({"event": "add", "item": b2, "search_seq": 3, "position": 0}),
            "position 0",
        ),
        (
            json!({"event": "add", "item": b2, "search_seq": 3}),
            "no position",
        ),
        (
            json!({"event": "remove", "item": first[&wb][23]}),
            "never added",
        ),
        (json!({"event": "move", "item": b2}), "unknown event"),
        (
            json!({"event": "search", "seq": 3, "q": "", "category": "", "results": [1, 2]}),
            "forged list",
        ),
    ] {
        let (status, body) = send(c.post(api(&wb, "/events")).json(&event)).await;
        assert_eq!(status, 400, "{why}: {body}");
    }
    // The page's own confirmation of a list it showed is accepted.
    let shown = json!({"event": "search", "seq": 3, "q": "", "category": "", "results": b_list});
    assert_eq!(send(c.post(api(&wb, "/events")).json(&shown)).await.0, 200);
    // One worker cannot use or see another's log: wa made 2 searches, wb's third is not wa's.
    let (status, _) = send(add(&wa, b2, 3, 10)).await;
    assert_eq!(status, 400);
    let (_, task) = send(c.get(api(&wa, ""))).await;
    assert_eq!(task["searches"], 2);
    let (status, _) = send(c.get(format!("{base}/api/v1/assignments/not-a-token/mashup"))).await;
    assert_eq!(status, 404);

    // The generic answer endpoint cannot finish a mash-up HIT.
    let (_, st) = send(c.get(format!("{base}/api/v1/assignments/{wa}"))).await;
    let q = &st["question"];
    let (status, body) = send(
        c.post(format!("{base}/api/v1/assignments/{wa}/answers"))
            .json(&json!({"position": q["position"], "choice": q["left"]["id"]})),
    )
    .await;
    assert_eq!(status, 409, "{body}");

    // Bad submissions: 400, the HIT stays open.
    for (body, why) in [
        (composition(&[a1], "grass"), "one piece"),
        (composition(&[a1, a2], "blank"), "another background"),
        (
            composition(&[a1, a2, first[&wa][20]], "grass"),
            "a piece never added",
        ),
        (
            json!({"document": {"version": 2, "width": 800, "height": 600, "background": "grass",
                             "pieces": []}}),
            "bad version",
        ),
        (json!({"doc": {}}), "unknown field"),
    ] {
        let (status, resp) = send(c.post(api(&wa, "/submit")).json(&body)).await;
        assert_eq!(status, 400, "{why}: {resp}");
    }
    for (token, items) in [(&wa, [a1, a2]), (&wb, [b2, b1])] {
        let (status, st) = send(
            c.post(api(token, "/submit"))
                .json(&composition(&items, "grass")),
        )
        .await;
        assert_eq!(status, 200, "{st}");
        assert_eq!(st["status"], "completed", "{st}");
        assert!(
            st["completion_code"]
                .as_str()
                .is_some_and(|c| !c.is_empty()),
            "{st}"
        );
        let (status, _) = send(
            c.post(api(token, "/submit"))
                .json(&composition(&items, "grass")),
        )
        .await;
        assert_eq!(status, 409, "a second submission");
        assert_eq!(
            send(add(token, items[0], 1, 1)).await.0,
            409,
            "events after the HIT"
        );
    }

    // The logged positions are those of the lists the server returned.
    let (adds, lists) = stored_log(&db.url).await;
    assert_eq!(adds[&wa], vec![(1, a1, 3), (2, a2, 6)]);
    assert_eq!(adds[&wb], vec![(1, b1, 1), (3, b2, 10)]);
    assert_eq!(lists[&(wa.clone(), 2)], a_list);
    assert_eq!(lists[&(wb.clone(), 3)], b_list);
    for (token, log) in &adds {
        for &(seq, item, position) in log {
            assert_eq!(lists[&(token.clone(), seq)][position as usize - 1], item);
        }
    }

    // The report: per condition, learner::stats on the stored positions.
    let (status, report) = send(
        c.get(format!("{base}/api/v1/admin/studies/{study}/report"))
            .header("cookie", &cookie),
    )
    .await;
    assert_eq!(status, 200, "{report}");
    assert_eq!(report["kind"], "mashup");
    let exported =
        crate::platform_report_export::check_report_export(&c, base, &cookie, study).await;
    assert_eq!(exported, report, "the export's report");
    for (condition, token, searches) in [("A", &wa, 2), ("B", &wb, 3)] {
        let r = report["conditions"]
            .as_array()
            .expect("conditions")
            .iter()
            .find(|r| r["condition"] == condition)
            .expect("condition");
        assert_eq!(
            (r["workers"].as_i64(), r["pieces"].as_i64()),
            (Some(1), Some(2)),
            "{r}"
        );
        assert_eq!(r["searches"].as_i64(), Some(searches));
        let positions: Vec<f64> = adds[token].iter().map(|a| a.2 as f64).collect();
        let want = learner::stats::mean_interval(&positions, 0.95).expect("interval");
        let got = |k: &str| r["position"][k].as_f64().expect(k);
        assert!((got("mean") - want.mean).abs() < 1e-12, "{r}");
        assert!((got("half_width") - want.half_width).abs() < 1e-9, "{r}");
        assert!((got("low") - want.low).abs() < 1e-9 && (got("high") - want.high).abs() < 1e-9);
        // The study page shows the same figures.
        let page = admin_text(&c, &format!("{base}/admin/studies/{study}"), &cookie).await;
        let row = page
            .split(&format!("id=\"mashup-condition-{condition}\""))
            .nth(1)
            .and_then(|rest| rest.split("</tr>").next())
            .unwrap_or_else(|| panic!("no row for {condition} on the page"));
        let shown = format!("{:.1} ± {:.1}", want.mean, want.half_width);
        assert!(row.contains(&shown), "{shown} not in {row}");
    }
}

both_databases!(mashup_study, mashup_study_sqlite, mashup_study_postgres);

/// A worker in each condition does a mash-up HIT in real Chromium: the task page, two pieces
/// dragged from the results (the second after the page re-searched), Submit, the end page with
/// the completion code; the logged positions are those of the lists the server returned, and
/// the stored composition has the two pieces on the fixed background.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn mashup_hit_in_chromium() {
    use crate::platform_mashup_browser::{
        click, document, drag, ids_shown, on_canvas, result_centre, until,
    };
    use e2e::browser::*;
    use fantoccini::Locator;

    let profile = tempfile::tempdir().expect("profile dir");
    let Some((driver, c)) = browser(profile.path(), Viewport::Desktop).await else {
        return;
    };
    let db = sqlite_db();
    let lib = small_library(3);
    import_library(&db, lib.path());
    let out = platform_ok(
        &[
            "study",
            "create",
            "--database-url",
            &db.url,
            "--name",
            "picnic",
            "--library",
            "fx",
            "--kind",
            "mashup",
            "--task",
            "A picnic by the lake",
            "--background",
            "grass",
            "--min-pieces",
            "2",
            "--tuples",
            "2",
        ],
        &[],
    );
    let study: i64 = out
        .split_whitespace()
        .nth(1)
        .and_then(|id| id.trim_end_matches(':').parse().ok())
        .expect("study id");
    let server = Server::start(&db.url);
    let http = client();
    let base = server.url("");
    let base = base.trim_end_matches('/');

    let mut seen = Vec::new();
    for w in 0..2 {
        let token = start_worker(&http, base, study, &format!("c{w}")).await;
        c.goto(&server.url(&format!("/a/{token}")))
            .await
            .expect("task page");
        let task = c
            .find(Locator::Id("mashup-task"))
            .await
            .expect("task")
            .text()
            .await
            .expect("text");
        assert_eq!(task, "A picnic by the lake");
        until(
            &c,
            "the first results",
            "return document.getElementById('mashup').dataset.searchSeq === '1';",
        )
        .await;
        let first = ids_shown(&c).await;
        assert_eq!(first.len(), 12, "{first:?}");
        // The fixed background: no drop-down.
        let bg = c
            .find(Locator::Id("mashup-background-label"))
            .await
            .expect("bg");
        assert!(!bg.is_displayed().await.expect("shown"));
        let summary = c
            .find(Locator::Id("mashup-summary"))
            .await
            .expect("summary")
            .text()
            .await
            .expect("text");
        assert_eq!(
            summary, "12 of 12 matching items.",
            "the summary names the order"
        );

        // Position 2 of the first list, then position 4 of the list the page shows next.
        drag(
            &c,
            result_centre(&c, 1).await,
            on_canvas(&c, 250.0, 300.0).await,
        )
        .await;
        until(
            &c,
            "the re-search",
            "return document.getElementById('mashup').dataset.searchSeq === '2';",
        )
        .await;
        let second = ids_shown(&c).await;
        drag(
            &c,
            result_centre(&c, 3).await,
            on_canvas(&c, 500.0, 300.0).await,
        )
        .await;
        until(
            &c,
            "the second re-search",
            "return document.getElementById('mashup').dataset.searchSeq === '3';",
        )
        .await;
        let doc = document(&c).await;
        let items: Vec<i64> = doc["pieces"]
            .as_array()
            .expect("pieces")
            .iter()
            .map(|p| p["item"].as_i64().unwrap())
            .collect();
        assert_eq!(items, vec![first[1], second[3]], "{doc}");

        mark(&c).await;
        click(&c, "mashup-submit").await;
        wait_navigated(&c).await;
        let code = c
            .find(Locator::Id("code"))
            .await
            .expect("completion code")
            .text()
            .await
            .expect("text");
        assert!(!code.is_empty());
        let violations = csp_violations(&c, &driver).await;
        assert!(violations.is_empty(), "{violations:?}");
        seen.push((token, first, second));
    }

    let cond = conditions(&db.url).await;
    let mut both: Vec<&String> = cond.values().collect();
    both.sort();
    assert_eq!(both, ["A", "B"], "one worker per condition");
    let (adds, lists) = stored_log(&db.url).await;
    for (token, first, second) in &seen {
        assert_eq!(
            adds[token],
            vec![(1, first[1], 2), (2, second[3], 4)],
            "{}",
            cond[token]
        );
        assert_eq!(&lists[&(token.clone(), 1)], first);
        assert_eq!(&lists[&(token.clone(), 2)], second);
    }
    let done = scalar(
        &db.url,
        "SELECT CAST(COUNT(*) AS BIGINT) FROM assignments WHERE status = 'completed'",
    )
    .await;
    assert_eq!(done, 2);
    let stored = rows(&db.url, "SELECT document FROM compositions").await;
    assert_eq!(stored.len(), 2);
    for r in stored {
        use sqlx::Row;
        let doc: Value = serde_json::from_str(&r.get::<String, _>("document")).expect("json");
        assert_eq!(doc["background"], "grass");
        assert_eq!(doc["pieces"].as_array().map(Vec::len), Some(2));
    }
}
