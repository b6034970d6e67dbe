use super::*;

#[test]
fn questions_insert_numbers_every_placeholder_once() {
    let sql = questions_insert_sql(3);
    assert!(sql.ends_with("($13, $14, $15, $16, $17, $18)"), "{sql}");
    for n in 1..=18 {
        assert_eq!(
            sql.matches(&format!("${n},")).count() + sql.matches(&format!("${n})")).count(),
            1,
            "${n}"
        );
    }
    assert!(!sql.contains("$19"));
}

#[test]
fn codes_depend_on_secret_kind_and_assignment() {
    let c = code("k", "complete", AssignmentId(7));
    assert_eq!(c.len(), 12);
    assert_eq!(c, code("k", "complete", AssignmentId(7)));
    assert_ne!(c, code("k2", "complete", AssignmentId(7)));
    assert_ne!(c, code("k", "screenout", AssignmentId(7)));
    assert_ne!(c, code("k", "complete", AssignmentId(8)));
}

#[test]
fn submit_addresses_are_checked_against_the_mode() {
    assert_eq!(
        check_submit_to("https://workersandbox.mturk.com/", MturkMode::Sandbox).ok(),
        Some(true)
    );
    assert!(check_submit_to("https://www.mturk.com", MturkMode::Sandbox).is_err());
    assert!(check_submit_to("https://evil.example", MturkMode::Live).is_err());
}

#[test]
fn external_ids_are_restricted() {
    assert!(valid_external("w", "A1B2C3").is_ok());
    assert!(valid_external("w", "").is_err());
    assert!(valid_external("w", "<script>").is_err());
    assert!(valid_external("w", &"x".repeat(129)).is_err());
}

/// A fresh SQLite file, and a fresh PostgreSQL database when `TEST_POSTGRES_URL` names a
/// server (`scripts/test` starts one; CI must have it).
pub(crate) async fn databases() -> Vec<(Db, Option<tempfile::TempDir>)> {
    let dir = tempfile::tempdir().expect("temp dir");
    let url = format!("sqlite://{}", dir.path().join("f.db").display());
    let mut dbs = vec![(Db::connect(&url, 4).await.expect("sqlite"), Some(dir))];
    match std::env::var("TEST_POSTGRES_URL")
        .ok()
        .filter(|u| !u.is_empty())
    {
        Some(admin) => {
            sqlx::any::install_default_drivers();
            let name = format!("f_{:016x}", rand::rng().random::<u64>());
            let mut conn = <AnyConnection as sqlx::Connection>::connect(&admin)
                .await
                .expect("connect to TEST_POSTGRES_URL");
            sqlx::Executor::execute(
                &mut conn,
                sqlx::AssertSqlSafe(format!("CREATE DATABASE {name}")),
            )
            .await
            .expect("create database");
            let (head, _) = admin.rsplit_once('/').expect("database path");
            let db = Db::connect(&format!("{head}/{name}"), 4)
                .await
                .expect("postgres");
            dbs.push((db, None));
        }
        None => assert!(
            std::env::var("CI").is_err(),
            "TEST_POSTGRES_URL is not set: CI must run the PostgreSQL half"
        ),
    }
    dbs
}

async fn assignments_of(db: &Db, worker: &str) -> i64 {
    sqlx::query(
        "SELECT CAST(COUNT(*) AS BIGINT) AS n FROM assignments a \
         JOIN workers w ON w.id = a.worker_id WHERE w.external_id = $1",
    )
    .bind(worker)
    .fetch_one(&db.pool)
    .await
    .expect("count")
    .get("n")
}

/// A start that read the study before an edit of its HIT shape, MTurk site or block list
/// committed allocates nothing with the old settings: the allocation re-reads them in its
/// own transaction and refuses (409, or 403 for a worker blocked meanwhile); a retry with
/// the study as it is now gets a HIT of the new shape. On both databases.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn starts_follow_settings_edited_since_the_study_was_read() {
    for (db, _dir) in databases().await {
        let id = crate::cli::bench::prepare(&db, 2, 1).await.expect("study");
        let direct = |worker: &str| StartRequest {
            source: Some(Source::Direct),
            worker_id: Some(worker.to_string()),
            ..StartRequest::default()
        };
        let stale = study::load(&db, id).await.expect("load");
        let shape = crate::studies::study_edit::SettingsPatch {
            questions_per_hit: Some(20),
            ..Default::default()
        };
        crate::studies::study_edit::edit(&db, id, &shape, "test")
            .await
            .expect("edit before any assignment");
        let refused = start(&db, &stale, direct("w1")).await;
        assert!(matches!(refused, Err(AppError::Conflict(_))), "{refused:?}");
        assert_eq!(assignments_of(&db, "w1").await, 0, "{:?}", db.backend);

        let fresh = study::load(&db, id).await.expect("load");
        let Ok(StartOutcome::Started { token, .. }) = start(&db, &fresh, direct("w1")).await else {
            panic!("a retry with the current settings starts")
        };
        let questions: i64 = sqlx::query(
            "SELECT CAST(COUNT(*) AS BIGINT) AS n FROM questions q \
             JOIN assignments a ON a.id = q.assignment_id WHERE a.token = $1",
        )
        .bind(&token)
        .fetch_one(&db.pool)
        .await
        .expect("questions")
        .get("n");
        assert_eq!(questions, 20);

        let block = crate::studies::study_edit::SettingsPatch {
            blocked_workers: Some(vec!["w2".into()]),
            ..Default::default()
        };
        crate::studies::study_edit::edit(&db, id, &block, "test")
            .await
            .expect("block");
        let blocked = start(&db, &fresh, direct("w2")).await;
        assert!(
            matches!(blocked, Err(AppError::Forbidden(_))),
            "{blocked:?}"
        );
        assert_eq!(assignments_of(&db, "w2").await, 0);
    }
}
