//! The study page's forms (settings, QC, decision, block, bonus, train): a refused input
//! re-renders the page with the error next to the form and what the admin typed kept, with the
//! error's status; nothing is changed. A request without the CSRF token stays refused plainly.

use e2e::both_databases;
use e2e::platform::*;
use serde_json::json;

use super::*;

/// Checks that `page` is the whole study page and that section `id` shows `error` (an
/// element with class `form-error` containing `mention`); returns the section.
fn inline_error<'p>(page: &'p str, id: &str, mention: &str) -> &'p str {
    assert!(
        page.contains("<nav class=\"study-nav\""),
        "not the study page: {page}"
    );
    let part = section(page, id);
    let error = part
        .split("class=\"form-error\"")
        .nth(1)
        .unwrap_or_else(|| panic!("no error in section {id}: {part}"));
    let error = error.split("</p>").next().unwrap_or_default();
    assert!(
        error.contains(mention),
        "{id}: {error:?} should mention {mention}"
    );
    part
}

async fn study_page_forms_show_errors_inline(db: TestDb) {
    let opts = StudyOpts {
        questions: 8,
        controls: 2,
        extra: json!({"reasons_probability": 0.0}),
        ..StudyOpts::default()
    };
    let study = setup_study(&db, &opts);
    let server = Server::start(&db.url);
    let c = client();
    let admin = Admin::login(&c, &server.base).await;
    let path = |p: &str| format!("/admin/studies/{study}/{p}");

    // Train before any answer: refused next to the train form, λ kept.
    let (status, page, _) = admin.form(&path("train"), &[("lambda", "0.5")]).await;
    assert_eq!(status, 409, "{page}");
    let part = inline_error(&page, "style-metric", "no answers");
    assert!(
        part.contains("name=\"lambda\"") && part.contains("value=\"0.5\""),
        "{part}"
    );
    let (status, page, _) = admin.form(&path("train"), &[("lambda", "abc")]).await;
    assert_eq!(status, 400);
    let part = inline_error(&page, "style-metric", "λ");
    assert!(part.contains("value=\"abc\""), "{part}");

    let s = Study {
        c: &c,
        base: &server.base,
        id: study,
        styles: item_styles(&db.url).await,
    };
    run_worker(&s, direct("DONE-1"), Run::Honest, "").await;
    run_worker(&s, direct("TRAIN-1"), Run::Start, "").await;
    let rows = admin.workers(study).await;
    let done = rows["DONE-1"]["assignment"].as_i64().expect("assignment");
    let training = rows["TRAIN-1"]["assignment"].as_i64().expect("assignment");

    // Settings: the error above the form, every field as typed, nothing saved.
    let (status, page, _) = admin
        .form(
            &path("settings"),
            &[
                ("description", "Kept <description>"),
                ("max_training_attempts", "4"),
                ("exclude_workers_of", "12, x"),
                ("blocked_workers", "KEPT-1\r\nKEPT-2"),
            ],
        )
        .await;
    assert_eq!(status, 400);
    let part = inline_error(&page, "settings", "exclude_workers_of");
    for kept in [
        "Kept &#60;description&#62;</textarea>",
        "name=\"max_training_attempts\" type=\"number\" min=\"1\" max=\"100\" value=\"4\"",
        "name=\"exclude_workers_of\" value=\"12, x\"",
        "KEPT-1\nKEPT-2</textarea>",
    ] {
        assert!(part.contains(kept), "{kept} not kept: {part}");
    }
    let settings = admin
        .json(&format!("/api/v1/admin/studies/{study}/settings"))
        .await;
    assert_eq!(settings["description"], "Compare the style of clip art.");
    assert_eq!(settings["blocked_workers"], json!([]));
    let (status, page, _) = admin.form(&path("settings"), &[("tuples", "5")]).await;
    assert_eq!(status, 400);
    inline_error(&page, "settings", "tuples");

    // QC: the threshold as typed.
    for threshold in ["0", "many"] {
        let (status, page, _) = admin
            .form(
                &path("qc"),
                &[("threshold", threshold), ("mode", "dry_run")],
            )
            .await;
        assert_eq!(status, 400, "{threshold}");
        let part = inline_error(&page, "quality-control", "threshold");
        assert!(part.contains(&format!("value=\"{threshold}\"")), "{part}");
    }

    // The forms of a worker's row: the error in that row.
    let (status, page, _) = admin
        .form(
            &path("decision"),
            &[
                ("assignment", &training.to_string()),
                ("decision", "approved"),
            ],
        )
        .await;
    assert_eq!(status, 409);
    inline_error(&page, "workers-section", "only completed");
    assert!(row(&page, training).contains("class=\"form-error\""));
    assert!(!row(&page, done).contains("class=\"form-error\""));
    let (status, page, _) = admin
        .form(
            &path(&format!("workers/{done}/block")),
            &[("action", "explode")],
        )
        .await;
    assert_eq!(status, 400);
    assert!(row(&page, done).contains("action: block or unblock"));
    let (status, page, _) = admin
        .form(
            &path(&format!("workers/{done}/bonus")),
            &[("amount", "12,50"), ("reason", "Kept \"reason\"")],
        )
        .await;
    assert_eq!(status, 400);
    let html = row(&page, done);
    assert!(html.contains("<details class=\"bonus\" open>"), "{html}");
    assert!(
        html.contains("value=\"12,50\"") && html.contains("value=\"Kept &#34;reason&#34;\""),
        "{html}"
    );
    assert!(html.contains("amount:"), "{html}");
    let (status, page, _) = admin
        .form(
            &path(&format!("workers/{training}/bonus")),
            &[("amount", "1"), ("reason", "Early")],
        )
        .await;
    assert_eq!(status, 409);
    assert!(row(&page, training).contains("still training"), "{page}");
    let bonuses = admin
        .json(&format!("/api/v1/admin/studies/{study}/bonuses"))
        .await;
    assert_eq!(bonuses, json!([]), "nothing recorded");
    // A worker-row form naming no row of this study: the error above the table.
    let (status, page, _) = admin
        .form(
            &path("decision"),
            &[("assignment", "7"), ("decision", "approved")],
        )
        .await;
    assert_eq!(status, 404);
    let part = section(&page, "workers-section");
    assert!(part.contains("id=\"workers-error\""), "{part}");

    // Without the CSRF token the request is refused plainly (it is not the admin's input).
    let resp = c
        .post(format!("{}{}", server.base, path("qc")))
        .header("cookie", &admin.cookie)
        .form(&[("threshold", "0"), ("mode", "dry_run")])
        .send()
        .await
        .expect("post");
    assert_eq!(resp.status().as_u16(), 403);
    assert!(!resp.text().await.expect("body").contains("study-nav"));
}
both_databases!(
    study_page_forms_show_errors_inline,
    study_page_forms_show_errors_inline_sqlite,
    study_page_forms_show_errors_inline_postgres
);
