//! The exports: no cell a spreadsheet would run as a formula (item names, worker ids, reasons
//! text), numbers left as numbers, the learner still reading `triplets.csv`; the filters apply
//! to every analysis file alike while the payment files list every HIT and bonus to pay; the
//! study page's exports form carries the options; ISO 8601 UTC columns.

use std::collections::BTreeSet;

use e2e::both_databases;
use e2e::platform::*;
use serde_json::{Value, json};

use super::*;

/// Worker ids the platform accepts that start like a formula.
const ALICE: &str = "@alice";
const MID: &str = "-mid";
/// An MTurk worker whose every hidden control is wrong: rejected by the rule.
const REJECTED: &str = "A1REJECTED0000";
const FORMULA_TEXT: &str = "=HYPERLINK(\"http://evil.example\",\"x\")";

/// Imports a library whose every item name starts with `-`, `=`, `+` or `@` (file names are
/// the researcher's input), creates a study and an admin; returns the study id.
fn setup_formula_study(db: &TestDb, opts: &StudyOpts) -> i64 {
    let lib = small_library(6);
    let labels = std::fs::read_to_string(lib.path().join("labels.csv")).expect("labels");
    let mut renamed = String::from("file,style,keywords\n");
    for (i, line) in labels.lines().skip(1).enumerate() {
        let mut cols = line.split(',');
        let (file, style) = (cols.next().expect("file"), cols.next().expect("style"));
        let prefix = ["-", "=", "+", "@"][i % 4];
        let new = format!("{prefix}{}", file.replace('/', "-"));
        std::fs::rename(lib.path().join(file), lib.path().join(&new)).expect("rename");
        renamed.push_str(&format!("{new},{style},\n"));
    }
    std::fs::write(lib.path().join("labels.csv"), renamed).expect("labels");
    import_library(db, lib.path());
    let settings = lib.path().join("settings.json");
    let mut body = json!({
        "questions_per_hit": opts.questions,
        "controls_per_hit": opts.controls,
        "tuples": opts.tuples,
        "replication": opts.replication,
        "training_questions": 2,
    });
    for (k, v) in opts.extra.as_object().expect("extra settings") {
        body[k] = v.clone();
    }
    std::fs::write(&settings, body.to_string()).expect("settings");
    let out = platform_ok(
        &[
            "study",
            "create",
            "--database-url",
            &db.url,
            "--name",
            "formulas",
            "--library",
            "fx",
            "--settings",
            &settings.to_string_lossy(),
        ],
        &[],
    );
    create_admin(&db.url);
    out.split_whitespace()
        .nth(1)
        .and_then(|id| id.trim_end_matches(':').parse().ok())
        .unwrap_or_else(|| panic!("no study id in {out:?}"))
}

/// The analysis files, which the filters apply to.
const ANALYSIS: [&str; 5] = [
    "triplets.csv",
    "reasons.csv",
    "workers.csv",
    "assignments.csv",
    "bonuses.csv",
];

fn ids(rows: &[HashMap<String, String>]) -> BTreeSet<String> {
    rows.iter().map(|r| r["worker_id"].clone()).collect()
}

/// A worker id as the files write it: with the spreadsheet quote when it starts like a formula.
fn written(id: &str) -> String {
    if id.starts_with(['=', '+', '-', '@']) {
        format!("'{id}")
    } else {
        id.to_string()
    }
}

async fn exports_are_spreadsheet_safe_and_filtered_alike(db: TestDb) {
    let opts = StudyOpts {
        questions: 8,
        controls: 2,
        extra: json!({"reasons_probability": 1.0}),
        ..StudyOpts::default()
    };
    let study = setup_formula_study(&db, &opts);
    let server = Server::start(&db.url);
    let c = client();
    let s = Study {
        c: &c,
        base: &server.base,
        id: study,
        styles: item_styles(&db.url).await,
    };
    run_worker(&s, direct(ALICE), Run::Honest, FORMULA_TEXT).await;
    run_worker(&s, mturk(REJECTED, "ASG-R"), Run::Wrong, "-2+3").await;
    // Three answers of a HIT with two hidden controls: at least one main answer.
    run_worker(&s, direct(MID), Run::Partly(3), "+cmd").await;
    let admin = Admin::login(&c, &server.base).await;
    let rows = admin.workers(study).await;
    assert_eq!(rows[REJECTED]["decision"], "rejected", "{rows:?}");
    for (worker, amount) in [(ALICE, "1.25"), (REJECTED, "0.50")] {
        let (status, body) = admin
            .api(
                &format!(
                    "/api/v1/admin/studies/{study}/assignments/{}/bonuses",
                    rows[worker]["assignment"]
                ),
                json!({"amount": amount, "reason": "Thank you"}),
            )
            .await;
        assert_eq!(status, 200, "{body}");
    }

    // Every text cell of every CSV that starts like a formula carries the quote; the number
    // columns the manifest lists are numbers.
    let everything = "?include_controls=true&include_rejected=true&include_incomplete=true";
    let (_, manifest) = admin.export(study, "manifest.json", everything).await;
    let manifest: Value = serde_json::from_str(&manifest).expect("manifest");
    for file in manifest["files"].as_array().expect("files") {
        let file = file.as_str().expect("name");
        if !file.ends_with(".csv") {
            continue;
        }
        let numbers: Vec<&str> = manifest["number_columns"][file]
            .as_array()
            .unwrap_or_else(|| panic!("{file}: number columns"))
            .iter()
            .filter_map(Value::as_str)
            .collect();
        let header = file != "prolific_bonuses.csv";
        let (_, text) = admin.export(study, file, everything).await;
        let names: Vec<String> = manifest["columns"][file]
            .as_object()
            .expect("dictionary")
            .keys()
            .cloned()
            .collect();
        let (_, table) = csv_table(&text, header);
        for r in &table {
            for (col, cell) in r {
                let name = if header {
                    col.clone()
                } else {
                    names[col.parse::<usize>().expect("index")].clone()
                };
                if numbers.contains(&name.as_str()) {
                    assert!(
                        cell.is_empty() || cell.parse::<f64>().is_ok(),
                        "{file}: {name} {cell:?}"
                    );
                } else {
                    assert!(
                        !cell.starts_with(['=', '+', '-', '@', '\t', '\r']),
                        "{file}: {name} = {cell:?} would run as a formula"
                    );
                }
            }
        }
    }
    let (_, reasons) = admin.export(study, "reasons.csv", everything).await;
    let (_, reasons) = csv_table(&reasons, true);
    let texts: BTreeSet<&str> = reasons.iter().map(|r| r["text"].as_str()).collect();
    assert!(
        texts.contains(format!("'{FORMULA_TEXT}").as_str()),
        "{texts:?}"
    );
    assert!(
        texts.contains("'-2+3") && texts.contains("'+cmd"),
        "{texts:?}"
    );
    let (_, triplets) = admin.export(study, "triplets.csv", everything).await;
    let (_, triplets) = csv_table(&triplets, true);
    assert!(
        triplets.iter().all(|t| t["a"].starts_with('\'')),
        "item names quoted"
    );
    let written_ids: BTreeSet<String> = ids(&triplets);
    assert_eq!(
        written_ids,
        [written(ALICE), written(MID), written(REJECTED)].into(),
        "{written_ids:?}"
    );
    // The learner reads the quoted names back: `platform train` fits on triplets.csv.
    let out = platform_ok(
        &[
            "train",
            &study.to_string(),
            "--database-url",
            &db.url,
            "--lambda",
            "0.1",
        ],
        &[],
    );
    assert!(!out.is_empty());

    // The filters apply to every analysis file alike.
    let cases: [(&str, &[&str], &[&str]); 4] = [
        ("", &[ALICE], &[ALICE]),
        (
            "?include_rejected=true",
            &[ALICE, REJECTED],
            &[ALICE, REJECTED],
        ),
        ("?include_incomplete=true", &[ALICE, MID], &[ALICE]),
        (
            "?include_rejected=true&include_incomplete=true",
            &[ALICE, REJECTED, MID],
            &[ALICE, REJECTED],
        ),
    ];
    for (query, workers, bonused) in cases {
        for file in ANALYSIS {
            let (_, text) = admin.export(study, file, query).await;
            let (_, table) = csv_table(&text, true);
            let want = if file == "bonuses.csv" {
                bonused
            } else {
                workers
            };
            let want: BTreeSet<String> = want.iter().map(|w| written(w)).collect();
            assert_eq!(ids(&table), want, "{file}{query}");
        }
        // The payment files ignore the filters: the rejected MTurk HIT gets its decision and
        // its bonus in every export.
        let (_, decisions) = admin.export(study, "mturk_decisions.csv", query).await;
        assert!(
            decisions.contains(&format!("ASG-R,{REJECTED},HIT1,,Too many")),
            "{query}: {decisions}"
        );
        let (_, bonuses) = admin.export(study, "mturk_bonuses.csv", query).await;
        assert!(
            bonuses.contains(&format!("{REJECTED},ASG-R,0.50,")),
            "{bonuses}"
        );
    }
    // Hidden controls: in triplets.csv and reasons.csv only with include_controls, and the
    // answer counts of workers.csv follow (they add up to triplets.csv's rows).
    for query in ["?include_incomplete=true", everything] {
        let controls = query.contains("include_controls");
        let (_, t) = admin.export(study, "triplets.csv", query).await;
        let (_, t) = csv_table(&t, true);
        let (_, r) = admin.export(study, "reasons.csv", query).await;
        let (_, r) = csv_table(&r, true);
        let (_, w) = admin.export(study, "workers.csv", query).await;
        let (_, w) = csv_table(&w, true);
        let is_control = |row: &HashMap<String, String>| row["tuple_id"].starts_with("control:");
        assert_eq!(t.iter().any(is_control), controls, "triplets{query}");
        assert_eq!(r.iter().any(is_control), controls, "reasons{query}");
        let answered: usize = w
            .iter()
            .map(|x| x["answered"].parse::<usize>().expect("n"))
            .sum();
        assert_eq!(answered, t.len(), "{query}");
    }
    // The manifest says what each filter does to each file, and why the payment files differ.
    let notes = &manifest["notes"];
    for filter in ["include_controls", "include_rejected", "include_incomplete"] {
        for file in ANALYSIS {
            assert!(
                notes["filters"][filter][file].is_string(),
                "{filter} {file}"
            );
        }
    }
    assert!(
        notes["payment_files"]
            .as_str()
            .is_some_and(|n| n.contains("mturk_decisions.csv")),
        "{notes}"
    );

    // Machine-readable times with an ISO 8601 UTC column beside them.
    let (_, a) = admin.export(study, "assignments.csv", "").await;
    let (_, a) = csv_table(&a, true);
    let ms: i64 = a[0]["started_at"].parse().expect("ms");
    let iso = &a[0]["started_at_utc"];
    let day_ms = ms.rem_euclid(86_400_000);
    let clock = format!(
        "T{:02}:{:02}:{:02}.{:03}Z",
        day_ms / 3_600_000,
        day_ms / 60_000 % 60,
        day_ms / 1000 % 60,
        day_ms % 1000
    );
    assert!(iso.len() == 24 && iso.ends_with(&clock), "{iso} for {ms}");

    // The command line writes a pseudonymous export without the payment files.
    let dir = tempfile::tempdir().expect("tmp");
    let out = dir.path().to_string_lossy().into_owned();
    let study_arg = study.to_string();
    platform_ok(
        &[
            "export",
            &study_arg,
            "--database-url",
            &db.url,
            "--out",
            &out,
            "--pseudonymous",
        ],
        &[],
    );
    let workers = std::fs::read_to_string(dir.path().join("workers.csv")).expect("workers.csv");
    assert!(
        !workers.contains("alice") && !workers.contains(REJECTED),
        "{workers}"
    );
    for file in [
        "mturk_decisions.csv",
        "mturk_bonuses.csv",
        "prolific_bonuses.csv",
    ] {
        assert!(
            !dir.path().join(file).exists(),
            "{file} in a pseudonymous export"
        );
    }

    // The study page's exports form: the links carry the options chosen.
    let page = admin
        .page(study, "?include_rejected=true&pseudonymous=true")
        .await;
    let exports = section(&page, "exports-section");
    assert!(
        exports.contains(&format!(
            "/admin/studies/{study}/export/workers.csv?include_rejected=true&#38;pseudonymous=true\""
        )),
        "{exports}"
    );
    assert!(exports.contains("name=\"include_rejected\" value=\"true\" checked"));
    assert!(!exports.contains("name=\"include_controls\" value=\"true\" checked"));
    assert!(
        !exports.contains("mturk_bonuses.csv"),
        "no payment file when pseudonymous"
    );
    let page = admin.page(study, "").await;
    let exports = section(&page, "exports-section");
    assert!(exports.contains(&format!(
        "/admin/studies/{study}/export/mturk_bonuses.csv\""
    )));
}
both_databases!(
    exports_are_spreadsheet_safe_and_filtered_alike,
    exports_are_spreadsheet_safe_and_filtered_alike_sqlite,
    exports_are_spreadsheet_safe_and_filtered_alike_postgres
);
