//! Every worker page on a phone (Chromium's device emulation at 390×844 and 360×740, the widths
//! of common phones), and the admin pages there too: nothing may stick out sideways (the
//! document is never wider than the screen) and both candidates of a question are fully on
//! screen. On the way, the consent step, the instructions with their worked example, the
//! practice feedback with the right answers, the reasons page showing the triplet, the
//! Prolific end page and the no-consent end page are checked as a participant sees them.
//! Screenshots are kept under `target/e2e-artifacts/platform-phone/`.

use std::collections::HashMap;

use e2e::browser::*;
use e2e::platform::*;
use e2e::workspace_root;
use fantoccini::{Client, Locator};
use serde_json::{Value, json};

/// Asserts that the page fits the screen: the document is no wider than the viewport.
pub(crate) async fn assert_fits(c: &Client, page: &str) {
    let v = c
        .execute(
            "const w = document.documentElement.clientWidth; \
             const wide = Array.from(document.querySelectorAll('body *')) \
               .filter(e => { const r = e.getBoundingClientRect(); \
                 return r.width > 0 && (r.right > w + 1 || r.left < -1); }) \
               .filter(e => !e.closest('table')) \
               .map(e => e.tagName.toLowerCase() + (e.id ? '#' + e.id : '') + \
                 (e.className ? '.' + e.className : '') + ' ' + \
                 Math.round(e.getBoundingClientRect().left) + '..' + \
                 Math.round(e.getBoundingClientRect().right)); \
             return [document.documentElement.scrollWidth, w, window.innerWidth, wide.slice(0, 8)];",
            vec![],
        )
        .await
        .expect("measure the page");
    let (scroll, client_width) = (v[0].as_i64().expect("px"), v[1].as_i64().expect("px"));
    assert!(
        scroll <= client_width,
        "{page}: the document is {scroll} px wide on a {client_width} px screen; sticking out: {}",
        v[3]
    );
    assert_eq!(
        v[3].as_array().map(Vec::len),
        Some(0),
        "{page}: elements outside the screen: {}",
        v[3]
    );
}

/// Asserts that an element is entirely inside the screen horizontally.
async fn assert_on_screen(c: &Client, css: &str) {
    let v = c
        .execute(
            "const r = document.querySelector(arguments[0]).getBoundingClientRect(); \
             return [r.left, r.right, document.documentElement.clientWidth];",
            vec![json!(css)],
        )
        .await
        .expect("measure");
    let (left, right, w) = (
        v[0].as_f64().expect("px"),
        v[1].as_f64().expect("px"),
        v[2].as_f64().expect("px"),
    );
    assert!(
        left >= 0.0 && right <= w,
        "{css} spans {left}..{right} on a {w} px screen"
    );
}

pub(crate) async fn click(c: &Client, css: &str) {
    mark(c).await;
    c.find(Locator::Css(css))
        .await
        .unwrap_or_else(|e| panic!("{css}: {e}"))
        .click()
        .await
        .unwrap_or_else(|e| panic!("click {css}: {e}"));
    wait_navigated(c).await;
}

async fn text(c: &Client, css: &str) -> String {
    c.find(Locator::Css(css))
        .await
        .unwrap_or_else(|e| panic!("{css}: {e}"))
        .text()
        .await
        .expect("text")
}

/// The practice questions on the page: (radio name, left id, right id, reference id).
async fn practice(c: &Client) -> Vec<(String, i64, i64, i64)> {
    let v = c
        .execute(
            "return Array.from(document.querySelectorAll('.training-q')).map(q => { \
               const r = q.querySelectorAll('input[type=radio]'); \
               return [r[0].name, Number(r[0].value), Number(r[1].value), \
                 q.querySelector('.reference img').getAttribute('src')]; });",
            vec![],
        )
        .await
        .expect("read practice questions");
    v.as_array()
        .expect("questions")
        .iter()
        .map(|q| {
            (
                q[0].as_str().expect("name").to_string(),
                q[1].as_i64().expect("id"),
                q[2].as_i64().expect("id"),
                id_from_src(q[3].as_str().expect("src")),
            )
        })
        .collect()
}

async fn answer_practice(c: &Client, styles: &HashMap<i64, String>, right: bool) {
    for (name, l, r, reference) in practice(c).await {
        let q = json!({"reference": {"id": reference}, "left": {"id": l}, "right": {"id": r}});
        let good = choose(&q, styles, Behaviour::Honest);
        let pick = if right {
            good
        } else if good == l {
            r
        } else {
            l
        };
        c.find(Locator::Css(&format!("input[name={name}][value='{pick}']")))
            .await
            .expect("radio")
            .click()
            .await
            .expect("tick");
    }
    click(c, "#submit-training").await;
}

/// A participant's whole visit on a phone of `width` × `height`.
async fn visit(
    width: u32,
    height: u32,
    server: &Server,
    study: i64,
    styles: &HashMap<i64, String>,
) {
    let profile = tempfile::tempdir().expect("profile dir");
    let Some((driver, c)) = browser(profile.path(), Viewport::Phone(width, height)).await else {
        return;
    };
    let shots = workspace_root().join(format!("target/e2e-artifacts/platform-phone/{width}"));
    std::fs::create_dir_all(&shots).expect("artifacts dir");
    let pid = format!("5f{width}a0b1c2d3e4f5a6b7c8d9e0");

    // Start page: instructions (Markdown with a library image), worked example, consent.
    c.goto(&server.url(&format!(
        "/s/{study}?PROLIFIC_PID={pid}&STUDY_ID=st{width}&SESSION_ID=se{width}"
    )))
    .await
    .expect("start page");
    shot(&c, &shots, "01-start.png").await;
    assert_fits(&c, "start").await;
    let instructions = c
        .find(Locator::Css("#instructions"))
        .await
        .expect("instructions")
        .html(true)
        .await
        .expect("html");
    assert!(
        instructions.contains("<strong>"),
        "Markdown: {instructions}"
    );
    assert!(
        instructions.contains("&lt;b&gt;raw&lt;/b&gt;"),
        "raw HTML is shown as text: {instructions}"
    );
    c.find(Locator::Css("#instructions img[src^='/media/items/']"))
        .await
        .expect("the instructions show a library item");
    c.find(Locator::Css("#worked-example figure.answer"))
        .await
        .expect("the worked example marks the answer");
    assert!(
        text(&c, "#consent")
            .await
            .contains("You may stop at any time")
    );
    // The consent box is required: the start button alone does not start.
    let required = attr(&c, "#consent-agree", "required").await;
    assert!(!required.is_empty(), "the consent checkbox is required");
    c.find(Locator::Id("consent-agree"))
        .await
        .expect("consent box")
        .click()
        .await
        .expect("tick");
    click(&c, "#start").await;

    // Practice: a wrong attempt shows the right answers and new practice triplets.
    assert_fits(&c, "practice").await;
    shot(&c, &shots, "02-practice.png").await;
    let first: Vec<_> = practice(&c).await.iter().map(|q| (q.1, q.2)).collect();
    answer_practice(&c, styles, false).await;
    c.find(Locator::Css("#training-feedback figure.answer"))
        .await
        .expect("feedback shows the right answers");
    assert_fits(&c, "practice feedback").await;
    shot(&c, &shots, "03-practice-feedback.png").await;
    let second: Vec<_> = practice(&c).await.iter().map(|q| (q.1, q.2)).collect();
    assert_ne!(first, second, "a retry draws other practice triplets");
    answer_practice(&c, styles, true).await;

    // Questions, the questionnaire (showing the triplet and the choice), the end page.
    let mut answered = 0;
    loop {
        if c.find(Locator::Id("answer-form")).await.is_ok() {
            assert_fits(&c, "question").await;
            assert_on_screen(&c, "#left").await;
            assert_on_screen(&c, "#right").await;
            if answered == 0 {
                shot(&c, &shots, "04-question.png").await;
                // A fast double input (tap left, then right before the page changes): the
                // first one is the answer.
                let url = c.current_url().await.expect("url");
                let token = url.path().trim_start_matches("/a/").to_string();
                let position: i64 = attr(&c, "input[name=position]", "value")
                    .await
                    .parse()
                    .expect("position");
                let left: i64 = attr(&c, "#left", "value").await.parse().expect("id");
                mark(&c).await;
                c.execute(
                    "document.getElementById('left').click(); \
                     document.getElementById('right').click(); return null;",
                    vec![],
                )
                .await
                .expect("double input");
                wait_navigated(&c).await;
                assert_eq!(stored_choice(&server.db_url, &token, position).await, left);
            } else {
                click(&c, "#left").await;
            }
            answered += 1;
        } else if c.find(Locator::Id("reasons-form")).await.is_ok() {
            assert_fits(&c, "reasons").await;
            c.find(Locator::Css("#reasons-triplet figure.chosen"))
                .await
                .expect("the questionnaire shows the chosen picture");
            shot(&c, &shots, "05-reasons.png").await;
            click(&c, "#send-reasons").await;
        } else {
            break;
        }
        assert!(answered <= 4, "more questions than the HIT holds");
    }
    assert_fits(&c, "done (Prolific)").await;
    shot(&c, &shots, "06-done-prolific.png").await;
    assert_eq!(text(&c, "#prolific-code").await, "PROLIFICOK1");
    let refresh = c
        .execute(
            "const m = document.querySelector('meta[http-equiv=refresh]'); \
             return m ? m.getAttribute('content') : null;",
            vec![],
        )
        .await
        .expect("meta");
    assert!(
        refresh
            .as_str()
            .is_some_and(|r| r.contains("app.prolific.com/submissions/complete?cc=PROLIFICOK1")),
        "automatic redirect to Prolific: {refresh}"
    );
    assert!(
        text(&c, "#reference-code")
            .await
            .contains("you do not need to enter it")
    );

    // A participant who does not consent.
    c.goto(&server.url(&format!("/s/{study}?participant=decline-{width}")))
        .await
        .expect("start page");
    click(&c, "#decline").await;
    assert_fits(&c, "declined").await;
    assert_eq!(attr(&c, "#done-page", "data-status").await, "declined");
    shot(&c, &shots, "07-declined.png").await;

    // Reopening the link mid-HIT, the MTurk preview and end page, an error page.
    let http = client();
    let token = api_start(
        &http,
        server,
        study,
        json!({"source": "mturk",
        "worker_id": format!("MT{width}"), "assignment_id": format!("AS{width}"),
        "hit_id": "HIT1", "turk_submit_to": "https://workersandbox.mturk.com"}),
    )
    .await;
    pass_training(&http, &server.base, &token, styles, Behaviour::Honest).await;
    c.goto(&server.url(&format!(
        "/s/{study}?assignmentId=AS{width}&hitId=HIT1&workerId=MT{width}\
         &turkSubmitTo=https://workersandbox.mturk.com"
    )))
    .await
    .expect("reopened link");
    assert!(
        text(&c, "#resume-notice")
            .await
            .contains("Continue where you left off")
    );
    assert_fits(&c, "start (resume)").await;
    answer_all(&http, &server.base, &token, styles, Behaviour::Honest).await;
    c.goto(&server.url(&format!("/a/{token}")))
        .await
        .expect("end page");
    assert_fits(&c, "done (MTurk)").await;
    c.find(Locator::Id("mturk-submit"))
        .await
        .expect("MTurk form");
    c.goto(&server.url(&format!(
        "/s/{study}?assignmentId=ASSIGNMENT_ID_NOT_AVAILABLE&hitId=HIT1\
         &turkSubmitTo=https://workersandbox.mturk.com"
    )))
    .await
    .expect("preview");
    assert_fits(&c, "MTurk preview").await;
    c.goto(&server.url(&format!("/a/{}", "0".repeat(32))))
        .await
        .expect("error page");
    assert_fits(&c, "error page").await;

    let violations = csp_violations(&c, &driver).await;
    assert!(violations.is_empty(), "worker pages: {violations:?}");

    // The admin pages do not overflow either (their tables scroll inside themselves).
    c.goto(&server.url("/admin/login")).await.expect("login");
    assert_fits(&c, "admin login").await;
    c.find(Locator::Id("username"))
        .await
        .expect("user")
        .send_keys("admin")
        .await
        .expect("type");
    c.find(Locator::Id("password"))
        .await
        .expect("password")
        .send_keys(ADMIN_PASSWORD)
        .await
        .expect("type");
    click(&c, "#login").await;
    assert_fits(&c, "admin studies").await;
    c.goto(&server.url(&format!("/admin/studies/{study}")))
        .await
        .expect("study page");
    assert_fits(&c, "admin study page").await;
    shot(&c, &shots, "08-admin-study.png").await;
    c.close().await.expect("close");
}

/// The item chosen at `position` of the assignment with `token`, as stored.
async fn stored_choice(db_url: &str, token: &str, position: i64) -> i64 {
    sqlx::any::install_default_drivers();
    let pool = sqlx::AnyPool::connect(db_url).await.expect("connect");
    let (choice, b, c): (String, i64, i64) = sqlx::query_as(
        "SELECT q.choice, t.b, t.c FROM questions q JOIN tuples t ON t.id = q.tuple_id \
         JOIN assignments a ON a.id = q.assignment_id WHERE a.token = $1 AND q.position = $2",
    )
    .bind(token)
    .bind(position)
    .fetch_one(&pool)
    .await
    .expect("the answer is stored");
    pool.close().await;
    if choice == "b" { b } else { c }
}

/// Starts a participant through the JSON API (consenting); returns the token.
async fn api_start(http: &reqwest::Client, server: &Server, study: i64, mut req: Value) -> String {
    req["consent"] = json!(true);
    let (status, body) = send(
        http.post(server.url(&format!("/api/v1/studies/{study}/start")))
            .json(&req),
    )
    .await;
    assert_eq!(status, 200, "start: {body}");
    body["token"].as_str().expect("token").to_string()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_worker_page_fits_a_phone() {
    if tool("chromium").is_none() && std::env::var("CI").is_err() {
        eprintln!("chromium not installed: skipping the phone test");
        return;
    }
    let db = sqlite_db();
    let study = setup_study(
        &db,
        &StudyOpts {
            questions: 4,
            controls: 1,
            extra: json!({
                "reasons_probability": 1.0,
                "prolific_completion_code": "PROLIFICOK1",
                "instructions": "Choose by **style**, not by subject. <b>raw</b>\n\n\
                                 ![an example picture](item:noto/dog-face.svg)",
                "consent": "## Information\n\nThis study asks you to compare pictures. \
                            You may stop at any time.",
            }),
            ..StudyOpts::default()
        },
    );
    let server = Server::start(&db.url);
    let styles = item_styles(&db.url).await;
    visit(390, 844, &server, study, &styles).await;
    visit(360, 740, &server, study, &styles).await;
}
