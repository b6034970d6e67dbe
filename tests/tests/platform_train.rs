//! Training the style metric from a study's answers, through the admin API and page and through
//! `platform train`, on SQLite and PostgreSQL: the stored model is checked against an
//! independent evaluation (distances recomputed here from the stored features and the exported
//! triplets), and the learner's report is served only to the admin.

use std::collections::HashMap;
use std::time::{Duration, Instant};

use e2e::both_databases;
use e2e::platform::*;
use serde_json::{Value, json};

both_databases!(
    train_from_answers,
    train_from_answers_sqlite,
    train_from_answers_postgres
);

/// (item id, item name, raw feature vector) of every item, read straight from the database.
async fn stored_features(db_url: &str) -> Vec<(i64, String, Vec<f64>)> {
    sqlx::any::install_default_drivers();
    let pool = sqlx::AnyPool::connect(db_url).await.expect("connect");
    let rows: Vec<(i64, String, String)> = sqlx::query_as("SELECT id, name, features FROM items")
        .fetch_all(&pool)
        .await
        .expect("items");
    pool.close().await;
    rows.into_iter()
        .map(|(id, name, f)| (id, name, serde_json::from_str(&f).expect("features JSON")))
        .collect()
}

/// A simulated rater whose hidden metric is the Euclidean distance over the 15 colour features
/// (standardised), answering by it with probability 0.9.
struct ColourRater {
    standardised: HashMap<i64, Vec<f64>>,
}

impl ColourRater {
    const COLOUR: usize = 15;

    fn new(features: &HashMap<i64, Vec<f64>>) -> Self {
        let n = features.len() as f64;
        let mean: Vec<f64> = (0..Self::COLOUR)
            .map(|k| features.values().map(|f| f[k]).sum::<f64>() / n)
            .collect();
        let sd: Vec<f64> = (0..Self::COLOUR)
            .map(|k| {
                let v = features
                    .values()
                    .map(|f| (f[k] - mean[k]).powi(2))
                    .sum::<f64>()
                    / n;
                if v > 0.0 { v.sqrt() } else { 1.0 }
            })
            .collect();
        let standardised = features
            .iter()
            .map(|(id, f)| {
                let z = (0..Self::COLOUR)
                    .map(|k| (f[k] - mean[k]) / sd[k])
                    .collect();
                (*id, z)
            })
            .collect();
        Self { standardised }
    }

    fn choose(&self, q: &Value) -> i64 {
        use rand::Rng;
        let id = |k: &str| q[k]["id"].as_i64().expect("item id");
        let (a, l, r) = (id("reference"), id("left"), id("right"));
        let d = |x: i64, y: i64| -> f64 {
            let (x, y) = (&self.standardised[&x], &self.standardised[&y]);
            x.iter().zip(y).map(|(p, q)| (p - q).powi(2)).sum()
        };
        let (near, far) = if d(a, l) <= d(a, r) { (l, r) } else { (r, l) };
        if rand::rng().random_bool(0.9) {
            near
        } else {
            far
        }
    }
}

/// Agreement of `model.json`'s metric with `triplets.csv`, computed here: `d(x, y)² = Σ w_k
/// ((x_k − y_k) / s_k)²` (eq. 5.5); an answer agrees when the chosen candidate is the nearer.
fn agreement(model: &Value, triplets_csv: &str, features: &HashMap<String, Vec<f64>>) -> f64 {
    let w: Vec<f64> = serde_json::from_value(model["weights"].clone()).expect("weights");
    let s: Vec<f64> = serde_json::from_value(model["scale"].clone()).expect("scale");
    let d2 = |x: &[f64], y: &[f64]| -> f64 {
        (0..w.len())
            .map(|k| w[k] * ((x[k] - y[k]) / s[k]).powi(2))
            .sum()
    };
    let mut reader = csv::Reader::from_reader(triplets_csv.as_bytes());
    let (mut agree, mut n) = (0.0, 0usize);
    for row in reader.records() {
        let row = row.expect("csv row");
        let f = |i: usize| {
            features
                .get(&row[i])
                .expect("item of the triplet")
                .as_slice()
        };
        let (dab, dac) = (d2(f(0), f(1)), d2(f(0), f(2)));
        let q_is_b = &row[3] == "1";
        agree += if dab == dac {
            0.5
        } else if (dab < dac) == q_is_b {
            1.0
        } else {
            0.0
        };
        n += 1;
    }
    assert!(n > 0, "no triplets exported");
    agree / n as f64
}

async fn train_from_answers(db: TestDb) {
    let study = setup_study(
        &db,
        &StudyOpts {
            questions: 20,
            controls: 2,
            tuples: 400,
            replication: 1,
            ..StudyOpts::default()
        },
    );
    let server = Server::start(&db.url);
    let base = server.base.clone();
    let c = client();
    let (cookie, csrf) = admin_login(&c, &base).await;
    let models_url = format!("{base}/api/v1/admin/studies/{study}/models");

    // Nothing to train on yet: a clear 409, and no model row.
    let (status, body) = send(
        c.post(&models_url)
            .header("cookie", &cookie)
            .header("x-csrf-token", &csrf)
            .json(&json!({})),
    )
    .await;
    assert_eq!(status, 409, "train without answers: {body}");
    assert!(
        body.to_string().contains("no answers"),
        "message should say why: {body}"
    );
    // The API refuses anonymous and CSRF-less requests.
    let (status, _) = send(c.post(&models_url).json(&json!({}))).await;
    assert_eq!(status, 401);
    let (status, _) = send(
        c.post(&models_url)
            .header("cookie", &cookie)
            .json(&json!({})),
    )
    .await;
    assert_eq!(status, 403);
    // Invalid options are a 400 naming the field.
    let (status, body) = send(
        c.post(&models_url)
            .header("cookie", &cookie)
            .header("x-csrf-token", &csrf)
            .json(&json!({"lambda": -1.0})),
    )
    .await;
    assert_eq!(status, 400, "negative λ: {body}");

    // Raters who judge by colour: each answers with the candidate nearer to A in the 15 colour
    // features (standardised over the library), 90% of the time. The fitted metric must find it.
    let styles = item_styles(&db.url).await;
    let item_features = stored_features(&db.url).await;
    let rater = ColourRater::new(
        &item_features
            .iter()
            .map(|(id, _, f)| (*id, f.clone()))
            .collect(),
    );
    const WORKERS: i64 = 20;
    for i in 0..WORKERS {
        let token = start_worker(&c, &base, study, &format!("train-{i}")).await;
        pass_training(&c, &base, &token, &styles, Behaviour::Honest).await;
        loop {
            let (status, st) = send(c.get(format!("{base}/api/v1/assignments/{token}"))).await;
            assert_eq!(status, 200, "state: {st}");
            let Some(q) = st.get("question").filter(|q| !q.is_null()) else {
                assert_eq!(st["status"], "completed", "{st}");
                break;
            };
            let (status, ack) = send(
                c.post(format!("{base}/api/v1/assignments/{token}/answers"))
                    .json(&json!({"position": q["position"], "choice": rater.choose(q)})),
            )
            .await;
            assert_eq!(status, 200, "answer: {ack}");
        }
    }

    // The admin page's Train button: CSRF-checked form, then a redirect to the model list.
    let train_url = format!("{base}/admin/studies/{study}/train");
    let resp = c
        .post(&train_url)
        .header("cookie", &cookie)
        .form(&[("lambda", "")])
        .send()
        .await
        .expect("train form");
    assert_eq!(resp.status().as_u16(), 403, "form without CSRF");
    let resp = c
        .post(&train_url)
        .header("cookie", &cookie)
        .form(&[("csrf", csrf.as_str()), ("lambda", "")])
        .send()
        .await
        .expect("train form");
    assert_eq!(resp.status().as_u16(), 303);
    assert_eq!(
        resp.headers()["location"],
        format!("/admin/studies/{study}#models").as_str()
    );

    // It trains in the background; poll the API until it is done.
    let deadline = Instant::now() + Duration::from_secs(300);
    let model = loop {
        let (status, list) = send(c.get(&models_url).header("cookie", &cookie)).await;
        assert_eq!(status, 200, "{list}");
        let list = list.as_array().expect("model list").clone();
        assert_eq!(list.len(), 1, "one training started: {list:?}");
        match list[0]["status"].as_str() {
            Some("running") => {
                assert!(Instant::now() < deadline, "training did not finish");
                tokio::time::sleep(Duration::from_millis(200)).await;
            }
            Some("done") => break list[0].clone(),
            other => panic!("training ended {other:?}: {}", list[0]),
        }
    };
    let model_id = model["id"].as_i64().expect("model id");
    // Trained on the main answers of the HITs the control rule kept (colour raters miss some
    // style controls, and ≥ 2 errors reject a HIT), exactly what triplets.csv exports.
    let (_, dash) = send(
        c.get(format!("{base}/api/v1/admin/studies/{study}/dashboard"))
            .header("cookie", &cookie),
    )
    .await;
    assert_eq!(dash["completed"], WORKERS, "{dash}");
    let kept = WORKERS - dash["rejected"].as_i64().expect("rejected count");
    assert_eq!(model["triplets"], kept * (20 - 2), "{model}");

    // The report and model.json, for the admin only.
    let report = format!("{base}/admin/studies/{study}/models/{model_id}/report/");
    let resp = c.get(&report).send().await.expect("report");
    assert_eq!(resp.status().as_u16(), 303, "anonymous report");
    assert_eq!(resp.headers()["location"], "/admin/login");
    let resp = c
        .get(&report)
        .header("cookie", &cookie)
        .send()
        .await
        .expect("report");
    assert_eq!(resp.status().as_u16(), 200);
    assert!(
        resp.headers()["content-type"]
            .to_str()
            .unwrap()
            .starts_with("text/html")
    );
    assert!(
        resp.headers()["content-security-policy"]
            .to_str()
            .unwrap()
            .contains("default-src 'none'")
    );
    // Issue 16: nothing may frame the report, and it leads back to its study.
    assert!(
        resp.headers()["content-security-policy"]
            .to_str()
            .unwrap()
            .contains("frame-ancestors 'none'")
    );
    let html = resp.text().await.expect("report body");
    assert!(html.contains("Style metric report"), "{html}");
    assert!(
        html.contains(&format!("<a href=\"/admin/studies/{study}#models\">")),
        "no link back to the study: {html}"
    );
    assert!(
        html.contains("Agreement with the study's answers"),
        "{html}"
    );
    for figure in ["weights.svg", "weights.png", "lambda.svg"] {
        assert!(html.contains(figure), "report links {figure}");
        let resp = c
            .get(format!("{report}{figure}"))
            .header("cookie", &cookie)
            .send()
            .await
            .expect("figure");
        assert_eq!(resp.status().as_u16(), 200, "{figure}");
        let bytes = resp.bytes().await.expect("figure bytes");
        if figure.ends_with(".png") {
            let img = image::load_from_memory(&bytes).expect("PNG decodes");
            assert!(img.width() > 100 && img.height() > 100);
        } else {
            assert!(String::from_utf8_lossy(&bytes).contains("<svg"));
        }
    }
    for bad in ["missing.svg", "..%2F..%2Fetc%2Fpasswd", "index.exe"] {
        let resp = c
            .get(format!("{report}{bad}"))
            .header("cookie", &cookie)
            .send()
            .await
            .expect("bad file");
        assert_eq!(resp.status().as_u16(), 404, "{bad}");
    }
    let model_json: Value = c
        .get(format!("{report}model.json"))
        .header("cookie", &cookie)
        .send()
        .await
        .expect("model.json")
        .json()
        .await
        .expect("model.json parses");
    let weights = model_json["weights"].as_array().expect("weights");
    assert_eq!(weights.len(), 169);
    let nonzero = weights
        .iter()
        .filter(|w| w.as_f64().expect("weight") > 0.0)
        .count();
    assert!(weights.iter().all(|w| w.as_f64().unwrap() >= 0.0));
    assert_eq!(model["nonzero"], nonzero);
    assert_eq!(model_json["lambda"], model["lambda"]);

    // Independent check of the stored agreement on the exported answers.
    let triplets_csv = admin_text(
        &c,
        &format!("{base}/admin/studies/{study}/export/triplets.csv"),
        &cookie,
    )
    .await;
    let mut names_ids: Vec<(String, i64)> = item_features
        .iter()
        .map(|(id, name, _)| (name.clone(), *id))
        .collect();
    names_ids.sort();
    let features: HashMap<String, Vec<f64>> = item_features
        .into_iter()
        .map(|(_, name, f)| (name, f))
        .collect();
    let ours = agreement(&model_json, &triplets_csv, &features);
    let stored = model["train_accuracy"].as_f64().expect("train accuracy");
    assert!(
        (ours - stored).abs() < 1e-9,
        "agreement recomputed {ours} vs stored {stored}"
    );
    eprintln!(
        "agreement: learned {stored:.3}, uniform {:.3}, held-out {:.3}",
        model["uniform_accuracy"], model["cv_accuracy"]
    );
    // 90% of the answers follow the colour distance: the metric recovers most of that.
    assert!(stored > 0.75, "learned agreement {stored}");
    let uniform = model["uniform_accuracy"]
        .as_f64()
        .expect("uniform accuracy");
    assert!(
        stored > uniform,
        "learned {stored} does not beat uniform {uniform}"
    );
    let held_out = model["cv_accuracy"].as_f64().expect("held-out accuracy");
    assert!(held_out > 0.65, "held-out {held_out}");

    // Style search over the study's library now uses this model (issue 17): "more like this"
    // is ordered by d(x, y) = √Σ w_k ((x_k − y_k) / s_k)² (eq. 5.5) with the stored weights.
    let (status, found) = send(
        c.get(format!(
            "{base}/api/v1/admin/search?library=fx&near={}&limit=200",
            names_ids[0].1
        ))
        .header("cookie", &cookie),
    )
    .await;
    assert_eq!(status, 200, "{found}");
    assert_eq!(found["model"].as_i64(), Some(model_id), "{found}");
    assert_eq!(found["uniform"], false);
    let w: Vec<f64> = serde_json::from_value(model_json["weights"].clone()).expect("weights");
    let s: Vec<f64> = serde_json::from_value(model_json["scale"].clone()).expect("scale");
    let reference = &features[&names_ids[0].0];
    let hits = found["results"].as_array().expect("results");
    assert_eq!(hits.len(), features.len() - 1);
    let mut last = 0.0;
    for hit in hits {
        let x = &features[hit["name"].as_str().expect("name")];
        let want = (0..w.len())
            .map(|k| w[k] * ((x[k] - reference[k]) / s[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        let got = hit["distance"].as_f64().expect("distance");
        assert!(
            (got - want).abs() <= 1e-4 * want.max(1.0),
            "{got} vs {want}"
        );
        assert!(got >= last - 1e-6, "not nearest first");
        last = got;
    }

    // The dashboard lists it with its report link.
    let page = admin_text(&c, &format!("{base}/admin/studies/{study}"), &cookie).await;
    assert!(page.contains(&format!("/admin/studies/{study}/models/{model_id}/report/")));

    // `platform train` with a fixed λ, writing the report to a folder.
    let out = tempfile::tempdir().expect("out dir");
    let printed = platform_ok(
        &[
            "train",
            &study.to_string(),
            "--database-url",
            &db.url,
            "--lambda",
            "0.5",
            "--out",
            &out.path().to_string_lossy(),
        ],
        &[],
    );
    assert!(printed.contains("λ = 0.5000"), "{printed}");
    let cli_model: Value = serde_json::from_str(
        &std::fs::read_to_string(out.path().join("model.json")).expect("model.json written"),
    )
    .expect("model.json parses");
    assert_eq!(cli_model["lambda"], 0.5);
    assert!(out.path().join("index.html").exists());
    assert!(out.path().join("weights.png").exists());
    let (_, list) = send(c.get(&models_url).header("cookie", &cookie)).await;
    assert_eq!(list.as_array().map(Vec::len), Some(2), "{list}");
    // A fixed λ has no cross-validation, hence no held-out figure.
    assert!(list[0]["cv_accuracy"].is_null(), "{list}");

    // A bad study id is a clear CLI error, not a panic.
    let bad = platform_cmd(&["train", "1", "--database-url", &db.url], &[]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("not found"));
}

/// Issue 16: `platform demo --simulate 20` trained a metric no better than uniform weights (λ at
/// the grid's end, 1 of 169 weights, agreement 0.567 against 0.568). Its honest raters now
/// answer by a hidden sparse style metric; the metric trained on their answers must beat uniform
/// weights on held-out answers with disjoint 95% intervals, and the report must mark the λ.
#[test]
fn demo_metric_beats_uniform_with_disjoint_intervals() {
    let dir = tempfile::tempdir().expect("temp dir");
    let url = format!("sqlite://{}", dir.path().join("demo.db").display());
    let fixtures = e2e::fixture("style");
    let printed = platform_ok(
        &[
            "demo",
            // 30 workers, not the 20 of the measured runs (disjoint in 100 of 100 seeds): the
            // simulation is not repeatable for a seed (ids are random, and they order HITs
            // and folds), and one run in a few dozen at 20 workers had the intervals touch.
            "--simulate",
            "30",
            "--seed",
            "17",
            "--no-serve",
            "--database-url",
            &url,
            "--bind",
            "127.0.0.1:0",
            "--fixtures",
            &fixtures.to_string_lossy(),
        ],
        &[],
    );
    eprintln!("{printed}");
    let line = printed
        .lines()
        .find(|l| l.starts_with("trained the style metric"))
        .unwrap_or_else(|| panic!("no training line:\n{printed}"));
    assert!(line.contains("held-out: learned"), "{line}");
    assert!(
        !printed.contains("listening on"),
        "--no-serve listens nowhere:\n{printed}"
    );
    assert!(!line.contains("overlap"), "{line}");
    assert!(
        !printed.contains("note:"),
        "no warning expected:\n{printed}"
    );

    let rt = tokio::runtime::Runtime::new().expect("runtime");
    let (held_out, lambda, nonzero, report, chart) = rt.block_on(async {
        sqlx::any::install_default_drivers();
        let pool = sqlx::AnyPool::connect(&url).await.expect("connect");
        let (held_out, lambda, nonzero, id): (String, f64, i64, i64) = sqlx::query_as(
            "SELECT held_out, lambda, nonzero, id FROM models WHERE status = 'done'",
        )
        .fetch_one(&pool)
        .await
        .expect("one trained model");
        let file = |name: &'static str| {
            let pool = pool.clone();
            async move {
                let (bytes,): (Vec<u8>,) = sqlx::query_as(
                    "SELECT bytes FROM model_files WHERE model_id = $1 AND name = $2",
                )
                .bind(id)
                .bind(name)
                .fetch_one(&pool)
                .await
                .expect(name);
                String::from_utf8(bytes).expect("text file")
            }
        };
        let report = file("index.html").await;
        let chart = file("lambda.svg").await;
        pool.close().await;
        (held_out, lambda, nonzero, report, chart)
    });
    let h: Value = serde_json::from_str(&held_out).expect("held_out JSON");
    let get = |who: &str, what: &str| h[who][what].as_f64().expect("interval bound");
    assert_eq!(h["unit"], "worker", "{h}");
    assert!(
        get("learned", "low") > get("uniform", "high"),
        "learned {} [{}, {}] vs uniform {} [{}, {}]",
        get("learned", "value"),
        get("learned", "low"),
        get("learned", "high"),
        get("uniform", "value"),
        get("uniform", "low"),
        get("uniform", "high"),
    );
    assert!(get("difference", "low") > 0.05, "{h}");
    // A sparse metric, neither empty nor everything.
    assert!((1..=40).contains(&nonzero), "{nonzero} weights");
    // The report shows the search with the chosen λ marked, in the table and on the chart.
    let label = format!("chosen λ = {lambda:.4}");
    assert!(report.contains(&label), "report lacks {label}");
    assert!(report.contains("class=\"chosen\""));
    assert!(report.contains("Held-out agreement"));
    assert!(chart.contains(&label), "chart lacks {label}");
}
