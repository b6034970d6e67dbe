//! Training the style metric from a study's answers (`platform train ID`, or the admin's Train
//! button): the study's `triplets.csv` export over the library's stored features goes to
//! [`learner::metric::train::train`] (eqs. 5.5–5.8 of Garces et al. 2014, λ by cross-validation
//! unless fixed); the model, its scores and the learner's HTML report are stored in the
//! database (`models`, `model_files`), so every server behind a load balancer can show them.

use std::path::Path;

use learner::metric::model::Model;
use learner::metric::train::{LambdaChoice, TrainParams};
use learner::table::FeatureTable;
use learner::triplets::TripletSet;
use serde::Serialize;
use sqlx::Row;

use crate::db::{Db, now_ms};
use crate::error::{AppError, Result};
use crate::export::{self, ExportOptions};
use crate::ids::{ModelId, StudyId};
use crate::library;
use crate::study::Study;

/// A training that started this long ago and never finished is taken for dead (its server
/// stopped); a new one may start.
pub const STALE_AFTER_MS: i64 = 6 * 3600 * 1000;

/// Files stored for every finished model: the learner's report (`index.html` and its figures)
/// and `model.json`.
const CONTENT_TYPES: &[(&str, &str)] = &[
    (".html", "text/html; charset=utf-8"),
    (".svg", "image/svg+xml"),
    (".png", "image/png"),
    (".json", "application/json"),
];

/// What the admin may choose; the rest follows the learner's defaults (the paper's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrainOptions {
    /// λ of eq. 5.8; `None`: chosen by cross-validation (default).
    pub lambda: Option<f64>,
    /// Cross-validation folds (grouped by worker when there are enough workers). Default 5.
    pub folds: usize,
}

impl Default for TrainOptions {
    fn default() -> Self {
        Self {
            lambda: None,
            folds: 5,
        }
    }
}

impl TrainOptions {
    fn params(&self) -> Result<TrainParams> {
        let params = TrainParams {
            lambda: match self.lambda {
                Some(l) => LambdaChoice::Fixed(l),
                None => LambdaChoice::Auto(None),
            },
            folds: self.folds,
            ..TrainParams::default()
        };
        params
            .validate()
            .map_err(|e| AppError::BadRequest(e.to_string()))?;
        Ok(params)
    }
}

/// One trained (or training, or failed) model of a study.
#[derive(Debug, Clone, PartialEq, Serialize, utoipa::ToSchema)]
pub struct ModelSummary {
    /// Id.
    pub id: ModelId,
    /// `running`, `done` or `failed`.
    pub status: String,
    /// Why it failed, or notes on how it was trained.
    pub message: Option<String>,
    /// Unix ms.
    pub started_at: i64,
    /// Unix ms, once finished.
    pub finished_at: Option<i64>,
    /// Training triplets (answers).
    pub triplets: Option<i64>,
    /// λ used.
    pub lambda: Option<f64>,
    /// Non-zero weights of the 169.
    pub nonzero: Option<i64>,
    /// Fraction of the training answers the learned metric agrees with.
    pub train_accuracy: Option<f64>,
    /// The same for the uniform metric (all weights equal), the baseline.
    pub uniform_accuracy: Option<f64>,
    /// Held-out accuracy at the chosen λ (cross-validation), when λ was chosen.
    pub cv_accuracy: Option<f64>,
}

/// The library's features and the study's answers, ready for the learner.
#[derive(Debug, Clone)]
pub struct TrainingData {
    /// Features of every library item, ids = item names (as in `triplets.csv`).
    pub table: FeatureTable,
    /// The exported answers (completed, non-rejected HITs; no controls, no training).
    pub set: TripletSet,
    /// Notes for the admin (e.g. folds grouped by tuple for lack of workers).
    pub notes: Vec<String>,
}

/// Reads the training data of `study`. Fails with a clear message when there are no answers.
pub async fn collect(db: &Db, study: &Study, opts: &TrainOptions) -> Result<TrainingData> {
    opts.params()?;
    let items = library::list_items(db, study.library).await?;
    let mut features = library::item_features(db, study.library).await?;
    let names: Vec<String> = learner::features::catalogue()
        .into_iter()
        .map(|f| f.name.to_string())
        .collect();
    let mut ids = Vec::with_capacity(items.len());
    let mut values = Vec::with_capacity(items.len() * names.len());
    for item in &items {
        let row = features
            .remove(&item.id)
            .ok_or_else(|| AppError::Internal(format!("item {} has no features", item.name)))?;
        if row.len() != names.len() {
            return Err(AppError::Internal(format!(
                "item {} has {} features, expected {}",
                item.name,
                row.len(),
                names.len()
            )));
        }
        ids.push(item.name.clone());
        values.extend(row);
    }
    let table = FeatureTable::new(names, ids, values).map_err(AppError::internal)?;
    let files = export::build(db, study, ExportOptions::default(), "").await?;
    let csv = files
        .into_iter()
        .find(|(name, _)| name == "triplets.csv")
        .map(|(_, bytes)| bytes)
        .ok_or_else(|| AppError::Internal("export has no triplets.csv".into()))?;
    let answers = csv
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        .saturating_sub(1);
    if answers == 0 {
        return Err(AppError::Conflict(
            "no answers to train on yet: the metric is fitted on the main answers of completed, \
             non-rejected HITs"
                .into(),
        ));
    }
    let mut set = learner::triplets::read_triplets_from(
        csv.as_slice(),
        Path::new("triplets.csv"),
        &table,
        false,
    )
    .map_err(|e| AppError::Internal(format!("exported triplets do not read back: {e}")))?;
    let mut notes = Vec::new();
    if opts.lambda.is_none() {
        let workers: std::collections::HashSet<Option<u32>> =
            set.triplets.iter().map(|t| t.worker).collect();
        let tuples: std::collections::HashSet<u32> = set.triplets.iter().map(|t| t.tuple).collect();
        if set.has_workers && workers.len() < opts.folds {
            set.has_workers = false;
            notes.push(format!(
                "cross-validation folds grouped by tuple: only {} worker(s) for {} folds",
                workers.len(),
                opts.folds
            ));
        }
        if tuples.len() < opts.folds {
            return Err(AppError::Conflict(format!(
                "too few answers to choose λ by {}-fold cross-validation ({} distinct triplets); \
                 collect more answers or give λ",
                opts.folds,
                tuples.len()
            )));
        }
    }
    Ok(TrainingData { table, set, notes })
}

/// A fitted model with its scores and the files to store.
#[derive(Debug, Clone)]
pub struct Fitted {
    /// The model.
    pub model: Model,
    /// Training-set accuracy of the learned metric.
    pub train_accuracy: f64,
    /// Training-set accuracy of the uniform metric.
    pub uniform_accuracy: f64,
    /// Held-out accuracy at the chosen λ.
    pub cv_accuracy: Option<f64>,
    /// `(name, bytes)`: `index.html`, its figures, `model.json`.
    pub files: Vec<(String, Vec<u8>)>,
    /// Notes carried from [`TrainingData`].
    pub notes: Vec<String>,
}

/// Fraction of answers a metric agrees with (`P(q = 1)` per triplet; ties count half).
fn accuracy(p_q1: &[f64], set: &TripletSet) -> f64 {
    let agree: f64 = p_q1
        .iter()
        .zip(&set.triplets)
        .map(|(&p, t)| {
            let p_answer = if t.q { p } else { 1.0 - p };
            if p_answer > 0.5 {
                1.0
            } else if p_answer == 0.5 {
                0.5
            } else {
                0.0
            }
        })
        .sum();
    agree / set.triplets.len().max(1) as f64
}

fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Fits the metric and renders the report (CPU-bound: call from a blocking thread).
pub fn fit(data: TrainingData, opts: &TrainOptions) -> Result<Fitted> {
    let params = opts.params()?;
    let TrainingData {
        table,
        set,
        mut notes,
    } = data;
    let model = learner::metric::train::train(&table, &set, &params, &mut |_| {})
        .map_err(|e| AppError::BadRequest(format!("training failed: {e}")))?;
    if model.nonzero == 0 {
        // Cross-validation's one-standard-error rule may prefer the empty metric on little or
        // noisy data; say so rather than show a report of zeros without comment.
        notes.push(format!(
            "every weight is zero at λ = {:.4}: the answers show no style signal the features \
             capture consistently; collect more answers or give a smaller λ",
            model.lambda
        ));
    }
    let predict = |w: &[f64]| {
        learner::eval::predict(&model, &table, &set.triplets, w)
            .map_err(|e| AppError::Internal(e.to_string()))
    };
    let train_accuracy = accuracy(&predict(&model.weights)?, &set);
    let uniform_accuracy = accuracy(
        &predict(&vec![model.uniform_scale; model.weights.len()])?,
        &set,
    );
    let cv_accuracy = model.cv.as_ref().and_then(|cv| {
        cv.rows
            .iter()
            .find(|r| r.lambda == cv.chosen)
            .map(|r| r.accuracy)
    });
    let mut extra = format!(
        "<h2>Agreement with the study's answers</h2><table><tr><th>metric</th><th>training \
         answers</th></tr><tr><td style=\"text-align:left\">learned</td><td>{train_accuracy:.3}\
         </td></tr><tr><td style=\"text-align:left\">uniform weights</td><td>\
         {uniform_accuracy:.3}</td></tr></table>"
    );
    if let Some(cv) = cv_accuracy {
        extra.push_str(&format!(
            "<p>Held-out accuracy at the chosen λ ({}-fold cross-validation): {cv:.3}</p>",
            params.folds
        ));
    }
    for note in &notes {
        extra.push_str(&format!("<p>{}</p>", html_escape(note)));
    }
    let dir = tempfile::tempdir().map_err(AppError::internal)?;
    let written = learner::eval::report::write_report(dir.path(), &model, None, &extra)
        .map_err(AppError::internal)?;
    let model_path = dir.path().join("model.json");
    model.save(&model_path).map_err(AppError::internal)?;
    let mut files = Vec::new();
    for path in written.iter().chain(std::iter::once(&model_path)) {
        let name = path
            .file_name()
            .and_then(|n| n.to_str())
            .ok_or_else(|| AppError::Internal("report file without a name".into()))?
            .to_string();
        files.push((name, std::fs::read(path).map_err(AppError::internal)?));
    }
    Ok(Fitted {
        model,
        train_accuracy,
        uniform_accuracy,
        cv_accuracy,
        files,
        notes,
    })
}

/// Records a training as running. Refuses when another one of the study is running (and not
/// stale), so repeated clicks do not queue CPU-heavy fits.
pub async fn begin(db: &Db, study: StudyId) -> Result<ModelId> {
    let mut tx = db.begin_write().await?;
    let running: i64 = sqlx::query(
        "SELECT COUNT(*) AS n FROM models WHERE study_id = $1 AND status = 'running' \
         AND started_at > $2",
    )
    .bind(study.0)
    .bind(now_ms() - STALE_AFTER_MS)
    .fetch_one(&mut *tx)
    .await?
    .try_get("n")?;
    if running > 0 {
        return Err(AppError::Conflict(
            "a training of this study is already running".into(),
        ));
    }
    let id = ModelId::generate();
    sqlx::query(
        "INSERT INTO models (id, study_id, status, started_at) VALUES ($1, $2, 'running', $3)",
    )
    .bind(id.0)
    .bind(study.0)
    .bind(now_ms())
    .execute(&mut *tx)
    .await?;
    tx.commit().await?;
    Ok(id)
}

/// Stores the outcome of a training started with [`begin`].
pub async fn complete(db: &Db, id: ModelId, outcome: Result<Fitted>) -> Result<()> {
    let mut tx = db.begin_write().await?;
    match outcome {
        Ok(f) => {
            let message = (!f.notes.is_empty()).then(|| f.notes.join("; "));
            sqlx::query(
                "UPDATE models SET status = 'done', message = $1, finished_at = $2, triplets = $3, \
                 lambda = $4, nonzero = $5, train_accuracy = $6, uniform_accuracy = $7, \
                 cv_accuracy = $8 WHERE id = $9",
            )
            .bind(message)
            .bind(now_ms())
            .bind(f.model.data.triplets as i64)
            .bind(f.model.lambda)
            .bind(f.model.nonzero as i64)
            .bind(f.train_accuracy)
            .bind(f.uniform_accuracy)
            .bind(f.cv_accuracy)
            .bind(id.0)
            .execute(&mut *tx)
            .await?;
            for (name, bytes) in f.files {
                sqlx::query("INSERT INTO model_files (model_id, name, bytes) VALUES ($1, $2, $3)")
                    .bind(id.0)
                    .bind(name)
                    .bind(bytes)
                    .execute(&mut *tx)
                    .await?;
            }
        }
        Err(e) => {
            sqlx::query(
                "UPDATE models SET status = 'failed', message = $1, finished_at = $2 WHERE id = $3",
            )
            .bind(e.to_string())
            .bind(now_ms())
            .bind(id.0)
            .execute(&mut *tx)
            .await?;
        }
    }
    tx.commit().await?;
    Ok(())
}

/// Fits on a blocking thread and stores the outcome; the error of the fit (if any) is stored
/// with the model and returned.
pub async fn fit_and_store(
    db: &Db,
    id: ModelId,
    data: TrainingData,
    opts: TrainOptions,
) -> Result<()> {
    let outcome = tokio::task::spawn_blocking(move || fit(data, &opts))
        .await
        .unwrap_or_else(|e| Err(AppError::Internal(format!("training thread: {e}"))));
    let failure = outcome.as_ref().err().map(ToString::to_string);
    complete(db, id, outcome).await?;
    match failure {
        Some(why) => Err(AppError::BadRequest(why)),
        None => Ok(()),
    }
}

/// Trains now and waits (the CLI): collect, record, fit, store.
pub async fn run(db: &Db, study: &Study, opts: TrainOptions) -> Result<ModelSummary> {
    let data = collect(db, study, &opts).await?;
    let id = begin(db, study.id).await?;
    fit_and_store(db, id, data, opts).await?;
    get(db, study.id, id).await
}

/// Starts a training in the background (the admin page and API) and returns at once. Errors
/// found before fitting (no answers, a training already running) are returned; later ones are
/// stored with the model.
pub async fn start(db: &Db, study: &Study, opts: TrainOptions) -> Result<ModelId> {
    let data = collect(db, study, &opts).await?;
    let id = begin(db, study.id).await?;
    let db = db.clone();
    tokio::spawn(async move {
        if let Err(e) = fit_and_store(&db, id, data, opts).await {
            eprintln!("training {id}: {e}");
        }
    });
    Ok(id)
}

fn summary(r: &sqlx::any::AnyRow) -> Result<ModelSummary> {
    Ok(ModelSummary {
        id: ModelId(r.try_get("id")?),
        status: r.try_get("status")?,
        message: r.try_get("message")?,
        started_at: r.try_get("started_at")?,
        finished_at: r.try_get("finished_at")?,
        triplets: r.try_get("triplets")?,
        lambda: r.try_get("lambda")?,
        nonzero: r.try_get("nonzero")?,
        train_accuracy: r.try_get("train_accuracy")?,
        uniform_accuracy: r.try_get("uniform_accuracy")?,
        cv_accuracy: r.try_get("cv_accuracy")?,
    })
}

/// `SELECT <summary columns> FROM models <rest>` as one static string (sqlx takes only
/// static SQL, which keeps every value a bound parameter).
macro_rules! select_models {
    ($rest:literal) => {
        concat!(
            "SELECT id, status, message, started_at, finished_at, triplets, lambda, nonzero, \
             train_accuracy, uniform_accuracy, cv_accuracy FROM models ",
            $rest
        )
    };
}

/// The models of a study, newest first.
pub async fn list(db: &Db, study: StudyId) -> Result<Vec<ModelSummary>> {
    sqlx::query(select_models!(
        "WHERE study_id = $1 ORDER BY started_at DESC, id"
    ))
    .bind(study.0)
    .fetch_all(&db.pool)
    .await?
    .iter()
    .map(summary)
    .collect()
}

/// One model of a study.
pub async fn get(db: &Db, study: StudyId, id: ModelId) -> Result<ModelSummary> {
    let row = sqlx::query(select_models!("WHERE study_id = $1 AND id = $2"))
        .bind(study.0)
        .bind(id.0)
        .fetch_optional(&db.pool)
        .await?
        .ok_or(AppError::NotFound("model"))?;
    summary(&row)
}

/// Names of the stored files of a model (report, figures, `model.json`), sorted.
pub async fn file_names(db: &Db, study: StudyId, id: ModelId) -> Result<Vec<String>> {
    let rows = sqlx::query(
        "SELECT f.name FROM model_files f JOIN models m ON m.id = f.model_id \
         WHERE m.study_id = $1 AND f.model_id = $2 ORDER BY f.name",
    )
    .bind(study.0)
    .bind(id.0)
    .fetch_all(&db.pool)
    .await?;
    rows.iter()
        .map(|r| r.try_get("name").map_err(AppError::from))
        .collect()
}

/// A stored report file or `model.json` with its content type. Only names the learner writes
/// are looked up (no path traversal: names are compared, never joined to a path).
pub async fn file(
    db: &Db,
    study: StudyId,
    id: ModelId,
    name: &str,
) -> Result<(&'static str, Vec<u8>)> {
    let name = if name.is_empty() { "index.html" } else { name };
    let content_type = CONTENT_TYPES
        .iter()
        .find(|(ext, _)| name.ends_with(ext))
        .map(|(_, t)| *t)
        .ok_or(AppError::NotFound("report file"))?;
    let row = sqlx::query(
        "SELECT f.bytes FROM model_files f JOIN models m ON m.id = f.model_id \
         WHERE m.study_id = $1 AND f.model_id = $2 AND f.name = $3",
    )
    .bind(study.0)
    .bind(id.0)
    .bind(name)
    .fetch_optional(&db.pool)
    .await?
    .ok_or(AppError::NotFound("report file"))?;
    Ok((content_type, row.try_get("bytes")?))
}
