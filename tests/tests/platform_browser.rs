//! The complete worker flow and the admin flow in real Chromium (Debian's chromium and
//! chromium-driver over WebDriver). Screenshots are kept under `target/e2e-artifacts/`.

use std::collections::HashMap;
use std::time::Duration;

use e2e::browser::*;
use e2e::platform::*;
use e2e::workspace_root;
use fantoccini::{Client, Locator};
use serde_json::json;

fn honest(reference: i64, left: i64, right: i64, styles: &HashMap<i64, String>) -> i64 {
    let q = json!({"reference": {"id": reference}, "left": {"id": left}, "right": {"id": right}});
    choose(&q, styles, Behaviour::Honest)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn worker_and_admin_flows_in_chromium() {
    let profile = tempfile::tempdir().expect("profile dir");
    let Some((driver, c)) = browser(profile.path(), Viewport::Desktop).await else {
        return;
    };
    let artifacts = workspace_root().join("target/e2e-artifacts/platform-browser");
    std::fs::create_dir_all(&artifacts).expect("artifacts dir");
    let db = sqlite_db();
    let study = setup_study(
        &db,
        &StudyOpts {
            questions: 6,
            controls: 1,
            extra: json!({"reasons_probability": 0.5}),
            ..StudyOpts::default()
        },
    );
    let server = Server::start(&db.url);
    let styles = item_styles(&db.url).await;

    // Start page with optional demographics.
    c.goto(&server.url(&format!("/s/{study}?participant=browser-1")))
        .await
        .expect("start page");
    shot(&c, &artifacts, "01-start.png").await;
    c.find(Locator::Css("select[name=art_experience]"))
        .await
        .expect("select")
        .select_by_value("some")
        .await
        .expect("choose");
    mark(&c).await;
    c.find(Locator::Id("start"))
        .await
        .expect("start")
        .click()
        .await
        .expect("click");
    wait_navigated(&c).await;

    // Training: a wrong attempt shows feedback, then the right answers pass the gate.
    for attempt in 0..2 {
        c.wait()
            .for_element(Locator::Id("training-form"))
            .await
            .expect("training page");
        let questions = c
            .find_all(Locator::Css(".training-q"))
            .await
            .expect("questions");
        for q in &questions {
            let imgs = q.find_all(Locator::Css("img")).await.expect("imgs");
            let reference =
                id_from_src(&imgs[0].attr("src").await.expect("src").unwrap_or_default());
            let radios = q
                .find_all(Locator::Css("input[type=radio]"))
                .await
                .expect("radios");
            let l: i64 = radios[0]
                .attr("value")
                .await
                .expect("v")
                .unwrap_or_default()
                .parse()
                .expect("id");
            let r: i64 = radios[1]
                .attr("value")
                .await
                .expect("v")
                .unwrap_or_default()
                .parse()
                .expect("id");
            let right = honest(reference, l, r, &styles);
            let pick = if attempt == 0 {
                if right == l { 1 } else { 0 }
            } else if right == l {
                0
            } else {
                1
            };
            radios[pick].click().await.expect("radio");
        }
        if attempt == 0 {
            shot(&c, &artifacts, "02-training.png").await;
        }
        mark(&c).await;
        c.find(Locator::Id("submit-training"))
            .await
            .expect("submit")
            .click()
            .await
            .expect("click");
        wait_navigated(&c).await;
        if attempt == 0 {
            c.wait()
                .for_element(Locator::Id("training-feedback"))
                .await
                .expect("feedback");
            shot(&c, &artifacts, "03-training-feedback.png").await;
        }
    }

    // Questions: by click and by keyboard; the questionnaire when it appears.
    let mut n = 0;
    let mut saw_reasons = false;
    loop {
        c.wait()
            .for_element(Locator::Css("h1, #progress"))
            .await
            .expect("page");
        if c.find(Locator::Id("answer-form")).await.is_ok() {
            let reference = id_from_src(&attr(&c, ".reference img", "src").await);
            let l: i64 = attr(&c, "#left", "value").await.parse().expect("left id");
            let r: i64 = attr(&c, "#right", "value").await.parse().expect("right id");
            let pick = honest(reference, l, r, &styles);
            if n == 0 {
                shot(&c, &artifacts, "04-question.png").await;
                // The style sheet is a file now (the CSP allows no inline style): it applied.
                let width = c
                    .execute("return getComputedStyle(document.body).maxWidth;", vec![])
                    .await
                    .expect("script");
                assert_eq!(width, json!("1100px"), "style.css did not apply");
            }
            mark(&c).await;
            if n % 2 == 0 {
                let id = if pick == l { "left" } else { "right" };
                c.find(Locator::Id(id))
                    .await
                    .expect("option")
                    .click()
                    .await
                    .expect("click");
            } else {
                let key = if pick == l { "1" } else { "2" };
                c.find(Locator::Css("body"))
                    .await
                    .expect("body")
                    .send_keys(key)
                    .await
                    .expect("key");
            }
            n += 1;
            wait_navigated(&c).await;
        } else if c.find(Locator::Id("reasons-form")).await.is_ok() {
            if !saw_reasons {
                shot(&c, &artifacts, "05-reasons.png").await;
            }
            saw_reasons = true;
            c.find(Locator::Css("input[value=shading_flat]"))
                .await
                .expect("box")
                .click()
                .await
                .expect("click");
            c.find(Locator::Css("input[name=text]"))
                .await
                .expect("text")
                .send_keys("flat colours")
                .await
                .expect("type");
            mark(&c).await;
            c.find(Locator::Id("send-reasons"))
                .await
                .expect("send")
                .click()
                .await
                .expect("click");
            wait_navigated(&c).await;
        } else if c.find(Locator::Id("code")).await.is_ok() {
            break;
        } else {
            panic!("unexpected page: {}", c.source().await.unwrap_or_default());
        }
        assert!(n <= 6, "more questions than the HIT has");
    }
    assert_eq!(n, 6);
    let code = c
        .find(Locator::Id("code"))
        .await
        .expect("code")
        .text()
        .await
        .expect("text");
    assert_eq!(code.len(), 12, "completion code {code:?}");
    shot(&c, &artifacts, "06-done.png").await;
    // Reload: still done, same code (resume).
    c.refresh().await.expect("reload");
    let again = c
        .find(Locator::Id("code"))
        .await
        .expect("code")
        .text()
        .await
        .expect("text");
    assert_eq!(again, code);
    let violations = csp_violations(&c, &driver).await;
    assert!(violations.is_empty(), "worker pages: {violations:?}");

    // Admin: login, study list, dashboard with this worker.
    c.goto(&server.url("/admin/login"))
        .await
        .expect("login page");
    c.find(Locator::Id("username"))
        .await
        .expect("user")
        .send_keys("admin")
        .await
        .expect("type");
    c.find(Locator::Id("password"))
        .await
        .expect("pass")
        .send_keys(ADMIN_PASSWORD)
        .await
        .expect("type");
    c.find(Locator::Id("login"))
        .await
        .expect("login")
        .click()
        .await
        .expect("click");
    c.wait()
        .for_element(Locator::Id("studies"))
        .await
        .expect("studies");
    shot(&c, &artifacts, "07-admin-studies.png").await;
    c.find(Locator::Css("#studies a"))
        .await
        .expect("study link")
        .click()
        .await
        .expect("click");
    c.wait()
        .for_element(Locator::Id("workers"))
        .await
        .expect("dashboard");
    let table = c
        .find(Locator::Id("workers"))
        .await
        .expect("workers")
        .text()
        .await
        .expect("text");
    assert!(
        table.contains("completed") && table.contains("approved"),
        "{table}"
    );
    c.find(Locator::Id("qc-dry"))
        .await
        .expect("dry run")
        .click()
        .await
        .expect("click");
    c.wait()
        .for_element(Locator::Id("qc-result"))
        .await
        .expect("qc result");
    shot(&c, &artifacts, "08-admin-dashboard.png").await;

    // The dashboard is live: answers given elsewhere appear without a reload.
    c.goto(&server.url(&format!("/admin/studies/{study}?refresh=1")))
        .await
        .expect("live dashboard");
    let answers_cell = || async {
        c.find(Locator::Css("[data-k=answers]"))
            .await
            .expect("answers cell")
            .text()
            .await
            .expect("text")
    };
    let before: i64 = answers_cell().await.parse().expect("answer count");
    mark(&c).await;
    let http = client();
    // The worker table is live too: a new worker's row appears while they answer and turns
    // into a completed HIT with the override buttons, all without a reload.
    let rows_before = worker_rows(&c).await;
    assert_eq!(rows_before.len(), 1, "{rows_before:?}");
    let token = start_worker(&http, &server.base, study, "api-0").await;
    pass_training(&http, &server.base, &token, &styles, Behaviour::Honest).await;
    let active = wait_rows(&c, |r| {
        r.len() == 2 && r.iter().any(|w| w.status == "active")
    })
    .await;
    let new_row = active
        .iter()
        .find(|w| !rows_before.iter().any(|b| b.assignment == w.assignment))
        .expect("the new worker's row")
        .clone();
    assert_eq!(new_row.answered, "0/6", "{new_row:?}");
    assert_eq!(
        new_row.buttons, 0,
        "no override before the HIT is completed"
    );
    answer_all(&http, &server.base, &token, &styles, Behaviour::Honest).await;
    let done = wait_rows(&c, |r| {
        r.iter()
            .any(|w| w.assignment == new_row.assignment && w.status == "completed")
    })
    .await;
    let row = done
        .iter()
        .find(|w| w.assignment == new_row.assignment)
        .expect("row");
    assert_eq!(
        (row.answered.as_str(), row.decision.as_str(), row.buttons),
        ("6/6", "approved", 2),
        "{row:?}"
    );
    for i in 1..4 {
        let token = start_worker(&http, &server.base, study, &format!("api-{i}")).await;
        pass_training(&http, &server.base, &token, &styles, Behaviour::Honest).await;
        answer_all(&http, &server.base, &token, &styles, Behaviour::Honest).await;
    }
    let expected = before + 4 * 5;
    let mut seen = before;
    for _ in 0..100 {
        seen = answers_cell().await.parse().expect("answer count");
        if seen == expected {
            break;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    assert_eq!(seen, expected, "the live dashboard did not update");
    let same_document = c
        .execute("return window.__old === true;", vec![])
        .await
        .expect("script");
    assert_eq!(
        same_document,
        serde_json::Value::Bool(true),
        "updated without a reload"
    );
    let all = wait_rows(&c, |r| {
        r.len() == 5 && r.iter().all(|w| w.status == "completed")
    })
    .await;
    shot(&c, &artifacts, "09-admin-dashboard-live.png").await;
    // The worker id the live refresh wrote is masked until clicked, and stays revealed across
    // the next refreshes.
    let id_css = format!(
        "#workers tr[data-assignment=\"{}\"] details.worker-id",
        new_row.assignment
    );
    let before = worker_id_shown(&c, &id_css).await;
    assert_ne!(before[0], json!("api-0"), "masked: {before}");
    assert_eq!(
        (&before[1], &before[2]),
        (&json!(false), &json!("api-0")),
        "{before}"
    );
    c.find(Locator::Css(&format!("{id_css} summary")))
        .await
        .expect("summary")
        .click()
        .await
        .expect("reveal");
    tokio::time::sleep(Duration::from_millis(2500)).await;
    let after = worker_id_shown(&c, &id_css).await;
    assert_eq!(
        (&after[1], &after[2]),
        (&json!(true), &json!("api-0")),
        "{after}"
    );
    shot(&c, &artifacts, "09b-admin-worker-revealed.png").await;
    // The override form the script built posts with the CSRF token: reject the new worker's HIT
    // (the page reloads with the decision), then approve it again.
    assert!(all.iter().any(|w| w.assignment == new_row.assignment));
    for (button, want) in [(1, "rejected"), (0, "approved")] {
        mark(&c).await;
        // The live refresh may replace the row between finding and clicking: then find again.
        let css = format!(
            "#workers tr[data-assignment=\"{}\"] form.decision-form button",
            new_row.assignment
        );
        let mut clicked = false;
        for _ in 0..5 {
            let buttons = c.find_all(Locator::Css(&css)).await.expect("buttons");
            if buttons[button].click().await.is_ok() {
                clicked = true;
                break;
            }
        }
        assert!(clicked, "could not click the override button");
        wait_navigated(&c).await;
        let rows = worker_rows(&c).await;
        let row = rows
            .iter()
            .find(|w| w.assignment == new_row.assignment)
            .expect("row after the override");
        assert_eq!(row.decision, want, "{row:?}");
    }
    // Settings edited on the page (with its CSRF token) are saved, listed with who changed
    // them, and take effect: the blocked worker cannot start.
    c.find(Locator::Id("settings-fixed-now"))
        .await
        .expect("the HIT shape is fixed once assignments exist");
    for (css, value) in [
        ("textarea[name=description]", "Edited in the browser."),
        ("input[name=reject_at_control_errors]", "3"),
        ("textarea[name=blocked_workers]", "BROWSER-BLOCKED"),
    ] {
        let field = c.find(Locator::Css(css)).await.expect(css);
        field.clear().await.expect("clear");
        field.send_keys(value).await.expect("type");
    }
    mark(&c).await;
    c.find(Locator::Id("save-settings"))
        .await
        .expect("save")
        .click()
        .await
        .expect("click");
    wait_navigated(&c).await;
    let changes = c
        .find(Locator::Id("settings-changes"))
        .await
        .expect("changes")
        .text()
        .await
        .expect("text");
    for field in ["description", "reject_at_control_errors", "blocked_workers"] {
        assert!(
            changes
                .lines()
                .any(|l| l.contains(field) && l.contains("admin:admin")),
            "{field} not listed: {changes}"
        );
    }
    let description = c
        .find(Locator::Css("textarea[name=description]"))
        .await
        .expect("description")
        .prop("value")
        .await
        .expect("value");
    assert_eq!(description.as_deref(), Some("Edited in the browser."));
    let (status, body) = send(
        http.post(server.url(&format!("/api/v1/studies/{study}/start")))
            .json(&json!({"source": "direct", "worker_id": "BROWSER-BLOCKED"})),
    )
    .await;
    assert_eq!(status, 403, "{body}");
    shot(&c, &artifacts, "10-admin-settings.png").await;
    let violations = csp_violations(&c, &driver).await;
    assert!(violations.is_empty(), "admin pages: {violations:?}");

    // Train the style metric from the page; the model appears with its report.
    c.find(Locator::Id("train"))
        .await
        .expect("train button")
        .click()
        .await
        .expect("click");
    let mut report_link = None;
    for _ in 0..300 {
        if let Ok(a) = c.find(Locator::Css("#model-list a")).await {
            report_link = Some(a);
            break;
        }
        if let Ok(row) = c
            .find(Locator::Css("#model-list tr[data-status=failed]"))
            .await
        {
            panic!("training failed: {}", row.text().await.unwrap_or_default());
        }
        tokio::time::sleep(Duration::from_millis(200)).await;
        c.goto(&server.url(&format!("/admin/studies/{study}")))
            .await
            .expect("dashboard");
    }
    report_link
        .expect("no report link after training")
        .click()
        .await
        .expect("open report");
    c.wait()
        .for_element(Locator::Css("figure img"))
        .await
        .expect("report figure");
    let drawn = c
        .execute(
            "return Array.from(document.images).every(i => i.complete && i.naturalWidth > 100);",
            vec![],
        )
        .await
        .expect("script");
    assert_eq!(drawn, serde_json::Value::Bool(true), "report figures load");
    let title = c
        .find(Locator::Css("h1"))
        .await
        .expect("h1")
        .text()
        .await
        .expect("text");
    assert_eq!(title, "Style metric report");
    shot(&c, &artifacts, "11-admin-model-report.png").await;
    let violations = csp_violations(&c, &driver).await;
    assert!(violations.is_empty(), "model report: {violations:?}");

    // The check above can see a violation: an injected inline script is blocked and reported.
    c.goto(&server.url(&format!("/admin/studies/{study}")))
        .await
        .expect("dashboard");
    let blocked = c
        .execute(
            "const s = document.createElement('script'); s.textContent = 'window.__ran = true;'; \
             document.head.appendChild(s); return window.__ran === undefined;",
            vec![],
        )
        .await
        .expect("script");
    assert_eq!(blocked, json!(true), "the CSP let an inline script run");
    let mut seen = Vec::new();
    for _ in 0..50 {
        seen = csp_violations(&c, &driver).await;
        if !seen.is_empty() {
            break;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    assert!(
        seen.iter().any(|m| m.contains("script-src")),
        "the injected inline script was not reported: {seen:?}"
    );
    let _ = saw_reasons;
    c.close().await.expect("close");
}

/// One row of the admin page's worker table, as shown.
#[derive(Debug, Clone)]
struct WorkerRowShown {
    assignment: String,
    status: String,
    decision: String,
    answered: String,
    /// Override buttons in the row.
    buttons: u64,
}

async fn worker_rows(c: &Client) -> Vec<WorkerRowShown> {
    let rows = c
        .execute(
            "return Array.from(document.querySelectorAll('#workers tr[data-assignment]')).map(r => \
             [r.dataset.assignment, r.cells[2].textContent, r.cells[3].textContent, \
              r.cells[4].textContent, r.querySelectorAll('form.decision-form button').length]);",
            vec![],
        )
        .await
        .expect("read the worker table");
    let text = |v: &serde_json::Value| v.as_str().expect("text").to_string();
    rows.as_array()
        .expect("rows")
        .iter()
        .map(|r| WorkerRowShown {
            assignment: text(&r[0]),
            status: text(&r[1]),
            decision: text(&r[2]),
            answered: text(&r[3]),
            buttons: r[4].as_u64().expect("count"),
        })
        .collect()
}

/// Waits (up to 10 s, the page refreshing every second) until the worker table satisfies
/// `ok`, and checks that the page was not reloaded meanwhile.
async fn wait_rows(c: &Client, ok: impl Fn(&[WorkerRowShown]) -> bool) -> Vec<WorkerRowShown> {
    let mut rows = Vec::new();
    // Up to 30 s: the page refreshes every second, but CI runs the other tests beside it.
    for _ in 0..300 {
        rows = worker_rows(c).await;
        if ok(&rows) {
            let same_document = c
                .execute("return window.__old === true;", vec![])
                .await
                .expect("script");
            assert_eq!(same_document, json!(true), "the page was reloaded");
            return rows;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    panic!("the worker table did not update: {rows:?}");
}

/// The masked text, whether the full id is visible, and the full id of a worker-id cell.
async fn worker_id_shown(c: &Client, css: &str) -> serde_json::Value {
    c.execute(
        "const d = document.querySelector(arguments[0]); \
         return [d.querySelector('summary').textContent, \
                 d.querySelector('code').checkVisibility(), d.querySelector('code').textContent];",
        vec![json!(css)],
    )
    .await
    .expect("read the worker id")
}
