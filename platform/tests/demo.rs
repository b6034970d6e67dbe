//! The library end to end in one process: `demo::setup` imports the fixture library, the
//! simulated workers of `platform demo --simulate` run through the flow, the control rule
//! rejects the spammers, and `app(state)` serves the dashboard over real HTTP on
//! `127.0.0.1:0`.

use platform::AppState;
use platform::cli::demo;
use platform::store::db::Db;
use platform::studies::{dashboard, export};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn demo_setup_simulation_and_dashboard() {
    let dir = tempfile::tempdir().expect("temp dir");
    let url = format!("sqlite://{}", dir.path().join("demo.db").display());
    let db = Db::connect(&url, 4).await.expect("connect");
    let fixtures =
        std::path::PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../fixtures/style"));
    let (study, password) = demo::setup(&db, Some(fixtures.clone()))
        .await
        .expect("setup");
    assert!(
        password.is_some_and(|p| p.len() == 20),
        "admin password printed once"
    );
    // Idempotent: a second setup reuses the library, the study and the admin.
    let (again, password) = demo::setup(&db, Some(fixtures)).await.expect("setup again");
    assert_eq!(again.id, study.id);
    assert!(password.is_none());

    let report = demo::simulate(&db, &study, 10, 7).await.expect("simulate");
    assert_eq!((report.honest, report.spammers), (8, 2));
    let (d, workers) = dashboard::compute(&db, &study).await.expect("dashboard");
    assert_eq!(d.completed, 10);
    // Spammers answer the 8 controls at random: most, not all, are caught; honest workers
    // (95% right on controls) are almost always kept.
    assert!(d.rejected <= 4, "{d:?}");
    assert!(workers.iter().all(|w| w.answered == 50));
    assert_eq!(d.answers, 10 * 42);

    let files = export::build(&db, &study, export::ExportOptions::default(), "http://x")
        .await
        .expect("export");
    let triplets = &files
        .iter()
        .find(|(n, _)| n == "triplets.csv")
        .expect("triplets")
        .1;
    let rows = String::from_utf8_lossy(triplets).lines().count() - 1;
    assert_eq!(rows as i64, (d.completed - d.rejected) * 42);

    let listener = tokio::net::TcpListener::bind("127.0.0.1:0")
        .await
        .expect("bind");
    let base = format!("http://{}", listener.local_addr().expect("addr"));
    let state = AppState::new(db, base.clone(), false, 65536);
    let server = tokio::spawn(async move { axum::serve(listener, platform::app(state)).await });
    let health = reqwest::get(format!("{base}/healthz"))
        .await
        .expect("healthz");
    assert_eq!(health.status().as_u16(), 200);
    let info: serde_json::Value = reqwest::get(format!("{base}/api/v1/studies/{}", study.id))
        .await
        .expect("study")
        .json()
        .await
        .expect("json");
    assert_eq!(info["questions_per_hit"], 50);
    server.abort();
}
