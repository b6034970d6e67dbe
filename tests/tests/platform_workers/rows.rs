//! The worker table: one id per worker (the crowd platform's) on every table of the page, in
//! the JSON and in the exports; block/unblock, approve/reject and bonuses from the worker's
//! row; sections with links; readable UTC times, newest first.

use e2e::both_databases;
use e2e::platform::*;
use serde_json::json;

use super::*;

const ALICE: &str = "ALICE-0001";
const PROLIFIC_PID: &str = "60ffe5c8371090c7041d43f8";
const MTURK_WORKER: &str = "A1MTURKWORKER00";
const MID_HIT: &str = "MID-HIT-77";
const TRAINEE: &str = "TRAINEE-9";

/// Whether `text` holds a dashboard pseudonym (`W` and 10 lowercase hex digits).
fn has_pseudonym(text: &str) -> bool {
    text.as_bytes().windows(11).any(|w| {
        w[0] == b'W'
            && w[1..]
                .iter()
                .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(b))
    })
}

async fn workers_are_managed_from_their_row(db: TestDb) {
    let opts = StudyOpts {
        questions: 8,
        controls: 2,
        extra: json!({"reasons_probability": 1.0}),
        ..StudyOpts::default()
    };
    let study = setup_study(&db, &opts);
    let server = Server::start(&db.url);
    let c = client();
    let s = Study {
        c: &c,
        base: &server.base,
        id: study,
        styles: item_styles(&db.url).await,
    };
    run_worker(&s, direct(ALICE), Run::Honest, "colours").await;
    run_worker(&s, prolific(PROLIFIC_PID), Run::Honest, "shapes").await;
    run_worker(&s, mturk(MTURK_WORKER, "ASG1"), Run::Honest, "lines").await;
    let mid_token = run_worker(&s, direct(MID_HIT), Run::Partly(1), "x").await;
    run_worker(&s, direct(TRAINEE), Run::Start, "").await;
    let admin = Admin::login(&c, &server.base).await;

    // Every row names the worker by their platform id, masked until clicked, and the JSON the
    // live refresh reads says the same; no pseudonym anywhere on the page.
    let rows = admin.workers(study).await;
    let ids = [ALICE, PROLIFIC_PID, MTURK_WORKER, MID_HIT, TRAINEE];
    assert_eq!(rows.len(), 5, "{rows:?}");
    let page = admin.page(study, "").await;
    for id in ids {
        let w = &rows[id];
        assert!(w.get("worker").is_none(), "no pseudonym field: {w}");
        let masked = w["worker_id_masked"].as_str().expect("masked");
        assert!(!masked.contains(id) && !masked.is_empty(), "{masked}");
        let html = row(&page, w["assignment"].as_i64().expect("assignment"));
        assert!(
            html.contains(&format!(
                "<details class=\"worker-id\"><summary title=\"Show the id\">{masked}</summary><code>{id}</code></details>"
            )),
            "{html}"
        );
        assert!(html.contains(" UTC</td>"), "readable start time: {html}");
    }
    assert!(!has_pseudonym(&page), "a pseudonym on the page");
    let assignment = |id: &str| rows[id]["assignment"].as_i64().expect("assignment");

    // Blocking from the row: the worker's open HIT ends (no further answer), they cannot start
    // or resume, and the block list holds their platform id (audited as a settings change).
    let (_, before) = send(c.get(format!("{}/api/v1/assignments/{mid_token}", server.base))).await;
    let open_question = before["question"].clone();
    assert!(open_question.is_object(), "{before}");
    let (status, _, location) = admin
        .form(
            &format!(
                "/admin/studies/{study}/workers/{}/block",
                assignment(MID_HIT)
            ),
            &[("action", "block")],
        )
        .await;
    assert_eq!(status, 303);
    assert_eq!(
        location,
        format!("/admin/studies/{study}#worker-{}", assignment(MID_HIT))
    );
    let (_, st) = send(c.get(format!("{}/api/v1/assignments/{mid_token}", server.base))).await;
    assert_eq!(st["status"], "abandoned", "{st}");
    let (status, body) = send(
        c.post(format!(
            "{}/api/v1/assignments/{mid_token}/answers",
            server.base
        ))
        .json(
            &json!({"position": open_question["position"], "choice": open_question["left"]["id"]}),
        ),
    )
    .await;
    assert!(
        status == 404 || status == 409,
        "answer after the block: {status} {body}"
    );
    let (status, body) = send(
        c.post(format!("{}/api/v1/studies/{study}/start", server.base))
            .json(&direct(MID_HIT)),
    )
    .await;
    assert_eq!(status, 403, "resume after the block: {body}");
    let settings = admin
        .json(&format!("/api/v1/admin/studies/{study}/settings"))
        .await;
    assert_eq!(settings["blocked_workers"], json!([MID_HIT]));
    let changes = admin
        .json(&format!("/api/v1/admin/studies/{study}/settings/changes"))
        .await;
    assert_eq!(changes[0]["field"], "blocked_workers");
    assert_eq!(changes[0]["actor"], "admin:admin");
    let page = admin.page(study, "").await;
    let html = row(&page, assignment(MID_HIT));
    assert!(
        html.contains("class=\"blocked\"") && html.contains("value=\"unblock\""),
        "{html}"
    );
    assert_eq!(admin.workers(study).await[MID_HIT]["blocked"], true);
    // The API does the same; blocking twice changes nothing.
    let (status, again) = admin
        .api(
            &format!(
                "/api/v1/admin/studies/{study}/assignments/{}/block",
                assignment(MID_HIT)
            ),
            json!({"blocked": true}),
        )
        .await;
    assert_eq!((status, &again["changed"]), (200, &json!(false)), "{again}");
    // Unblocking from the row lets them back in.
    let (status, _, _) = admin
        .form(
            &format!(
                "/admin/studies/{study}/workers/{}/block",
                assignment(MID_HIT)
            ),
            &[("action", "unblock")],
        )
        .await;
    assert_eq!(status, 303);
    let (status, body) = send(
        c.post(format!("{}/api/v1/studies/{study}/start", server.base))
            .json(&direct(MID_HIT)),
    )
    .await;
    assert_eq!(status, 200, "after the unblock: {body}");

    // Approve/reject from the row, audited with the worker's id, newest first, readable time.
    let (status, _, _) = admin
        .form(
            &format!("/admin/studies/{study}/decision"),
            &[
                ("assignment", &assignment(ALICE).to_string()),
                ("decision", "rejected"),
            ],
        )
        .await;
    assert_eq!(status, 303);
    let audit = admin
        .json(&format!("/api/v1/admin/studies/{study}/audit"))
        .await;
    let audit = audit.as_array().expect("audit");
    assert_eq!(
        audit.len(),
        4,
        "3 rule decisions and the override: {audit:?}"
    );
    assert_eq!(
        (&audit[0]["worker_id"], &audit[0]["rule"]),
        (&json!(ALICE), &json!("override")),
        "newest first"
    );
    assert!(
        audit
            .windows(2)
            .all(|p| p[0]["decided_at"].as_i64() >= p[1]["decided_at"].as_i64())
    );
    let page = admin.page(study, "").await;
    let trail = section(&page, "audit-section");
    let first = trail
        .split("<tr><td class=\"when\">")
        .nth(1)
        .expect("an audit row")
        .to_string();
    assert!(
        first.contains(&format!("<code>{ALICE}</code>")) && first.contains("override"),
        "{first}"
    );
    let at = first.split("</td>").next().expect("time cell");
    assert!(
        at.len() == 20 && at.ends_with(" UTC") && at.as_bytes()[4] == b'-',
        "readable UTC: {at:?}"
    );
    assert!(
        !trail
            .split(|ch: char| !ch.is_ascii_digit())
            .any(|n| n.len() >= 13),
        "Unix ms in the audit trail: {trail}"
    );

    // Bonuses from the row (amount and reason), stored with who and when.
    for (worker, amount, reason) in [
        (PROLIFIC_PID, "2.5", "Thorough answers"),
        (MTURK_WORKER, "1", "Thanks, A+ work"),
    ] {
        let (status, body, _) = admin
            .form(
                &format!(
                    "/admin/studies/{study}/workers/{}/bonus",
                    assignment(worker)
                ),
                &[("amount", amount), ("reason", reason)],
            )
            .await;
        assert_eq!(status, 303, "{body}");
    }
    let (status, api_bonus) = admin
        .api(
            &format!(
                "/api/v1/admin/studies/{study}/assignments/{}/bonuses",
                assignment(ALICE)
            ),
            json!({"amount": 0.75, "reason": "Extra"}),
        )
        .await;
    assert_eq!(
        (status, &api_bonus["amount"]),
        (200, &json!("0.75")),
        "{api_bonus}"
    );
    let bonuses = admin
        .json(&format!("/api/v1/admin/studies/{study}/bonuses"))
        .await;
    let bonuses = bonuses.as_array().expect("bonuses");
    let mut listed: Vec<(&str, &str)> = bonuses
        .iter()
        .map(|b| {
            (
                b["worker_id"].as_str().unwrap(),
                b["amount"].as_str().unwrap(),
            )
        })
        .collect();
    assert!(
        bonuses
            .windows(2)
            .all(|p| p[0]["created_at"].as_i64() >= p[1]["created_at"].as_i64()),
        "newest first: {bonuses:?}"
    );
    listed.sort();
    assert_eq!(
        listed,
        [
            (PROLIFIC_PID, "2.50"),
            (MTURK_WORKER, "1.00"),
            (ALICE, "0.75")
        ]
    );
    assert!(bonuses.iter().all(|b| b["actor"] == "admin:admin"
        && b["created_at"].as_i64().is_some_and(|t| t > 0)));
    assert_eq!(admin.workers(study).await[PROLIFIC_PID]["bonus_cents"], 250);
    let page = admin.page(study, "").await;
    let bonus_table = section(&page, "workers-section")
        .split("<table id=\"bonuses\">")
        .nth(1)
        .expect("bonus table");
    assert!(
        bonus_table.contains(&format!("<code>{MTURK_WORKER}</code>"))
            && bonus_table.contains("Thanks, A+ work")
            && bonus_table.contains(" UTC</td>"),
        "{bonus_table}"
    );

    // The payment files, in the platforms' formats (MTurk's send-bonus fields with a token
    // per bonus; Prolific's `PROLIFIC_PID,amount` lines), and the same id in every export.
    let mturk_bonus = bonuses
        .iter()
        .find(|b| b["worker_id"] == MTURK_WORKER)
        .expect("mturk bonus");
    let (_, csv) = admin.export(study, "mturk_bonuses.csv", "").await;
    assert_eq!(
        csv,
        format!(
            "WorkerId,AssignmentId,BonusAmount,Reason,UniqueRequestToken\n\
             {MTURK_WORKER},ASG1,1.00,\"Thanks, A+ work\",bonus-{}\n",
            mturk_bonus["id"]
        )
    );
    let (_, csv) = admin.export(study, "prolific_bonuses.csv", "").await;
    assert_eq!(csv, format!("{PROLIFIC_PID},2.50\n"));
    let (_, csv) = admin.export(study, "mturk_decisions.csv", "").await;
    assert!(
        csv.contains(&format!("ASG1,{MTURK_WORKER},HIT1,x,")),
        "{csv}"
    );
    for file in [
        "triplets.csv",
        "reasons.csv",
        "workers.csv",
        "assignments.csv",
        "bonuses.csv",
    ] {
        let (status, text) = admin
            .export(
                study,
                file,
                "?include_rejected=true&include_incomplete=true",
            )
            .await;
        assert_eq!(status, 200, "{file}");
        let (header, rows) = csv_table(&text, true);
        assert!(
            header.iter().any(|h| h == "worker_id"),
            "{file}: {header:?}"
        );
        assert!(!rows.is_empty(), "{file}");
        for r in &rows {
            assert!(ids.contains(&r["worker_id"].as_str()), "{file}: {r:?}");
            if let Some(w) = r.get("worker") {
                assert_eq!(w, &r["worker_id"], "{file}");
            }
        }
        assert!(!has_pseudonym(&text), "{file}: {text}");
    }
    // A pseudonymous export for sharing: pseudonyms only, no payment file.
    let (_, text) = admin
        .export(study, "workers.csv", "?pseudonymous=true")
        .await;
    let (_, rows) = csv_table(&text, true);
    assert!(!rows.is_empty());
    for r in &rows {
        let p = &r["worker_id"];
        assert!(p.len() == 11 && has_pseudonym(p), "{p}");
    }
    assert!(ids.iter().all(|id| !text.contains(id)), "{text}");
    let (status, body) = admin
        .export(study, "mturk_bonuses.csv", "?pseudonymous=true")
        .await;
    assert_eq!(status, 400, "{body}");

    // The QC dry run names the workers the same way.
    let (status, page, _) = admin
        .form(
            &format!("/admin/studies/{study}/qc"),
            &[("threshold", "1"), ("mode", "dry_run")],
        )
        .await;
    assert_eq!(status, 200);
    let result = section(&page, "quality-control");
    for id in [ALICE, PROLIFIC_PID, MTURK_WORKER] {
        assert!(result.contains(&format!("<code>{id}</code>")), "{result}");
    }
    assert!(!has_pseudonym(result));

    // Sections with a bar of links to each, and no inline script or style.
    let page = admin.page(study, "").await;
    let nav = page
        .split("<nav class=\"study-nav\"")
        .nth(1)
        .and_then(|n| n.split("</nav>").next())
        .expect("section links");
    for id in [
        "overview",
        "quality-control",
        "workers-section",
        "audit-section",
        "settings",
        "exports-section",
        "style-metric",
    ] {
        assert!(nav.contains(&format!("href=\"#{id}\"")), "no link to {id}");
        section(&page, id);
    }
    assert_no_inline_code(&page);

    // The JSON API documents what the rows post.
    let (_, doc) = send(c.get(format!("{}/api/v1/openapi.json", server.base))).await;
    for (path, method) in [
        (
            "/api/v1/admin/studies/{study}/assignments/{assignment}/block",
            "post",
        ),
        (
            "/api/v1/admin/studies/{study}/assignments/{assignment}/bonuses",
            "post",
        ),
        ("/api/v1/admin/studies/{study}/bonuses", "get"),
    ] {
        assert!(doc["paths"][path][method].is_object(), "{method} {path}");
    }
    assert!(doc["components"]["schemas"]["BonusRecord"].is_object());
    assert!(doc["components"]["schemas"]["WorkerRow"]["properties"]["worker_id"].is_object());
}
both_databases!(
    workers_are_managed_from_their_row,
    workers_are_managed_from_their_row_sqlite,
    workers_are_managed_from_their_row_postgres
);

/// No inline `<script>`, `style=` or `on…=` handler (the CSP forbids them).
fn assert_no_inline_code(page: &str) {
    for script in page.split("<script").skip(1) {
        let tag = script.split('>').next().unwrap_or_default();
        assert!(tag.contains(" src="), "inline script: <script{tag}>");
    }
    assert!(
        !page.contains("<style") && !page.contains(" style="),
        "inline style"
    );
    for tag in page.split('<').skip(1) {
        let tag = tag.split('>').next().unwrap_or_default();
        let handler = tag
            .split_whitespace()
            .skip(1)
            .any(|attr| attr.starts_with("on") && attr.contains('=') && !attr.starts_with("one"));
        assert!(!handler, "inline handler: <{tag}>");
    }
}
