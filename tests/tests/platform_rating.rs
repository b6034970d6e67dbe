//! The composition-rating study (2AFC, §5.7.3, Appendix 5.B) over real HTTP against the real
//! `platform` binary, on SQLite and PostgreSQL: created from a folder of compositions and a CSV
//! with `platform study create --kind composition-rating`, answered by workers through the
//! shared HIT machinery (training gate, hidden controls), and reported with the t-test of
//! `learner::stats` on the answers as stored.

use std::collections::HashMap;
use std::path::Path;

use e2e::both_databases;
use e2e::browser::*;
use e2e::fixture;
use e2e::platform::*;
use fantoccini::Locator;
use serde_json::{Value, json};

/// A composition: fixture clip art placed side by side in one SVG (nested `<svg>` elements;
/// the twemoji and emojione-monotone drawings define no ids that could clash).
fn composition(pieces: &[&str]) -> String {
    let mut out = String::from(
        r##"<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" width="300" height="120" viewBox="0 0 300 120"><rect width="300" height="120" fill="#ffffff"/>"##,
    );
    for (i, piece) in pieces.iter().enumerate() {
        let svg =
            std::fs::read_to_string(fixture(&format!("style/{piece}.svg"))).expect("clip art");
        let start = svg.find("<svg").expect("svg element");
        let placed =
            svg[start..].replacen("<svg ", &format!(r#"<svg x="{}" y="15" "#, 10 + 100 * i), 1);
        // The piece's own size attributes give way to 80x80.
        let placed = placed
            .replacen(r#"width="36""#, r#"width="80""#, 1)
            .replacen(r#"height="36""#, r#"height="80""#, 1)
            .replacen(r#"width="64""#, r#"width="80""#, 1)
            .replacen(r#"height="64""#, r#"height="80""#, 1);
        out.push_str(&placed);
    }
    out.push_str("</svg>");
    out
}

const COHERENT: [&[&str]; 4] = [
    &["twemoji/dog-face", "twemoji/cat-face", "twemoji/bird"],
    &["twemoji/banana", "twemoji/bicycle", "twemoji/airplane"],
    &[
        "emojione-monotone/dog-face",
        "emojione-monotone/cat-face",
        "emojione-monotone/bird",
    ],
    &[
        "emojione-monotone/banana",
        "emojione-monotone/bicycle",
        "emojione-monotone/airplane",
    ],
];
const MIXED: [&[&str]; 2] = [
    &[
        "twemoji/dog-face",
        "emojione-monotone/cat-face",
        "twemoji/bird",
    ],
    &[
        "emojione-monotone/banana",
        "twemoji/bicycle",
        "emojione-monotone/airplane",
    ],
];

/// Writes the compositions and the CSV: three main tasks (2 A × 1 B, 1 A × 2 B, 1 A × 1 B: five
/// pairs) and eight known-answer tasks (a coherent against a mixed composition).
fn compositions(dir: &Path) -> std::path::PathBuf {
    let folder = dir.join("compositions");
    std::fs::create_dir_all(&folder).expect("mkdir");
    let mut csv = String::from("file,condition,task,control_expected\n");
    let mut put = |name: &str, pieces: &[&str], condition: &str, task: &str, expected: &str| {
        std::fs::write(folder.join(name), composition(pieces)).expect("write composition");
        csv.push_str(&format!("{name},{condition},{task},{expected}\n"));
    };
    put("farm-a1.svg", COHERENT[0], "A", "farm", "");
    put("farm-a2.svg", COHERENT[2], "A", "farm", "");
    put("farm-b1.svg", MIXED[0], "B", "farm", "");
    put("trip-a1.svg", COHERENT[1], "A", "trip", "");
    put("trip-b1.svg", MIXED[1], "B", "trip", "");
    put(
        "trip-b2.svg",
        &[
            "twemoji/banana",
            "emojione-monotone/dog-face",
            "twemoji/cat-face",
        ],
        "B",
        "trip",
        "",
    );
    put("zoo-a1.svg", COHERENT[3], "A", "zoo", "");
    put(
        "zoo-b1.svg",
        &[
            "emojione-monotone/bird",
            "twemoji/airplane",
            "twemoji/dog-face",
        ],
        "B",
        "zoo",
        "",
    );
    for k in 0..8 {
        let good = COHERENT[k % 4];
        let bad = MIXED[k % 2];
        // Distinct files per known task (a file belongs to one task); mirrored layouts.
        let mut good_rev: Vec<&str> = good.to_vec();
        let mut bad_rev: Vec<&str> = bad.to_vec();
        if k >= 4 {
            good_rev.reverse();
            bad_rev.reverse();
        }
        put(
            &format!("known{k}-good.svg"),
            &good_rev,
            "A",
            &format!("known{k}"),
            "1",
        );
        put(
            &format!("known{k}-bad.svg"),
            &bad_rev,
            "B",
            &format!("known{k}"),
            "0",
        );
    }
    let csv_path = dir.join("compositions.csv");
    std::fs::write(&csv_path, csv).expect("write csv");
    folder
}

/// Item id → name.
async fn item_names(db_url: &str) -> HashMap<i64, String> {
    sqlx::any::install_default_drivers();
    let pool = sqlx::AnyPool::connect(db_url).await.expect("connect");
    let rows: Vec<(i64, String)> = sqlx::query_as("SELECT id, name FROM items")
        .fetch_all(&pool)
        .await
        .expect("items");
    pool.close().await;
    rows.into_iter().collect()
}

/// The condition-A share of main answers per worker, straight from the stored rows.
async fn stored_rates(db_url: &str) -> Vec<f64> {
    sqlx::any::install_default_drivers();
    let pool = sqlx::AnyPool::connect(db_url).await.expect("connect");
    let rows: Vec<(i64, String)> = sqlx::query_as(
        "SELECT a.worker_id, q.choice FROM questions q JOIN assignments a ON a.id = q.assignment_id \
         JOIN tuples t ON t.id = q.tuple_id WHERE t.kind = 'main' AND q.choice IS NOT NULL \
         AND a.status = 'completed' ORDER BY a.worker_id",
    )
    .fetch_all(&pool)
    .await
    .expect("answers");
    pool.close().await;
    let mut by: std::collections::BTreeMap<i64, (f64, f64)> = Default::default();
    for (w, choice) in rows {
        let e = by.entry(w).or_default();
        e.0 += 1.0;
        e.1 += f64::from(u8::from(choice == "b"));
    }
    by.values().map(|(n, a)| a / n).collect()
}

async fn rating_study(db: TestDb) {
    let dir = tempfile::tempdir().expect("temp dir");
    let folder = compositions(dir.path());
    let csv = dir.path().join("compositions.csv");
    let settings = dir.path().join("settings.json");
    std::fs::write(
        &settings,
        json!({"questions_per_hit": 4, "controls_per_hit": 1, "replication": 3,
               "training_questions": 1, "max_training_attempts": 2})
        .to_string(),
    )
    .expect("settings");
    let (folder_s, csv_s, settings_s) = (
        folder.to_string_lossy().into_owned(),
        csv.to_string_lossy().into_owned(),
        settings.to_string_lossy().into_owned(),
    );
    let base_args = [
        "study",
        "create",
        "--database-url",
        &db.url,
        "--name",
        "coherence",
        "--library",
        "compositions",
        "--kind",
        "composition-rating",
        "--settings",
        &settings_s,
    ];
    // Bad input first: a clear error, nothing half made.
    let missing = platform_cmd(&base_args, &[]);
    assert!(!missing.status.success());
    let message = String::from_utf8_lossy(&missing.stderr);
    assert!(
        message.contains("--compositions") && message.contains("--pairs"),
        "{message}"
    );
    let bad_csv = dir.path().join("bad.csv");
    std::fs::write(&bad_csv, "file,condition,task\nfarm-a1.svg,C,farm\n").expect("bad csv");
    let bad = platform_cmd(
        &[
            &base_args[..],
            &[
                "--compositions",
                &folder_s,
                "--pairs",
                &bad_csv.to_string_lossy(),
            ],
        ]
        .concat(),
        &[],
    );
    assert!(!bad.status.success());
    let message = String::from_utf8_lossy(&bad.stderr);
    assert!(
        message.contains("line 2") && message.contains("\"C\""),
        "{message}"
    );

    let out = platform_ok(
        &[
            &base_args[..],
            &[
                "--compositions",
                &folder_s,
                "--pairs",
                &csv_s,
                "--question",
                "coherence",
            ],
        ]
        .concat(),
        &[],
    );
    // 5 main pairs × R = 3 slots; 8 known pairs: 6 practice (1 per attempt × 5 attempts + the
    // worked example's), 2 hidden controls.
    assert!(
        out.contains("5 main tuples, 15 slots, 2 controls, 6 training"),
        "{out}"
    );
    let study: i64 = out
        .split_whitespace()
        .nth(1)
        .and_then(|id| id.trim_end_matches(':').parse().ok())
        .expect("study id");
    create_admin(&db.url);
    let server = Server::start(&db.url);
    let base = &server.base;
    let c = client();
    let names = item_names(&db.url).await;
    let name = |v: &Value| names[&v["id"].as_i64().expect("id")].clone();

    // Five workers fill the 15 slots (3 main pairs and 1 control per HIT). Worker k picks the
    // condition-A composition in its first k main questions (at least one), the B one after.
    let mut sides = HashMap::<&str, usize>::new();
    let (mut picked_a, mut main_answers) = (0, 0);
    for k in 0..5 {
        let token = start_worker(&c, base, study, &format!("rater-{k}")).await;
        let (_, st) = send(c.get(format!("{base}/api/v1/assignments/{token}"))).await;
        assert_eq!(st["status"], "training", "{st}");
        let answers: Vec<Value> = st["training"]
            .as_array()
            .expect("training")
            .iter()
            .map(|q| {
                assert!(
                    q.get("reference").is_none(),
                    "a pair shows no reference: {q}"
                );
                let good = if name(&q["left"]).contains("-good") {
                    &q["left"]
                } else {
                    &q["right"]
                };
                json!({"position": q["position"], "choice": good["id"]})
            })
            .collect();
        let (status, result) = send(
            c.post(format!("{base}/api/v1/assignments/{token}/training"))
                .json(&json!({"answers": answers})),
        )
        .await;
        assert_eq!(
            (status, result["passed"].clone()),
            (200, json!(true)),
            "{result}"
        );
        let mut main_seen = 0;
        loop {
            let (_, st) = send(c.get(format!("{base}/api/v1/assignments/{token}"))).await;
            let q = st["question"].clone();
            if q.is_null() {
                assert_eq!(st["status"], "completed", "{st}");
                break;
            }
            assert!(q.get("reference").is_none(), "{q}");
            let (left, right) = (name(&q["left"]), name(&q["right"]));
            let choice = if left.starts_with("known") || right.starts_with("known") {
                // A hidden control: the coherent one.
                if left.contains("-good") {
                    &q["left"]
                } else {
                    &q["right"]
                }
            } else {
                let a_side = if left.contains("-a") { "left" } else { "right" };
                *sides.entry(a_side).or_default() += 1;
                main_seen += 1;
                let pick_a = main_seen <= k.max(1);
                picked_a += usize::from(pick_a);
                main_answers += 1;
                let side = if pick_a {
                    a_side
                } else if a_side == "left" {
                    "right"
                } else {
                    "left"
                };
                &q[side]
            };
            let (status, ack) = send(
                c.post(format!("{base}/api/v1/assignments/{token}/answers"))
                    .json(&json!({"position": q["position"], "choice": choice["id"]})),
            )
            .await;
            assert_eq!(status, 200, "{ack}");
        }
        // Slots are claimed one per tuple from a random start: a HIT holds up to 3 pairs.
        assert!((1..=3).contains(&main_seen), "worker {k}: {main_seen}");
    }
    // The A composition is not always on the same side.
    assert!(sides.len() == 2, "A shown on one side only: {sides:?}");

    let (cookie, _) = admin_login(&c, base).await;
    let (status, report) = send(
        c.get(format!("{base}/api/v1/admin/studies/{study}/report"))
            .header("cookie", &cookie),
    )
    .await;
    assert_eq!(status, 200, "{report}");
    assert_eq!(report["kind"], "composition-rating");
    assert_eq!(report["question"], "coherence");
    assert_eq!(report["workers"], 5);
    // Every main answer is counted, and A is what the workers chose (the test knows each
    // composition's condition from its file name; the server from the pair's order).
    assert_eq!(report["answers"], main_answers);
    assert_eq!(report["chose_a"], picked_a);
    let rates = stored_rates(&db.url).await;
    assert_eq!(rates.len(), 5);
    let expected =
        learner::stats::one_sample_t_test(&rates, &learner::stats::TTestParams::default())
            .expect("t-test");
    let mean = rates.iter().sum::<f64>() / 5.0;
    let close = |key: &str, want: f64| {
        let got = report["stats"][key].as_f64().unwrap_or(f64::NAN);
        assert!(
            (got - want).abs() <= 1e-12 * want.abs().max(1.0),
            "{key}: {got} vs {want}"
        );
    };
    assert!((report["mean_rate"].as_f64().expect("mean") - mean).abs() < 1e-12);
    close("t", expected.t);
    close("df", 4.0);
    close("p", expected.p);
    close("effect_size", expected.effect_size);
    close("ci_low", expected.interval.low);
    close("ci_high", expected.interval.high);
    assert_eq!(report["per_worker"].as_array().map(Vec::len), Some(5));
    // The export holds the same report (report.json, report.csv).
    let exported =
        crate::platform_report_export::check_report_export(&c, base, &cookie, study).await;
    assert_eq!(exported, report);
    // The study page shows the same report.
    let admin_page = admin_text(&c, &format!("{base}/admin/studies/{study}"), &cookie).await;
    assert!(admin_page.contains("id=\"rating-report\""), "{admin_page}");
    assert!(
        admin_page.contains(&format!("{:.1}%", mean * 100.0)),
        "mean rate {mean} not on the page"
    );

    // Workers see the kind's question on the HTML page, and no reference picture.
    let token = start_worker(&c, base, study, "late-rater").await;
    let page = c
        .get(format!("{base}/a/{token}"))
        .send()
        .await
        .expect("page")
        .text()
        .await
        .expect("body");
    assert!(page.contains("Practice"), "{page}");
    assert!(!page.contains("alt=\"reference\""), "{page}");
    assert!(
        page.contains("Which composition has a more coherent style?"),
        "{page}"
    );
}

both_databases!(rating_study, rating_study_sqlite, rating_study_postgres);

/// One 2AFC HIT in real Chromium: the practice pair, then the pairs side by side with the
/// kind's question and no reference picture, answered by click and by keyboard, to the end page.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn rating_hit_in_chromium() {
    let profile = tempfile::tempdir().expect("profile dir");
    let Some((_driver, c)) = browser(profile.path(), Viewport::Desktop).await else {
        return;
    };
    let db = sqlite_db();
    let dir = tempfile::tempdir().expect("temp dir");
    let folder = compositions(dir.path());
    let csv = dir.path().join("compositions.csv");
    let settings = dir.path().join("settings.json");
    std::fs::write(
        &settings,
        json!({"questions_per_hit": 3, "controls_per_hit": 1, "training_questions": 1}).to_string(),
    )
    .expect("settings");
    let out = platform_ok(
        &[
            "study",
            "create",
            "--database-url",
            &db.url,
            "--name",
            "preference",
            "--library",
            "compositions",
            "--kind",
            "composition-rating",
            "--question",
            "preference",
            "--settings",
            &settings.to_string_lossy(),
            "--compositions",
            &folder.to_string_lossy(),
            "--pairs",
            &csv.to_string_lossy(),
        ],
        &[],
    );
    let study: i64 = out
        .split_whitespace()
        .nth(1)
        .and_then(|id| id.trim_end_matches(':').parse().ok())
        .expect("study id");
    let server = Server::start(&db.url);
    let names = item_names(&db.url).await;
    let artifacts = e2e::workspace_root().join("target/e2e-artifacts/platform-rating");
    std::fs::create_dir_all(&artifacts).expect("artifacts dir");

    c.goto(&server.url(&format!("/s/{study}?participant=chromium-rater")))
        .await
        .expect("start page");
    mark(&c).await;
    c.find(Locator::Id("start"))
        .await
        .expect("start")
        .click()
        .await
        .expect("click");
    wait_navigated(&c).await;
    c.wait()
        .for_element(Locator::Id("training-form"))
        .await
        .expect("training");
    let legend = c
        .find(Locator::Css(".training-q legend"))
        .await
        .expect("legend");
    assert_eq!(
        legend.text().await.expect("text"),
        "Which composition do you like better?"
    );
    assert!(
        c.find(Locator::Css(".reference")).await.is_err(),
        "a pair has no reference"
    );
    for radio in c
        .find_all(Locator::Css("input[type=radio]"))
        .await
        .expect("radios")
    {
        let id: i64 = radio
            .attr("value")
            .await
            .expect("v")
            .unwrap_or_default()
            .parse()
            .expect("id");
        if names[&id].contains("-good") {
            radio.click().await.expect("radio");
        }
    }
    mark(&c).await;
    c.find(Locator::Id("submit-training"))
        .await
        .expect("submit")
        .click()
        .await
        .expect("click");
    wait_navigated(&c).await;

    let mut answered = 0;
    loop {
        c.wait()
            .for_element(Locator::Css("h1, #progress"))
            .await
            .expect("page");
        if c.find(Locator::Id("answer-form")).await.is_err() {
            break;
        }
        assert_eq!(attr(&c, "#answer-form", "class").await, "pair");
        let prompt = c.find(Locator::Id("prompt")).await.expect("prompt");
        assert_eq!(
            prompt.text().await.expect("text"),
            "Which composition do you like better?"
        );
        assert!(c.find(Locator::Css(".reference")).await.is_err());
        if answered == 0 {
            shot(&c, &artifacts, "01-pair.png").await;
        }
        mark(&c).await;
        if answered % 2 == 0 {
            c.find(Locator::Id("left"))
                .await
                .expect("left")
                .click()
                .await
                .expect("click");
        } else {
            c.find(Locator::Css("body"))
                .await
                .expect("body")
                .send_keys("2")
                .await
                .expect("key");
        }
        answered += 1;
        wait_navigated(&c).await;
    }
    assert_eq!(answered, 3);
    c.wait()
        .for_element(Locator::Id("code"))
        .await
        .expect("completion code");
    shot(&c, &artifacts, "02-done.png").await;
    assert_eq!(
        scalar(
            &db.url,
            "SELECT CAST(COUNT(*) AS BIGINT) FROM questions WHERE choice IS NOT NULL"
        )
        .await,
        3
    );
}
