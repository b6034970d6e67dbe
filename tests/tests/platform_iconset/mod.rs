//! The icon-set study (issue 18, Garces et al. 2016 §6.6) over real HTTP against the real
//! `platform` binary, on SQLite and PostgreSQL: created with `platform study create --kind
//! iconset` (bad labels, counts, κ/τ and models refused with a clear message, nothing stored),
//! the explorer stored at creation with every branch member reachable, one HIT per condition —
//! A picks from the explorer, B from the search ordered by style (the admin search's order
//! for the same label and the current set's icons) — with deletions, bad steps refused, and the
//! report's means and 95% t intervals equal to `learner::stats` on the times and deletions the
//! test computes from the stored events; `iconset_sets.csv` holds the same sets. In Chromium:
//! `browser`.

use std::collections::{BTreeSet, HashMap};

use e2e::both_databases;
use e2e::platform::*;
use serde_json::{Value, json};

mod browser;
mod support;

use support::*;

async fn iconset_study(db: TestDb) {
    import_icons(&db);
    // Bad creations: a clear message, no study.
    for (extra, needle) in [
        (
            &["--kind", "iconset", "--labels", "face,cat"][..],
            "cat not in this library",
        ),
        (
            &["--kind", "iconset", "--labels", "face,face"][..],
            "given twice",
        ),
        (
            &["--kind", "iconset", "--labels", "face,,fish"][..],
            "labels",
        ),
        (&["--kind", "iconset", "--sets", "0"][..], "sets: 0"),
        (
            &["--kind", "iconset", "--sets", "9"][..],
            "\"fish\" has 8 items",
        ),
        (
            &["--kind", "iconset", "--tau", "8"][..],
            "prune every branch",
        ),
        (&["--kind", "iconset", "--model", "12345"][..], "model"),
        (&["--kind", "iconset", "--model", "best"][..], "model"),
        (
            &["--kind", "iconset", "--questions-per-hit", "3"][..],
            "questions_per_hit",
        ),
        (&["--labels", "face"][..], "--kind iconset"),
    ] {
        let out = create(&db, extra);
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
    let study = created(&create(&db, GOOD));
    let label_of_item = labels(&db.url).await;

    // The explorer was stored at creation: every branch member once on its grid.
    let stored = rows(&db.url, "SELECT result FROM iconset_explorers").await;
    assert_eq!(stored.len(), 1);
    let explorer: Value =
        serde_json::from_str(&sqlx::Row::get::<String, _>(&stored[0], "result")).expect("json");
    let styles = explorer["styles"].as_array().expect("styles");
    assert!(!styles.is_empty(), "{explorer}");
    for st in styles {
        let mut members = Vec::new();
        for cell in st["grid"]["cells"].as_array().expect("cells") {
            members.extend(cell["shown"].as_i64());
            members.extend(
                cell["hidden"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|h| h.as_i64().unwrap()),
            );
        }
        let unique: BTreeSet<i64> = members.iter().copied().collect();
        assert_eq!(unique.len(), members.len(), "an item twice on a grid");
        assert_eq!(members.len() as i64, st["count"].as_i64().unwrap());
        // Every label of the task is in every branch (τ = 1: more than one of each).
        for l in ["face", "fish", "flower", "bird"] {
            let n = members.iter().filter(|i| label_of_item[i] == l).count();
            assert!(n > 1, "{l}: {n}");
        }
    }

    create_admin(&db.url);
    let server = Server::start(&db.url);
    let base = server.url("");
    let base = base.trim_end_matches('/');
    let c = client();
    let api = |token: &str, path: &str| format!("{base}/api/v1/assignments/{token}/iconset{path}");

    // The browser form: a bad field is shown again with its reason and a 400, nothing stored;
    // a good one stores the study with its explorer.
    let (cookie, csrf) = admin_login(&c, base).await;
    let post = |fields: Vec<(&'static str, &'static str)>| {
        let mut fields: Vec<(&str, String)> = fields
            .into_iter()
            .map(|(k, v)| (k, v.to_string()))
            .collect();
        fields.push(("csrf", csrf.clone()));
        c.post(format!("{base}/admin/studies/new/iconset"))
            .header("cookie", &cookie)
            .form(&fields)
            .send()
    };
    let good = vec![
        ("name", "form icon sets"),
        ("library", "icons"),
        ("labels", "face, fish"),
        ("sets", "3"),
        ("model", "uniform"),
        ("kappa", "5"),
        ("tau", "1"),
        ("trays", "2"),
        ("mturk_mode", "sandbox"),
    ];
    for (field, value, needle) in [
        ("labels", "face,cat", "cat not in this library"),
        (
            "sets",
            "three",
            "Sets: &#34;three&#34; is not a whole number",
        ),
        ("sets", "11", "sets: 11 not in 1..=10"),
        ("tau", "9", "prune every branch"),
        ("model", "best", "model: a model id or"),
        ("library", "nope", "library not found"),
    ] {
        let mut fields = good.clone();
        fields.retain(|(k, _)| *k != field);
        fields.push((field, value));
        let resp = post(fields).await.expect("post");
        assert_eq!(resp.status().as_u16(), 400, "{field}={value}");
        let page = resp.text().await.expect("page");
        assert!(page.contains(needle), "{field}={value}: {page}");
    }
    let studies = |db_url: String| async move {
        scalar(&db_url, "SELECT CAST(COUNT(*) AS BIGINT) FROM studies").await
    };
    assert_eq!(studies(db.url.clone()).await, 1);
    let resp = post(good.clone()).await.expect("post");
    assert_eq!(resp.status().as_u16(), 303);
    assert_eq!(studies(db.url.clone()).await, 2);
    assert_eq!(
        scalar(
            &db.url,
            "SELECT CAST(COUNT(*) AS BIGINT) FROM iconset_explorers"
        )
        .await,
        2
    );

    // Three workers open the task: balanced conditions, nothing names them.
    let mut tokens = Vec::new();
    for w in 0..3 {
        let token = start_worker(&c, base, study, &format!("i{w}")).await;
        let (status, task) = send(c.get(api(&token, ""))).await;
        assert_eq!(status, 200, "{task}");
        assert_eq!(
            task["task"],
            "Find icons for face, fish, flower and bird in one style. Make 2 sets, each in a \
             different style."
        );
        assert_eq!(task["current"], 1);
        assert_eq!(task["tray"]["sets"].as_array().map(Vec::len), Some(2));
        let body = task.to_string();
        assert!(
            !body.contains("condition") && !body.contains("\"A\""),
            "{body}"
        );
        tokens.push(token);
    }
    let cond = conditions(&db.url).await;
    assert_eq!(cond.len(), 3);
    let a_tokens: Vec<&String> = tokens.iter().filter(|t| cond[*t] == "A").collect();
    let b_tokens: Vec<&String> = tokens.iter().filter(|t| cond[*t] == "B").collect();
    assert!(
        !a_tokens.is_empty()
            && !b_tokens.is_empty()
            && a_tokens.len().abs_diff(b_tokens.len()) == 1,
        "{cond:?}"
    );
    let (wa, wb) = (a_tokens[0].clone(), b_tokens[0].clone());
    let (_, task) = send(c.get(api(&wa, ""))).await;
    assert_eq!(task["interface"], "explorer");
    let (_, task) = send(c.get(api(&wb, ""))).await;
    assert_eq!(task["interface"], "search");

    let event = |token: &str, body: Value| c.post(api(token, "/events")).json(&body);
    let add = |token: &str, item: i64| event(token, json!({"event": "add", "item": item}));
    let remove =
        |token: &str, label: &str| event(token, json!({"event": "remove", "label": label}));
    let finish = |token: &str| event(token, json!({"event": "finish"}));
    let ok = |(status, body): (u16, Value)| assert_eq!(status, 200, "{body}");

    // Condition A: the explorer (the stored one); no search.
    let (status, seen) = send(c.get(api(&wa, "/explorer"))).await;
    assert_eq!(status, 200, "{seen}");
    assert_eq!(
        seen, explorer,
        "the worker's explorer is not the stored one"
    );
    assert_eq!(send(c.get(api(&wa, "/search?label=face"))).await.0, 409);
    let members = |k: usize| -> Vec<i64> {
        let st = &styles[k % styles.len()];
        let mut m = Vec::new();
        for cell in st["grid"]["cells"].as_array().unwrap() {
            m.extend(cell["shown"].as_i64());
            m.extend(
                cell["hidden"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|h| h.as_i64().unwrap()),
            );
        }
        m
    };
    let pick = |from: &[i64], label: &str, nth: usize| -> i64 {
        *from
            .iter()
            .filter(|i| label_of_item[i] == label)
            .nth(nth)
            .unwrap_or_else(|| panic!("no {label} {nth}"))
    };
    let sky = *label_of_item.iter().find(|(_, l)| *l == "sky").unwrap().0;
    let s1 = members(0);
    // Bad steps first: 4xx, nothing stored.
    for (body, why) in [
        (json!({"event": "add", "item": sky}), "not a task label"),
        (
            json!({"event": "add", "item": 1}),
            "not an item of the library",
        ),
        (json!({"event": "add"}), "no item"),
        (json!({"event": "remove", "label": "face"}), "empty slot"),
        (json!({"event": "remove", "label": "cat"}), "no such slot"),
        (json!({"event": "finish"}), "set not full"),
        (json!({"event": "move", "item": s1[0]}), "unknown event"),
        (json!({"event": "finish", "set": 1}), "unknown field"),
    ] {
        let (status, body) = send(event(&wa, body)).await;
        assert_eq!(status, 400, "{why}: {body}");
    }
    let (status, body) = send(c.post(api(&wa, "/submit"))).await;
    assert_eq!(status, 400, "submitted before the sets: {body}");
    ok(send(add(&wa, pick(&s1, "face", 0))).await);
    let (status, body) = send(add(&wa, pick(&s1, "face", 1))).await;
    assert_eq!(status, 400, "the face slot is filled: {body}");
    ok(send(add(&wa, pick(&s1, "fish", 0))).await);
    ok(send(remove(&wa, "fish")).await);
    ok(send(add(&wa, pick(&s1, "fish", 1))).await);
    ok(send(add(&wa, pick(&s1, "flower", 0))).await);
    ok(send(add(&wa, pick(&s1, "bird", 0))).await);
    let (status, tray) = send(finish(&wa)).await;
    assert_eq!(status, 200, "{tray}");
    assert!(tray["sets"][0]["finished_at"].is_i64(), "{tray}");
    // Set 2 from another style when there is one; an icon of set 1 cannot be used again.
    let s2 = members(1);
    let (status, body) = send(add(&wa, pick(&s1, "face", 0))).await;
    assert_eq!(status, 400, "reused icon: {body}");
    let other = |label: &str| {
        let used: Vec<i64> = ["face", "fish", "flower", "bird"]
            .iter()
            .map(|l| pick(&s1, l, 0))
            .chain([pick(&s1, "fish", 1)])
            .collect();
        *s2.iter()
            .rfind(|i| label_of_item[*i] == label && !used.contains(i))
            .unwrap()
    };
    for l in ["face", "fish", "flower", "bird"] {
        ok(send(add(&wa, other(l))).await);
    }
    ok(send(remove(&wa, "face")).await);
    ok(send(remove(&wa, "bird")).await);
    ok(send(add(&wa, other("bird"))).await);
    ok(send(add(&wa, other("face"))).await);
    ok(send(finish(&wa)).await);
    assert_eq!(send(finish(&wa)).await.0, 409, "no set left");

    // Condition B: the search, ordered by style to the current set; no explorer.
    assert_eq!(send(c.get(api(&wb, "/explorer"))).await.0, 409);
    for bad in ["/search?label=sky", "/search", "/search?label=face&limit=0"] {
        assert_eq!(send(c.get(api(&wb, bad))).await.0, 400, "{bad}");
    }
    let (cookie, _) = admin_login(&c, base).await;
    let admin_order = |label: &str, near: &[i64]| {
        let near: Vec<String> = near.iter().map(ToString::to_string).collect();
        let mut url = format!(
            "{base}/api/v1/admin/search?library=icons&model=uniform&category={label}&limit=48"
        );
        if !near.is_empty() {
            url.push_str(&format!("&near={}", near.join(",")));
        }
        let (c, cookie) = (c.clone(), cookie.clone());
        async move {
            let (status, body) = send(c.get(url).header("cookie", cookie)).await;
            assert_eq!(status, 200, "{body}");
            ids(&body)
        }
    };
    let mut used: Vec<i64> = Vec::new();
    for set in 0..2 {
        let mut in_set: Vec<i64> = Vec::new();
        for (k, l) in ["face", "fish", "flower", "bird"].iter().enumerate() {
            let (status, list) = send(c.get(api(&wb, &format!("/search?label={l}")))).await;
            assert_eq!(status, 200, "{list}");
            let got = ids(&list);
            assert_eq!(got, admin_order(l, &in_set).await, "not the style order");
            assert!(got.iter().all(|i| label_of_item[i] == *l));
            let item = *got.iter().find(|i| !used.contains(i)).unwrap();
            ok(send(add(&wb, item)).await);
            in_set.push(item);
            used.push(item);
            if set == 0 && k == 1 {
                // Changed mind: the fish goes, another comes.
                ok(send(remove(&wb, "fish")).await);
                in_set.pop();
                let item = *got.iter().rfind(|i| !used.contains(i)).unwrap();
                ok(send(add(&wb, item)).await);
                in_set.push(item);
                used.push(item);
            }
        }
        ok(send(finish(&wb)).await);
    }

    // A third worker finishes one set only: not counted.
    let wc = tokens
        .iter()
        .find(|t| **t != wa && **t != wb)
        .unwrap()
        .clone();
    let ic = if cond[&wc] == "A" {
        let s = members(0);
        ["face", "fish", "flower", "bird"].map(|l| pick(&s, l, 0))
    } else {
        let mut picked = [0; 4];
        for (k, l) in ["face", "fish", "flower", "bird"].iter().enumerate() {
            let (_, list) = send(c.get(api(&wc, &format!("/search?label={l}")))).await;
            picked[k] = ids(&list)[0];
        }
        picked
    };
    for i in ic {
        ok(send(add(&wc, i)).await);
    }
    ok(send(finish(&wc)).await);

    // The generic answer endpoint cannot finish an icon-set HIT; submitting can, once.
    let (_, st) = send(c.get(format!("{base}/api/v1/assignments/{wa}"))).await;
    let q = &st["question"];
    let (status, body) = send(
        c.post(format!("{base}/api/v1/assignments/{wa}/answers"))
            .json(&json!({"position": q["position"], "choice": q["left"]["id"]})),
    )
    .await;
    assert_eq!(status, 409, "{body}");
    for token in [&wa, &wb] {
        let (status, st) = send(c.post(api(token, "/submit"))).await;
        assert_eq!(status, 200, "{st}");
        assert_eq!(st["status"], "completed", "{st}");
        assert!(
            st["completion_code"]
                .as_str()
                .is_some_and(|c| !c.is_empty())
        );
        assert_eq!(send(c.post(api(token, "/submit"))).await.0, 409, "twice");
        assert_eq!(send(remove(token, "face")).await.0, 409, "after the HIT");
    }
    let (status, _) = send(c.get(format!("{base}/api/v1/assignments/nope/iconset"))).await;
    assert_eq!(status, 404);
    // Worker pages are theirs alone: the admin report needs the admin.
    let (status, _) = send(c.get(format!("{base}/api/v1/admin/studies/{study}/report"))).await;
    assert_eq!(status, 401);

    // The report: per condition, learner::stats on the times and deletions computed here.
    let computed = sets_from_events(&db.url).await;
    assert_eq!(computed[&wc].len(), 1);
    let deletions: Vec<usize> = computed[&wa].iter().map(|s| s.1).collect();
    assert_eq!(deletions, [1, 2]);
    let deletions: Vec<usize> = computed[&wb].iter().map(|s| s.1).collect();
    assert_eq!(deletions, [1, 0]);
    let report = crate::platform_report_export::check_report_export(&c, base, &cookie, study).await;
    assert_eq!(report["kind"], "iconset");
    assert_eq!(report["confidence"], 0.95);
    let page = admin_text(&c, &format!("{base}/admin/studies/{study}"), &cookie).await;
    for (condition, token) in [("A", &wa), ("B", &wb)] {
        let r = report["conditions"]
            .as_array()
            .unwrap()
            .iter()
            .find(|r| r["condition"] == condition)
            .expect("condition");
        assert_eq!(
            (r["workers"].as_i64(), r["sets"].as_i64()),
            (Some(1), Some(2)),
            "{r}"
        );
        let row = page
            .split(&format!("id=\"iconset-condition-{condition}\""))
            .nth(1)
            .and_then(|rest| rest.split("</tr>").next())
            .expect("row on the page");
        for (key, values, digits) in [
            (
                "seconds_per_set",
                computed[token].iter().map(|s| s.0).collect::<Vec<f64>>(),
                1,
            ),
            (
                "deletions_per_set",
                computed[token].iter().map(|s| s.1 as f64).collect(),
                2,
            ),
        ] {
            let want = learner::stats::mean_interval(&values, 0.95).expect("interval");
            let got = |k: &str| {
                r[key][k]
                    .as_f64()
                    .unwrap_or_else(|| panic!("{key}.{k}: {r}"))
            };
            assert!((got("mean") - want.mean).abs() < 1e-9, "{key}: {r}");
            assert!(
                (got("half_width") - want.half_width).abs() < 1e-9,
                "{key}: {r}"
            );
            assert!((got("sd") - want.sd).abs() < 1e-9, "{key}: {r}");
            let shown = format!("{:.*} ± {:.*}", digits, want.mean, digits, want.half_width);
            assert!(row.contains(&shown), "{shown} not in {row}");
        }
    }

    // iconset_sets.csv: the completed HITs' sets, the same numbers.
    let resp = c
        .get(format!(
            "{base}/api/v1/admin/studies/{study}/export/iconset_sets.csv"
        ))
        .header("cookie", &cookie)
        .send()
        .await
        .expect("export");
    assert_eq!(resp.status().as_u16(), 200);
    let text = resp.text().await.expect("csv");
    let mut reader = csv::Reader::from_reader(text.as_bytes());
    let header: Vec<String> = reader
        .headers()
        .unwrap()
        .iter()
        .map(str::to_string)
        .collect();
    assert_eq!(
        &header[..4],
        ["assignment", "worker_id", "condition", "set"]
    );
    let col = |name: &str| header.iter().position(|h| h == name).expect(name);
    let records: Vec<csv::StringRecord> = reader.records().map(|r| r.expect("row")).collect();
    assert_eq!(records.len(), 4, "{text}");
    // The style spread: the mean distance of eq. 5.5 between two icons of a set, recomputed
    // here with learner's uniform weighting over the stored features.
    let space = uniform_space(&db.url).await;
    let mut spreads: HashMap<String, Vec<f64>> = HashMap::new();
    for rec in &records {
        let names: Vec<&str> = rec[col("items")].split(';').collect();
        let want = space.spread(&names);
        let got: f64 = rec[col("spread")].parse().expect("spread");
        assert!((got - want).abs() < 1e-9 * want.max(1.0), "{got} vs {want}");
        spreads
            .entry(rec[col("condition")].to_string())
            .or_default()
            .push(want);
    }
    for r in report["conditions"].as_array().unwrap() {
        let values = &spreads[r["condition"].as_str().unwrap()];
        let want = learner::stats::mean_interval(values, 0.95).expect("interval");
        let got = r["spread_per_set"]["mean"].as_f64().expect("spread mean");
        assert!((got - want.mean).abs() < 1e-9, "{r}");
    }
    for rec in &records {
        let condition = &rec[col("condition")];
        let token = if condition == "A" { &wa } else { &wb };
        let set: usize = rec[col("set")].parse().unwrap();
        let (seconds, deletions) = computed[token][set - 1];
        assert_eq!(rec[col("seconds")].parse::<f64>().unwrap(), seconds);
        assert_eq!(rec[col("deletions")].parse::<usize>().unwrap(), deletions);
        assert_eq!(&rec[col("labels")], "face;fish;flower;bird");
        assert_eq!(rec[col("items")].split(';').count(), 4);
    }
}

both_databases!(iconset_study, iconset_sqlite, iconset_postgres);
