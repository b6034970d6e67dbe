//! The admin forms that create a mash-up study and a composition-rating study from a mash-up
//! study's compositions: each kind created in real Chromium (no CSP violation, a refused value
//! shown again in the form), and every bad input over HTTP a 4xx with a clear message in the
//! re-shown form and nothing created, on SQLite and PostgreSQL.

use e2e::both_databases;
use e2e::platform::*;
use serde_json::Value;

use crate::platform_rating_from_mashup::{mashup_study, submit_compositions};

mod browser;

/// A form's fields as sent.
type Form = Vec<(&'static str, String)>;

async fn count(db: &TestDb, table: &'static str) -> i64 {
    let sql = match table {
        "studies" => "SELECT CAST(COUNT(*) AS BIGINT) FROM studies",
        _ => "SELECT CAST(COUNT(*) AS BIGINT) FROM items",
    };
    scalar(&db.url, sql).await
}

/// GETs the study's kind from the API.
pub(crate) async fn kind(c: &reqwest::Client, base: &str, cookie: &str, study: i64) -> Value {
    let (status, body) = send(
        c.get(format!("{base}/api/v1/admin/studies/{study}/report"))
            .header("cookie", cookie),
    )
    .await;
    assert_eq!(status, 200, "{body}");
    body["kind"].clone()
}

async fn forms_refuse_bad_input(db: TestDb) {
    let lib = small_library(3);
    import_library(&db, lib.path());
    let mashup = mashup_study(&db, "farm", 4);
    let empty = mashup_study(&db, "empty farm", 2);
    create_admin(&db.url);
    let server = Server::start(&db.url);
    let base = server.url("");
    let base = base.trim_end_matches('/').to_string();
    // One worker per condition (the first pair of the balanced sequence).
    submit_compositions(&base, mashup, 2, "w").await;
    let c = client();
    let (cookie, csrf) = admin_login(&c, &base).await;
    let (m, e) = (mashup.to_string(), empty.to_string());

    // Not logged in: the login page; no CSRF token: 403. Nothing is created either way.
    let good_mashup: Vec<(&str, &str)> = vec![
        ("name", "picnic"),
        ("library", "fx"),
        ("task", "A picnic by the lake"),
        ("background", "grass"),
        ("min_pieces", "2"),
        ("min_searches", "1"),
        ("compositions", "6"),
        ("mturk_mode", "sandbox"),
    ];
    let url = |kind: &str| format!("{base}/admin/studies/new/{kind}");
    let before = count(&db, "studies").await;
    let resp = c
        .post(url("mashup"))
        .form(&good_mashup)
        .send()
        .await
        .expect("post");
    assert_eq!(resp.status().as_u16(), 303);
    assert_eq!(resp.headers()["location"], "/admin/login");
    let resp = c
        .post(url("mashup"))
        .header("cookie", &cookie)
        .form(&good_mashup)
        .send()
        .await
        .expect("post");
    assert_eq!(resp.status().as_u16(), 403);
    assert_eq!(count(&db, "studies").await, before);
    let resp = c
        .get(url("triplet"))
        .header("cookie", &cookie)
        .send()
        .await
        .expect("get");
    assert_eq!(
        resp.status().as_u16(),
        404,
        "the triplet form is on the studies list"
    );

    let with = |base: &[(&'static str, String)], key: &'static str, value: &str| {
        let mut form: Form = vec![("csrf", csrf.clone())];
        form.extend(base.iter().filter(|(k, _)| *k != key).cloned());
        form.push((key, value.to_string()));
        form
    };
    let owned = |form: &[(&'static str, &str)]| -> Vec<(&'static str, String)> {
        form.iter().map(|(k, v)| (*k, v.to_string())).collect()
    };
    let good_mashup = owned(&good_mashup);
    let good_rating = owned(&[
        ("name", "coherence"),
        ("mashup", &m),
        ("question", "coherence"),
        ("library", ""),
        ("pairs", ""),
        ("questions_per_hit", "10"),
        ("replication", "3"),
        ("mturk_mode", "sandbox"),
    ]);
    let cases: Vec<(&str, Form, &str)> = vec![
        (
            "mashup",
            with(&good_mashup, "task", "   "),
            "task: 1..=2000 characters",
        ),
        (
            "mashup",
            with(&good_mashup, "min_pieces", "abc"),
            "Minimum pieces: &#34;abc&#34; is not a whole number",
        ),
        (
            "mashup",
            with(&good_mashup, "min_pieces", "0"),
            "min_pieces: 0 not in 1..=200",
        ),
        (
            "mashup",
            with(&good_mashup, "min_searches", "-1"),
            "Minimum searches",
        ),
        (
            "mashup",
            with(&good_mashup, "background", "moon"),
            "background: &#34;moon&#34; is not one of",
        ),
        (
            "mashup",
            with(&good_mashup, "library", "nope"),
            "no library named &#34;nope&#34;",
        ),
        (
            "mashup",
            with(&good_mashup, "compositions", "0"),
            "tuples: 0 not in",
        ),
        (
            "mashup",
            with(&good_mashup, "name", " "),
            "name: 1-200 characters",
        ),
        ("mashup", with(&good_mashup, "mturk_mode", "prod"), "MTurk"),
        (
            "composition-rating",
            with(&good_rating, "mashup", ""),
            "choose a mash-up study",
        ),
        (
            "composition-rating",
            with(&good_rating, "mashup", &e),
            "a pair needs one of each",
        ),
        (
            "composition-rating",
            with(&good_rating, "mashup", "99999"),
            "there is no study 99999",
        ),
        (
            "composition-rating",
            with(&good_rating, "question", "both"),
            "Question: &#34;both&#34;",
        ),
        (
            "composition-rating",
            with(&good_rating, "pairs", "5"),
            "make 1..=1 distinct pairs",
        ),
        (
            "composition-rating",
            with(&good_rating, "library", "fx"),
            "holds the clip art",
        ),
        (
            "composition-rating",
            with(&good_rating, "replication", "0"),
            "replication: 0 not in",
        ),
        (
            "composition-rating",
            with(&good_rating, "questions_per_hit", "x"),
            "Questions per HIT",
        ),
    ];
    let items = count(&db, "items").await;
    for (kind, form, needle) in &cases {
        let resp = c
            .post(url(kind))
            .header("cookie", &cookie)
            .form(form)
            .send()
            .await
            .expect("post");
        let status = resp.status().as_u16();
        let page = resp.text().await.expect("body");
        assert_eq!(status, 400, "{kind} {form:?}: {page}");
        let error = page
            .split("id=\"form-error\"")
            .nth(1)
            .unwrap_or_else(|| panic!("{kind} {form:?}: no message in {page}"));
        assert!(error.contains(needle), "{kind}: {needle} not in {error}");
        // The form is shown again with what was typed.
        assert!(page.contains("id=\"new-study\""), "{page}");
        let name = &form.iter().find(|(k, _)| *k == "name").expect("name").1;
        if !name.trim().is_empty() {
            assert!(
                page.contains(&format!("name=\"name\" value=\"{name}\"")),
                "{page}"
            );
        }
    }
    assert_eq!(
        count(&db, "studies").await,
        before,
        "a refused form created a study"
    );
    assert_eq!(
        count(&db, "items").await,
        items,
        "a refused form rendered compositions"
    );

    // The good forms: a study of each kind.
    for (kind_path, form, want) in [
        (
            "mashup",
            with(&good_mashup, "mturk_mode", "sandbox"),
            "mashup",
        ),
        (
            "composition-rating",
            with(&good_rating, "question", "preference"),
            "composition-rating",
        ),
    ] {
        let resp = c
            .post(url(kind_path))
            .header("cookie", &cookie)
            .form(&form)
            .send()
            .await
            .expect("post");
        assert_eq!(
            resp.status().as_u16(),
            303,
            "{}",
            resp.text().await.unwrap_or_default()
        );
        let location = resp.headers()["location"]
            .to_str()
            .expect("location")
            .to_string();
        let id: i64 = location
            .rsplit('/')
            .next()
            .and_then(|i| i.parse().ok())
            .expect(&location);
        assert_eq!(kind(&c, &base, &cookie, id).await, want);
        let (_, detail) = send(
            c.get(format!("{base}/api/v1/admin/studies/{id}"))
                .header("cookie", &cookie),
        )
        .await;
        assert_eq!(detail["status"], "ready", "{detail}");
        if want == "mashup" {
            let m = &detail["settings"]["mashup"];
            assert_eq!(
                (m["task"].as_str(), m["background"].as_str()),
                (Some("A picnic by the lake"), Some("grass"))
            );
            assert_eq!(
                (
                    m["min_pieces"].as_i64(),
                    detail["settings"]["tuples"].as_i64()
                ),
                (Some(2), Some(6))
            );
        } else {
            let s = &detail["settings"];
            assert_eq!(s["question"], "preference");
            assert_eq!(
                (s["tuples"].as_i64(), s["replication"].as_i64()),
                (Some(1), Some(3))
            );
            assert_eq!(
                (
                    s["controls_per_hit"].as_i64(),
                    s["training_questions"].as_i64()
                ),
                (Some(0), Some(0))
            );
        }
    }
    assert_eq!(count(&db, "studies").await, before + 2);
}

both_databases!(
    forms_refuse_bad_input,
    new_study_forms_refuse_bad_input_sqlite,
    new_study_forms_refuse_bad_input_postgres
);
