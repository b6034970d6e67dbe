//! The Explore pages on a phone (Chromium's device emulation at 390×844): the Explore form,
//! the representative styles, a branch's grid with a hidden-image pop-up open, and the style
//! map never stick out sideways. Screenshots under `target/e2e-artifacts/platform-explore/`.

use std::time::Duration;

use e2e::browser::*;
use e2e::platform::*;
use fantoccini::Locator;
use serde_json::{Value, json};

use super::{import, wait_done};
use crate::platform_phone::{assert_fits, click};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn explore_pages_fit_a_phone() {
    let profile = tempfile::tempdir().expect("profile dir");
    let artifacts = e2e::workspace_root().join("target/e2e-artifacts/platform-explore");
    std::fs::create_dir_all(&artifacts).expect("artifacts dir");
    let Some((driver, c)) = browser(profile.path(), Viewport::Phone(390, 844)).await else {
        return;
    };
    let db = sqlite_db();
    import(&db);
    let server = Server::start(&db.url);
    // The jobs are started over JSON; the pages are what a phone shows.
    let http = client();
    let (cookie, csrf) = admin_login(&http, &server.base).await;
    let mut ids = Vec::new();
    for (path, body) in [
        (
            "taxonomy",
            json!({"library": "clipart", "model": "uniform", "labels": ["noto", "fluent-emoji"], "kappa": 3, "tau": 1}),
        ),
        (
            "map",
            json!({"library": "clipart", "model": "uniform", "labels": ["noto", "fluent-emoji"], "perplexity": 5}),
        ),
    ] {
        let (status, started) = send(
            http.post(server.url(&format!("/api/v1/admin/explore/{path}")))
                .header("cookie", &cookie)
                .header("x-csrf-token", &csrf)
                .json(&body),
        )
        .await;
        assert_eq!(status, 202, "{started}");
        let id = started["id"].as_i64().expect("id");
        wait_done(&http, &server.base, &cookie, id).await;
        ids.push(id);
    }

    c.goto(&server.url("/admin/login"))
        .await
        .expect("login page");
    for (id, text) in [("username", "admin"), ("password", ADMIN_PASSWORD)] {
        c.find(Locator::Id(id))
            .await
            .expect(id)
            .send_keys(text)
            .await
            .expect("type");
    }
    click(&c, "#login").await;
    c.wait()
        .for_element(Locator::Id("studies"))
        .await
        .expect("studies");

    c.goto(&server.url("/admin/explore?library=clipart"))
        .await
        .expect("explore page");
    assert_fits(&c, "Explore form").await;
    shot(&c, &artifacts, "phone-01-explore.png").await;

    c.goto(&server.url(&format!("/admin/explore/jobs/{}", ids[0])))
        .await
        .expect("taxonomy page");
    c.wait()
        .for_element(Locator::Css("#styles .style-link"))
        .await
        .expect("representative styles");
    assert_fits(&c, "representative styles").await;

    for shape in ["", "?rows=2&cols=2"] {
        c.goto(&server.url(&format!("/admin/explore/jobs/{}/styles/0{shape}", ids[0])))
            .await
            .expect("grid page");
        c.wait()
            .for_element(Locator::Id("grid"))
            .await
            .expect("grid");
        assert_fits(&c, &format!("branch grid {shape}")).await;
    }
    shot(&c, &artifacts, "phone-02-grid.png").await;
    c.find(Locator::Css(".has-hidden"))
        .await
        .expect("a node with hidden images")
        .click()
        .await
        .expect("open its pop-up");
    assert_fits(&c, "hidden-image pop-up").await;
    shot(&c, &artifacts, "phone-03-hidden.png").await;

    c.goto(&server.url(&format!("/admin/explore/jobs/{}", ids[1])))
        .await
        .expect("map page");
    let drawn = "const m = document.getElementById('map'); return m && m.dataset.scale ? Number(m.dataset.thumbnails) : null";
    let mut thumbnails = Value::Null;
    for _ in 0..400 {
        thumbnails = c.execute(drawn, vec![]).await.expect("map state");
        if thumbnails.as_f64().is_some_and(|n| n >= 1.0) {
            break;
        }
        tokio::time::sleep(Duration::from_millis(25)).await;
    }
    assert!(
        thumbnails.as_f64().is_some_and(|n| n >= 1.0),
        "{thumbnails}"
    );
    assert_fits(&c, "style map").await;
    // The map's canvas is shown at the phone's width, not cut off.
    let shown = c
        .execute(
            "const r = document.getElementById('map').getBoundingClientRect(); return [r.width, document.documentElement.clientWidth];",
            vec![],
        )
        .await
        .expect("canvas size");
    assert!(
        shown[0].as_f64() > Some(300.0) && shown[0].as_f64() <= shown[1].as_f64(),
        "{shown}"
    );
    shot(&c, &artifacts, "phone-04-map.png").await;

    let violations = csp_violations(&c, &driver).await;
    assert!(violations.is_empty(), "{violations:?}");
    c.close().await.expect("close");
}
