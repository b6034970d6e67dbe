//! `platform demo`: a study a researcher can click through in a minute (fixture library with
//! style labels, a study with replicated tuples, an admin whose password is printed once), and
//! in-process simulated workers (honest ones with known noise, spammers) for the dashboard.

use std::path::PathBuf;

use rand::{Rng, SeedableRng};
use sqlx::Row;

use crate::cli::DemoArgs;
use crate::error::{AppError, Result};
use crate::flow::{self, AnswerRequest, Source, StartOutcome, StartRequest, TrainingAnswer};
use crate::store::db::Db;
use crate::store::ids::StudyId;
use crate::studies::library;
use crate::studies::study::{self, Study, StudySettings};
use crate::web::admin;

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
                // Eight hidden controls instead of five: a spammer guessing at random passes
                // the rule (at most one error) 3.5% of the time instead of 19%, at the price of
                // 5.7% of honest workers (95% right on controls) instead of 2.3%. With five,
                // one demo run in six kept two spammers or more, whose coin-flip answers made
                // the intervals of the held-out agreement (bootstrap over workers) too wide to
                // show what the learned metric gains over uniform weights.
                controls_per_hit: 8,
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

/// The hidden style metric of the simulated honest raters: the six largest weights of the
/// metric learned on the dev set (`docs/metric/README.md`, "Figures"), over the features
/// standardised across the library, in the paper's model (eqs. 5.5–5.6) — so there is a real
/// sparse metric for `platform train` to find, and the demo shows what the learned metric
/// gains over uniform weights.
pub const HIDDEN_METRIC: [(&str, f64); 6] = [
    ("shading_colour_grad_half_bin6", 6.65),
    ("texture_glcm_cluster_prominence", 3.90),
    ("shading_black_grad_half_bin4", 3.45),
    ("colour_black_fraction", 3.15),
    ("shading_colour_grad_1x_bin0", 2.13),
    ("colour_luminance_entropy", 1.73),
];

/// How sure an honest rater is on the study's median main tuple: `P(nearer candidate)` there.
/// The logistic choice of eq. 5.6 with the temperature set from it, so the answers carry
/// signal without being deterministic (on the fixture library ≈ 80% of the honest answers
/// follow the hidden metric, the share of the former label-following raters).
pub const MEDIAN_CONFIDENCE: f64 = 0.95;

/// Honest raters' choice model: `P(B) = σ((d*(A, C) − d*(A, B)) / T)`, `d*` the hidden metric.
struct HiddenRater {
    /// Per item, its hidden-metric coordinates `√w_k · z_k` (so `d*` is Euclidean in them).
    coords: std::collections::HashMap<i64, Vec<f64>>,
    temperature: f64,
}

impl HiddenRater {
    async fn new(db: &Db, study: &Study) -> Result<Self> {
        let features = library::item_features(db, study.library).await?;
        let catalogue = learner::features::catalogue();
        let columns: Vec<(usize, f64)> = HIDDEN_METRIC
            .iter()
            .map(|(name, w)| {
                catalogue
                    .iter()
                    .position(|f| f.name == *name)
                    .map(|k| (k, *w))
                    .ok_or_else(|| {
                        AppError::Internal(format!("feature {name} not in the catalogue"))
                    })
            })
            .collect::<Result<_>>()?;
        let n = features.len().max(1) as f64;
        let stats: Vec<(f64, f64)> = columns
            .iter()
            .map(|&(k, _)| {
                let mean = features.values().map(|f| f[k]).sum::<f64>() / n;
                let var = features
                    .values()
                    .map(|f| (f[k] - mean).powi(2))
                    .sum::<f64>()
                    / n;
                (mean, if var > 1e-24 { var.sqrt() } else { 1.0 })
            })
            .collect();
        let coords: std::collections::HashMap<i64, Vec<f64>> = features
            .iter()
            .map(|(id, f)| {
                let c = columns
                    .iter()
                    .zip(&stats)
                    .map(|(&(k, w), &(m, sd))| w.sqrt() * (f[k] - m) / sd)
                    .collect();
                (id.0, c)
            })
            .collect();
        let mut rater = Self {
            coords,
            temperature: 1.0,
        };
        let tuples =
            sqlx::query("SELECT a, b, c FROM tuples WHERE study_id = $1 AND kind = 'main'")
                .bind(study.id.0)
                .fetch_all(&db.pool)
                .await?;
        let mut margins = tuples
            .iter()
            .map(|r| {
                Ok(rater
                    .margin(r.try_get("a")?, r.try_get("b")?, r.try_get("c")?)
                    .abs())
            })
            .collect::<Result<Vec<f64>>>()?;
        margins.sort_by(f64::total_cmp);
        if let Some(&median) = margins.get(margins.len() / 2)
            && median > 0.0
        {
            let logit = (MEDIAN_CONFIDENCE / (1.0 - MEDIAN_CONFIDENCE)).ln();
            rater.temperature = median / logit;
        }
        Ok(rater)
    }

    /// `d*(A, C) − d*(A, B)`: positive when B is nearer to A.
    fn margin(&self, a: i64, b: i64, c: i64) -> f64 {
        let d = |x: i64, y: i64| match (self.coords.get(&x), self.coords.get(&y)) {
            (Some(x), Some(y)) => x
                .iter()
                .zip(y)
                .map(|(p, q)| (p - q).powi(2))
                .sum::<f64>()
                .sqrt(),
            _ => 0.0,
        };
        d(a, c) - d(a, b)
    }

    /// `P(the rater picks B)`.
    fn p_b(&self, a: i64, b: i64, c: i64) -> f64 {
        learner::metric::objective::sigmoid(self.margin(a, b, c) / self.temperature)
    }
}

/// Runs `n` simulated workers through the flow functions (in process): honest workers answer
/// controls right with probability 0.95, and main questions by the hidden style metric
/// [`HIDDEN_METRIC`] with the logistic choice of eq. 5.6 ([`MEDIAN_CONFIDENCE`] sets its
/// temperature); every fifth worker is a spammer answering at random. So a metric trained on
/// the demo's answers (`platform train`) has a real, sparse style metric to recover.
pub async fn simulate(db: &Db, study: &Study, n: u32, seed: u64) -> Result<SimReport> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let mut report = SimReport::default();
    let rater = HiddenRater::new(db, study).await?;
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
                .bind(
                    q.reference
                        .as_ref()
                        .ok_or_else(|| AppError::Internal("a triplet without a reference".into()))?
                        .id
                        .0,
                )
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
                        crate::store::ids::ItemId(right)
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
            let (b, c): (i64, i64) = (r.try_get("b")?, r.try_get("c")?);
            let picks_b = if spammer {
                rng.random_bool(0.5)
            } else if kind == "control" {
                rng.random_bool(0.95)
            } else {
                rng.random_bool(rater.p_b(r.try_get("a")?, b, c))
            };
            let req = AnswerRequest {
                position: r.try_get("position")?,
                choice: crate::store::ids::ItemId(if picks_b { b } else { c }),
                elapsed_ms: Some(rng.random_range(1500..6000)),
            };
            flow::answer(db, &token, &req, flow::AnsweredBy::Question).await?;
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
pub async fn run(args: DemoArgs) -> Result<()> {
    let db = args.server.db.connect().await?;
    let (study, password) = setup(&db, args.fixtures.clone()).await?;
    if args.simulate > 0 {
        let seed = args
            .seed
            .unwrap_or_else(|| crate::store::db::now_ms() as u64);
        let report = simulate(&db, &study, args.simulate, seed).await?;
        outln!(
            "simulated {} honest worker(s) and {} spammer(s)",
            report.honest,
            report.spammers
        )?;
        // The simulated answers are enough to fit the metric; a failure here (too few
        // answers for cross-validation) is reported, not fatal.
        match crate::studies::train::run(
            &db,
            &study,
            crate::studies::train::TrainOptions::default(),
        )
        .await
        {
            Ok(m) => {
                outln!(
                    "trained the style metric (report on the study's admin page): {}",
                    m.describe()
                )?;
                if let Some(note) = &m.message {
                    outln!("note: {note}")?;
                }
            }
            Err(e) => outln!("style metric not trained: {e}")?,
        }
    }
    // With --no-serve nothing listens: the links use the address a later `serve` would bind.
    let serving = if args.no_serve {
        None
    } else {
        Some(args.server.bind(db).await?)
    };
    let base = match &serving {
        Some((_, state)) => state.settings.public_url.clone(),
        None => args.server.public_base(args.server.bind),
    };
    let base = base.trim_end_matches('/').to_string();
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
    outln!("style search (after login): {base}/admin/search?library={DEMO_LIBRARY}")?;
    outln!(
        "MTurk sandbox test: {base}/s/{}?assignmentId=A1&hitId=H1&workerId=W1&turkSubmitTo=https://workersandbox.mturk.com",
        study.id
    )?;
    let Some((listener, state)) = serving else {
        return Ok(());
    };
    crate::serve(listener, state)
        .await
        .map_err(AppError::internal)
}
