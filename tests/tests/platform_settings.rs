//! Editing a study's settings after creation, on the real server and the real command line,
//! on SQLite and PostgreSQL: what may change when, validation, access control, the audit
//! trail, and that the changes take effect (blocked and excluded workers, the control-error
//! threshold of later QC decisions, the description workers see).

use std::collections::HashMap;

use e2e::both_databases;
use e2e::platform::*;
use serde_json::{Value, json};

/// A logged-in admin's JSON requests.
struct AdminApi<'a> {
    c: &'a reqwest::Client,
    base: &'a str,
    cookie: String,
    csrf: String,
}

impl AdminApi<'_> {
    async fn get(&self, path: &str) -> (u16, Value) {
        send(
            self.c
                .get(format!("{}{path}", self.base))
                .header("cookie", &self.cookie),
        )
        .await
    }

    async fn patch(&self, study: i64, body: Value) -> (u16, Value) {
        send(
            self.c
                .patch(format!(
                    "{}/api/v1/admin/studies/{study}/settings",
                    self.base
                ))
                .header("cookie", &self.cookie)
                .header("x-csrf-token", &self.csrf)
                .json(&body),
        )
        .await
    }

    async fn settings(&self, study: i64) -> Value {
        let (status, body) = self
            .get(&format!("/api/v1/admin/studies/{study}/settings"))
            .await;
        assert_eq!(status, 200, "{body}");
        body
    }
}

/// Answers every question with the option an honest worker would not pick, so every hidden
/// control is wrong; returns the final state. Checks that no questionnaire is asked when the
/// study's reasons probability is 0.
async fn answer_all_wrong(
    c: &reqwest::Client,
    base: &str,
    token: &str,
    styles: &HashMap<i64, String>,
) -> Value {
    loop {
        let (status, st) = send(c.get(format!("{base}/api/v1/assignments/{token}"))).await;
        assert_eq!(status, 200, "state: {st}");
        let Some(q) = st.get("question").filter(|q| !q.is_null()) else {
            return st;
        };
        let honest = choose(q, styles, Behaviour::Honest);
        let wrong = if q["left"]["id"].as_i64() == Some(honest) {
            &q["right"]["id"]
        } else {
            &q["left"]["id"]
        };
        let (status, ack) = send(
            c.post(format!("{base}/api/v1/assignments/{token}/answers"))
                .json(&json!({"position": q["position"], "choice": wrong, "elapsed_ms": 900})),
        )
        .await;
        assert_eq!(status, 200, "answer: {ack}");
        assert_eq!(ack["ask_reasons"], false, "reasons_probability is 0: {ack}");
    }
}

/// `(control errors, decision)` of the study's completed HITs, sorted.
async fn completed_hits(api: &AdminApi<'_>, study: i64) -> Vec<(i64, String)> {
    let (status, rows) = api
        .get(&format!("/api/v1/admin/studies/{study}/workers"))
        .await;
    assert_eq!(status, 200, "{rows}");
    let mut out: Vec<(i64, String)> = rows
        .as_array()
        .expect("rows")
        .iter()
        .filter(|r| r["status"] == "completed")
        .map(|r| {
            (
                r["control_errors"].as_i64().expect("errors"),
                r["decision"].as_str().unwrap_or_default().to_string(),
            )
        })
        .collect();
    out.sort();
    out
}

async fn edit_settings(db: TestDb) {
    let study = setup_study(&db, &StudyOpts::default());
    let server = Server::start(&db.url);
    let c = client();
    let base = server.base.as_str();
    let styles = item_styles(&db.url).await;
    let settings_url = format!("{base}/api/v1/admin/studies/{study}/settings");

    // Anonymous and CSRF-less requests are refused and change nothing.
    let (status, _) = send(c.get(&settings_url)).await;
    assert_eq!(status, 401);
    let (status, _) = send(c.patch(&settings_url).json(&json!({"description": "x"}))).await;
    assert_eq!(status, 401);
    let (cookie, csrf) = admin_login(&c, base).await;
    for token in [None, Some("0123456789abcdef0123456789abcdef")] {
        let mut req = c
            .patch(&settings_url)
            .header("cookie", &cookie)
            .json(&json!({"description": "x"}));
        if let Some(t) = token {
            req = req.header("x-csrf-token", t);
        }
        let (status, body) = send(req).await;
        assert_eq!(status, 403, "{body}");
    }
    let (status, _) = send(
        c.get(format!("{settings_url}/changes"))
            .header("x-csrf-token", &csrf),
    )
    .await;
    assert_eq!(status, 401, "the changes need a session");
    let api = AdminApi {
        c: &c,
        base,
        cookie,
        csrf,
    };
    let original = api.settings(study).await;
    assert_eq!(original["description"], "Compare the style of clip art.");
    assert_eq!(original["reject_at_control_errors"], 2);

    // Malformed bodies and invalid values: 4xx naming the problem, nothing stored.
    let malformed = c
        .patch(&settings_url)
        .header("cookie", &api.cookie)
        .header("x-csrf-token", &api.csrf)
        .header("content-type", "application/json")
        .body("{not json");
    let (status, body) = send(malformed).await;
    assert_eq!(status, 400, "{body}");
    let text = c
        .patch(&settings_url)
        .header("cookie", &api.cookie)
        .header("x-csrf-token", &api.csrf)
        .body("description=x");
    let (status, body) = send(text).await;
    assert_eq!(status, 415, "{body}");
    let other = {
        let (status, body) = send(
            c.post(format!("{base}/api/v1/admin/studies"))
                .header("cookie", &api.cookie)
                .header("x-csrf-token", &api.csrf)
                .json(&json!({"name": "earlier study", "library": "fx",
                    "settings": {"questions_per_hit": 6, "controls_per_hit": 1, "tuples": 50}})),
        )
        .await;
        assert_eq!(status, 200, "{body}");
        body["id"].as_i64().expect("study id")
    };
    for (body, want, mention) in [
        (json!({"surprise": 1}), 400, "surprise"),
        (
            json!({"reasons_probability": "high"}),
            400,
            "reasons_probability",
        ),
        (
            json!({"reasons_probability": 1.5}),
            400,
            "reasons_probability",
        ),
        (
            json!({"reject_at_control_errors": 0}),
            400,
            "reject_at_control_errors",
        ),
        (
            json!({"prolific_completion_code": "no spaces"}),
            400,
            "prolific",
        ),
        (json!({"blocked_workers": [""]}), 400, "blocked_workers"),
        (json!({"exclude_workers_of": [study]}), 400, "own workers"),
        (json!({"exclude_workers_of": [4242]}), 400, "no study 4242"),
        (json!({"questions_per_hit": 3}), 400, "controls_per_hit"),
        // What the pool was built from never changes.
        (json!({"tuples": 5}), 409, "tuples: cannot change"),
        (json!({"replication": 3}), 409, "replication: cannot change"),
        (json!({"seed": 99}), 409, "seed: cannot change"),
        (
            json!({"training_questions": 1}),
            409,
            "training_questions: cannot change",
        ),
    ] {
        let (status, answer) = api.patch(study, body.clone()).await;
        assert_eq!(status, want, "{body} → {answer}");
        let message = answer["error"].as_str().expect("error message");
        assert!(message.contains(mention), "{body} → {message}");
    }
    let (status, _) = api.patch(999_999, json!({"description": "x"})).await;
    assert_eq!(status, 404);
    assert_eq!(
        api.settings(study).await,
        original,
        "refused edits changed nothing"
    );
    // Sending back the current values is no change (a client may PATCH what it read).
    let (status, same) = api.patch(study, original.clone()).await;
    assert_eq!(status, 200, "{same}");
    assert_eq!(same["changes"], json!([]));

    // Before any assignment the HIT shape and the MTurk site may change.
    let (status, edited) = api
        .patch(
            study,
            json!({"questions_per_hit": 8, "controls_per_hit": 2, "mturk_mode": "live"}),
        )
        .await;
    assert_eq!(status, 200, "{edited}");
    assert_eq!(edited["changes"].as_array().map(Vec::len), Some(3));
    let (_, info) = send(c.get(format!("{base}/api/v1/studies/{study}"))).await;
    assert_eq!(
        (&info["questions_per_hit"], &info["mturk_mode"]),
        (&json!(8), &json!("live"))
    );
    let (status, body) = api.patch(study, json!({"mturk_mode": "sandbox"})).await;
    assert_eq!(status, 200, "{body}");

    // What steers what happens next changes at any time and shows at once.
    let (status, edited) = api
        .patch(
            study,
            json!({
                "description": "Rate the <b>style</b>, please.",
                "reasons_probability": 0.0,
                "reject_at_control_errors": 3,
                "blocked_workers": ["BLOCKED-1"],
                "exclude_workers_of": [other],
                "prolific_completion_code": "DONE42",
                "max_training_attempts": 4
            }),
        )
        .await;
    assert_eq!(status, 200, "{edited}");
    assert_eq!(edited["changes"].as_array().map(Vec::len), Some(7));
    assert_eq!(edited["settings"]["reject_at_control_errors"], 3);
    let (_, info) = send(c.get(format!("{base}/api/v1/studies/{study}"))).await;
    assert_eq!(info["description"], "Rate the <b>style</b>, please.");
    let page = c
        .get(format!("{base}/s/{study}?participant=reader"))
        .send()
        .await
        .expect("start page")
        .text()
        .await
        .expect("html");
    assert!(
        page.contains("Rate the ") && page.contains("style") && !page.contains("<b>style"),
        "the start page shows the new description, escaped: {page}"
    );

    // A blocked worker cannot start; nor can a worker of the excluded study.
    let (status, body) = send(
        c.post(format!("{base}/api/v1/studies/{study}/start"))
            .json(&json!({"source": "direct", "worker_id": "BLOCKED-1"})),
    )
    .await;
    assert_eq!(status, 403, "{body}");
    start_worker(&c, base, other, "veteran").await;
    let (status, body) = send(
        c.post(format!("{base}/api/v1/studies/{study}/start"))
            .json(&json!({"source": "direct", "worker_id": "veteran"})),
    )
    .await;
    assert_eq!(status, 403, "{body}");

    // The threshold applies to HITs completed after the change: a worker who gets both hidden
    // controls wrong is approved at 3 errors, rejected once it is back at 2.
    let mut expected = Vec::new();
    for (worker, threshold, verdict) in [
        ("contrarian-1", 3, "approved"),
        ("contrarian-2", 2, "rejected"),
    ] {
        if threshold == 2 {
            let (status, body) = api
                .patch(study, json!({"reject_at_control_errors": 2}))
                .await;
            assert_eq!(status, 200, "{body}");
        }
        let token = start_worker(&c, base, study, worker).await;
        pass_training(&c, base, &token, &styles, Behaviour::Honest).await;
        let done = answer_all_wrong(&c, base, &token, &styles).await;
        assert_eq!(done["status"], "completed", "{done}");
        assert_eq!(done["total"], 8, "the HIT has the edited size");
        expected.push((2, verdict.to_string()));
        assert_eq!(
            completed_hits(&api, study).await,
            expected,
            "threshold {threshold}"
        );
    }
    let (_, audit) = api
        .get(&format!("/api/v1/admin/studies/{study}/audit"))
        .await;
    let rules: Vec<&str> = audit
        .as_array()
        .expect("audit")
        .iter()
        .filter_map(|d| d["rule"].as_str())
        .collect();
    assert!(
        rules.contains(&"control_errors>=3") && rules.contains(&"control_errors>=2"),
        "{audit}"
    );

    // Once assignments exist, the HIT shape and the site are fixed, with the reason.
    for (body, field) in [
        (json!({"mturk_mode": "live"}), "mturk_mode"),
        (json!({"questions_per_hit": 10}), "questions_per_hit"),
        (json!({"controls_per_hit": 1}), "controls_per_hit"),
    ] {
        let (status, answer) = api.patch(study, body.clone()).await;
        assert_eq!(status, 409, "{body} → {answer}");
        let message = answer["error"].as_str().expect("message");
        assert!(
            message.starts_with(field) && message.contains("assignments have started"),
            "{message}"
        );
    }
    // null removes a Prolific code.
    let (status, body) = api
        .patch(study, json!({"prolific_completion_code": null}))
        .await;
    assert_eq!(status, 200, "{body}");
    assert_eq!(
        api.settings(study).await["prolific_completion_code"],
        Value::Null
    );

    // The audit trail: every change with who, when, old and new value, newest first.
    let (status, changes) = api
        .get(&format!("/api/v1/admin/studies/{study}/settings/changes"))
        .await;
    assert_eq!(status, 200, "{changes}");
    let changes = changes.as_array().expect("changes");
    // 3 + 1 (site back) + 7 + 1 (threshold back) + 1 (code removed).
    assert_eq!(changes.len(), 13, "{changes:?}");
    assert!(changes.iter().all(|c| c["actor"] == "admin:admin"
        && c["changed_at"].as_i64().is_some_and(|t| t > 0)));
    let thresholds: Vec<(&Value, &Value)> = changes
        .iter()
        .filter(|c| c["field"] == "reject_at_control_errors")
        .map(|c| (&c["old"], &c["new"]))
        .collect();
    assert_eq!(
        thresholds,
        [(&json!(3), &json!(2)), (&json!(2), &json!(3))],
        "newest first"
    );
    let description = changes
        .iter()
        .find(|c| c["field"] == "description")
        .expect("description change");
    assert_eq!(description["old"], "Compare the style of clip art.");
    assert_eq!(description["new"], "Rate the <b>style</b>, please.");

    // The study page's settings form: CSRF required, fields parsed with their names, the
    // same rules, audited like the API.
    let form_url = format!("{base}/admin/studies/{study}/settings");
    let post_form = |fields: Vec<(&'static str, &'static str)>, csrf: bool| {
        let mut fields = fields;
        if csrf {
            fields.push(("csrf", api.csrf.as_str()));
        }
        c.post(&form_url)
            .header("cookie", &api.cookie)
            .form(&fields)
            .send()
    };
    let resp = post_form(vec![("max_training_attempts", "2")], false)
        .await
        .expect("form");
    assert_eq!(resp.status().as_u16(), 403, "settings form without CSRF");
    for (fields, want, mention) in [
        (
            vec![("max_training_attempts", "lots")],
            400,
            "max_training_attempts",
        ),
        (
            vec![("exclude_workers_of", "12, x")],
            400,
            "exclude_workers_of",
        ),
        (vec![("mturk_mode", "moon")], 400, "mturk_mode"),
        (vec![("tuples", "5")], 400, "tuples"),
        (vec![("questions_per_hit", "10")], 409, "questions_per_hit"),
    ] {
        let resp = post_form(fields.clone(), true).await.expect("form");
        assert_eq!(resp.status().as_u16(), want, "{fields:?}");
        let page = resp.text().await.expect("html");
        assert!(page.contains(mention), "{fields:?}: {page}");
    }
    let resp = post_form(
        vec![
            ("max_training_attempts", "2"),
            ("blocked_workers", "BLOCKED-1\r\nBLOCKED-2\r\n"),
            ("prolific_screenout_code", " OUT7 "),
        ],
        true,
    )
    .await
    .expect("form");
    assert_eq!(resp.status().as_u16(), 303);
    let now = api.settings(study).await;
    assert_eq!(now["max_training_attempts"], 2);
    assert_eq!(now["blocked_workers"], json!(["BLOCKED-1", "BLOCKED-2"]));
    assert_eq!(now["prolific_screenout_code"], "OUT7");
    let page = admin_text(&c, &format!("{base}/admin/studies/{study}"), &api.cookie).await;
    assert!(
        page.contains("id=\"settings-fixed-now\""),
        "shape fixed: {page}"
    );
    assert!(!page.contains("name=\"questions_per_hit\""), "{page}");
    let (_, changes) = api
        .get(&format!("/api/v1/admin/studies/{study}/settings/changes"))
        .await;
    assert_eq!(changes.as_array().map(Vec::len), Some(16), "{changes}");

    // The OpenAPI document describes the edit.
    let (_, doc) = send(c.get(format!("{base}/api/v1/openapi.json"))).await;
    let path = &doc["paths"]["/api/v1/admin/studies/{study}/settings"];
    assert!(
        path.get("patch").is_some() && path.get("get").is_some(),
        "{path}"
    );
    assert!(
        doc["components"]["schemas"]["SettingsPatch"]["properties"]
            .get("reject_at_control_errors")
            .is_some()
    );
    assert!(
        doc["paths"]
            .get("/api/v1/admin/studies/{study}/settings/changes")
            .is_some()
    );

    // Blocking a worker mid-HIT ends that HIT: the answer already given stays, the next one
    // is refused, and the assignment shows as abandoned.
    let token = start_worker(&c, base, study, "midway").await;
    pass_training(&c, base, &token, &styles, Behaviour::Honest).await;
    let state = format!("{base}/api/v1/assignments/{token}");
    let answer = |q: &Value| {
        c.post(format!("{base}/api/v1/assignments/{token}/answers"))
            .json(&json!({"position": q["position"], "choice": choose(q, &styles, Behaviour::Honest)}))
    };
    let (_, st) = send(c.get(&state)).await;
    let first = st["question"].clone();
    let (status, ack) = send(answer(&first)).await;
    assert_eq!(status, 200, "{ack}");
    let (_, st) = send(c.get(&state)).await;
    let second = st["question"].clone();
    assert_ne!(second["position"], first["position"], "{st}");
    let (status, body) = api
        .patch(
            study,
            json!({"blocked_workers": ["BLOCKED-1", "BLOCKED-2", "midway"]}),
        )
        .await;
    assert_eq!(status, 200, "{body}");
    let (status, body) = send(answer(&second)).await;
    assert_eq!(status, 409, "an answer after the block: {body}");
    let (status, st) = send(c.get(&state)).await;
    assert_eq!((status, &st["status"]), (200, &json!("abandoned")), "{st}");
    let (_, rows) = api
        .get(&format!("/api/v1/admin/studies/{study}/workers"))
        .await;
    let ended: Vec<&Value> = rows
        .as_array()
        .expect("rows")
        .iter()
        .filter(|r| r["status"] == "abandoned")
        .collect();
    assert_eq!(
        ended.len(),
        1,
        "only the blocked worker's HIT ended: {rows}"
    );
    assert_eq!(
        ended[0]["answered"], 1,
        "the answer given before the block stays: {rows}"
    );
}

both_databases!(edit_settings, edit_settings_sqlite, edit_settings_postgres);

/// `platform study edit`: flags and a settings file, list flags that add and remove, the same
/// refusals as the API, audited as `cli`.
async fn edit_settings_cli(db: TestDb) {
    let study = setup_study(&db, &StudyOpts::default());
    let id = study.to_string();
    let edit = |extra: &[&str]| {
        let mut args = vec!["study", "edit", "--database-url", &db.url, &id];
        args.extend_from_slice(extra);
        platform_cmd(&args, &[])
    };
    let out = edit(&[
        "--reasons-probability",
        "0.25",
        "--block-worker",
        "W-A",
        "--block-worker",
        "W-B",
        "--description",
        "Edited on the command line.",
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("reasons_probability: 0.1 -> 0.25"),
        "{stdout}"
    );
    assert!(
        stdout.contains(r#"blocked_workers: [] -> ["W-A","W-B"]"#),
        "{stdout}"
    );
    let out = edit(&["--unblock-worker", "W-A"]);
    assert!(out.status.success());
    // The same values again: no change.
    let out = edit(&["--reasons-probability", "0.25"]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("no change"));
    // Refusals: the pool's fields (from a settings file) and invalid values.
    let dir = tempfile::tempdir().expect("temp dir");
    let file = dir.path().join("patch.json");
    std::fs::write(&file, r#"{"tuples": 3}"#).expect("write patch");
    let file = file.to_string_lossy().into_owned();
    for (args, mention) in [
        (
            vec!["--settings-json", file.as_str()],
            "tuples: cannot change",
        ),
        (vec!["--reasons-probability", "2"], "reasons_probability"),
    ] {
        let out = edit(&args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} should fail");
        assert!(stderr.contains(mention), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
    }
    // What the server shows.
    let server = Server::start(&db.url);
    let c = client();
    let (cookie, csrf) = admin_login(&c, &server.base).await;
    let api = AdminApi {
        c: &c,
        base: &server.base,
        cookie,
        csrf,
    };
    let settings = api.settings(study).await;
    assert_eq!(settings["reasons_probability"], 0.25);
    assert_eq!(settings["blocked_workers"], json!(["W-B"]));
    assert_eq!(settings["description"], "Edited on the command line.");
    assert_eq!(settings["tuples"], 200);
    let (_, changes) = api
        .get(&format!("/api/v1/admin/studies/{study}/settings/changes"))
        .await;
    let changes = changes.as_array().expect("changes");
    assert_eq!(changes.len(), 4, "{changes:?}");
    assert!(changes.iter().all(|c| c["actor"] == "cli"));
    let (status, body) = send(
        c.post(format!("{}/api/v1/studies/{study}/start", server.base))
            .json(&json!({"source": "direct", "worker_id": "W-B"})),
    )
    .await;
    assert_eq!(status, 403, "a worker blocked on the command line: {body}");
}

both_databases!(
    edit_settings_cli,
    edit_settings_cli_sqlite,
    edit_settings_cli_postgres
);
