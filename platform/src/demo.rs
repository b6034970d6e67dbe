//! `platform demo`: a study a researcher can click through in a minute (fixture library with
//! style labels, a study with replicated tuples, an admin whose password is printed once), and
//! in-process simulated workers (honest ones with known noise, spammers) for the dashboard.

use std::path::PathBuf;

use rand::{Rng, SeedableRng};
use sqlx::Row;

use crate::cli::DemoArgs;
use crate::db::Db;
use crate::error::{AppError, Result};
use crate::flow::{self, AnswerRequest, Source, StartOutcome, StartRequest, TrainingAnswer};
use crate::ids::StudyId;
use crate::study::{self, Study, StudySettings};
use crate::{admin, library};

/// Name of the demo library.
pub const DEMO_LIBRARY: &str = "fixture-style";
/// Name of the demo study.
pub const DEMO_STUDY: &str = "Demo: clip-art style";

/// A random 20-character password.
pub fn generate_password() -> String {
    use rand::distr::{Alphanumeric, SampleString};
    Alphanumeric.sample_string(&mut rand::rng(), 20)
}

fn default_fixtures() -> PathBuf {
    let local = PathBuf::from("fixtures/style");
    if local.join("labels.csv").exists() {
        local
    } else {
        PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../fixtures/style"))
    }
}

/// Sets up (idempotently) the demo library, study and admin; returns the study.
pub async fn setup(db: &Db, fixtures: Option<PathBuf>) -> Result<(Study, Option<String>)> {
    let fixtures = fixtures.unwrap_or_else(default_fixtures);
    let library = library::ensure_library(db, DEMO_LIBRARY).await?;
    if library::list_items(db, library).await?.is_empty() {
        let labels = fixtures.join("labels.csv");
        let report = library::import_paths(
            db,
            DEMO_LIBRARY,
            std::slice::from_ref(&fixtures),
            labels.exists().then_some(labels.as_path()),
        )
        .await?;
        outln!(
            "imported {} items from {} ({} skipped)",
            report.imported,
            fixtures.display(),
            report.skipped.len()
        )?;
    }
    let existing =
        sqlx::query("SELECT id FROM studies WHERE name = $1 ORDER BY created_at LIMIT 1")
            .bind(DEMO_STUDY)
            .fetch_optional(&db.pool)
            .await?;
    let id = match existing {
        Some(r) => StudyId(r.try_get("id")?),
        None => {
            let settings = StudySettings {
                description: "Which picture is closer in style? Pay attention to colours, \
                              shading, outlines and shapes, not to what is drawn."
                    .into(),
                tuples: 400,
                replication: 3,
                ..StudySettings::default()
            };
            study::create(db, DEMO_STUDY, library, settings).await?.0
        }
    };
    let admins = sqlx::query("SELECT CAST(COUNT(*) AS BIGINT) AS n FROM admins")
        .fetch_one(&db.pool)
        .await?;
    let password = if admins.try_get::<i64, _>("n")? == 0 {
        let p = generate_password();
        admin::create_admin(db, "admin", &p).await?;
        Some(p)
    } else {
        None
    };
    Ok((study::load(db, id).await?, password))
}

/// What a simulation did.
#[derive(Debug, Default, Clone, serde::Serialize)]
pub struct SimReport {
    /// Honest workers that completed.
    pub honest: usize,
    /// Spammers that completed.
    pub spammers: usize,
}

/// Runs `n` simulated workers through the flow functions (in process): honest workers answer
/// controls right with probability 0.95, and main questions like a person who sees style —
/// the candidate sharing A's style label when exactly one does, otherwise a hidden per-tuple
/// truth — with probability 0.8; every fifth worker is a spammer answering at random. So a
/// metric trained on the demo's answers (`platform train`) has style to find.
pub async fn simulate(db: &Db, study: &Study, n: u32, seed: u64) -> Result<SimReport> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut report = SimReport::default();
    let styles: std::collections::HashMap<i64, Option<String>> =
        sqlx::query("SELECT id, style FROM items WHERE library_id = $1")
            .bind(study.library.0)
            .fetch_all(&db.pool)
            .await?
            .iter()
            .map(|r| Ok((r.try_get("id")?, r.try_get("style")?)))
            .collect::<Result<_>>()?;
    let style = |id: i64| styles.get(&id).cloned().flatten();
    for i in 0..n {
        let spammer = i % 5 == 4;
        let outcome = flow::start(
            db,
            study,
            StartRequest {
                source: Some(Source::Direct),
                worker_id: Some(format!("sim-{seed}-{i}")),
                ..StartRequest::default()
            },
        )
        .await?;
        let StartOutcome::Started { token, .. } = outcome else {
            continue;
        };
        let mut a = flow::by_token(db, &token).await?;
        while a.status == "training" {
            let qs = flow::training_questions(db, &a).await?;
            let mut answers = Vec::new();
            for q in &qs {
                let row = sqlx::query(
                    "SELECT b FROM tuples WHERE study_id = $1 AND kind = 'training' AND a = $2 \
                     AND (b = $3 OR b = $4)",
                )
                .bind(study.id.0)
                .bind(q.reference.id.0)
                .bind(q.left.id.0)
                .bind(q.right.id.0)
                .fetch_one(&db.pool)
                .await?;
                let right: i64 = row.try_get("b")?;
                // Spammers too get through the training (by retrying until they guess right,
                // as real ones do); the hidden controls are what catches them.
                let pick_right = true;
                let wrong = if q.left.id.0 == right {
                    q.right.id
                } else {
                    q.left.id
                };
                answers.push(TrainingAnswer {
                    position: q.position,
                    choice: if pick_right {
                        crate::ids::ItemId(right)
                    } else {
                        wrong
                    },
                });
            }
            match flow::submit_training(db, study, &a, &answers).await {
                Ok(_) => {}
                Err(AppError::Conflict(_)) => break,
                Err(e) => return Err(e),
            }
            a = flow::by_token(db, &token).await?;
        }
        if a.status != "active" {
            continue;
        }
        let rows = sqlx::query(
            "SELECT q.position, t.kind, t.id, t.a, t.b, t.c FROM questions q JOIN tuples t ON t.id = q.tuple_id \
             WHERE q.assignment_id = $1 ORDER BY q.position",
        )
        .bind(a.id.0)
        .fetch_all(&db.pool)
        .await?;
        for r in rows {
            let kind: String = r.try_get("kind")?;
            let tuple: i64 = r.try_get("id")?;
            let (b, c): (i64, i64) = (r.try_get("b")?, r.try_get("c")?);
            let picks_b = if spammer {
                rng.random_bool(0.5)
            } else if kind == "control" {
                rng.random_bool(0.95)
            } else {
                let a_style = style(r.try_get("a")?);
                let truth_b = match (style(b) == a_style, style(c) == a_style) {
                    (true, false) if a_style.is_some() => true,
                    (false, true) if a_style.is_some() => false,
                    _ => tuple % 2 == 0,
                };
                if rng.random_bool(0.8) {
                    truth_b
                } else {
                    !truth_b
                }
            };
            let req = AnswerRequest {
                position: r.try_get("position")?,
                choice: crate::ids::ItemId(if picks_b { b } else { c }),
                elapsed_ms: Some(rng.random_range(1500..6000)),
            };
            flow::answer(db, &token, &req).await?;
        }
        if spammer {
            report.spammers += 1;
        } else {
            report.honest += 1;
        }
    }
    Ok(report)
}

/// `platform demo`.
pub async fn run(mut args: DemoArgs) -> Result<()> {
    if std::env::var_os("PLATFORM_DATABASE_URL").is_none()
        && args.server.db.database_url == "sqlite://platform.db"
    {
        args.server.db.database_url = "sqlite://platform-demo.db".into();
    }
    let db = args.server.db.connect().await?;
    let (study, password) = setup(&db, args.fixtures.clone()).await?;
    if args.simulate > 0 {
        let report = simulate(&db, &study, args.simulate, crate::db::now_ms() as u64).await?;
        outln!(
            "simulated {} honest worker(s) and {} spammer(s)",
            report.honest,
            report.spammers
        )?;
        // The simulated answers are enough to fit the metric; a failure here (too few
        // answers for cross-validation) is reported, not fatal.
        match crate::train::run(&db, &study, crate::train::TrainOptions::default()).await {
            Ok(m) => outln!(
                "trained the style metric on {} answers: {} of 169 weights non-zero (report on the \
                 study's admin page)",
                m.triplets.unwrap_or(0),
                m.nonzero.unwrap_or(0)
            ),
            Err(e) => outln!("style metric not trained: {e}"),
        }?;
    }
    let (listener, state) = args.server.bind(db).await?;
    let base = state.settings.public_url.trim_end_matches('/').to_string();
    match password {
        Some(p) => {
            outln!("admin login: {base}/admin/login  user: admin  password (shown once): {p}")
        }
        None => outln!(
            "admin login: {base}/admin/login  (password was printed when the account was created; \
             reset it with `platform admin create`)"
        ),
    }?;
    outln!(
        "worker link: {base}/s/{}?participant=demo-worker-1",
        study.id
    )?;
    outln!(
        "MTurk sandbox test: {base}/s/{}?assignmentId=A1&hitId=H1&workerId=W1&turkSubmitTo=https://workersandbox.mturk.com",
        study.id
    )?;
    if args.no_serve {
        return Ok(());
    }
    crate::serve(listener, state)
        .await
        .map_err(AppError::internal)
}
