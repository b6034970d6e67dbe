//! The new-study forms in real Chromium.

use e2e::platform::*;
use fantoccini::Locator;

use super::kind;
use crate::platform_rating_from_mashup::submit_compositions;

/// Sets the form field `name` (input, textarea or select) to `value`.
async fn fill(c: &fantoccini::Client, name: &str, value: &str) {
    let css = format!("[name={name}]");
    let field = c
        .find(Locator::Css(&css))
        .await
        .unwrap_or_else(|e| panic!("{css}: {e}"));
    if field.tag_name().await.expect("tag") == "select" {
        field.select_by_value(value).await.expect("select");
    } else {
        field.clear().await.expect("clear");
        field.send_keys(value).await.expect("type");
    }
}

async fn submit(c: &fantoccini::Client) {
    e2e::browser::mark(c).await;
    c.find(Locator::Id("create"))
        .await
        .expect("button")
        .click()
        .await
        .expect("click");
    e2e::browser::wait_navigated(c).await;
}

/// The admin creates a mash-up study through its form (after one refused value), workers
/// submit compositions, and the admin creates a composition-rating study from it through the
/// other form; both study pages open, without a CSP violation.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn new_study_forms_in_chromium() {
    use e2e::browser::*;
    let profile = tempfile::tempdir().expect("profile dir");
    let Some((driver, c)) = browser(profile.path(), Viewport::Desktop).await else {
        return;
    };
    let db = sqlite_db();
    let lib = small_library(3);
    import_library(&db, lib.path());
    create_admin(&db.url);
    let server = Server::start(&db.url);
    c.goto(&server.url("/admin/login"))
        .await
        .expect("login page");
    fill(&c, "username", "admin").await;
    fill(&c, "password", ADMIN_PASSWORD).await;
    mark(&c).await;
    c.find(Locator::Id("login"))
        .await
        .expect("login")
        .click()
        .await
        .expect("click");
    wait_navigated(&c).await;

    mark(&c).await;
    c.find(Locator::Id("new-mashup"))
        .await
        .expect("link")
        .click()
        .await
        .expect("click");
    wait_navigated(&c).await;
    fill(&c, "name", "farm in the browser").await;
    fill(&c, "task", "A farm in the morning").await;
    fill(&c, "background", "grass").await;
    fill(&c, "min_pieces", "0").await;
    fill(&c, "compositions", "4").await;
    submit(&c).await;
    // Refused: the message, and the form with what was typed.
    let error = c.find(Locator::Id("form-error")).await.expect("message");
    assert!(
        error
            .text()
            .await
            .expect("text")
            .contains("min_pieces: 0 not in 1..=200")
    );
    assert_eq!(
        attr(&c, "[name=name]", "value").await,
        "farm in the browser"
    );
    assert_eq!(
        attr(&c, "[name=background] option[selected]", "value").await,
        "grass"
    );
    fill(&c, "min_pieces", "2").await;
    submit(&c).await;
    let url = c.current_url().await.expect("url");
    let mashup: i64 = url
        .path()
        .rsplit('/')
        .next()
        .and_then(|i| i.parse().ok())
        .expect("study page");

    let base = server.url("");
    let base = base.trim_end_matches('/');
    submit_compositions(base, mashup, 3, "b").await;

    c.goto(&server.url("/admin")).await.expect("studies");
    mark(&c).await;
    c.find(Locator::Id("new-rating"))
        .await
        .expect("link")
        .click()
        .await
        .expect("click");
    wait_navigated(&c).await;
    fill(&c, "name", "coherence in the browser").await;
    fill(&c, "mashup", &mashup.to_string()).await;
    fill(&c, "question", "preference").await;
    fill(&c, "replication", "2").await;
    submit(&c).await;
    let url = c.current_url().await.expect("url");
    let rating: i64 = url
        .path()
        .rsplit('/')
        .next()
        .and_then(|i| i.parse().ok())
        .expect("study page");
    assert_ne!(rating, mashup);
    let http = client();
    let (cookie, _) = admin_login(&http, base).await;
    assert_eq!(
        kind(&http, base, &cookie, rating).await,
        "composition-rating"
    );
    assert_eq!(kind(&http, base, &cookie, mashup).await, "mashup");
    // Three compositions (2 + 1): max(2, 1) = 2 pairs, each rated by two workers.
    let (_, detail) = send(
        http.get(format!("{base}/api/v1/admin/studies/{rating}"))
            .header("cookie", &cookie),
    )
    .await;
    assert_eq!(detail["settings"]["question"], "preference");
    assert_eq!(detail["settings"]["tuples"], 2, "{detail}");
    let violations = csp_violations(&c, &driver).await;
    assert!(violations.is_empty(), "{violations:?}");
}
