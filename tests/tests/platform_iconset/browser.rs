//! One icon-set HIT in each condition in real Chromium (§6.6): the worker page's plain forms —
//! in condition A a representative style opened as its balanced grid, icons picked from the
//! grid and from a node's hidden-image pop-up; in condition B the search, one label at a time —
//! a removal, two finished sets, Submit, the completion code; no CSP violation. The stored
//! sets are the icons clicked, and the report counts one HIT per condition. Screenshots of both
//! interfaces go to target/e2e-artifacts/platform-iconset.

use std::collections::HashMap;

use e2e::browser::*;
use e2e::platform::*;
use fantoccini::{Client, Locator};
use serde_json::Value;

use super::support::{
    GOOD, conditions, create, created, import_icons, labels, rows, sets_from_events,
};

const LABELS: [&str; 4] = ["face", "fish", "flower", "bird"];

/// Clicks the element `css` and waits for the page the form or link leads to.
async fn click_to_next(c: &Client, css: &str) {
    mark(c).await;
    c.find(Locator::Css(css))
        .await
        .unwrap_or_else(|e| panic!("{css}: {e}"))
        .click()
        .await
        .unwrap_or_else(|e| panic!("click {css}: {e}"));
    wait_navigated(c).await;
}

/// The page's error, if it shows one.
async fn page_error(c: &Client) -> Option<String> {
    match c.find(Locator::Id("iconset-error")).await {
        Ok(e) => Some(e.text().await.expect("text")),
        Err(_) => None,
    }
}

/// The pick buttons on the page as (item, the pop-up holding it, if any).
async fn picks(c: &Client) -> Vec<(i64, Option<String>)> {
    let v = c
        .execute(
            "return Array.from(document.querySelectorAll('button.iconset-pick')).map(b => { \
               const d = b.closest('dialog'); \
               return [Number(b.dataset.item), d ? d.id : null]; });",
            vec![],
        )
        .await
        .expect("picks");
    v.as_array()
        .expect("array")
        .iter()
        .map(|p| {
            (
                p[0].as_i64().expect("item"),
                p[1].as_str().map(str::to_string),
            )
        })
        .collect()
}

/// Picks `item`: straight from the grid or results, or by opening its node's pop-up first.
async fn pick(c: &Client, item: i64, dialog: Option<&str>) {
    if let Some(d) = dialog {
        c.find(Locator::Css(&format!(
            "button.has-hidden[data-dialog=\"{d}\"]"
        )))
        .await
        .expect("node with hidden images")
        .click()
        .await
        .expect("open pop-up");
        click_to_next(
            c,
            &format!("dialog#{d}[open] button.iconset-pick[data-item=\"{item}\"]"),
        )
        .await;
    } else {
        click_to_next(c, &format!("button.iconset-pick[data-item=\"{item}\"]")).await;
    }
    assert_eq!(page_error(c).await, None, "picking {item}");
}

/// The icons of the current set, by label, as the page shows them.
async fn current_set(c: &Client) -> HashMap<String, i64> {
    let v = c
        .execute(
            "return Array.from(document.querySelectorAll('.iconset-set.current .iconset-slot')) \
               .filter(s => s.dataset.item).map(s => [s.dataset.label, Number(s.dataset.item)]);",
            vec![],
        )
        .await
        .expect("slots");
    v.as_array()
        .expect("array")
        .iter()
        .map(|p| (p[0].as_str().unwrap().to_string(), p[1].as_i64().unwrap()))
        .collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn iconset_hits_in_chromium() {
    let profile = tempfile::tempdir().expect("profile dir");
    let artifacts = e2e::workspace_root().join("target/e2e-artifacts/platform-iconset");
    std::fs::create_dir_all(&artifacts).expect("artifacts dir");
    let Some((driver, c)) = browser(profile.path(), Viewport::Desktop).await else {
        return;
    };
    let db = sqlite_db();
    import_icons(&db);
    let study = created(&create(&db, GOOD));
    let label_of = labels(&db.url).await;
    let server = Server::start(&db.url);
    let http = client();
    let base = server.url("");
    let base = base.trim_end_matches('/');

    let mut clicked: HashMap<String, Vec<Vec<i64>>> = HashMap::new();
    for w in 0..2 {
        let token = start_worker(&http, base, study, &format!("b{w}")).await;
        c.goto(&server.url(&format!("/a/{token}")))
            .await
            .expect("task page");
        let interface = attr(&c, "#iconset-page", "data-interface").await;
        let body = c.source().await.expect("source");
        assert!(!body.contains("condition"), "the page names the condition");
        let mut used: Vec<i64> = Vec::new();
        let mut sets = Vec::new();
        for set in 0..2 {
            assert_eq!(
                attr(&c, "#iconset-page", "data-current-set").await,
                (set + 1).to_string()
            );
            if interface == "explorer" {
                // A representative style per set, opened as its grid.
                let styles = c
                    .find_all(Locator::Css("a.iconset-style"))
                    .await
                    .expect("styles")
                    .len();
                assert!(styles > 0);
                click_to_next(&c, &format!("#style-{}", set % styles)).await;
                let mut popped = false;
                for label in LABELS {
                    let on_page = picks(&c).await;
                    // Prefer an icon behind a node once, to go through the pop-up.
                    let mut candidates: Vec<&(i64, Option<String>)> = on_page
                        .iter()
                        .filter(|(i, _)| label_of[i] == label && !used.contains(i))
                        .collect();
                    if !popped {
                        candidates.sort_by_key(|(_, d)| d.is_none());
                    }
                    let (item, dialog) = candidates.first().expect("an icon of the label");
                    popped |= dialog.is_some();
                    if set == 0 && label == "fish" && !popped {
                        shot(&c, &artifacts, "explorer-grid.png").await;
                    }
                    pick(&c, *item, dialog.as_deref()).await;
                    used.push(*item);
                    if set == 0 && popped && !artifacts.join("explorer-popup.png").exists() {
                        // The next pop-up, open, for the screenshot.
                        if let Some((_, Some(d))) =
                            picks(&c).await.iter().find(|(_, d)| d.is_some())
                        {
                            c.find(Locator::Css(&format!(
                                "button.has-hidden[data-dialog=\"{d}\"]"
                            )))
                            .await
                            .expect("node")
                            .click()
                            .await
                            .expect("open");
                            shot(&c, &artifacts, "explorer-popup.png").await;
                            c.refresh().await.expect("close the pop-up");
                        }
                    }
                }
                assert!(
                    popped || set == 1,
                    "no icon was behind a node: the pop-up was not used"
                );
                if set == 0 {
                    shot(&c, &artifacts, "explorer.png").await;
                }
            } else {
                for label in LABELS {
                    c.find(Locator::Id("iconset-label"))
                        .await
                        .expect("label select")
                        .select_by_value(label)
                        .await
                        .expect("select");
                    click_to_next(&c, "#iconset-search button[type=submit]").await;
                    let results = picks(&c).await;
                    assert!(results.iter().all(|(i, _)| label_of[i] == label));
                    let item = results
                        .iter()
                        .map(|(i, _)| *i)
                        .find(|i| !used.contains(i))
                        .expect("an unused icon");
                    pick(&c, item, None).await;
                    used.push(item);
                }
                if set == 0 {
                    shot(&c, &artifacts, "search.png").await;
                }
            }
            // One change of mind per HIT: the fish of set 1 goes, another comes.
            if set == 0 {
                let before = current_set(&c).await;
                click_to_next(&c, "#remove-fish").await;
                assert!(!current_set(&c).await.contains_key("fish"));
                if interface == "search" {
                    c.find(Locator::Id("iconset-label"))
                        .await
                        .expect("label select")
                        .select_by_value("fish")
                        .await
                        .expect("select");
                    click_to_next(&c, "#iconset-search button[type=submit]").await;
                }
                // Another fish when the page shows one, else the same one back.
                let fish: Vec<(i64, Option<String>)> = picks(&c)
                    .await
                    .into_iter()
                    .filter(|(i, _)| label_of[i] == "fish")
                    .collect();
                let (replacement, dialog) = fish
                    .iter()
                    .find(|(i, _)| !used.contains(i))
                    .or_else(|| fish.iter().find(|(i, _)| *i == before["fish"]))
                    .cloned()
                    .expect("a fish on the page");
                pick(&c, replacement, dialog.as_deref()).await;
                used.push(replacement);
            }
            // The icons already in a set cannot be picked again.
            let in_sets: Vec<i64> = sets.iter().flatten().copied().collect();
            let enabled = c
                .execute(
                    "return Array.from(document.querySelectorAll('button.iconset-pick')) \
                       .filter(b => !b.disabled).map(b => Number(b.dataset.item));",
                    vec![],
                )
                .await
                .expect("enabled picks");
            let shown = current_set(&c).await;
            for item in enabled.as_array().expect("array") {
                let item = item.as_i64().expect("item");
                assert!(
                    !in_sets.contains(&item) && !shown.values().any(|&i| i == item),
                    "{item} is in a set but can be picked"
                );
            }
            assert_eq!(shown.len(), 4, "{shown:?}");
            sets.push(LABELS.iter().map(|l| shown[*l]).collect::<Vec<i64>>());
            click_to_next(&c, "#iconset-finish").await;
            assert_eq!(page_error(&c).await, None);
        }
        click_to_next(&c, "#iconset-submit").await;
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
        clicked.insert(token, sets);
    }

    let cond = conditions(&db.url).await;
    let mut both: Vec<&String> = cond.values().collect();
    both.sort();
    assert_eq!(both, ["A", "B"], "one worker per condition");
    // The stored sets are the icons clicked, in label order; one deletion each.
    let stored = rows(
        &db.url,
        "SELECT a.token, e.set_index, e.label, e.item_id, e.event FROM iconset_events e \
         JOIN assignments a ON a.id = e.assignment_id ORDER BY e.assignment_id, e.seq",
    )
    .await;
    let mut slots: HashMap<(String, i64, String), i64> = HashMap::new();
    for r in &stored {
        use sqlx::Row;
        let key = (
            r.get("token"),
            r.get("set_index"),
            r.get::<Option<String>, _>("label").unwrap_or_default(),
        );
        match r.get::<String, _>("event").as_str() {
            "add" => {
                slots.insert(key, r.get::<Option<i64>, _>("item_id").unwrap());
            }
            "remove" => {
                slots.remove(&key);
            }
            _ => {}
        }
    }
    for (token, sets) in &clicked {
        for (k, set) in sets.iter().enumerate() {
            for (l, item) in LABELS.iter().zip(set) {
                assert_eq!(slots[&(token.clone(), k as i64 + 1, l.to_string())], *item);
            }
        }
    }
    let computed = sets_from_events(&db.url).await;
    for token in clicked.keys() {
        let deletions: Vec<usize> = computed[token].iter().map(|s| s.1).collect();
        assert_eq!(deletions, [1, 0], "{}", cond[token]);
    }
    create_admin(&db.url);
    let (cookie, _) = admin_login(&http, base).await;
    let (status, report): (u16, Value) = send(
        http.get(format!("{base}/api/v1/admin/studies/{study}/report"))
            .header("cookie", &cookie),
    )
    .await;
    assert_eq!(status, 200, "{report}");
    for r in report["conditions"].as_array().expect("conditions") {
        assert_eq!(
            (r["workers"].as_i64(), r["sets"].as_i64()),
            (Some(1), Some(2)),
            "{r}"
        );
    }
}
