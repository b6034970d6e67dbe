//! The study's report in its export (`report.json`, `report.csv`) for every kind: the JSON is
//! the report endpoint's body, and every number of the endpoint is a row of the CSV that reads
//! back as the same f64. The rating and mash-up studies' tests call
//! [`check_report_export`] after their workers answered; a triplet study is checked here, over
//! the API and `platform export`.

use e2e::both_databases;
use e2e::platform::*;
use serde_json::Value;

/// The rows of `report.csv` as (group, measure) → (value, text).
fn csv_rows(text: &str) -> Vec<(String, String, String, String, String)> {
    let mut r = csv::Reader::from_reader(text.as_bytes());
    let header: Vec<String> = r
        .headers()
        .expect("header")
        .iter()
        .map(str::to_string)
        .collect();
    assert_eq!(header, ["kind", "group", "measure", "value", "text"]);
    r.records()
        .map(|rec| {
            let rec = rec.expect("record");
            let get = |i: usize| rec.get(i).expect("cell").to_string();
            (get(0), get(1), get(2), get(3), get(4))
        })
        .collect()
}

/// Every number of `report` (the endpoint's body) under `group`, as (group, measure, value).
fn numbers(report: &Value) -> Vec<(String, String, Option<f64>)> {
    let mut out = Vec::new();
    let push_all = |out: &mut Vec<_>, group: &str, obj: &Value, prefix: &str, keys: &[&str]| {
        for k in keys {
            out.push((group.to_string(), format!("{prefix}{k}"), obj[*k].as_f64()));
        }
    };
    match report["kind"].as_str().expect("kind") {
        "composition-rating" => {
            push_all(
                &mut out,
                "",
                report,
                "",
                &["workers", "answers", "chose_a", "mean_rate"],
            );
            let stats = &report["stats"];
            push_all(
                &mut out,
                "",
                stats,
                "",
                &["t", "df", "p", "effect_size", "sd", "ci_low", "ci_high"],
            );
            for w in report["per_worker"].as_array().expect("per_worker") {
                let group = format!("worker {}", w["worker"]);
                push_all(&mut out, &group, w, "", &["answers", "chose_a", "rate"]);
            }
        }
        "mashup" => {
            for c in report["conditions"].as_array().expect("conditions") {
                let group = c["condition"].as_str().expect("condition");
                push_all(&mut out, group, c, "", &["workers", "pieces", "searches"]);
                let p = &c["position"];
                let keys = ["mean", "half_width", "low", "high", "sd"];
                push_all(&mut out, group, p, "position_", &keys);
            }
        }
        "iconset" => {
            push_all(&mut out, "", report, "", &["confidence"]);
            for c in report["conditions"].as_array().expect("conditions") {
                let group = c["condition"].as_str().expect("condition");
                push_all(&mut out, group, c, "", &["workers", "sets"]);
                let keys = ["mean", "half_width", "low", "high", "sd"];
                for m in [
                    "seconds_per_set",
                    "deletions_per_set",
                    "searches_per_set",
                    "spread_per_set",
                ] {
                    push_all(&mut out, group, &c[m], &format!("{m}_"), &keys);
                }
            }
        }
        _ => {}
    }
    out
}

/// Fetches `report.json` and `report.csv` of `study` from the export and checks them against
/// `GET /api/v1/admin/studies/ID/report`; returns the report.
pub(crate) async fn check_report_export(
    c: &reqwest::Client,
    base: &str,
    cookie: &str,
    study: i64,
) -> Value {
    let get = |path: String| {
        let req = c.get(format!("{base}{path}")).header("cookie", cookie);
        async move {
            let resp = req.send().await.expect("request");
            assert_eq!(resp.status().as_u16(), 200, "{path}");
            resp.text().await.expect("body")
        }
    };
    let report: Value =
        serde_json::from_str(&get(format!("/api/v1/admin/studies/{study}/report")).await)
            .expect("report");
    let exported = get(format!("/api/v1/admin/studies/{study}/export/report.json")).await;
    let exported: Value = serde_json::from_str(&exported).expect("report.json");
    assert_eq!(exported, report, "report.json is not the endpoint's report");
    let rows = csv_rows(&get(format!("/api/v1/admin/studies/{study}/export/report.csv")).await);
    assert!(
        rows.iter().all(|r| r.0 == report["kind"].as_str().unwrap()),
        "{rows:?}"
    );
    let want = numbers(&report);
    for (group, measure, value) in &want {
        let row = rows
            .iter()
            .find(|r| &r.1 == group && &r.2 == measure)
            .unwrap_or_else(|| panic!("report.csv has no row {group:?} {measure}: {rows:?}"));
        let got = (!row.3.is_empty()).then(|| row.3.parse::<f64>().expect("number"));
        assert_eq!(got, *value, "{group:?} {measure}");
    }
    if report["kind"] == "composition-rating" {
        let question = rows
            .iter()
            .find(|r| r.2 == "question")
            .expect("question row");
        assert_eq!(question.4, report["question"].as_str().unwrap());
        // Every number row is one of the report's.
        let numeric = rows
            .iter()
            .filter(|r| r.2 != "question" && r.2 != "note")
            .count();
        assert_eq!(numeric, want.len(), "{rows:?}");
    }
    // The study page lists both files.
    let page = get(format!("/admin/studies/{study}")).await;
    for f in ["report.json", "report.csv"] {
        assert!(
            page.contains(&format!("/admin/studies/{study}/export/{f}")),
            "{f}"
        );
    }
    report
}

async fn triplet_report_export(db: TestDb) {
    let study = setup_study(
        &db,
        &StudyOpts {
            tuples: 30,
            ..StudyOpts::default()
        },
    );
    let server = Server::start(&db.url);
    let base = server.url("");
    let base = base.trim_end_matches('/');
    let c = client();
    let (cookie, _) = admin_login(&c, base).await;
    let report = check_report_export(&c, base, &cookie, study).await;
    assert_eq!(report, serde_json::json!({"kind": "triplet"}));
    // `platform export` writes the same two files.
    let dir = tempfile::tempdir().expect("dir");
    let out = dir.path().to_string_lossy().into_owned();
    platform_ok(
        &[
            "export",
            &study.to_string(),
            "--database-url",
            &db.url,
            "--out",
            &out,
        ],
        &[],
    );
    let json: Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("report.json")).expect("report.json"),
    )
    .expect("json");
    assert_eq!(json, report);
    let csv = std::fs::read_to_string(dir.path().join("report.csv")).expect("report.csv");
    let rows = csv_rows(&csv);
    assert_eq!(rows.len(), 1, "{rows:?}");
    assert_eq!(
        (rows[0].0.as_str(), rows[0].2.as_str()),
        ("triplet", "note")
    );
}

both_databases!(
    triplet_report_export,
    triplet_report_export_sqlite,
    triplet_report_export_postgres
);
